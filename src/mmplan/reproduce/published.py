"""Every number the papers publish for their examples, and the numbers of the reference runs.

Papers are cited by their keys in docs/references.md; ``[RefRuns]`` are the runs of an
independent reference implementation described there. Data for ``mmplan reproduce``
(:mod:`mmplan.reproduce.run`): which runs to make (the built-in paper scenarios of
docs/conventions.md and two "switched off" variants that the references compare against)
and, per published number, where our value comes from (:class:`Measure`), how to judge the
difference (:class:`Check`) and the source of the number. Our values are never written here:
they are read from each run's summary.json, scenario.yaml and trajectory.csv.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from types import MappingProxyType
from typing import Any

#: Built-in paper scenarios (docs/conventions.md), in reproduction order, with their paper.
#: The youBot runs are the ``-unlimited`` variants: the papers' robot, without the velocity and
#: acceleration limits of the real youBot that the plain scenario names hold (run those with
#: ``--only``).
SCENARIOS: Mapping[str, str] = MappingProxyType({
    "youbot3r-obstacles-unlimited": "[PajakPajak]",
    "youbot3r-obstacles-torque-unlimited": "[PajakPajak]",
    "youbot4r-reach-unlimited": "[Pajak]",
    "youbot4r-reach-smooth-unlimited": "[Pajak]",
    "diffdrive3-track": "[AbdessemedDjebrani] s.2",
    "omni3-impedance": "[AbdessemedDjebrani] s.3",
    "car-rtr-free": "[JaniakTchon]",
    "car-rtr-steer60": "[JaniakTchon]",
    "car-rtr-steer30": "[JaniakTchon]",
    "wall-segment": "[Nagatani]",
})


@dataclass(frozen=True)
class Variant:
    """A built-in scenario with planner settings changed (a comparison the references make).

    Attributes:
        name: Run name (its directory under the reproduction folder).
        base: Built-in scenario it derives from; the variant runs whenever its base does.
        planner: Planner settings that replace the base scenario's.
        note: What the variant switches off, and why.
        scenario: Top-level scenario keys that replace the base scenario's (``ground``).
    """

    name: str
    base: str
    planner: Mapping[str, Any]
    note: str
    scenario: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))


VARIANTS: tuple[Variant, ...] = (
    Variant("diffdrive3-track-no-obstacle-term", "diffdrive3-track",
            MappingProxyType({"beta2": 0.0, "stop_on_collision": False}),
            "obstacle potential off (beta2 = 0), not stopped at contact: the reference runs "
            "[RefRuns] compare the clearance with and without the obstacle term"),
    Variant("omni3-impedance-off", "omni3-impedance",
            MappingProxyType({"b_obs": 0.0, "stop_on_collision": False}),
            "virtual impedance off (b_obs = 0), not stopped at contact: the reference runs "
            "[RefRuns] compare the platform-obstacle distance with and without it"),
)


#: Paper scenarios planned a second time without the floor (``ground: null``): the papers have
#: no floor, ours is an obstacle (docs/conventions.md, "Floor"). Every row that reads one of
#: them gets a note with its value without the floor (:func:`no_floor`), so that the table
#: explains any change the floor makes. The extended-Jacobian runs: the only paper plans that
#: come near the floor (youbot3r: the arm 9 cm below it without the floor); the other methods'
#: paper plans are bit-identical with and without it.
FLOOR_TWINS: tuple[str, ...] = (
    "youbot3r-obstacles-unlimited", "youbot3r-obstacles-torque-unlimited",
    "youbot4r-reach-unlimited", "youbot4r-reach-smooth-unlimited",
)


def no_floor(run: str) -> str:
    """Name of the run without the floor of a run in :data:`FLOOR_TWINS`."""
    return f"{run}-no-floor"


VARIANTS += tuple(
    Variant(no_floor(name), name, MappingProxyType({}),
            "without the floor (ground: null), as in the paper: the table's floor notes",
            MappingProxyType({"ground": None}))
    for name in FLOOR_TWINS
)


class Op(Enum):
    """How a :class:`Measure` turns run files into one value."""

    VALUE = "value"              # value at key in runs[0]
    INCREASE = "increase"        # value(runs[1]) / value(runs[0]) - 1
    MINUS = "minus"              # value at key minus value at other, both in runs[0]
    COLUMN_MAX_ABS = "max_abs"   # max |column| over the trajectory and the columns in key
    COLUMN_FIRST_ABS = "first"   # max |column| at the first sample over the columns in key
    PLANAR_NORM_MAX = "norm"     # max over samples of |(column key[0], column key[1])|


@dataclass(frozen=True)
class Measure:
    """Where our value of a published number comes from.

    Key paths start at summary.json; a path whose first element is ``"@scenario"`` reads the
    resolved scenario.yaml instead. For the column operations ``key`` lists trajectory.csv
    column names.

    Attributes:
        runs: Run names the value needs; the first one is linked from the table.
        key: Key path or column names.
        op: The operation.
        other: Second key path (``Op.MINUS``).
    """

    runs: tuple[str, ...]
    key: tuple[str, ...]
    op: Op = Op.VALUE
    other: tuple[str, ...] = ()


class Check(Enum):
    """How our value is judged against the published one (tolerance ``Reference.tol``)."""

    CLOSE = "close"          # |ours - paper| <= tol (relative when Reference.relative)
    AT_MOST = "at_most"      # ours <= paper (holds), <= paper + tol (within slack)
    AT_LEAST = "at_least"    # ours >= paper
    EQUALS = "equals"        # same value (text or integer)


@dataclass(frozen=True)
class Reference:
    """One published number and how ours is compared with it.

    Attributes:
        figure: Paper and place ("[PajakPajak] s.5"), "[RefRuns] <method>" for a value of
            the reference runs, or the docs page that states a requirement.
        quantity: What is measured (the run name is added by the table).
        paper: Published value; a pair for a point (x, y); text for a label.
        unit: Unit of paper and ours ("%" values are fractions, printed times 100).
        measure: Where our value comes from.
        check: How ours is judged.
        tol: Tolerance of the check (see :class:`Check`).
        relative: ``tol`` is relative to ``|paper|`` (else absolute, in ``unit``).
        source: Where the number is printed (and how it was read).
        paper_text: How to print the paper value (with its unit) when not just the number.
        known_gap: Why a difference is expected (shown when the verdict is "differs").
    """

    figure: str
    quantity: str
    paper: float | tuple[float, float] | str
    unit: str
    measure: Measure
    check: Check = Check.CLOSE
    tol: float = 0.1
    relative: bool = True
    source: str = ""
    paper_text: str = ""
    known_gap: str = field(default="")


def _v(run: str, *key: str) -> Measure:
    return Measure((run,), key)


Y3, Y3T, Y4, Y4S = ("youbot3r-obstacles-unlimited", "youbot3r-obstacles-torque-unlimited",
                    "youbot4r-reach-unlimited", "youbot4r-reach-smooth-unlimited")
DD, DD0, OM, OM0 = ("diffdrive3-track", "diffdrive3-track-no-obstacle-term", "omni3-impedance",
                    "omni3-impedance-off")
CAR, CAR60, CAR30, WALL = "car-rtr-free", "car-rtr-steer60", "car-rtr-steer30", "wall-segment"
CREEP = ("the paper's unpublished kappa, C and varrho make its robot creep near obstacles "
         "(about 4x longer, docs/extended_jacobian.md); matching these seconds is not the goal")
T_PAPER = "T(1 mm)"
T_NOTE = ("; the paper gives no completion criterion: ours is T(1 mm) (the reference runs "
          "[RefRuns] report both)")
PSI = ("planner_info", "max_abs.psi")
OVER = ("planner_info", "bound_overshoot.psi")
#: Figure labels of the reference runs' values, by planner method.
REF_EJ, REF_PI, REF_IMP, REF_ENDO, REF_MA = (
    "[RefRuns] extended-jacobian", "[RefRuns] pseudoinverse", "[RefRuns] impedance",
    "[RefRuns] endogenous", "[RefRuns] manipulability-area")

REFERENCES: tuple[Reference, ...] = (
    # ---- [PajakPajak] (Pajak & Pajak), section 5 -------------------------------------------
    Reference("[PajakPajak] s.5", f"{T_PAPER}, no torque limits", 44.6, "s",
              _v(Y3, "duration_1mm_s"),
              source="[PajakPajak] s.5 text: 'task execution is equal to 44.6 s'" + T_NOTE,
              known_gap=CREEP),
    Reference("[PajakPajak] s.5", f"{T_PAPER}, with torque limits", 49.4, "s",
              _v(Y3T, "duration_1mm_s"),
              source="[PajakPajak] s.5 text: 'the final time slightly increased to 49.4 s'"
                     + T_NOTE, known_gap=CREEP),
    Reference("[PajakPajak] s.5", "time added by the torque limits", 49.4 / 44.6 - 1, "%",
              Measure((Y3, Y3T), ("duration_1mm_s",), Op.INCREASE), tol=0.05, relative=False,
              source="[PajakPajak] s.5: 49.4 s / 44.6 s (about +10 %)",
              known_gap="in the reference runs [RefRuns] (11.3 s vs 11.7 s) the limits need "
                        "not slow the plan down"),
    # ---- [Pajak], section 5 ----------------------------------------------------------------
    Reference("[Pajak] s.5", f"{T_PAPER}, plain generator", 7.13, "s", _v(Y4, "duration_1mm_s"),
              source="[Pajak] s.5.3 text: 'equal to 7.13 [s] and 7.34 [s], respectively'"
                     + T_NOTE),
    Reference("[Pajak] s.5", f"{T_PAPER}, extended generator (wheel torque limits)", 7.34, "s",
              _v(Y4S, "duration_1mm_s"),
              source="[Pajak] s.5.3 text (second of the two times)" + T_NOTE),
    Reference("[Pajak] s.5", "time added by the torque limits", 7.34 / 7.13 - 1, "%",
              Measure((Y4, Y4S), ("duration_1mm_s",), Op.INCREASE), tol=0.05, relative=False,
              source="[Pajak] s.5.3: 7.34 s / 7.13 s"),
    # ---- [JaniakTchon], section III --------------------------------------------------------
    Reference("[JaniakTchon] s.III-A", "max |psi| without bounds", math.pi / 2, "rad",
              _v(CAR, *PSI), Check.AT_LEAST, tol=0.0, paper_text="> pi/2 = 1.571 rad",
              source="[JaniakTchon] s.III-A, Fig. 2: 'the turn angle of the front wheels takes "
                     "unrealistic values greater than pi/2'"),
    Reference("[JaniakTchon] s.III-B", "max |psi| with |psi| <= pi/3", math.pi / 3, "rad",
              _v(CAR60, *PSI), Check.AT_MOST, tol=0.03,
              source="[JaniakTchon] s.III-B, Fig. 3 (bound pi/3, alpha = 50); 3 % slack, as "
                     "in [RefRuns]", paper_text="<= pi/3 = 1.047 rad"),
    Reference("[JaniakTchon] s.III-B", "max |psi| with |psi| <= pi/6", math.pi / 6, "rad",
              _v(CAR30, *PSI), Check.AT_MOST, tol=0.03,
              source="[JaniakTchon] s.III-B, Fig. 4 (bound pi/6, alpha = 50); 3 % slack, as "
                     "in [RefRuns]", paper_text="<= pi/6 = 0.524 rad"),
    Reference(REF_ENDO, "max |psi| without bounds", 6.57, "rad", _v(CAR, *PSI), tol=0.02,
              source="[RefRuns], [JaniakTchon] examples (l2 = l3 = 0.5, |e| < 1e-4)"),
    Reference(REF_ENDO, "overshoot of max |psi| above pi/3", 0.03, "%", _v(CAR60, *OVER),
              Check.AT_MOST, tol=0.0, source="[RefRuns], [JaniakTchon] examples: within "
              "about 2-3 % above the bound", paper_text="<= 3 %"),
    Reference(REF_ENDO, "overshoot of max |psi| above pi/6", 0.03, "%", _v(CAR30, *OVER),
              Check.AT_MOST, tol=0.0, source="[RefRuns], [JaniakTchon] examples",
              paper_text="<= 3 %"),
)

_CLEAR = ("min_clearance_m",)
_MARGIN = ("@scenario", "planner", "obstacle_margin")
_WHEELS = ("tau.wheel1", "tau.wheel2")
_Y3_REF, _Y4_REF = "[RefRuns], [PajakPajak] example", "[RefRuns], [Pajak] example"

REFERENCES += (
    # ---- reference runs of the [PajakPajak] and [Pajak] examples (extended Jacobian) -------
    Reference(REF_EJ, "T(1 cm), no torque limits", 9.3, "s", _v(Y3, "duration_1cm_s"),
              source=f"{_Y3_REF} (RK4, dt 2 ms)"),
    Reference(REF_EJ, "T(1 mm), no torque limits", 11.7, "s", _v(Y3, "duration_1mm_s"),
              source=_Y3_REF),
    Reference(REF_EJ, "T(1 cm), with torque limits", 8.9, "s", _v(Y3T, "duration_1cm_s"),
              source=_Y3_REF),
    Reference(REF_EJ, "T(1 mm), with torque limits", 11.3, "s", _v(Y3T, "duration_1mm_s"),
              source=_Y3_REF),
    Reference(REF_EJ, "min distance to the enlarged obstacles (clearance - margin)", 0.07,
              "m", Measure((Y3,), _CLEAR, Op.MINUS, _MARGIN), tol=0.02, relative=False,
              source=f"{_Y3_REF}; ours: exact clearance to the "
                     "original obstacles minus the planner's obstacle_margin (exact for the "
                     "sphere and the cylinder sides)"),
    Reference(REF_EJ, "min clearance to the original obstacles, with torque limits", 0.0,
              "m", _v(Y3T, *_CLEAR), Check.AT_LEAST, tol=0.0,
              source=f"{_Y3_REF} with torque limits: collision-free",
              paper_text=">= 0 m (collision-free)"),
    Reference("docs/extended_jacobian.md", "max torque-limit violation, with torque limits",
              0.0, "N m", _v(Y3T, "max_torque_violation"), Check.AT_MOST, tol=0.0,
              source="docs/extended_jacobian.md: mmplan never accepts a plan that breaks a "
                     "limit silently (the reference run [RefRuns] with torque limits broke a "
                     "wheel limit for 0.17 s at the start)",
              paper_text="0 N m (within limits)"),
    Reference(REF_EJ, "manipulability at the start ([PajakPajak] example)", 0.00974, "m^3",
              _v(Y3, "manipulability_start"), tol=0.02,
              source=f"{_Y3_REF}: mu 0.00974 -> 0.01985"),
    Reference(REF_EJ, "manipulability at the end ([PajakPajak] example)", 0.01985, "m^3",
              _v(Y3, "manipulability_end"), tol=0.02,
              source=f"{_Y3_REF}: mu 0.00974 -> 0.01985 (with the joint-limit penalty)"),
    Reference(REF_EJ, "peak platform speed", 2.0, "m/s",
              Measure((Y3,), ("dq.x", "dq.y"), Op.PLANAR_NORM_MAX), tol=0.25,
              source=f"{_Y3_REF}: peak platform speed about 2 m/s", paper_text="about 2 m/s"),
    Reference(REF_EJ, "T(1 cm), plain generator ([Pajak] example)", 6.1, "s",
              _v(Y4, "duration_1cm_s"), source=f"{_Y4_REF} (RK4, dt 5 ms)"),
    Reference(REF_EJ, "wheel torque at t = 0, plain generator", 2.35, "N m",
              Measure((Y4,), _WHEELS, Op.COLUMN_FIRST_ABS), tol=0.05,
              source=f"{_Y4_REF}: the plain generator steps the wheel torque from 0 to "
                     "2.35 N m at t = 0"),
    Reference(REF_EJ, "max |wheel torque| with the virtual control", 0.18, "N m",
              Measure((Y4S,), _WHEELS, Op.COLUMN_MAX_ABS), Check.AT_MOST, tol=0.02,
              relative=False, source=f"{_Y4_REF}: all wheel torques stay within +-0.18 N m "
              "(limit 0.2 N m)", paper_text="<= 0.18 N m (limit 0.2)"),
    Reference(REF_EJ, "manipulability at the start ([Pajak] example)", 0.0100, "m^3",
              _v(Y4, "manipulability_start"), tol=0.02, source=_Y4_REF),
    Reference(REF_EJ, "manipulability at the end ([Pajak] example)", 0.0202, "m^3",
              _v(Y4, "manipulability_end"), tol=0.02, source=_Y4_REF),
    # ---- [AbdessemedDjebrani]: it prints figures only; reference runs of its examples -------
    Reference("[AbdessemedDjebrani] s.2", "obstacle avoided with the obstacle term (min "
              "clearance)", 0.0, "m", _v(DD, *_CLEAR), Check.AT_LEAST, tol=0.0,
              source="[AbdessemedDjebrani] s.2.4 figures (no numbers printed)",
              paper_text="> 0 m (avoided)"),
    Reference(REF_PI, "max tracking error after 2 s", 5.2e-4, "m",
              _v(DD, "planner_info", "max_error_after_settle_m"),
              source="[RefRuns], [AbdessemedDjebrani] s.2 example: after 2 s the tracking "
                     "error stays below 5.2e-4 m"),
    Reference(REF_PI, "min clearance with the obstacle term", 0.055, "m", _v(DD, *_CLEAR),
              tol=0.01, relative=False,
              source="[RefRuns], [AbdessemedDjebrani] s.2 example: clearance +0.055 m"),
    Reference(REF_PI, "min clearance without the obstacle term", -0.30, "m",
              _v(DD0, *_CLEAR), tol=0.05, relative=False,
              source="[RefRuns], [AbdessemedDjebrani] s.2 example: -0.30 m (collision) "
                     "without it"),
    Reference("[AbdessemedDjebrani] s.3.4", "collision avoided by the impedance (min "
              "clearance)", 0.0, "m", _v(OM, *_CLEAR), Check.AT_LEAST, tol=0.0,
              source="[AbdessemedDjebrani] s.3.4, Figs. 24-25: 'the collision is avoided'",
              paper_text="> 0 m (avoided)"),
    Reference(REF_IMP, "max end-effector error for t >= 1 s", 3.7e-3, "m",
              _v(OM, "planner_info", "max_error_after_settle_m"),
              source="[RefRuns], [AbdessemedDjebrani] s.3 example: end-effector error "
                     "<= 3.7e-3 m for t >= 1 s"),
    Reference(REF_IMP, "platform-obstacle distance at the pass, with impedance", 0.365, "m",
              _v(OM, "planner_info", "platform_obstacle_distance_at_pass_m"), tol=0.02,
              relative=False, source="[RefRuns], [AbdessemedDjebrani] s.3 "
              "example: 0.365 m with impedance"),
    Reference(REF_IMP, "platform-obstacle distance at the pass, without impedance", 0.247,
              "m", _v(OM0, "planner_info", "platform_obstacle_distance_at_pass_m"), tol=0.02,
              relative=False, source="[RefRuns], [AbdessemedDjebrani] s.3 "
              "example: 0.247 m without"),
    # ---- [Nagatani] (Nagatani et al.), section 5; reference runs of its example ----------
    Reference("[Nagatani] s.5.5", "a straight base segment exists in the LMA", "straight", "",
              _v(WALL, "planner_info", "path_kind"), Check.EQUALS,
              source="[Nagatani] s.5.5, Fig. 8: 'the path was found ..., expressed by a black "
                     "segment'"),
    Reference(REF_MA, "grid cells per layer", 22100.0, "", _v(WALL, "planner_info",
              "cells_per_layer"), Check.EQUALS,
              source="[RefRuns], [Nagatani] example: 22,100 cells"),
    Reference(REF_MA, "horizontal base path length", 0.122, "m",
              _v(WALL, "planner_info", "path_length_m"), tol=0.005, relative=False,
              source="[RefRuns], [Nagatani] example"),
    Reference(REF_MA, "base path start (x, y)", (0.27, 0.26), "m",
              _v(WALL, "planner_info", "start_xy"), tol=0.0142, relative=False,
              source="[RefRuns], [Nagatani] example; tolerance one grid-cell "
                     "diagonal (1 cm grid)"),
    Reference(REF_MA, "base path end (x, y)", (0.29, 0.38), "m",
              _v(WALL, "planner_info", "end_xy"), tol=0.0142, relative=False,
              source="[RefRuns], [Nagatani] example; tolerance one grid-cell "
                     "diagonal (1 cm grid)"),
    Reference(REF_MA, "manipulability threshold (0.5 max w)", 0.00397, "m^3",
              _v(WALL, "planner_info", "manipulability_threshold"), tol=0.01,
              source="[RefRuns], [Nagatani] example"),
    Reference(REF_MA, "min w along the path (exact IK)", 0.00398, "m^3",
              _v(WALL, "planner_info", "manipulability_min"), tol=0.01,
              source="[RefRuns], [Nagatani] example"),
    Reference(REF_MA, "min w minus threshold along the path", 0.0, "m^3",
              Measure((WALL,), ("planner_info", "manipulability_min"), Op.MINUS,
                      ("planner_info", "manipulability_threshold")), Check.AT_LEAST, tol=0.0,
              source="[RefRuns], [Nagatani] example; [Nagatani] s.3.3: the base "
                     "stays in the MA (w >= threshold)", paper_text=">= 0 m^3"),
)
