"""A CasADi-generated C file cut into translation units that compile in parallel.

gcc spends about 7 us per byte of the generated code (youbot-3r's generator: 677 kB, 4.8 s at
-O2) and uses one core; the file is a preamble (macros, sparsity patterns, small helpers)
followed by one ``static int casadi_fN(...)`` per CasADi function and the exported API.
:func:`split` cuts it at the top level: each unit gets the preamble's macros and constant data
and a prototype of every function, the functions are dealt out by size, the exported API goes
to the first unit and CasADi's small helpers (``casadi_sq``, ...) become static copies in every
unit (:func:`_local`: inlined, not called); the functions that only rarely called entry points reach
(``cold``, found through the calls in the code) get a unit of their own, which the caller
compiles without optimisation. The generated functions lose ``static`` (they are called
across units) and become hidden, so the linked library exports what the one-file build
exports (less the helpers). The numbers stay those of the one-file build only without fused
multiply-adds (:data:`mmplan.compile.codegen.FIXED_FLAGS`): gcc fuses across the calls it
inlines, and what it inlines depends on the unit.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

#: A generated function as CasADi writes it (``static int casadi_f12(...)``).
_WORKER = re.compile(r"static int (casadi_f\d+)\(")
_CALL = re.compile(r"\b(casadi_f\d+)\(")
_HIDDEN = '__attribute__((visibility("hidden"))) int'
#: A name CasADi's source renames (``#define casadi_sq CASADI_PREFIX(sq)``).
_PREFIXED = re.compile(r"#define (\w+) CASADI_PREFIX\(")
#: What :func:`items` stops at inside an item, outside and inside braces.
_TOP = re.compile(r"/\*|//|[\"'{};]")
_NESTED = re.compile(r"/\*|//|[\"'{}]")


def _skip_comment(src: str, i: int) -> int:
    return src.index("*/", i + 2) + 2


def _skip_string(src: str, i: int) -> int:
    quote, i = src[i], i + 1
    while src[i] != quote:
        i += 2 if src[i] == "\\" else 1
    return i + 1


def items(src: str) -> list[tuple[str, str]]:
    """Top-level items of C source in order, as ``(kind, text)``: ``"line"`` (a preprocessor
    line or a comment), ``"decl"`` (up to a ``;``: data, a prototype) or ``"func"`` (a
    function definition).

    Between an item's start and its end only comments, strings, braces and (outside braces)
    semicolons matter: the scan jumps from one to the next with a regular expression
    (youBot-3r's 677 kB generator: 0.011 s, against 0.32-0.40 s character by character, the
    same items; 0.9 s of a profiled first compile on a loaded machine)."""
    out: list[tuple[str, str]] = []
    i = start = depth = 0
    n = len(src)
    while i < n:
        if depth == 0 and i == start:
            c = src[i]
            if c in " \t\n":
                i = start = i + 1
                continue
            if c == "#":
                end = src.index("\n", i) + 1
                while src.endswith("\\\n", 0, end):  # a continued line
                    end = src.index("\n", end) + 1
                out.append(("line", src[i:end]))
                i = start = end
                continue
            if src.startswith(("/*", "//"), i):
                end = _skip_comment(src, i) if src[i + 1] == "*" else src.index("\n", i) + 1
                out.append(("line", src[i:end]))
                i = start = end
                continue
        found = (_NESTED if depth else _TOP).search(src, i)
        if found is None:
            break
        i, token = found.start(), found.group()
        if token == "/*":
            i = _skip_comment(src, i)
        elif token == "//":
            i = src.index("\n", i)
        elif token in "\"'":
            i = _skip_string(src, i)
        elif token == "{":
            depth, i = depth + 1, i + 1
        elif token == "}":
            depth, i = depth - 1, i + 1
            text = src[start:i]
            if depth == 0 and text[: text.index("{")].rstrip().endswith(")"):
                out.append(("func", text))
                start = i
        else:  # ";" outside braces
            out.append(("decl", src[start : i + 1]))
            i = start = i + 1
    if src[start:].strip():
        raise ValueError("unterminated C source")
    return out


@dataclass(frozen=True)
class Unit:
    """A translation unit; ``cold``: only functions behind rarely called entry points."""

    text: str
    cold: bool = False


def _helper(text: str, renamed: set[str]) -> bool:
    """True for a non-static function whose name CasADi renames by ``CASADI_PREFIX`` (its
    small helpers: ``casadi_sq``, ``casadi_fmax``, ``casadi_copy``, ...)."""
    head = text[: text.index("{")]
    return not head.lstrip().startswith("static") and _name(head) in renamed


def _local(src: str, helpers: Sequence[str]) -> str:
    """``src`` with the ``helpers`` made ``static``.

    CasADi writes its helpers as global functions. In a shared library built with -fPIC a
    global function may be replaced at load time (semantic interposition), so gcc calls it
    through the procedure linkage table and never inlines it: on youBot-3r's generator
    casadi_sq, casadi_fmax, casadi_fabs and casadi_copy took about 10 % of a chunk's time
    as calls (perf). Static, they are inlined; the numbers are the same (no fused
    multiply-adds, :data:`mmplan.compile.codegen.FIXED_FLAGS`)."""
    for text in helpers:
        src = src.replace(text, f"static {text}", 1)
    return src


def _name(head: str) -> str:
    return head[: head.index("(")].split()[-1]


def _reached(roots: Iterable[str], calls: dict[str, set[str]]) -> set[str]:
    seen: set[str] = set()
    todo = list(roots)
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            todo.extend(calls.get(name, ()))
    return seen


def split(src: str, parts: int, cold: Sequence[str] = ()) -> list[Unit]:
    """``src`` as at most ``parts`` translation units (the first one holds the exported API),
    plus a cold unit with the generated functions that only the exported functions ``cold``
    reach. One unit, ``src`` itself, when there is nothing to cut: ``parts`` is 1 and no
    function is cold, at most one generated function, or a function inside an ``#if``
    block."""
    try:
        top = items(src)
    except (ValueError, IndexError):  # unbalanced, unterminated: not CasADi's C
        return [Unit(src)]
    renamed = set(_PREFIXED.findall(src))
    helpers = [t for k, t in top if k == "func" and _helper(t, renamed)]
    whole = [Unit(_local(src, helpers))]
    common: list[str] = []  # macros and static data: every unit
    protos: list[str] = []
    workers: dict[str, str] = {}
    first: list[str] = []  # helpers, the exported API and global data: the first unit
    calls: dict[str, set[str]] = {}
    level = 0  # of #if blocks: a function or data inside one is not moved
    for kind, text in top:
        if kind == "line" and text.startswith("#"):
            level += text.startswith("#if") - text.startswith("#endif")
        elif level:
            return whole
        if kind == "func":
            head, body = text[: text.index("{")].rstrip(), text[text.index("{") :]
            name = _name(head)
            calls[name] = set(_CALL.findall(body))
            if _WORKER.match(head):
                head = _HIDDEN + head[len("static int") :]
                workers[name] = f"{head} {body}"
                protos.append(f"{head};")
            elif head.startswith("static"):  # a file-local helper: a copy in every unit
                common.append(text)
            elif text in helpers:  # CasADi's helper (casadi_sq, ...): the same, made static
                common.append(f"static {text}")
            else:
                first.append(text)
                protos.append(f"{head};")
        elif kind == "decl" and not text.lstrip().startswith("static"):
            first.append(text)
        else:
            common.append(text)
    hot = _reached((f for f in calls if f not in workers and f not in cold), calls)
    cold_workers = [t for f, t in workers.items() if f not in hot]
    hot_workers = [t for f, t in workers.items() if f in hot]
    if len(workers) <= 1 or (parts <= 1 and not cold_workers) or not hot_workers:
        return whole
    units: list[list[str]] = [[] for _ in range(max(1, min(parts, len(hot_workers))))]
    sizes = [sum(map(len, first))] + [0] * (len(units) - 1)
    for text in sorted(hot_workers, key=len, reverse=True):  # largest first, to the lightest
        k = sizes.index(min(sizes))
        units[k].append(text)
        sizes[k] += len(text)
    units[0].extend(first)
    header = "\n".join([*common, *protos])
    out = [Unit("\n".join([header, *unit]) + "\n") for unit in units]
    if cold_workers:
        out.append(Unit("\n".join([header, *cold_workers]) + "\n", cold=True))
    return out
