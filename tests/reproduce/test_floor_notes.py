"""Floor notes of the reproduction table: the extended-Jacobian paper scenarios are also planned
without the floor, and every row reading them says what the floor changes."""

from __future__ import annotations

from pathlib import Path

from mmplan.reproduce import run as repro
from mmplan.reproduce.evaluate import evaluate, with_floor_note
from mmplan.reproduce.published import FLOOR_TWINS, REFERENCES, SCENARIOS, Measure, no_floor
from mmplan.reproduce.table import HEADER, floor_note, markdown
from tests.reproduce.test_reproduce import fake_runs


def test_every_extended_jacobian_paper_run_has_a_twin_without_the_floor() -> None:
    specs = {s.name: s for s in repro.run_specs()}
    ej = [n for n in SCENARIOS if n.startswith("youbot")]
    assert set(FLOOR_TWINS) == set(ej)
    for name in FLOOR_TWINS:
        twin = specs[no_floor(name)]
        assert twin.base == name and twin.scenario == {"ground": None} and not twin.planner
        assert repro.load_run(twin).scene.ground is None
        assert repro.load_run(specs[name]).scene.ground == 0.0
    picked = [s.name for s in repro.run_specs(["youbot3r-obstacles-unlimited"])]
    assert picked == ["youbot3r-obstacles-unlimited", "youbot3r-obstacles-unlimited-no-floor"]
    assert "floor note" in HEADER


def test_floor_note_gives_the_value_without_the_floor(tmp_path: Path) -> None:
    ref = next(r for r in REFERENCES if r.measure.runs == ("youbot3r-obstacles-unlimited",)
               and r.measure.key == ("duration_1mm_s",))
    twin = Measure((no_floor(ref.measure.runs[0]),), ref.measure.key)
    runs = {**fake_runs(tmp_path / "a", ref.measure, 11.40),
            **fake_runs(tmp_path / "b", twin, 11.74)}
    row = with_floor_note(evaluate(ref, runs), runs)
    assert row.without_floor is not None and row.without_floor.ours == 11.74
    assert row.floor_changed and floor_note(row).startswith("floor: 11.74 s without it")
    same = {**runs, **fake_runs(tmp_path / "c", twin, 11.40)}
    unchanged = with_floor_note(evaluate(ref, same), same)
    assert floor_note(unchanged) == "floor: no change (the same without it)"
    # a row reading no twin run gets no note; a twin that was not run neither
    other = next(r for r in REFERENCES if r.measure.runs == ("wall-segment",))
    plain = fake_runs(tmp_path / "d", other.measure, 0.1)
    assert floor_note(with_floor_note(evaluate(other, plain), plain)) == ""
    alone = fake_runs(tmp_path / "e", ref.measure, 11.4)
    assert with_floor_note(evaluate(ref, alone), alone).without_floor is None
    text = markdown([], [row, unchanged], 1.0)
    assert "Floor notes: the papers plan without a floor" in text
    assert "| floor: 11.74 s without it" in text


def test_reproduction_table_carries_the_floor_notes(tmp_path: Path) -> None:
    """End to end: the youbot3r run and its twin without the floor; every row of that run gets
    a floor note (a value without the floor, or "no change")."""
    done = repro.reproduce(tmp_path, only=["youbot3r-obstacles-unlimited"], report=False)
    names = [r.spec.name for r in done.runs]
    assert names == ["youbot3r-obstacles-unlimited", "youbot3r-obstacles-unlimited-no-floor"]
    assert all(r.status == "reached" for r in done.runs)
    assert done.rows and all(floor_note(r).startswith("floor: ") for r in done.rows)
    text = done.markdown.read_text()
    assert text.count("| floor: ") == len(done.rows)
    assert "Floor notes:" in text and "Floor notes:" in done.html.read_text()
