"""Plan directories: exact round trips, contract column order and keys, atomic writes."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mmplan import (
    InputError,
    PlanResult,
    Scenario,
    Status,
    Trajectory,
    get_robot,
    read_plan,
    read_trajectory_csv,
    write_plan,
)
from mmplan.verify.check import check
from tests.eta_planner import METHOD

CONTRACT_KEYS = ["status", "planner", "robot", "duration_s", "duration_1cm_s", "duration_1mm_s",
             "final_error_m", "min_clearance_m", "min_self_clearance_m", "min_floor_clearance_m",
             "max_joint_limit_violation",
             "max_torque_violation", "max_pfaffian_residual", "manipulability_start",
             "manipulability_end", "manipulability_min", "compute_time_s", "samples",
             "peak_platform_speed_mps", "peak_platform_yaw_rate_radps",
             "peak_platform_acceleration_mps2", "peak_platform_yaw_acceleration_radps2",
             "peak_velocity", "peak_acceleration", "limit_margins"]
START = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.17, 0.35]


def robot_coordinates() -> tuple[str, ...]:
    return get_robot("youbot-3r").coordinates


def make_scenario() -> Scenario:
    return Scenario.from_dict({
        "name": "io", "robot": "youbot-3r", "start": START,
        "goal": {"position": [1.0, 0.0, 0.3], "tolerance": 0.01},
        "obstacles": [{"shape": "sphere", "center": [2.0, 1.0, 0.3], "radius": 0.2}],
        "planner": {"method": METHOD, "eta": [0.1, 0.0, 0.0, 0.0, 0.0]},
    })


def make_result(rng: np.random.Generator, with_extras: bool = True) -> PlanResult:
    """Random-valued trajectory (values are not physical: this tests storage only)."""
    robot = get_robot("youbot-3r")
    N = 37
    t = np.cumsum(rng.uniform(0.01, 0.1, N))
    cols: dict[str, Any] = {"q": rng.normal(size=(N, 8)) / 3, "dq": rng.normal(size=(N, 8)),
                            "ddq": rng.normal(size=(N, 8))}
    cols["ee"] = np.array([robot.ee_position(q) for q in cols["q"]])
    if with_extras:
        cols.update(actuators=robot.actuators, tau=rng.normal(size=(N, 5)), u=rng.normal(size=N),
                    extra={"rho": rng.normal(size=N)})
    tr = Trajectory(robot.coordinates, t, **cols)
    history = {"error": rng.uniform(size=5), "step": np.arange(5.0)} if with_extras else {}
    artifacts = {"grid": rng.normal(size=(3, 4))} if with_extras else {}
    return PlanResult(Status.STALLED, tr, METHOD, "stuck near x = 0.3", 0.25,
                      info={"iterations": np.int64(12), "cond_max": np.float64(3.5)},
                      history=history, artifacts=artifacts)


def test_round_trip_is_bit_exact(tmp_path: Path, rng: np.random.Generator) -> None:
    sc, result = make_scenario(), make_result(rng)
    write_plan(tmp_path / "plan", result, sc.build(), sc, fmt="npz")
    tr, sc2 = read_plan(tmp_path / "plan")
    orig = result.trajectory
    for name in ("t", "q", "dq", "ddq", "ee", "tau", "u"):
        np.testing.assert_array_equal(getattr(tr, name), getattr(orig, name), err_msg=name)
    np.testing.assert_array_equal(tr.extra["rho"], orig.extra["rho"])
    assert tr.coordinates == orig.coordinates and tr.actuators == orig.actuators
    assert sc2.resolved_dict() == sc.resolved_dict()
    npz = np.load(tmp_path / "plan" / "trajectory.npz")
    np.testing.assert_array_equal(npz["q"], orig.q)
    assert tuple(npz["coordinates"]) == orig.coordinates


def test_csv_header_follows_spec_order(tmp_path: Path, rng: np.random.Generator) -> None:
    sc = make_scenario()
    write_plan(tmp_path / "p", make_result(rng), sc.build(), sc)
    header = (tmp_path / "p" / "trajectory.csv").read_text().splitlines()[0].split(",")
    coords = ["x", "y", "theta", "phi1", "phi2", "q1", "q2", "q3"]
    expected = (["t"] + [f"q.{c}" for c in coords] + [f"dq.{c}" for c in coords]
                + [f"ddq.{c}" for c in coords]
                + [f"tau.{a}" for a in ("wheel1", "wheel2", "q1", "q2", "q3")]
                + ["u", "rho", "ee.x", "ee.y", "ee.z"])
    assert header == expected
    assert not (tmp_path / "p" / "trajectory.npz").exists()


def test_summary_keys_values_and_side_files(tmp_path: Path, rng: np.random.Generator) -> None:
    sc, result = make_scenario(), make_result(rng)
    write_plan(tmp_path / "p", result, sc.build(), sc)
    summary = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert list(summary)[: len(CONTRACT_KEYS)] == CONTRACT_KEYS
    assert set(summary) - set(CONTRACT_KEYS) == {"message", "scenario", "planner_info",
                                             "check_passed", "check_failures"}
    assert summary["status"] == "stalled" and summary["planner"] == METHOD
    assert summary["planner_info"] == {"iterations": 12, "cond_max": 3.5}
    assert summary["compute_time_s"] == 0.25 and summary["samples"] == 37
    assert summary["scenario"] == "io" and summary["message"] == "stuck near x = 0.3"
    assert summary["duration_s"] is None  # stalled far from the goal
    # rate peaks of the dq / ddq columns by coordinate, a margin per finite default limit
    dq = result.trajectory.dq
    assert summary["peak_velocity"] == pytest.approx(
        {c: float(np.max(np.abs(dq[:, j]))) for j, c in enumerate(robot_coordinates())})
    assert summary["peak_platform_speed_mps"] == pytest.approx(
        float(np.max(np.hypot(dq[:, 0], dq[:, 1]))))
    rates = sc.robot.limits.rates
    assert summary["limit_margins"]["platform_speed"] == pytest.approx(
        rates.platform_speed - summary["peak_platform_speed_mps"])
    assert set(summary["limit_margins"]) == {
        *(f"velocity.{c}" for c in rates.velocity),
        *(f"acceleration.{c}" for c in rates.acceleration),
        "platform_speed", "platform_yaw_rate", "platform_acceleration", "platform_yaw_acceleration"}
    # independent values: clearance to the sphere from per-sample collision points
    robot = sc.robot
    gaps = [np.min(np.linalg.norm(robot.collision_points(q) - [2.0, 1.0, 0.3], axis=1) - 0.2)
            for q in result.trajectory.q]
    assert summary["min_clearance_m"] == pytest.approx(min(gaps), abs=1e-9)
    hist = (tmp_path / "p" / "history.csv").read_text().splitlines()
    assert hist[0] == "error,step" and len(hist) == 6
    with np.load(tmp_path / "p" / "artifacts.npz") as art:
        np.testing.assert_array_equal(art["grid"], result.artifacts["grid"])


def test_no_side_files_without_history_or_artifacts(tmp_path: Path,
                                                     rng: np.random.Generator) -> None:
    sc = make_scenario()
    write_plan(tmp_path / "p", make_result(rng, with_extras=False), sc.build(), sc)
    names = sorted(p.name for p in (tmp_path / "p").iterdir())
    assert names == ["scenario.yaml", "summary.json", "trajectory.csv"]


@pytest.mark.parametrize("exc", [RuntimeError("disk full"), KeyboardInterrupt()])
def test_failed_write_leaves_no_partial_output(tmp_path: Path, rng: np.random.Generator,
                                               monkeypatch: pytest.MonkeyPatch,
                                               exc: BaseException) -> None:
    sc, result = make_scenario(), make_result(rng)
    out = tmp_path / "plan"

    def boom(self: Scenario) -> str:  # fails after trajectory.csv and summary.json are written
        raise exc

    monkeypatch.setattr(Scenario, "to_yaml", boom)
    with pytest.raises(type(exc)):
        write_plan(out, result, sc.build(), sc)
    assert list(tmp_path.iterdir()) == []  # no out dir, no temporary leftovers
    # an existing plan survives a failed overwrite untouched
    monkeypatch.undo()
    write_plan(out, result, sc.build(), sc)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    monkeypatch.setattr(Scenario, "to_yaml", boom)
    with pytest.raises(type(exc)):
        write_plan(out, make_result(np.random.default_rng(1)), sc.build(), sc)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert [p.name for p in tmp_path.iterdir()] == ["plan"]


def test_successful_write_replaces_existing_plan_directory(tmp_path: Path,
                                                           rng: np.random.Generator) -> None:
    sc = make_scenario()
    out = tmp_path / "plan"
    write_plan(out, make_result(rng), sc.build(), sc)
    (out / "report.html").write_text("old report")  # mmplan's own files may be replaced
    write_plan(out, make_result(rng), sc.build(), sc)
    assert not (out / "report.html").exists() and (out / "trajectory.csv").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["plan"]
    assert (out.stat().st_mode & 0o777) == 0o777 & ~_umask()  # not mkdtemp's 0700


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def test_write_never_replaces_a_folder_with_foreign_content(tmp_path: Path,
                                                            rng: np.random.Generator) -> None:
    """Review defect 1: --out on a user's folder must not delete its content."""
    sc, result = make_scenario(), make_result(rng)
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    with pytest.raises(InputError, match="exists and is not a plan directory"):
        write_plan(out, result, sc.build(), sc)
    write_plan(tmp_path / "p", result, sc.build(), sc)
    (tmp_path / "p" / "notes.txt").write_text("mine")  # a plan folder the user added to
    with pytest.raises(InputError, match="not a plan directory"):
        write_plan(tmp_path / "p", result, sc.build(), sc)
    assert (out / "thesis.tex").read_text() == "precious"
    assert (tmp_path / "p" / "notes.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "p"]  # no .old-/.tmp- left
    (tmp_path / "empty").mkdir()  # an empty folder is fine
    write_plan(tmp_path / "empty", result, sc.build(), sc)
    assert (tmp_path / "empty" / "summary.json").is_file()


def test_bad_inputs_raise_input_errors(tmp_path: Path, rng: np.random.Generator) -> None:
    sc, result = make_scenario(), make_result(rng)
    with pytest.raises(InputError, match="unknown format"):
        write_plan(tmp_path / "p", result, sc.build(), sc, fmt="xlsx")
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="not a directory"):
        write_plan(tmp_path / "file", result, sc.build(), sc)
    with pytest.raises(InputError, match="no such directory"):
        read_plan(tmp_path / "missing")
    (tmp_path / "bad.csv").write_text("t,q.x\n0,1\n")
    with pytest.raises(InputError, match="header"):
        read_trajectory_csv(tmp_path / "bad.csv")
    (tmp_path / "nan.csv").write_text("t,q.x,dq.x,ddq.x,ee.x,ee.y,ee.z\n0,1,2,3,4,5,oops\n")
    with pytest.raises(InputError, match="malformed"):
        read_trajectory_csv(tmp_path / "nan.csv")


def test_check_of_read_back_plan_equals_check_in_memory(tmp_path: Path,
                                                        rng: np.random.Generator) -> None:
    sc, result = make_scenario(), make_result(rng)
    write_plan(tmp_path / "p", result, sc.build(), sc)
    tr, sc2 = read_plan(tmp_path / "p")
    assert check(tr, sc2.build()) == check(result.trajectory, sc.build())
    summary = json.loads((tmp_path / "p" / "summary.json").read_text())
    expected = check(tr, sc2.build()).summary(status="stalled", planner=METHOD,
                                              compute_time_s=0.25)
    report = check(tr, sc2.build(), status="stalled")
    expected.update(check_passed=report.ok, check_failures=report.failures())
    expected.update(message="stuck near x = 0.3", scenario="io",
                    planner_info={"iterations": 12, "cond_max": 3.5})
    assert summary == expected


def test_non_finite_numbers_are_written_as_null(tmp_path: Path, rng: np.random.Generator) -> None:
    """Review defect 5: no "nan" strings (nor NaN/Infinity tokens) in summary.json."""
    sc, base = make_scenario(), make_result(rng)
    result = PlanResult(base.status, base.trajectory, base.planner, base.message, 0.25,
                        info={"manipulability_threshold": float("nan"), "cond": float("inf"),
                              "series": [1.0, float("-inf")]})
    write_plan(tmp_path / "p", result, sc.build(), sc)
    text = (tmp_path / "p" / "summary.json").read_text()
    assert "nan" not in text.lower() and "inf" not in text.lower().replace("planner_info", "")
    summary = json.loads(text)
    assert summary["manipulability_threshold"] is None
    assert summary["planner_info"] == {"manipulability_threshold": None, "cond": None,
                                       "series": [1.0, None]}
