"""Temporary directories that name their owner, and removal of those whose owner is gone.

:func:`owned_temp_dir` makes ``.<name>.<kind>-<pid>-<start>-XXXXXXXX`` next to the target
(``kind`` is ``tmp`` for a plan being written, ``old`` for a plan moved aside while it is
replaced; ``start`` is the owner's start time in clock ticks since boot, from
``/proc/<pid>/stat``, so a reused PID is not mistaken for the owner) and holds an exclusive
``flock`` on it until :func:`release`. A process killed mid-write (``kill -9``) leaves the
directory; :func:`remove_stale` removes it on the next write into the same parent when

* nobody holds its lock (a live writer always does; locks die with their process, whatever
  PID namespace the cleaner runs in), and
* its owner PID is not running, or runs with another start time (the PID was reused).

A stale ``old`` directory holds the previous plan under the target's name; when the target
is missing (the writer died between its two renames) that plan is put back, else it is
removed. Directories named otherwise (e.g. by mmplan versions before this scheme) are never
touched.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: ownership by PID and start time only
    fcntl = None  # type: ignore[assignment]

#: ``.<name>.<kind>-<pid>-<start>-<8 mkdtemp characters>``
_NAME = re.compile(r"^\..*\.(?P<kind>tmp|old)-(?P<pid>\d+)-(?P<start>\d+)-[a-z0-9_]{8}$")
#: Longest part of the target's name kept in a temporary name (NAME_MAX is 255).
_NAME_KEPT = 180


def start_time(pid: int) -> int:
    """Start time of process ``pid`` in clock ticks since boot; 0 when unknown (no /proc).

    Raises:
        ProcessLookupError: no such process (where /proc exists).
    """
    try:
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
    except FileNotFoundError:
        if Path("/proc/self/stat").exists():
            raise ProcessLookupError(pid) from None
        return 0
    except OSError:
        return 0
    fields = stat[stat.rfind(")") + 2:].split()  # after "pid (comm) ": field 3 (state) on
    try:
        return int(fields[19])  # field 22: starttime
    except (IndexError, ValueError):
        return 0


def owned_temp_dir(target: Path, kind: str) -> tuple[Path, int | None]:
    """A new ``.<name>.<kind>-<pid>-<start>-*`` directory next to ``target``, locked.

    Returns:
        The directory and the descriptor holding its lock (pass it to :func:`release`).
    """
    pid = os.getpid()
    try:
        start = start_time(pid)
    except ProcessLookupError:  # pragma: no cover - we are running
        start = 0
    prefix = f".{target.name[:_NAME_KEPT]}.{kind}-{pid}-{start}-"
    folder = Path(tempfile.mkdtemp(prefix=prefix, dir=target.parent))
    return folder, _lock(folder)


def release(lock: int | None) -> None:
    """Drop the lock taken by :func:`owned_temp_dir`."""
    if lock is not None:
        os.close(lock)


def remove_stale(parent: Path) -> list[Path]:
    """Remove (or put back) the temporary directories in ``parent`` whose owner is gone.

    Best effort: a directory that cannot be examined or removed is left alone.

    Returns:
        The directories handled.
    """
    handled: list[Path] = []
    try:
        entries = [e for e in os.scandir(parent) if e.name.startswith(".")]
    except OSError:
        return handled
    for entry in entries:
        match = _NAME.match(entry.name)
        if match is None or not entry.is_dir(follow_symlinks=False):
            continue
        folder = Path(entry.path)
        if _owner_alive(int(match["pid"]), int(match["start"])):
            continue
        try:
            lock = _lock(folder, wait=False)
        except (BlockingIOError, PermissionError):
            continue  # a live writer holds it
        except OSError:
            continue  # gone meanwhile, or not ours to open
        try:
            if match["kind"] == "old":
                _put_back(folder, parent)
            shutil.rmtree(folder, ignore_errors=True)
            handled.append(folder)
        finally:
            release(lock)
    return handled


def _put_back(old: Path, parent: Path) -> None:
    """The plan moved aside in ``old`` back to its name, unless that name exists again."""
    try:
        inside = list(old.iterdir())
        if len(inside) == 1 and inside[0].is_dir() and not inside[0].is_symlink():
            target = parent / inside[0].name
            if not os.path.lexists(target):
                os.replace(inside[0], target)
    except OSError:
        pass


def _owner_alive(pid: int, start: int) -> bool:
    """True when process ``pid`` runs and (where known) started at ``start``."""
    if os.name != "posix":  # pragma: no cover - os.kill(pid, 0) would end the process
        return True
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # exists, another user's
    except OSError:
        return True  # cannot tell: keep it
    try:
        now = start_time(pid)
    except ProcessLookupError:
        return False
    return start == 0 or now == 0 or now == start


def _lock(folder: Path, wait: bool = True) -> int | None:
    """An open descriptor of ``folder`` holding an exclusive flock (None without fcntl).

    Raises:
        BlockingIOError: ``wait`` is False and another process holds the lock.
    """
    if fcntl is None:  # pragma: no cover
        return None
    fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except BaseException:
        os.close(fd)
        raise
    return fd
