"""The ``mmplan`` command: list robots and scenarios, plan a scenario, check a written plan.

A thin layer over the public API. No traceback reaches the user: an
:class:`~mmplan.errors.MmplanError` prints ``error: <one line>`` and exits with its code
(2 bad input, 3 planning failed); anything else exits 1 with a hint to report it.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any, NoReturn

import click

import mmplan
from mmplan.cli.output import (
    err,
    made,
    out,
    print_check,
    print_export,
    print_plan,
    rate_limits_text,
    unavailable_text,
)
from mmplan.cli.progress import Progress, live_on
from mmplan.errors import MmplanError

ISSUES_HINT = "this is a bug in mmplan; please report it with the command you ran"
#: Longest line printed for an error or a failed check (the rest is cut with "...").
MAX_LINE = 500


def _one_line(text: str, limit: int = MAX_LINE) -> str:
    """``text`` on one line (line breaks escaped) of at most ``limit`` characters."""
    text = text[:4 * limit].replace("\r", "\\r").replace("\n", "\\n").replace("\t", " ")
    text = "".join(c if c.isprintable() else "?" for c in text)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _print_error(message: str) -> None:
    err.print(_one_line(f"error: {message}"), markup=False, soft_wrap=True)


def _fail(message: str, code: int) -> NoReturn:
    _print_error(message)
    raise SystemExit(code)


class _UsageLine(click.ClickException):
    """A usage error (missing argument, bad choice, ...) shown as one line, exit code 2."""

    exit_code = 2

    def show(self, file: object = None) -> None:
        _print_error(self.message)


#: Raised by click >= 8.2 for a bare `mmplan` (it shows the help); click 8.1 exits instead.
_HELP_ERRORS: tuple[type[BaseException], ...] = tuple(
    c for c in (getattr(click.exceptions, "NoArgsIsHelpError", None),) if c is not None)


@contextmanager
def _usage_in_one_line() -> Iterator[None]:
    """Click's usage errors (usage block + hint + message) become one ``error:`` line."""
    try:
        yield
    except _HELP_ERRORS:
        raise  # bare `mmplan`: the help text is the answer
    except _UsageLine:
        raise
    except click.ClickException as exc:
        ctx = getattr(exc, "ctx", None)
        hint = f" (see '{ctx.command_path} --help')" if isinstance(exc, click.UsageError) \
            and ctx is not None else ""
        raise _UsageLine(f"{exc.format_message()}{hint}") from None


class _Group(click.Group):
    """The ``mmplan`` group: every usage error of it and its commands is one line."""

    def make_context(self, info_name: str | None, args: list[str],
                     parent: click.Context | None = None, **extra: Any) -> click.Context:
        with _usage_in_one_line():
            return super().make_context(info_name, args, parent, **extra)

    def invoke(self, ctx: click.Context) -> Any:
        with _usage_in_one_line():
            return super().invoke(ctx)


@contextmanager
def _user_errors() -> Iterator[None]:
    """Turn every exception into one line on stderr and an exit code.

    Floating-point RuntimeWarnings (overflow, NaN from absurd input) are not printed: what
    went wrong is the error line, the FAIL lines or summary.json.
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            yield
    except MmplanError as exc:
        _fail(str(exc), exc.exit_code)
    except KeyboardInterrupt:
        _fail("interrupted", 130)
    except (SystemExit, click.exceptions.Exit, click.ClickException):
        raise
    except OSError as exc:  # a path the system refuses (too long, not writable, ...): bad input
        if exc.filename is None:
            _fail(f"internal error: {type(exc).__name__}: {exc} ({ISSUES_HINT})", 1)
        name = str(exc.filename)
        name = name if len(name) <= 120 else f"{name[:60]}...{name[-40:]} ({len(name)} characters)"
        _fail(f"{name}: {exc.strerror or exc}", 2)
    except Exception as exc:
        first = str(exc).splitlines()[0] if str(exc) else ""
        _fail(f"internal error: {type(exc).__name__}: {first} ({ISSUES_HINT})", 1)


def _is_dir(path: Path) -> bool:
    """``path.is_dir()``, False for a name the system refuses (too long, ...)."""
    try:
        return path.is_dir()
    except (OSError, ValueError):
        return False


def _print_version(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    """``--version``: looked up only when asked (importlib.metadata costs ~30 ms a start)."""
    if value and not ctx.resilient_parsing:
        click.echo(f"mmplan, version {mmplan.__version__}")
        ctx.exit()


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True,
              callback=_print_version, help="Show the version and exit.")
def main() -> None:
    """Whole-body trajectory planning for mobile manipulators.

    \b
    Typical session:
      mmplan robots                                  # built-in robots
      mmplan scenarios                               # built-in scenarios
      mmplan plan youbot3r-obstacles --out run1      # plan, write run1/
      mmplan check run1                              # re-verify run1/ independently
      mmplan report run1                             # run1/report.html (figures, 3D)
      mmplan export run1 --out run1-100hz --ros2 bag # fixed rate; ROS 2 bag
      mmplan reproduce --out repro                   # all paper examples vs the papers

    Exit codes: 0 success, 2 bad input, 3 planned but the task was not reached / check
    failed, 1 internal error. A scenario is a built-in name or a YAML file (see
    docs/conventions.md).
    """


@main.command()
def robots() -> None:
    """List the built-in robots (name, n coordinates, h constraints, coordinates) and their
    velocity and acceleration limits (sources: docs/conventions.md, Limits). Robots loaded from
    example-robot-data (tiago, ur5-omni) show "not installed" and the pip command without it."""
    with _user_errors():
        from rich.markup import escape
        from rich.table import Table

        table = Table("robot", "n", "h", "coordinates", "description")
        table.columns[0].no_wrap = True  # a name a user types: never cut
        rates = Table("robot", "velocity limits (m/s, rad/s)", "acceleration limits (/s^2)",
                      caption="sources of the numbers: docs/conventions.md, Limits")
        reasons: dict[str, list[str]] = {}
        for name in mmplan.robot_names():
            try:
                r = mmplan.get_robot(name)
            except mmplan.InputError as exc:  # a real robot whose files are not installed
                status, reason = unavailable_text(exc)
                table.add_row(name, "-", "-", "-", f"{status} (below)")
                rates.add_row(name, "-", "-")
                reasons.setdefault(f"{status} ({{}}): {reason}", []).append(name)
                continue
            table.add_row(name, str(r.n), str(r.h), " ".join(r.coordinates), r.description)
            rates.add_row(name, *rate_limits_text(r.limits.rates))
        out.print(table)
        out.print(rates)
        for line, names in reasons.items():  # whole, never cut by a column (new-user trial)
            out.print(escape(line.format(", ".join(names))), soft_wrap=True)


@main.command()
def scenarios() -> None:
    """List the built-in scenarios (robot, planning method, whether both are installed here)."""
    with _user_errors():
        from rich.markup import escape
        from rich.table import Table

        from mmplan.scenario.loader import robot_unavailable

        table = Table()
        for column in ("scenario", "robot", "method", "installed"):  # names a user types:
            table.add_column(column, no_wrap=True)  # never cut (the reasons follow the table)
        available = set(mmplan.methods())
        reasons: dict[str, list[str]] = {}
        for name, path in mmplan.builtin_scenarios().items():
            try:
                robot, method = mmplan.scenario_header(path)
            except mmplan.InputError as exc:
                table.add_row(name, "?", "?", "no")
                reasons.setdefault(f"invalid file: {exc.problem}", []).append(name)
                continue
            missing = robot_unavailable(path)  # a built-in robot's or a URDF robot's files
            if method not in available:
                missing = f"the {method} planner is not installed"
            table.add_row(name, robot, method, "yes" if missing is None else "no")
            if missing is not None:
                reasons.setdefault(missing, []).append(name)
        # a pipe or a file gets the names whole, however wide (a terminal: its width)
        console = made(out)
        if not console.is_terminal:
            from rich.console import Console

            console = Console(file=console.file, width=1000, highlight=False)
        console.print(table)
        for reason, names in reasons.items():
            out.print(escape(f"not installed ({', '.join(names)}): {reason}"), soft_wrap=True)


@main.command()
@click.argument("scenario")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Directory to write (replaced atomically if it exists).")
@click.option("--format", "fmt", type=click.Choice(["csv", "npz"]), default="csv",
              show_default=True, help="npz also writes trajectory.npz next to trajectory.csv.")
@click.option("--quiet", "-q", is_flag=True, help="No progress bar and no metrics; exit code only.")
@click.option("--report", "with_report", is_flag=True,
              help="Also write OUT/report.html (figures and 3D animation; needs the report extra).")
def plan(scenario: str, out_dir: Path, fmt: str, quiet: bool, with_report: bool) -> None:
    """Plan SCENARIO (a built-in name or a YAML file) and write the plan to --out.

    Writes OUT/trajectory.csv (one row per sample), OUT/summary.json (status and metrics
    recomputed by the independent checker) and OUT/scenario.yaml (the scenario with every
    default filled in).

    The plan is re-verified by the same independent checks as `mmplan check`; a failed
    check is printed (FAIL ...) and recorded in summary.json (check_passed: false,
    check_failures), status keeps what the planner said. --out must be a new folder, an
    empty one or an earlier plan folder (anything else is never replaced).

    Examples:

    \b
      mmplan plan youbot3r-obstacles --out runs/youbot
      mmplan plan my_scenario.yaml --out runs/mine --format npz
      mmplan plan wall-segment --out runs/wall --report   # + runs/wall/report.html

    A minimal scenario file (start lists the coordinates shown by `mmplan robots`):

    \b
      name: my-reach
      robot: youbot-3r
      start: [0, 0, 0, 0, 0, 0, -0.17, 0.35]
      goal: {position: [1.5, 0.5, 0.3], tolerance: 0.001}
      obstacles:
        - {shape: sphere, center: [1.0, 0.3, 0.4], radius: 0.1}
      planner: {method: extended-jacobian, t_max: 60}

    Exit code 0 when the task was reached and every check holds, 3 when planning ended
    without reaching it (summary.json says why) or a check failed, 2 for bad input.
    """
    with _user_errors(), Progress(live_on(quiet)) as progress, ExitStack() as stack:
        from mmplan.io.plan_folder import check_out_dir
        from mmplan.verify.native import compiled_checks

        if _is_dir(Path(scenario)):
            raise mmplan.InputError("SCENARIO", f"{scenario} is a directory; give a scenario "
                                    "file or a built-in name (`mmplan scenarios`)")
        progress("loading the scenario")
        sc = mmplan.load_scenario(scenario)
        check_out_dir(out_dir)  # before planning: refuse a folder we would not replace
        # the checker's robot functions in C (built meanwhile the first time, for the next run)
        stack.enter_context(compiled_checks(sc.robot, build=True))
        problem = sc.build()
        planner = mmplan.get_planner(sc.method)()
        progress("planning")
        try:
            result = planner.plan(problem, progress=progress.fraction)
        except mmplan.ScenarioError:
            raise
        except mmplan.InputError as exc:  # a planner's own check of the scenario: name the file
            raise mmplan.ScenarioError(sc.source, exc.field, exc.problem) from None
        from mmplan.analysis import analyse

        progress("studying the plan")
        result = analyse(result, problem)
        progress("checking and writing the plan")
        written = mmplan.write_plan(out_dir, result, problem, sc, fmt=fmt)
        summary = mmplan.read_summary(written)
        progress.close()
        if not quiet:
            print_plan(result, summary, written)
        failures = [str(f) for f in summary.get("check_failures", [])]
        for line in failures:
            err.print(_one_line(f"FAIL {line}"), markup=False, soft_wrap=True)
        if with_report:
            from mmplan.report import write_report  # optional extra: imported only here

            page = write_report(written, step=progress)
            progress.close()
            if not quiet:
                out.print(f"report: {page}", markup=False)
        if not result.reached or failures:
            raise SystemExit(3)


@main.command(name="check")
@click.argument("directory", type=click.Path(path_type=Path))
@click.option("--quiet", "-q", is_flag=True,
              help="No progress line and no listing: FAIL lines and the exit code only.")
def check_cmd(directory: Path, quiet: bool) -> None:
    """Re-verify the plan in DIRECTORY independently of the planner that made it.

    Recomputes from q alone: end effector by forward kinematics, clearance to the original
    obstacles by exact geometry, joint and torque limits, Pfaffian residual |A(q) dq|,
    dq against q, velocity and acceleration limits (on the dq, ddq columns and on what any
    motion through consecutive samples needs, from q and dq; slack 1e-6 relative), completion times
    T(1 cm), T(1 mm); checks that the status in
    summary.json agrees with the task error and that every checked number in summary.json
    agrees with the recomputed one (relative 1e-6). Example:

    \b
      mmplan check runs/youbot

    Exit code 0 when every check holds, 3 naming each failed check, 2 on unreadable input.
    """
    with _user_errors(), Progress(live_on(quiet)) as progress:
        from mmplan.verify.native import compiled_checks
        from mmplan.verify.summary import summary_disagreements

        if directory.exists() and not directory.is_dir():
            raise mmplan.InputError(str(directory), "is a file; give a plan directory "
                                    "(written by mmplan plan --out DIR)")
        progress("reading the plan")
        trajectory, sc = mmplan.read_plan(directory)
        claimed = mmplan.read_summary(directory)
        status = claimed.get("status")
        problem = sc.build()
        progress("checking the plan")
        with compiled_checks(problem.robot):  # compiled when `mmplan plan` built them
            report = mmplan.check(trajectory, problem,
                                  status=None if status is None else str(status))
        failures = report.failures() + summary_disagreements(claimed, report, sc.method)
        progress.close()
        if not quiet:
            print_check(report, trajectory_end_s=float(trajectory.t[-1]))
        for line in failures:
            err.print(_one_line(f"FAIL {line}"), markup=False, soft_wrap=True)
        if failures:
            raise SystemExit(3)
        if not quiet:
            out.print("check passed", markup=False)


@main.command()
@click.argument("plan_dir", type=click.Path(path_type=Path))
@click.option("--quiet", "-q", is_flag=True,
              help="No progress line and no \"wrote\" line (warnings and errors only).")
def report(plan_dir: Path, quiet: bool) -> None:
    """Write PLAN_DIR/report.html and PLAN_DIR/figures/*.png for a written plan.

    One self-contained HTML file (opens offline): summary table, the papers' figures for the
    planner used and a 3D animation of the robot among the obstacles. Needs the optional
    report extra (without it the command says how to install it). Example:

    \b
      mmplan plan youbot4r-reach --out runs/y4 && mmplan report runs/y4

    Exit code 0 when written, 2 when PLAN_DIR is not a readable plan directory.
    """
    with _user_errors(), Progress(live_on(quiet)) as progress:
        from mmplan.cli.report_cmd import write_checked_report  # optional extra: only here

        page, failed = write_checked_report(plan_dir, progress)
        progress.close()
        if not quiet:
            figures = len(list((page.parent / "figures").glob("*.png")))
            out.print(f"wrote {page} ({page.stat().st_size / 1e6:.1f} MB, {figures} figures "
                      f"in {page.parent / 'figures'})", markup=False)
        if failed:
            more = f" (+{len(failed) - 1} more)" if len(failed) > 1 else ""
            err.print(_one_line(f"warning: this plan FAILS its checks: {failed[0]}{more}; see "
                                f"`mmplan check {plan_dir}`"), markup=False, soft_wrap=True)


@main.command(name="export")
@click.argument("plan_dir", type=click.Path(path_type=Path))
@click.option("--rate", type=float, default=100.0, show_default=True,
              help="Control rate in Hz (1 to 10000): one sample every 1/rate s.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Plan folder to write at the control rate (new, empty or an earlier plan "
                   "folder; replaced atomically).")
@click.option("--ros2", "bag", type=click.Path(file_okay=False, path_type=Path),
              help="rosbag2 folder to write (new, empty or an earlier bag; needs "
                   "the ros extra).")
@click.option("--quiet", "-q", is_flag=True, help="Print nothing but failures; exit code only.")
def export_cmd(plan_dir: Path, rate: float, out_dir: Path | None, bag: Path | None,
               quiet: bool) -> None:
    """Export the plan in PLAN_DIR at a fixed control rate: a plan folder and/or a ROS 2 bag.

    The plan is resampled every 1/rate s (the last step ends at the plan's final time): q,
    dq, ddq from the plan's own meaning between its samples, the cubic Hermite through q
    and dq (ddq its derivative; the curve the planners hold their limits on), dq projected
    onto the wheels' Pfaffian constraints A(q) dq = 0, efforts (tau) and u interpolated
    linearly, ee recomputed by forward kinematics.

    --out writes a plan folder checked like `mmplan plan` does (summary.json recomputed;
    `mmplan check OUT` re-verifies it). --ros2 writes a rosbag2 (sqlite3, ROS 2 Humble/Jazzy
    messages) without ROS: /joint_trajectory (one JointTrajectory: wheel/steering and arm
    joints, a point per sample), /cmd_vel (a Twist per sample: base velocity in the platform
    frame) and /base_path (one Path of the base pose, frame odom). Examples:

    \b
      mmplan export runs/youbot --out runs/youbot-100hz
      mmplan export runs/youbot --rate 250 --ros2 bags/youbot
      mmplan export runs/youbot --out runs/y100 --ros2 bags/y100

    Exit code 0 when written and the exported trajectory passes every check, 3 when written
    but a check fails (FAIL lines), 2 for bad input (no plan folder, a rate outside 1-10000
    Hz, an output that may not be written, rosbags not installed).
    """
    with _user_errors(), Progress(live_on(quiet)) as progress:
        from mmplan.io.export import export_plan

        done = export_plan(plan_dir, rate=rate, out=out_dir, ros2=bag, step=progress)
        progress.close()
        if not quiet:
            print_export(done)
        for line in done.failures:
            err.print(f"FAIL {line}", markup=False, soft_wrap=True)
        step = done.resampled.source_step_min
        if any(f.startswith("dq consistency") for f in done.failures) and step * rate < 1:
            err.print(f"hint: the plan's own steps are down to {step:.3g} s; a higher --rate "
                      f"(up to {1 / step:.4g} Hz) resolves its motion", markup=False)
        if done.failures:
            raise SystemExit(3)


@main.command(name="reproduce")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the runs (OUT/<scenario>/) and the tables.")
@click.option("--only", multiple=True, metavar="NAME",
              help="Run only these scenarios (repeatable, comma lists; further NAMES as "
                   "arguments); variants come with their scenario.")
@click.option("--no-report", is_flag=True, help="Skip the per-scenario report.html (faster).")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=None,
              help="Runs at a time, each in its own process (default: one per idle CPU, "
                   "at least 1, at most 4).")
@click.option("--quiet", "-q", is_flag=True,
              help="No progress line; of the runs only the failed ones are listed.")
@click.argument("names", nargs=-1, metavar="[NAME]...")
def reproduce_cmd(out_dir: Path, only: tuple[str, ...], no_report: bool, jobs: int | None,
                  quiet: bool, names: tuple[str, ...]) -> None:
    """Plan every built-in paper scenario and compare our numbers with the papers'.

    Writes OUT/<scenario>/ (plan and report.html) for each built-in paper scenario (and
    the switched-off variants the references compare against), then OUT/REPRODUCTION.md and
    OUT/reproduction.html: paper figure | quantity | paper | ours | difference | verdict for
    every number the papers publish and the reference runs' numbers ([RefRuns], see
    docs/references.md), each linked to its report. Each run is listed as it finishes.
    Examples:

    \b
      mmplan reproduce --out repro
      mmplan reproduce --out repro --only car-rtr-free wall-segment --no-report

    Exit code 0 when every scenario reached its task (even if a number differs), 3 when a
    scenario failed to plan (its row says why), 2 for bad input.
    """
    with _user_errors(), Progress(live_on(quiet)) as progress:
        from mmplan.reproduce.run import reproduce, run_specs
        from mmplan.reproduce.runs import RunOutcome

        selected = (*only, *names)
        specs = run_specs(selected)  # validates the names before any work
        width = max([36, *(len(spec.name) for spec in specs)])  # the names' column
        progress("reproducing")

        def advance(name: str, done: float, count: int) -> None:
            progress.describe(f"{name} ({min(int(done) + 1, count)}/{count})")
            progress.fraction(done / count)

        def finished(run: RunOutcome) -> None:
            failed = run.status != "reached" and run.spec.base is None
            if failed or not quiet:
                mark = "ok  " if run.status == "reached" else "FAIL" if failed else "    "
                progress.print(f"{mark} {run.spec.name:{width}s} {run.status:10s} "
                               f"{run.wall_time_s:6.1f} s" + (f"  (report: {run.report_error})"
                                                              if run.report_error else ""))

        result = reproduce(out_dir, selected, report=not no_report, progress=advance,
                           jobs=jobs, finished=finished)
        progress.close()
        verdicts = [row.verdict.split(" (")[0] for row in result.rows]
        counts = ", ".join(f"{v} {verdicts.count(v)}" for v in sorted(set(verdicts)))
        out.print(f"{len(result.rows)} numbers compared ({counts}) in {result.wall_time_s:.0f} s",
                  markup=False)
        out.print(f"wrote {result.markdown} and {result.html}", markup=False)
        if result.failed:
            raise SystemExit(3)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
