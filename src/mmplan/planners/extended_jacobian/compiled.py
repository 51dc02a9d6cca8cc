"""The compiled generator on disk: found again on a later run without building the model.

A compiled generator library (:mod:`~mmplan.planners.extended_jacobian.generator`) is keyed by
:func:`disk_key`: the robot model (:func:`mmplan.compile.fingerprint.robot_fingerprint`),
the obstacle shape types with their slot counts, the settings that enter the symbolic model
and the code version (every source file of this package and of :mod:`mmplan.compile`).
Next to the library a small JSON file records the parameter layout and the sizes, so that
:func:`load` returns working functions straight from the library: no criterion, no
symbolic step, no code generation (the SX ``terms`` is built only if something asks for
it). Scenes, goals and partitions are numbers in p
(:mod:`~mmplan.planners.extended_jacobian.parameters`), so they never change the key.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import casadi as ca

from mmplan.compile import codegen as cg
from mmplan.compile import family as cf
from mmplan.compile.fingerprint import python_files, robot_fingerprint, source_fingerprint
from mmplan.planners.extended_jacobian.active import shape_name
from mmplan.planners.extended_jacobian.functions import GeneratorFunctions, LazyFunction
from mmplan.planners.extended_jacobian.parameters import ParameterLayout, Shape

#: Functions of the library, loaded by name (``mmplan_ej_<name>``).
NAMES = ("terms_flat", "step_flat", "chunk", "record_step", "effort", "E")
#: C compiler flags of the generated generator (measured: -O2 about 2x faster than -O1 here,
#: -O3 -ffast-math no faster and 3x slower to compile). Re-measured on youbot-3r with two
#: obstacle slots (677 kB of C, 3 alternating builds, load ~2 on 2 cores): gcc 4.64-4.74 s
#: with -O2 -march=native, 3.28-3.55 s with -O1 -march=native, whose rollout chunks ran only
#: 3 % slower (10.2-10.4 ms against 9.9 ms a youbot3r-obstacles-torque plan). Since every build
#: is without fused multiply-adds (:data:`mmplan.compile.codegen.FIXED_FLAGS`) -O1 and -O2
#: give the same plans to the bit (youbot3r-obstacles-torque, its -unlimited variant and
#: youbot4r-reach compared); the build is cut into units compiled in parallel
#: (:mod:`mmplan.compile.split`).
CFLAGS = ("-O2", "-march=native")
#: For a compiler that rejects one of :data:`CFLAGS` (an Apple clang without -march=native):
#: the generic instruction set, the same plans (no fused multiply-adds either way).
PLAIN_CFLAGS = ("-O2",)
#: Functions of the library called about once a plan (:meth:`GeneratorFunctions.evaluate`):
#: the code only they reach is compiled without optimisation (:func:`mmplan.compile.codegen.
#: compile_library`'s ``cold``; the same results, every build being without fused
#: multiply-adds).
COLD = ("mmplan_ej_terms_flat",)


def _code_files() -> list[str]:
    here = Path(__file__).parent
    return [*python_files(here, recursive=True), *python_files(Path(cg.__file__).parent)]


def disk_key(
    robot: Any,
    slots: Sequence[tuple[Shape, int]],
    settings: Sequence[Any],
    partition: Sequence[int] | None = None,
) -> str:
    """Key of the compiled generator of ``robot`` with these slots and model settings
    (``partition``: a partition built in, None when it is a parameter)."""
    parts = [
        robot_fingerprint(robot),
        repr(tuple(slots)),
        repr(tuple(settings)),
        repr(None if partition is None else tuple(partition)),
        source_fingerprint(_code_files()),
        repr(CFLAGS),
        cg.host() if cg.native_flags(CFLAGS) else "",  # -march=native: this CPU's code
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]


def family_key(robot: Any, settings: Sequence[Any]) -> str:
    """Key of the generators of ``robot`` and these model settings whatever their obstacle
    slots (partition a parameter): the libraries :func:`remember` lists together."""
    parts = [
        "family",
        robot_fingerprint(robot),
        repr(tuple(settings)),
        source_fingerprint(_code_files()),
        repr(CFLAGS),
        cg.host() if cg.native_flags(CFLAGS) else "",
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]


#: File-name prefix of the family lists (:mod:`mmplan.compile.family`).
FAMILY = "ej_family"


def remember(family: str, slots: Sequence[tuple[Shape, int]], key: str) -> None:
    """List the library ``key`` (these slots) among its family's."""
    cf.remember(FAMILY, family, slots, key)


def wider(family: str, slots: Sequence[tuple[Shape, int]]) -> list[tuple[str, Any]]:
    """Libraries with at least ``slots``' slots of each shape type, the fewest first
    (:func:`mmplan.compile.family.wider`)."""
    return cf.wider(FAMILY, family, slots)


def covering(family: str, slots: Sequence[tuple[Shape, int]]) -> list[tuple[str, Any]]:
    """Libraries with a slot of every shape type of ``slots`` but fewer of some, the most
    first (:func:`mmplan.compile.family.covering`; the near obstacles in the slots:
    :mod:`~mmplan.planners.extended_jacobian.active`)."""
    return cf.covering(FAMILY, family, slots)


def why_compile(family: str, slots: Sequence[tuple[Shape, int]]) -> str:
    """Why a generator of this family is compiled although others are on disk: the shape
    types none of them has a slot for ("" when there is no other, or all types are held: the
    caller says why, e.g. a crowded scene)."""
    listed = cf.listed(FAMILY, family)
    held = {e for _, have in listed for e, k in have if k}
    missing = sorted({shape_name(e) for e, _ in slots if tuple(e) not in held})
    if not listed or not missing:
        return ""
    return f"no compiled generator of this robot has a slot for {', '.join(missing)} obstacles"


def _external(name: str, library: str) -> ca.Function:
    (fn,) = cg.load([name], library)
    return fn


def _meta_path(key: str) -> Path:
    return cg.cache_dir() / f"ej_{key}.json"


def save(key: str, fns: GeneratorFunctions, library: str) -> None:
    """Record the layout and sizes of a freshly compiled library (atomic write)."""
    lay = fns.layout
    meta = {
        "library": library,
        "n": fns.n,
        "n_act": fns.n_act,
        "layout": {
            "slots": [[list(e), k] for e, k in lay.slots],
            "heading": lay.heading,
            "n_arm": lay.n_arm,
            "n_platform": lay.n_platform,
            "choices": list(lay.choices),
        },
    }
    path = _meta_path(key)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as out:
            json.dump(meta, out)
        os.replace(tmp, path)
    except OSError:
        pass  # no cache: the next run compiles again


def load(key: str, symbolic: Callable[[], GeneratorFunctions]) -> GeneratorFunctions | None:
    """The compiled generator stored under ``key``, None when absent or unreadable.

    Args:
        key: :func:`disk_key`.
        symbolic: Builds the SX generator; called only if the SX ``terms`` is needed.
    """
    path = _meta_path(key)
    if cg.compiler() is None or not path.exists():
        return None
    try:
        meta = json.loads(path.read_text())
        library = str(meta["library"])
        lay = meta["layout"]
        layout = ParameterLayout(
            tuple(((float(e[0]), float(e[1])), int(k)) for e, k in lay["slots"]),
            bool(lay["heading"]),
            int(lay["n_arm"]),
            int(lay["n_platform"]),
            tuple(int(i) for i in lay["choices"]),
        )
        # each loaded on its first call (0.1-0.2 ms apiece; a plan calls two or three)
        terms_flat, step_flat, chunk, record, effort, E = (
            LazyFunction(functools.partial(_external, f"mmplan_ej_{x}", library)) for x in NAMES
        )
        native = cg.NativeFunction(library, "mmplan_ej_chunk_flat")
        if not all(native.has(f"mmplan_ej_{x}") for x in (*NAMES, "ee_flat")):
            return None  # loaded lazily: a library without one of them is built again now
    except (OSError, ValueError, KeyError, TypeError, RuntimeError, AttributeError):
        return None
    reference: dict[str, GeneratorFunctions] = {}

    def built() -> GeneratorFunctions:
        if "fns" not in reference:
            reference["fns"] = symbolic()
        return reference["fns"]

    def terms() -> ca.Function:
        fn = built().terms
        return fn.function if isinstance(fn, LazyFunction) else fn

    return GeneratorFunctions(
        None, LazyFunction(terms), E, int(meta["n"]), int(meta["n_act"]), True, terms_flat,
        step_flat, effort, chunk, record=record, native_chunk=native, layout=layout, key=key,
        library=library,
        cache={"symbolic": built},
    )  # fmt: skip
