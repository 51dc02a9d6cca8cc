"""A small hand-made plan directory for the report tests (no planner involved)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mmplan.robot import get_robot

# [PajakPajak]'s three obstacles (docs/conventions.md), with their influence neighbourhoods.
PAPER_OBSTACLES: list[dict[str, Any]] = [
    {
        "shape": "superellipsoid",
        "center": [0.15, 0.75, 0.10],
        "semi_axes": [0.25, 0.25, 0.10],
        "exponents": [0.1, 1.0],
        "influence": 0.35,
    },
    {"shape": "sphere", "center": [1.25, 0.70, 0.45], "radius": 0.15, "influence": 0.15},
    {
        "shape": "cylinder",
        "base_center": [1.25, 2.5, 0.0],
        "radius": 0.40,
        "height": 0.10,
        "influence": 0.35,
    },
]


def _smooth(tau: np.ndarray) -> np.ndarray:
    return tau**3 * (10 - 15 * tau + 6 * tau**2)


def make_plan_dir(
    folder: Path, obstacles: list[dict[str, Any]] | None = None, samples: int = 401
) -> Path:
    """A small hand-made youbot-3r plan: the platform drives a smooth S-curve past obstacle 1
    (heading along the path, wheel angles integrated from the rolling constraints), the arm
    moves; efforts from the robot's dynamics; history.csv and artifacts.npz with synthetic
    method data."""
    robot = get_robot("youbot-3r")
    obstacles = PAPER_OBSTACLES if obstacles is None else obstacles
    T = 8.0
    t = np.linspace(0.0, T, samples)
    s = _smooth(t / T)
    x = -0.45 * (1 - np.cos(2 * np.pi * s)) / 2
    y = -0.5 + 3.0 * s
    dx_ds, dy_ds = -0.45 * np.pi * np.sin(2 * np.pi * s), np.full_like(s, 3.0)
    theta = np.arctan2(dy_ds, dx_ds)  # heading along the path
    v = np.hypot(dx_ds, dy_ds) * np.gradient(s, t)
    w = np.gradient(theta, t)
    r, d = 0.05, 0.16
    dphi1, dphi2 = (v - d * w) / r, (v + d * w) / r

    def integrate(rate: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])

    q = np.column_stack(
        [
            x,
            y,
            theta,
            integrate(dphi1),
            integrate(dphi2),
            0.3 * np.sin(np.pi * s),
            -0.17 + 0.3 * s,
            0.35 - 0.2 * s,
        ]
    )
    dq = np.gradient(q, t, axis=0)
    ddq = np.gradient(dq, t, axis=0)
    tau = np.array([robot.actuator_efforts(q[i], dq[i], ddq[i]) for i in range(samples)])
    u = 1.0 - np.exp(-t)
    ee = np.array([robot.ee_position(qi) for qi in q])
    names = ["t"] + [f"{p}.{c}" for p in ("q", "dq", "ddq") for c in robot.coordinates]
    names += [f"tau.{a}" for a in robot.actuators] + ["u", "ee.x", "ee.y", "ee.z"]
    data = np.column_stack([t, q, dq, ddq, tau, u, ee])
    folder.mkdir(parents=True, exist_ok=True)
    np.savetxt(
        folder / "trajectory.csv",
        data,
        fmt="%.17g",
        delimiter=",",
        header=",".join(names),
        comments="",
    )
    goal = [float(v) for v in ee[-1]]
    mu = [robot.manipulability(qi) for qi in q]
    summary = {
        "status": "reached",
        "planner": "extended-jacobian",
        "robot": "youbot-3r",
        "duration_s": 7.5,
        "duration_1cm_s": 7.0,
        "duration_1mm_s": 7.5,
        "final_error_m": 0.0,
        "min_clearance_m": 0.12,
        "max_joint_limit_violation": 0.0,
        "max_torque_violation": 0.25,
        "max_pfaffian_residual": 1.5e-3,
        "manipulability_start": mu[0],
        "manipulability_end": mu[-1],
        "manipulability_min": min(mu),
        "compute_time_s": 1.25,
        "samples": samples,
        "message": "hand-made test plan",
        "planner_info": {"max_cond_E": 4e3},
    }
    (folder / "summary.json").write_text(json.dumps(summary, indent=2))
    scenario = {
        "name": "report-test",
        "robot": "youbot-3r",
        "start": [float(v) for v in q[0]],
        "goal": {"position": goal, "tolerance": 0.001},
        "obstacles": obstacles,
        "limits": {
            "joints": {"min": [-2.9496, -1.1345, -2.6354], "max": [2.9496, 1.5708, 2.5307]},
            "torque": {"min": [-1.5, -1.5, -1.0, -10.0, -5.0], "max": [1.5, 1.5, 1.0, 0.0, 0.0]},
        },
        "planner": {"method": "extended-jacobian", "t_max": 120.0, "margin": 0.05},
    }
    (folder / "scenario.yaml").write_text(yaml.safe_dump(scenario, sort_keys=False))
    iterations = np.arange(12.0)
    history = np.column_stack([iterations, 2.0 * 0.5**iterations])
    np.savetxt(
        folder / "history.csv",
        history,
        delimiter=",",
        header="iteration,error_norm",
        comments="",
        fmt="%.17g",
    )
    gx, gy = np.linspace(0.0, 1.0, 21), np.linspace(-0.5, 0.5, 11)
    X, Y = np.meshgrid(gx, gy, indexing="ij")  # (nx, ny), as the LMA planner stores grids
    grid = np.exp(-((X - 0.5) ** 2 + Y**2) * 8.0)
    freq = np.linspace(0.0, 50.0, 101)
    np.savez(
        folder / "artifacts.npz",
        grid_x=gx,
        grid_y=gy,
        manipulability_first=grid,
        ma_masks=np.stack([grid > 0.5, grid > 0.4, grid > 0.3]).astype(float),
        path_xy=np.column_stack([np.linspace(0.4, 0.6, 5), np.linspace(-0.2, 0.2, 5)]),
        freq_hz=freq,
        tip_acceleration=1.0 / (1.0 + (freq - 15.0) ** 2),
    )
    return folder


#: TIAGo's start: torso half way up, the arm bent (q in tiago's coordinate order, n = 13).
TIAGO_START = [0.0, 0.0, 0.0, 0.0, 0.0, 0.15, 0.3, 0.2, 0.0, 1.2, 0.0, 0.0, 0.0]
#: Constant eta of the test planner: both wheels forward (the right one faster, a left turn),
#: torso up, every arm joint turning.
TIAGO_ETA = [3.0, 4.0, 0.02, 0.3, 0.1, -0.2, 0.25, 0.3, 0.2, 0.5]


def make_tiago_plan_dir(folder: Path, seconds: float = 4.0) -> Path:
    """A TIAGo plan written by the test planner (``tests/eta_planner.py``, dq = N(q) eta):
    the platform drives a left curve past a table-sized box and a cylinder while the torso
    rises and the arm turns; the goal is where the end effector is after ``seconds``, so the
    plan reaches it. Efforts from the robot's dynamics (the checker asks for them)."""
    import dataclasses

    from mmplan import Scenario, Trajectory, get_planner, write_plan
    from tests.eta_planner import METHOD

    data: dict[str, Any] = {
        "name": "tiago-report-test",
        "robot": "tiago",
        "start": TIAGO_START,
        "goal": {"position": [5.0, 5.0, 1.0], "tolerance": 0.01},
        "obstacles": [
            {"shape": "box", "center": [1.6, -0.9, 0.35], "size": [0.8, 0.6, 0.7], "yaw": 0.2},
            {"shape": "cylinder", "base_center": [0.6, 1.4, 0.0], "radius": 0.25, "height": 1.0},
        ],
        "planner": {"method": METHOD, "eta": TIAGO_ETA, "t_max": seconds, "dt": 0.02},
    }
    first = get_planner(METHOD)().plan(Scenario.from_dict(data).build())
    data["goal"]["position"] = [float(v) for v in first.trajectory.ee[-1]]
    data["planner"]["t_max"] = seconds + 1.0
    scenario = Scenario.from_dict(data)
    problem = scenario.build()
    result = get_planner(METHOD)().plan(problem)
    tr, robot = result.trajectory, problem.robot
    tau = np.array([robot.actuator_efforts(q, dq, ddq)
                    for q, dq, ddq in zip(tr.q, tr.dq, tr.ddq, strict=True)])
    with_efforts = Trajectory(tr.coordinates, tr.t, tr.q, tr.dq, tr.ddq, tr.ee,
                              robot.actuators, tau)
    write_plan(folder, dataclasses.replace(result, trajectory=with_efforts), problem, scenario)
    return folder
