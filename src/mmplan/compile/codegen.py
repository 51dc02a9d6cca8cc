"""C code generation for CasADi functions, compiled with the system compiler and cached on disk.

:func:`compile_library` generates one C file for several functions with CasADi's
``CodeGenerator``, builds a shared library with ``gcc`` (or ``cc``) and returns its path;
:func:`load` turns it into ``casadi.external`` functions. Libraries are cached by the hash of
their source, the flags and the CasADi version in :func:`cache_dir`, so a problem of the same
shape compiles once; a concurrent build never exposes half a file (atomic rename). A large
file is cut into units compiled by one compiler process per core (:mod:`.split`), every build
without fused multiply-adds (the same numbers however it is cut, :data:`FIXED_FLAGS`).
Without a compiler, or when compiling fails, the caller keeps the CasADi virtual machine.
"""

from __future__ import annotations

import atexit
import ctypes
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any, TypeVar

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from mmplan.compile.split import Unit, split

T = TypeVar("T")

#: C bytes per compiler process (:func:`_units`; gcc -O2 spends about 7 us a byte of generated
#: code, on one core).
UNIT_BYTES = 100_000
#: Added to every build: no fused multiply-adds, so that a library computes the same bits
#: whatever the compiler inlines, however the source is cut into units and whatever the -O
#: level (contractions across an inlined call made the one-file and the two-unit builds of
#: youBot-3r's generator differ by up to 6e-9 in a plan with -march=native).
FIXED_FLAGS = ("-ffp-contract=off",)
#: Linker flags on Linux (a linker without them links without): the addresses a library
#: takes of its own exported functions (the describer, :func:`_describer`) are its own, not
#: those of a same-named function another library loaded globally (found by review: with
#: such a library loaded, a NativeFunction called the other one).
LINK_FLAGS = ("-Wl,-Bsymbolic-functions",)
#: Added for the code only rarely called functions reach (``cold`` of :func:`compile_library`):
#: youBot-3r's ``terms`` (called once a plan, 14 % of its generator's C) compiles in 0.17 s
#: instead of 0.9-1.0 s at -O2.
COLD_FLAGS = ("-O0",)


def cache_dir() -> Path:
    """Folder of the compiled libraries: ``$MMPLAN_CACHE`` or ``$TMPDIR/mmplan-codegen``."""
    return _cache_dir(os.environ.get("MMPLAN_CACHE"), tempfile.gettempdir())


@lru_cache(maxsize=16)
def _cache_dir(given: str | None, temporary: str) -> Path:
    # remembered: a plan asks a few dozen times (the robot's compiled functions look it up
    # at each call), each a Path of a few us
    return Path(given) if given is not None else Path(temporary) / "mmplan-codegen"


def compiler() -> str | None:
    """Path of the C compiler (``$CC`` when set, else gcc or cc), None when there is none
    (looked up once per value of ``$CC`` and ``$PATH``: a lookup costs 1-5 ms and a plan asks
    several times). A ``$CC`` naming one program that is not found is no compiler (not another
    one in its place: a new user's ``CC=/nonexistent`` compiled with cc); a ``$CC`` with
    arguments (``ccache gcc``), which this module cannot pass on, is not used (gcc or cc)."""
    return _which(_given_cc(), os.environ.get("PATH", ""))


def _given_cc() -> str | None:
    cc = os.environ.get("CC", "").strip()
    return cc if cc and len(cc.split()) == 1 else None


@lru_cache(maxsize=8)
def _which(cc: str | None, path: str) -> str | None:
    if cc:
        return shutil.which(cc, path=path)
    return shutil.which("gcc", path=path) or shutil.which("cc", path=path)


def no_compiler() -> str:
    """What is missing, for a notice: no compiler found, or ``$CC`` not found."""
    cc = _given_cc()
    return f"the C compiler $CC = {cc} was not found" if cc else "no C compiler found"


def _source(functions: Sequence[ca.Function]) -> str:
    gen = ca.CodeGenerator("mmplan_gen.c", {"with_header": False})
    for f in functions:
        gen.add(f)
    return str(gen.dump()) + _describer([f.name() for f in functions])


#: Numbers :func:`_describer`'s function writes before the sparsity patterns.
_HEAD = 8
#: The describer's symbol; a new layout of its numbers gets a new name (a library of another
#: layout, e.g. in a cache folder shared between versions, is then read symbol by symbol).
_DESCRIBE = "mmplan_describe_v1"
#: ``out[0]`` of the describer: not exported, no outputs, an input not dense (its index in
#: ``out[1]``).
_ABSENT, _NO_OUTPUT, _SPARSE_INPUT = -1, -2, -3
_DESCRIBE_ONE = """
/* mmplan: what codegen.NativeFunction needs of an exported function, in one call (its work
   sizes, its memory, the sparsity of its inputs and of its first output): ctypes looked up
   six symbols and called each once, 0.15-0.2 ms a function in a new process. o: [0] the
   numbers written (or needed, when more than cap; negative: not described, codegen.py),
   [1] sizeof(casadi_int), [2..5] the work sizes, [6] inputs, [7] the checked-out memory,
   then the patterns as CasADi stores them. Nothing is checked out unless all is written. */
__attribute__((visibility("hidden"))) void* mmplan_describe_one(long long* o, long long cap,
    int (*work)(casadi_int*, casadi_int*, casadi_int*, casadi_int*), casadi_int (*n_in)(void),
    casadi_int (*n_out)(void), const casadi_int* (*sp_in)(casadi_int),
    const casadi_int* (*sp_out)(casadi_int), void (*incref)(void), int (*checkout)(void),
    void* fn) {
  casadi_int sz[4], i, k, n = n_in(), len, at = %(head)d;
  const casadi_int* sp;
  if (n_out() < 1) { o[0] = %(no_output)d; return 0; }
  for (i = 0; i <= n; ++i) {
    sp = i < n ? sp_in(i) : sp_out(0);
    if (i < n && sp[2] != 1) { o[0] = %(sparse_input)d; o[1] = i; return 0; }
    at += sp[2] == 1 ? 3 : 3 + sp[1] + sp[2 + sp[1]];
  }
  o[0] = at;
  if (at > cap) return 0;
  work(sz, sz + 1, sz + 2, sz + 3);
  o[1] = (long long) sizeof(casadi_int);
  for (k = 0; k < 4; ++k) o[2 + k] = sz[k];
  o[6] = n;
  at = %(head)d;
  for (i = 0; i <= n; ++i) {
    sp = i < n ? sp_in(i) : sp_out(0);
    len = sp[2] == 1 ? 3 : 3 + sp[1] + sp[2 + sp[1]];
    for (k = 0; k < len; ++k) o[at + k] = sp[k];
    at += len;
  }
  incref();
  o[7] = checkout();
  return fn;
}

__attribute__((visibility("hidden"))) int mmplan_describe_same(const char* a, const char* b) {
  while (*a && *a == *b) { ++a; ++b; }
  return *a == *b;
}
"""


def _describer(names: Sequence[str]) -> str:
    """C appended to a generated library: ``mmplan_describe_v1(name, out, cap)``, everything
    :class:`NativeFunction` needs of the function ``name`` in one call (a null pointer and a
    negative ``out[0]`` when it cannot: :data:`_ABSENT` and the others). Its own names are
    prefixed (a generated function named ``out`` or ``strcmp`` must not be shadowed, review);
    the library is linked so that these addresses are its own (:func:`_compile`)."""
    cases = "".join(
        f'  if (mmplan_describe_same(mmplan_name, "{n}")) return mmplan_describe_one(mmplan_o, '
        f"mmplan_cap, {n}_work, {n}_n_in, {n}_n_out, {n}_sparsity_in, {n}_sparsity_out, "
        f"{n}_incref, {n}_checkout, (void*) {n});\n"
        for n in names
    )
    head = {"head": _HEAD, "no_output": _NO_OUTPUT, "sparse_input": _SPARSE_INPUT}
    return (
        _DESCRIBE_ONE % head
        + f"CASADI_SYMBOL_EXPORT void* {_DESCRIBE}(const char* mmplan_name, "
        + "long long* mmplan_o, long long mmplan_cap) {\n"
        + cases
        + f"  mmplan_o[0] = {_ABSENT};\n  return 0;\n}}\n"
    )


def _library(source: str, prefix: str, flags: Sequence[str]) -> Path:
    cpu = host() if native_flags(flags) else ""  # -march=native: this CPU's code
    if len(source) > _REMEMBERED:  # a generated source, asked for once or twice
        return cache_dir() / _file_name(source, prefix, tuple(flags), cpu)
    return cache_dir() / _remembered_name(source, prefix, tuple(flags), cpu)


#: Longest source (or key) whose library name is remembered (:func:`_remembered_name`).
_REMEMBERED = 65_536


def _file_name(source: str, prefix: str, flags: tuple[str, ...], cpu: str) -> str:
    """The library's file name: a hash of its source (or key), flags, CasADi's version and
    the CPU (:func:`host`, for -march=native code; else empty)."""
    parts = [source, *flags, *FIXED_FLAGS, ca.CasadiMeta.version()]
    if cpu:
        parts.append(cpu)
    key = "\n".join(parts)
    return f"{prefix}_{hashlib.sha256(key.encode()).hexdigest()[:20]}.so"


@lru_cache(maxsize=64)
def _remembered_name(source: str, prefix: str, flags: tuple[str, ...], cpu: str) -> str:
    """:func:`_file_name`, remembered: a process asks 3-4 times for each of the time
    scaling's and the thread helper's libraries (their 9-30 kB sources hashed each time)."""
    return _file_name(source, prefix, flags, cpu)


def native_flags(flags: Sequence[str]) -> bool:
    """The flags compile for this machine's CPU (-march=native and the like)."""
    return any(f.endswith("=native") for f in flags)


@lru_cache(maxsize=1)
def host() -> str:
    """What -march=native compiles for, as a short hash: the first processor's model and
    feature flags (Linux: /proc/cpuinfo) and the platform's machine and processor names. In
    the key of every library built for the native CPU, so that a cache folder shared between
    machines (``$MMPLAN_CACHE`` on a network home) never hands one CPU's instructions to
    another (an illegal instruction kills the process; a missing key only costs a build).
    The processor's name from :func:`platform.processor` only where /proc/cpuinfo is missing:
    on Linux it runs ``uname -p`` in a subprocess (1.6 ms of a command's first plan, measured)
    and adds nothing to the model name and flags."""
    import platform

    wanted = ("model name", "flags", "Features", "CPU implementer", "CPU part")
    found: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as info:
            for line in info:
                name = line.split(":", 1)[0].strip()
                if name in wanted and name not in found:
                    found[name] = line.strip()
                if not line.strip() and found:  # the first processor's block is enough
                    break
    except OSError:
        pass
    name = platform.processor() if not found else ""
    text = "\n".join([platform.machine(), name, *sorted(found.values())])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def is_cached(functions: Sequence[ca.Function], prefix: str, flags: Sequence[str]) -> bool:
    """True when the library of ``functions`` is already built (no compile needed)."""
    return _library(_source(functions), prefix, flags).exists()


def compile_library(
    functions: Sequence[ca.Function] | Callable[[], Sequence[ca.Function]],
    prefix: str,
    flags: Sequence[str] = ("-O2",),
    notify: Callable[[str], None] | None = None,
    key: str | None = None,
    cold: Sequence[str] = (),
    fallback: Sequence[str] | None = None,
) -> str | None:
    """Compile ``functions`` into one cached shared library; its path, or None on failure.

    Args:
        functions: CasADi functions (loaded back by name with :func:`load`), or a callable
            making them (called only when the library must be built; needs ``key``).
        prefix: File-name prefix in the cache folder.
        flags: C compiler flags (``-shared -fPIC`` are added).
        notify: Called with a message before a (slow) build that is not cached.
        key: Cache key that determines the functions (default: their generated source).
        cold: Names of functions called rarely (once a plan): the code only they reach is
            compiled with :data:`COLD_FLAGS` (:func:`_build`).
        fallback: Plainer flags for a compiler that rejects one of ``flags`` (e.g. an
            Apple clang without -march=native): built when ``flags`` fail, and taken from
            the cache by later runs without trying ``flags`` again.
    """
    cc = compiler()
    if cc is None:
        return None
    sets = _flag_sets(flags, fallback)
    if key is not None:
        for f in sets:
            library = _library(key, prefix, [*f, *cold])  # the flags are in the key
            if library.exists():
                return str(library)
    if callable(functions):
        if key is None:
            raise ValueError("a lazily made library needs a key")
        functions = functions()
    source = _source(functions)
    for i, f in enumerate(sets):
        library = _library(key if key is not None else source, prefix, [*f, *cold])
        if library.exists():
            return str(library)
        if notify is not None and i == 0:
            notify(f"compiling {prefix} to C (once; cached in {library.parent})")
        if _build(cc, source, library, prefix, f, cold):
            return str(library)
    return None


def _flag_sets(flags: Sequence[str], fallback: Sequence[str] | None) -> list[tuple[str, ...]]:
    """The flag sets to try in order: ``flags``, then ``fallback`` (when given and other)."""
    sets = [tuple(flags)]
    if fallback is not None and tuple(fallback) != sets[0]:
        sets.append(tuple(fallback))
    return sets


def _units(source: str, cold: Sequence[str] = ()) -> list[Unit]:
    """``source`` cut into translation units (:mod:`.split`): one per ``UNIT_BYTES``, at
    most one per idle core, and one for the code only the functions ``cold`` reach.

    Idle cores: the cores less the load average besides this process. On a busy machine
    the scheduler shares the cores between sessions (autogroup), not processes, so more
    compiler processes than idle cores only share this session's part (2 cores at load ~3:
    first youBot-3r plans with its generator in two processes took 7.5-8.9 s, with one
    6.8-7.8 s)."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    idle = max(1, round((cores or 1) - max(0.0, os.getloadavg()[0] - 1.0)))
    return split(source, min(idle, -(-len(source) // UNIT_BYTES)), cold)


def _compile(cc: str, units: Sequence[Unit], so_file: Path, flags: Sequence[str]) -> bool:
    """Compile ``units`` by parallel compiler processes (a cold one with :data:`COLD_FLAGS`
    added) and link them into ``so_file``."""
    objects = [so_file.with_name(f"{so_file.stem}_{i}.o") for i in range(len(units))]
    runs: list[subprocess.Popen[bytes]] = []
    try:
        for unit, obj in zip(units, objects, strict=True):
            obj.with_suffix(".c").write_text(unit.text)
            cmd = [cc, *flags, *(COLD_FLAGS if unit.cold else ()), "-fPIC", "-c",
                   str(obj.with_suffix(".c")), "-o", str(obj)]  # fmt: skip
            runs.append(subprocess.Popen(cmd, stdout=subprocess.DEVNULL,
                                         stderr=subprocess.DEVNULL))  # fmt: skip
        if any(run.wait(timeout=900) for run in runs):
            return False
    finally:
        for run in runs:  # a failed or timed-out build leaves no compiler running
            if run.poll() is None:
                run.kill()
                run.wait()
    link = [cc, *flags, "-shared", *map(str, objects), "-o", str(so_file), "-lm"]
    if sys.platform.startswith("linux"):  # the library's own functions bind to themselves
        bound = [*link[:-1], *LINK_FLAGS, link[-1]]
        if subprocess.run(bound, capture_output=True, timeout=900).returncode == 0:
            return True
    return subprocess.run(link, capture_output=True, timeout=900).returncode == 0


def _build(
    cc: str, source: str, library: Path, prefix: str, flags: Sequence[str],
    cold: Sequence[str] = (),
) -> bool:  # fmt: skip
    """Compile ``source`` into ``library`` (atomic rename); False on failure. A large
    generated source is cut into units compiled in parallel (:func:`_units`; the one-file
    build if that fails); every build adds :data:`FIXED_FLAGS`."""
    # mkdtemp and rmtree, not TemporaryDirectory: its weakref finalizer runs at interpreter
    # exit, possibly before the exit handler that waits for a background build
    # (:func:`mmplan.compile.threads.prefetch`), and removed the folder under the compiler
    # (measured: 20 of 30 processes that exited during the build left no library)
    tmp = ""
    try:
        library.parent.mkdir(parents=True, exist_ok=True)
        tmp = tempfile.mkdtemp(dir=library.parent)
        so_file = Path(tmp) / f"{prefix}.so"
        units = _units(source, cold)
        tries = [units, [Unit(source)]] if len(units) > 1 else [units]
        if not any(_compile(cc, u, so_file, [*flags, *FIXED_FLAGS]) for u in tries):
            return False
        os.replace(so_file, library)
    except (OSError, subprocess.SubprocessError):
        return False
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    return True


def compile_source(source: str, prefix: str, flags: Sequence[str] = ("-O2",)) -> str | None:
    """Compile the C ``source`` (written by hand, e.g. :mod:`mmplan.time_scaling.native`)
    into a shared library cached like :func:`compile_library`'s; its path, or None without a
    compiler or when the build fails."""
    cc = compiler()
    if cc is None:
        return None
    library = _library(source, prefix, flags)
    if library.exists():
        return str(library)
    return str(library) if _build(cc, source, library, prefix, flags) else None


def load_source(
    source: str,
    prefix: str,
    flags: Sequence[str],
    make: Callable[[ctypes.CDLL], T],
    fallback: Sequence[str] | None = None,
) -> T | None:
    """``make(library)`` of :func:`compile_source`'s library of ``source``, loaded with
    ctypes; None without a compiler, when the build fails or when the cached file does not
    load here (damaged, a missing symbol): the caller keeps its fallback.

    ``fallback``: plainer flags for a compiler that rejects one of ``flags`` (e.g. gcc's
    -fvect-cost-model elsewhere): a library built with them on an earlier run is taken as it
    is, without trying ``flags`` again."""
    sets = _flag_sets(flags, fallback)
    cached = [f for f in sets if _library(source, prefix, f).exists()]
    for f in cached or sets:
        path = compile_source(source, prefix, f)
        if path is None:
            continue
        try:
            return make(ctypes.CDLL(path))
        except (OSError, AttributeError):
            continue
    return None


def source_is_cached(
    source: str, prefix: str, flags: Sequence[str] = ("-O2",),
    fallback: Sequence[str] | None = None,
) -> bool:  # fmt: skip
    """True when :func:`load_source` would load ``source``'s library without a build (with
    ``flags``, or with ``fallback`` when given)."""
    return any(_library(source, prefix, f).exists() for f in _flag_sets(flags, fallback))


def start_build(
    make: Callable[[], Sequence[ca.Function]],
    prefix: str,
    key: str,
    flags: Sequence[str] = ("-O2",),
    cold: Sequence[str] = (),
) -> threading.Thread | None:
    """Start building the library :func:`compile_library` would build under ``key``: the C
    source is generated here (CasADi is used from this thread only), the compiler runs in a
    background thread (returned; join it before :func:`compile_library` looks for the file).
    None when the library exists or there is no compiler."""
    cc = compiler()
    library = _library(key, prefix, [*flags, *cold])
    if cc is None or library.exists():
        return None
    source = _source(make())
    return in_background(_build, cc, source, library, prefix, flags, cold)


#: Builds started by :func:`in_background`, waited for when the process exits.
_BACKGROUND: list[threading.Thread] = []


def in_background(target: Callable[..., object], *args: Any) -> threading.Thread:
    """Run a build ``target(*args)`` on a thread of its own, now; the process waits for it
    when it exits (an exit handler, which ``mmplan`` commands run before their fast exit).
    Found by a new-user trial: ``mmplan plan`` ended before the second-core helper's build
    was done, so the helper never reached the disk and no command used the second core."""
    thread = threading.Thread(target=target, args=args, daemon=True)
    thread.start()
    _BACKGROUND.append(thread)
    return thread


def _finish_builds() -> None:
    for thread in _BACKGROUND:
        thread.join(timeout=60.0)


atexit.register(_finish_builds)


def compile_function(
    function: ca.Function, flags: Sequence[str] = ("-O2",)
) -> tuple[ca.Function, str]:
    """A C-compiled equivalent of ``function`` (cached library named after it) and the backend
    used, ``"c"``; ``(function, "vm")`` without a compiler or when compiling fails."""
    if compiler() is None:
        notice(f"{no_compiler()}: {function.name()} runs on CasADi's virtual machine")
        return function, "vm"
    library = compile_library([function], function.name(), flags)
    if library is None:
        return function, "vm"
    try:
        return load([function.name()], library)[0], "c"
    except RuntimeError:
        return function, "vm"


_NOTICES: set[str] = set()


def notice(message: str) -> None:
    """One line on stderr, once per process and message (a slow build, no compiler)."""
    if message not in _NOTICES:
        _NOTICES.add(message)
        print(f"mmplan: {message}", file=sys.stderr, flush=True)


def load(names: Sequence[str], library: str) -> list[ca.Function]:
    """The functions ``names`` of a compiled library as ``casadi.external``."""
    return [ca.external(name, library) for name in names]


@lru_cache(maxsize=64)
def _cdll(path: str) -> ctypes.CDLL:
    """The library at ``path`` loaded once per process (its functions share one handle; a
    file replaced or removed later does not change what was loaded)."""
    return ctypes.CDLL(path)


class _Pattern:
    """A sparsity pattern as CasADi's generated code writes it: [rows, cols, 1] when dense,
    else [rows, cols, column starts (cols + 1), row of each nonzero]."""

    def __init__(self, shape: tuple[int, int], rows: Any = None, cols: Any = None) -> None:
        self.shape = shape
        self.rows, self.cols = rows, cols
        self.nnz = shape[0] * shape[1] if rows is None else len(rows)

    @classmethod
    def read(cls, sp: Any) -> _Pattern:
        """The pattern a generated ``*_sparsity_*`` function returns (a C pointer)."""
        ncol = int(sp[1])
        length = 3 if int(sp[2]) == 1 else 3 + ncol + int(sp[2 + ncol])
        return cls.parse(np.array([int(sp[k]) for k in range(length)], dtype=np.int64), 0)[0]

    @classmethod
    def parse(cls, numbers: NDArray[np.int64], at: int) -> tuple[_Pattern, int]:
        """The pattern stored at ``numbers[at:]`` and where the next starts."""
        nrow, ncol = int(numbers[at]), int(numbers[at + 1])
        if int(numbers[at + 2]) == 1:  # dense (a sparse pattern's first column starts at 0)
            return cls((nrow, ncol)), at + 3
        starts = numbers[at + 2 : at + 3 + ncol]
        nnz = int(starts[-1])
        rows = numbers[at + 3 + ncol : at + 3 + ncol + nnz].astype(np.intp)
        cols = np.repeat(np.arange(ncol), np.diff(starts))
        return cls((nrow, ncol), rows, cols), at + 3 + ncol + nnz

    def dense(self, values: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.rows is None:
            return np.array(values).reshape(self.shape, order="F")
        out = np.zeros(self.shape)
        out[self.rows, self.cols] = values
        return out


#: A described function: casadi_int's ctypes type, the work sizes (arg, res, iw, w), the
#: input patterns, the first output's pattern, the ctypes function and its memory.
_Described = tuple[Any, tuple[int, int, int, int], list[_Pattern], _Pattern, Any, int]


@lru_cache(maxsize=64)
def _describe(path: str) -> Any:
    """The library's describer (:data:`_DESCRIBE`, :func:`_describer`), None when it has
    none."""
    try:
        describe = getattr(_cdll(path), _DESCRIBE)
    except AttributeError:
        return None
    describe.restype = ctypes.c_void_p
    describe.argtypes = (ctypes.c_char_p, ctypes.c_void_p, ctypes.c_longlong)
    return describe


def _described(lib: ctypes.CDLL, path: str, name: str) -> _Described | None:
    """What :class:`NativeFunction` needs of ``name``, from one call of the library's
    describer; None when the library has none. Raises AttributeError when the library does
    not export ``name`` (as a symbol lookup does), ValueError for a function without outputs
    or with an input that is not dense (nothing checked out then)."""
    describe = _describe(path)
    if describe is None:
        return None
    out = np.zeros(256, dtype=np.int64)
    address = describe(name.encode(), out.ctypes.data, len(out))
    if not address and out[0] > len(out):  # long sparsity patterns
        out = np.zeros(int(out[0]), dtype=np.int64)
        address = describe(name.encode(), out.ctypes.data, len(out))
    if not address:
        if out[0] == _SPARSE_INPUT:
            raise ValueError(f"{name}: input {int(out[1])} is not dense")
        if out[0] == _NO_OUTPUT:
            raise ValueError(f"{name}: no output")
        raise AttributeError(f"{path}: no function {name}")
    cint = ctypes.c_longlong if int(out[1]) == 8 else ctypes.c_int
    sizes = tuple(max(1, int(x)) for x in out[2:6])
    patterns, at = [], _HEAD
    for _ in range(int(out[6]) + 1):  # the inputs, then the first output
        pattern, at = _Pattern.parse(out, at)
        patterns.append(pattern)
    function = lib._FuncPtr(address)  # as getattr(lib, name), without the symbol lookup
    return cint, sizes, patterns[:-1], patterns[-1], function, int(out[7])  # type: ignore[return-value]


def _looked_up(lib: ctypes.CDLL, name: str) -> _Described:
    """What :class:`NativeFunction` needs of ``name``, symbol by symbol (a library without
    the describer)."""
    cint = ctypes.c_longlong if lib.mmplan_gen_casadi_int_size() == 8 else ctypes.c_int
    sizes = [cint() for _ in range(4)]
    getattr(lib, f"{name}_work")(*(ctypes.byref(x) for x in sizes))
    count = getattr(lib, f"{name}_n_in")
    count.restype = cint
    sparsity = getattr(lib, f"{name}_sparsity_in")
    sparsity.restype = ctypes.POINTER(cint)
    ins = [_Pattern.read(sparsity(i)) for i in range(int(count()))]
    sparsity = getattr(lib, f"{name}_sparsity_out")
    sparsity.restype = ctypes.POINTER(cint)
    out = _Pattern.read(sparsity(0))
    getattr(lib, f"{name}_incref")()
    mem = int(getattr(lib, f"{name}_checkout")())
    work = tuple(max(1, int(x.value)) for x in sizes)
    return cint, work, ins, out, getattr(lib, name), mem  # type: ignore[return-value]


def _address(array: NDArray[Any]) -> ctypes.c_void_p:
    """The address of ``array``'s data as a ctypes object that keeps ``array`` alive (a
    :class:`mmplan.compile.threads.Job` holding it keeps the buffer)."""
    pointer = ctypes.c_void_p(array.ctypes.data)
    pointer._mmplan_owner = array  # type: ignore[attr-defined]
    return pointer


class NativeFunction:
    """A compiled function called via ctypes: its inputs (dense) concatenated in ``x``, its
    first output's nonzeros in ``y`` (:meth:`dense` scatters them into the full matrix).

    Skips the CasADi Python call (about 10-15 us a call, and the first ``casadi.external`` of
    a process, about 0.45 ms): the inputs are written into a preallocated buffer and the
    generated C function is called directly. The same C code as CasADi's call, the same bits.
    """

    def __init__(self, library: str, name: str) -> None:
        lib = _cdll(library)
        described = _described(lib, library, name)
        if described is None:  # a library built without mmplan_describe
            described = _looked_up(lib, name)
        cint, (n_arg, n_res, n_iw, n_w), ins, self.pattern, self._fn, self._mem = described
        # the pointer and integer arrays as NumPy arrays, passed by address: a ctypes array
        # type per length is made at its first use in a process (eight functions' set-ups in a
        # first plan took about 0.7 of their time without them, measured)
        self.x, self.y = np.zeros(sum(p.nnz for p in ins)), np.zeros(self.pattern.nnz)
        #: Inputs of the function (all dense, concatenated in ``x``).
        self.inputs = len(ins)
        self._w = np.zeros(n_w)
        self._iw = np.zeros(n_iw, dtype=np.int64 if ctypes.sizeof(cint) == 8 else np.int32)
        self._arg, self._res = np.zeros(n_arg, dtype=np.uintp), np.zeros(n_res, dtype=np.uintp)
        at = 0
        for i, p in enumerate(ins):  # each input's part of x (dense inputs only)
            if p.rows is not None:
                raise ValueError(f"{name}: input {i} is not dense")
            self._arg[i] = self.x.ctypes.data + 8 * at
            at += p.nnz
        self._res[0] = self.y.ctypes.data
        # ctypes objects made once: a call passes them as they are (0.76 us a call against
        # 0.98 us for addresses converted by declared argument types, measured)
        self._args = (*(_address(a) for a in (self._arg, self._res, self._iw, self._w)),
                      ctypes.c_int(self._mem))  # fmt: skip
        self._lib = lib

    def dense(self) -> NDArray[np.float64]:
        """The first output of the last call as a full (rows, cols) array (a copy)."""
        return self.pattern.dense(self.y)

    def has(self, name: str) -> bool:
        """The library defines the symbol ``name``."""
        return hasattr(self._lib, name)

    def signature(self) -> tuple[Any, Any, Any, Any, Any, Any]:
        """The ctypes function and its fixed arguments (arg, res, iw, w, mem): to call it from
        C, e.g. on a thread of its own (:mod:`mmplan.compile.threads`)."""
        return (self._fn, *self._args)

    def __call__(self) -> NDArray[np.float64]:
        """Evaluate at the current ``self.x``; returns ``self.y`` (overwritten by the next call)."""
        if self._fn(*self._args):
            raise RuntimeError("compiled function failed")
        return self.y
