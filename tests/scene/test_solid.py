"""Obstacles describe their true shape (Obstacle.solid) for drawing: the report asks them,
so a new shape is one new scene/ file (no shape dispatch in the report)."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.report.scene3d_static import obstacle_geometry
from mmplan.report.shapes import footprint
from mmplan.scene import obstacle_from_dict
from mmplan.scene.obstacle import Solid
from mmplan.scene.sphere import Sphere


def test_each_shape_states_its_solid() -> None:
    box = obstacle_from_dict({"shape": "box", "center": [1, 2, 0.2], "size": [0.4, 0.6, 0.4],
                              "yaw": 0.3})
    assert box.solid() == Solid("box", (0.4, 0.6, 0.4), (1.0, 2.0, 0.2), 0.3)
    cyl = obstacle_from_dict({"shape": "cylinder", "base_center": [0, 0, 0], "radius": 0.2,
                              "height": 0.5})
    assert cyl.solid() == Solid("cylinder", (0.2, 0.5), (0.0, 0.0, 0.25))
    sph = obstacle_from_dict({"shape": "sphere", "center": [0, 1, 0.5], "radius": 0.1})
    assert sph.solid() == Solid("sphere", (0.1,), (0.0, 1.0, 0.5))
    se = obstacle_from_dict({"shape": "superellipsoid", "center": [0, 0, 0.1],
                             "semi_axes": [0.3, 0.3, 0.1], "exponents": [0.1, 1.0]})
    assert se.solid().kind == "model"


def test_the_report_draws_what_the_solid_says() -> None:
    """A shape defined outside the report (here a sphere that calls itself a box) is drawn by
    its solid, not by its class."""

    class Cube(Sphere):
        def solid(self) -> Solid:
            d = 2 * self.radius
            return Solid("box", (d, d, d), self.center, 0.0)

    cube = Cube((1.0, 0.0, 0.5), 0.25, None)
    geometry, pose = obstacle_geometry(cube)
    assert type(geometry).__name__ == "Box"
    np.testing.assert_allclose(pose[:3, 3], [1.0, 0.0, 0.5])
    outline = footprint(cube)
    assert len(outline) == 5  # a closed rectangle, not a circle
    np.testing.assert_allclose(np.abs(outline[:4] - [1.0, 0.0]).max(axis=0), [0.25, 0.25])


def test_a_new_shape_needs_only_its_own_class(
    tmp_path: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A shape registered outside mmplan (here a test-only sphere variant) is accepted by the
    scenario schema, planned around and checked: no schema, planner or report edit."""
    from dataclasses import dataclass
    from pathlib import Path

    import yaml

    import mmplan
    from mmplan.scene import obstacle as obstacle_module
    from mmplan.scene.obstacle import register_shape

    # The shape is registered in a copy of the registry, restored after the test.
    monkeypatch.setattr(obstacle_module, "_REGISTRY", dict(obstacle_module._REGISTRY))

    @register_shape
    @dataclass(frozen=True)
    class TestBall(Sphere):
        shape = "test-ball"

    data = yaml.safe_load(mmplan.builtin_scenarios()["diffdrive3-track"].read_text())
    data["obstacles"] = [{"shape": "test-ball", "center": [9.0, 9.0, 0.5], "radius": 0.2}]
    path = Path(str(tmp_path)) / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    problem = mmplan.load_scenario(path).build()
    assert type(problem.scene.obstacles[0]).__name__ == "TestBall"
    result = mmplan.get_planner("pseudoinverse")().plan(problem)
    assert mmplan.check(result.trajectory, problem, status=result.status.value).failures() == []
    bad = dict(data, obstacles=[{"shape": "test-ball", "center": [0, 0, 0], "radius": -1}])
    path.write_text(yaml.safe_dump(bad))
    try:
        mmplan.load_scenario(path)
    except mmplan.InputError as exc:
        assert "obstacles[0].radius" in str(exc)
    else:
        raise AssertionError("a negative radius of the new shape was accepted")
