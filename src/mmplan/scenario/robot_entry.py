"""A scenario's robot: a built-in robot's name or a URDF robot; building and recording it.

**Paths** (``urdf``, ``srdf``, ``package_dirs``) are absolute, relative to the folder of the
scenario file (of the plan folder for its scenario.yaml; the working directory for a scenario
given as a mapping), or ``package://NAME/PATH``: ``NAME/PATH`` is looked up in each folder of
the environment variable ``MMPLAN_PACKAGE_PATH`` (folders separated by ``:``, ``;`` on
Windows; e.g. ``export MMPLAN_PACKAGE_PATH=$ROS_PACKAGE_PATH``), then in the ``robots`` folder
of the installed example-robot-data (``pip install 'mmplan[robots]'``), so
``package://tiago_description/robots/tiago.urdf`` names the unmodified TIAGo wherever pip put
it. ``urdf`` may also be the URDF text itself (starting with ``<``). The URDF's own
``package://`` mesh paths are looked up in every folder above the URDF file and in
``MMPLAN_PACKAGE_PATH`` (or in ``package_dirs`` when given).

**Recording** (the resolved scenario.yaml of a plan folder, :func:`record_robot`): a built-in
robot by its name; a URDF robot by the arguments it was loaded with
(:attr:`~mmplan.robot.urdf.UrdfSource.arguments`: the effective collision options, file paths
made **absolute**, ``package://`` paths kept as written since they are resolved the same way
on every machine). So a plan folder can be moved anywhere; the URDF must stay where it is.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mmplan.errors import InputError, MmplanError
from mmplan.robot import Robot, get_robot, robot_names
from mmplan.scenario.robot_schema import UrdfRobotSpec

#: Environment variable naming folders that hold packages for ``package://`` paths.
PACKAGE_PATH_ENV = "MMPLAN_PACKAGE_PATH"
PACKAGE_SCHEME = "package://"

#: URDF robots built in this process, by their resolved arguments and file times.
_CACHE: dict[str, Robot] = {}
_CACHE_SIZE = 8

RobotEntry = str | dict[str, Any]


def _env_dirs() -> list[Path]:
    text = os.environ.get(PACKAGE_PATH_ENV, "")
    return [Path(p).expanduser() for p in text.split(os.pathsep) if p.strip()]


def package_roots() -> list[Path]:
    """Folders searched for ``package://NAME/...``: ``$MMPLAN_PACKAGE_PATH``, then the
    example-robot-data ``robots`` folder when it is installed."""
    from mmplan.robot.robot_data import robot_data_dir

    roots = _env_dirs()
    with contextlib.suppress(InputError):  # example-robot-data not installed
        roots.append(robot_data_dir())
    return roots


def urdf_unavailable(entry: object) -> str | None:
    """Why a scenario's URDF robot entry cannot be built here, one line (Pinocchio missing, a
    ``package://`` file that no package folder holds), None when nothing is seen missing or
    the entry is not a URDF robot. Reads no URDF (for listings: ``mmplan scenarios``; a new-user
    trial found TIAGo-with-a-pen scenarios listed as installed without example-robot-data)."""
    if not isinstance(entry, dict) or not isinstance(entry.get("urdf"), str):
        return None
    import importlib.util

    if importlib.util.find_spec("pinocchio") is None:
        from mmplan.extras import install_command

        return f"URDF robots need Pinocchio: {install_command('urdf')}"
    urdf = str(entry["urdf"])
    if urdf.startswith(PACKAGE_SCHEME):
        try:
            _package_file(urdf, "robot.urdf")
        except InputError as exc:
            return exc.problem
    return None


def _package_file(uri: str, key: str) -> Path:
    rest = uri[len(PACKAGE_SCHEME):]
    name, _, relative = rest.partition("/")
    if not name or not relative:
        raise InputError(key, f"expected package://NAME/PATH, got {uri!r}")
    roots = package_roots()
    for root in roots:
        path = root / name / relative
        if path.is_file():
            return path.resolve()
    searched = ", ".join(str(r) for r in roots) or "nothing"
    hints = []
    if not os.environ.get(PACKAGE_PATH_ENV):
        hints.append(f"${PACKAGE_PATH_ENV} is not set")
    if not any(r.name == "robots" and r.parent.name == "example-robot-data" for r in roots):
        from mmplan.extras import install_command

        hints.append(f"example-robot-data is not installed ({install_command('robots')})")
    hint = f" ({'; '.join(hints)})" if hints else ""
    raise InputError(key, f"{name}/{relative} not found in any package folder; searched "
                     f"{searched}{hint}")


def resolve_path(value: str, base_dir: Path, key: str, *, folder: bool = False) -> Path:
    """An existing file (or ``folder``) named absolutely, relative to ``base_dir`` or by
    ``package://``; InputError naming ``key`` otherwise."""
    if value.startswith(PACKAGE_SCHEME) and not folder:
        return _package_file(value, key)
    try:
        path = Path(value).expanduser()
        full = path if path.is_absolute() else base_dir / path
        ok = full.is_dir() if folder else full.is_file()
    except (OSError, ValueError) as exc:  # too long, a NUL byte
        raise InputError(key, f"bad path {value[:120]!r}: {exc}") from None
    if not ok:
        where = "" if path.is_absolute() else f" (relative to {base_dir})"
        raise InputError(key, f"no such {'folder' if folder else 'file'}: {full}{where}")
    return full.resolve()


def _is_xml(text: str) -> bool:
    return text.lstrip().startswith("<")


def _load_arguments(spec: UrdfRobotSpec, base_dir: Path) -> dict[str, Any]:
    """Keyword arguments of :func:`~mmplan.robot.urdf.load_urdf_robot` for ``spec``."""
    from mmplan.robot.urdf import CollisionOptions

    urdf: str | Path = spec.urdf if _is_xml(spec.urdf) else resolve_path(spec.urdf, base_dir,
                                                                          "robot.urdf")
    dirs: list[Path] | None = None
    if spec.package_dirs is not None:
        dirs = [resolve_path(d, base_dir, f"robot.package_dirs[{i}]", folder=True)
                for i, d in enumerate(spec.package_dirs)]
    elif _env_dirs():
        dirs = _env_dirs() + ([] if isinstance(urdf, str) else list(urdf.parents))
    collision = None
    if spec.collision is not None:
        given = spec.collision.model_dump(exclude_none=True, exclude={"spheres"})
        spheres = {body: [((s.center[0], s.center[1], s.center[2]), s.radius) for s in items]
                   for body, items in (spec.collision.spheres or {}).items()}
        collision = CollisionOptions(**given, spheres=spheres)
    return {
        "urdf": urdf,
        "platform": spec.platform.model_dump(mode="json", exclude_none=True),
        "end_effector": spec.end_effector,
        "locked": spec.locked,
        "mount": None if spec.mount is None else spec.mount.model_dump(exclude_none=True),
        "name": spec.name,
        "ee_offset": tuple(spec.ee_offset or (0.0, 0.0, 0.0)),
        "package_dirs": dirs,
        "srdf": None if spec.srdf is None else resolve_path(spec.srdf, base_dir, "robot.srdf"),
        "collision": collision,
        "description": spec.description,
    }


def _cache_key(kwargs: Mapping[str, Any]) -> str:
    stamps = []
    for key in ("urdf", "srdf"):
        value = kwargs[key]
        if isinstance(value, Path):
            stamps.append(value.stat().st_mtime_ns)
    return json.dumps([repr(sorted(kwargs.items())), stamps])


def build_robot(entry: str | UrdfRobotSpec, base_dir: Path) -> Robot:
    """The robot a scenario names: a built-in robot, or a URDF robot loaded once per process
    (again when its file changes).

    Raises:
        InputError: an unknown built-in name; a missing file or package; a joint, frame or
            body the URDF does not have (the key path names the scenario key).
    """
    if isinstance(entry, str):
        return get_robot(entry)
    from mmplan.robot.urdf import load_urdf_robot  # Pinocchio: only for URDF robots

    kwargs = _load_arguments(entry, base_dir)
    key = _cache_key(kwargs)
    if key not in _CACHE:
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = load_urdf_robot(**kwargs)
    return _CACHE[key]


def robot_of_entry(entry: Any, base_dir: Path, source: str = "scenario.yaml") -> Robot:
    """The robot of a scenario's raw ``robot:`` value (a name, or a URDF robot mapping), for
    readers of a resolved scenario.yaml that do not load the whole scenario (the report).

    Raises:
        InputError: neither form, or what :func:`build_robot` raises.
    """
    from pydantic import ValidationError

    from mmplan.scenario.parse import validation_error

    if isinstance(entry, Mapping):
        try:
            entry = UrdfRobotSpec.model_validate(dict(entry))
        except ValidationError as exc:
            raise validation_error(exc, dict(entry), source, prefix="robot",
                                   model=UrdfRobotSpec) from None
    if not isinstance(entry, str | UrdfRobotSpec):
        raise InputError("robot", f"expected a robot name or a URDF robot mapping, got "
                         f"{type(entry).__name__}")
    return build_robot(entry, base_dir)


def record_robot(robot: Robot, entry: str | UrdfRobotSpec | None = None) -> RobotEntry:
    """The ``robot:`` entry that rebuilds ``robot`` (see the module doc).

    Args:
        robot: The robot (built from ``entry``, or in Python when ``entry`` is None).
        entry: The scenario's entry it was built from, if any.

    Raises:
        InputError: a robot built in Python that is neither a built-in robot nor loaded by
            :func:`~mmplan.robot.urdf.load_urdf_robot` (or whose collision spheres were replaced
            afterwards).
    """
    if isinstance(entry, str):
        return entry
    if entry is None:
        return _python_robot_entry(robot)
    out = dict(_arguments(robot) or {})
    if not out:
        raise InputError("robot", f"{robot.name}: its URDF arguments were not kept")
    for key in ("urdf", "srdf"):
        value = getattr(entry, key)
        if value is not None and value.startswith(PACKAGE_SCHEME):
            out[key] = value
    if entry.package_dirs is None:
        out.pop("package_dirs", None)  # derived again from $MMPLAN_PACKAGE_PATH
    return out


def _arguments(robot: Robot) -> Mapping[str, Any] | None:
    source = getattr(robot, "source", None)
    arguments = getattr(source, "arguments", None)
    return arguments if isinstance(arguments, Mapping) else None


def _same_model(a: Robot, b: Robot) -> bool:
    return (a.tree is b.tree and a.collision == b.collision and a.end_effector == b.end_effector
            and getattr(a, "self_collision", None) is getattr(b, "self_collision", None))


def _python_robot_entry(robot: Robot) -> RobotEntry:
    if robot.name in robot_names():
        try:
            builtin = get_robot(robot.name)
        except MmplanError:  # a real robot whose files are not installed here
            builtin = None
        if builtin is not None and _same_model(robot, builtin):
            return robot.name
    arguments = _arguments(robot)
    if arguments:
        return dict(arguments)
    raise InputError("robot", f"robot {robot.name!r} cannot be recorded in a plan folder: it is "
                     "neither a built-in robot (mmplan robots) nor loaded by "
                     "mmplan.robot.urdf.load_urdf_robot (whose arguments it keeps; spheres "
                     "placed by hand go in CollisionOptions(spheres=...)); write the plan with "
                     "a Scenario instead")


__all__ = ["PACKAGE_PATH_ENV", "build_robot", "package_roots", "record_robot", "resolve_path",
           "robot_of_entry"]
