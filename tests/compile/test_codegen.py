"""Shared C code generation (mmplan.compile.codegen): cache, lazy build, direct ctypes call."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from mmplan.compile import codegen as cg


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    return tmp_path


def _function() -> ca.Function:
    x = ca.SX.sym("x", 3)
    y = ca.vertcat(ca.sin(x[0]) * x[1], x[2] ** 3 / (1 + x[0] ** 2), 0)  # a structural zero
    return ca.Function("mmplan_test_fn", [x], [ca.densify(y)])


def test_compiled_library_is_cached_and_lazily_built(cache: Path) -> None:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    made: list[int] = []

    def make() -> list[ca.Function]:
        made.append(1)
        return [_function()]

    first = cg.compile_library(make, "t", ("-O0",), key="k1")
    again = cg.compile_library(make, "t", ("-O0",), key="k1")
    assert first is not None and first == again and len(made) == 1  # second call: cache hit
    assert Path(first).parent == cache
    messages: list[str] = []
    other = cg.compile_library([_function()], "t", ("-O0",), notify=messages.append)
    assert other is not None and other != first and "once" in messages[0]
    (fn,) = cg.load(["mmplan_test_fn"], other)
    x = np.array([0.3, -1.2, 2.0])
    np.testing.assert_allclose(np.asarray(fn(x)).ravel(), np.asarray(_function()(x)).ravel())


def test_native_call_equals_the_casadi_call(cache: Path) -> None:
    library = cg.compile_library([_function()], "t", ("-O0",))
    assert library is not None
    native = cg.NativeFunction(library, "mmplan_test_fn")
    rng = np.random.default_rng(5)
    for _ in range(5):
        x = rng.normal(size=3)
        native.x[:] = x
        np.testing.assert_array_equal(native().copy(), np.asarray(_function()(x)).ravel())


def test_one_described_call_equals_the_symbol_lookups(cache: Path) -> None:
    """mmplan_describe (one C call) gives what the symbol-by-symbol lookup gives: work sizes,
    patterns (a sparse output, long enough to need a second call), memory, the function."""
    a, b = ca.SX.sym("a", 2), ca.SX.sym("b", 300)
    sparse = ca.Function("mmplan_test_sparse", [a, b], [ca.diag(b * a[0] + a[1])])
    library = cg.compile_library([_function(), sparse], "t", ("-O0",))
    assert library is not None
    lib = cg._cdll(library)
    for name in ("mmplan_test_fn", "mmplan_test_sparse"):
        described = cg._described(lib, library, name)
        looked_up = cg._looked_up(lib, name)
        assert described is not None
        assert described[0] is looked_up[0] and described[1] == looked_up[1]
        for p, q in zip([*described[2], described[3]], [*looked_up[2], looked_up[3]],
                        strict=True):  # fmt: skip
            assert p.shape == q.shape and p.nnz == q.nnz
            if q.rows is not None:
                np.testing.assert_array_equal(p.rows, q.rows)
                np.testing.assert_array_equal(p.cols, q.cols)
        assert ctypes_address(described[4]) == ctypes_address(looked_up[4])
    assert described[3].nnz == 300 and described[3].rows is not None
    native = cg.NativeFunction(library, "mmplan_test_sparse")
    x = np.random.default_rng(1).normal(size=302)
    native.x[:] = x
    expected = np.asarray(sparse(x[:2], x[2:]).full())
    native()
    np.testing.assert_array_equal(native.dense(), expected)
    with pytest.raises(AttributeError, match="no function"):
        cg.NativeFunction(library, "mmplan_test_absent")


def ctypes_address(function: object) -> int:
    import ctypes

    return int(ctypes.cast(function, ctypes.c_void_p).value or 0)


def test_a_library_for_the_native_cpu_is_keyed_by_the_cpu(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A shared cache folder must not hand one CPU's -march=native code to another: the host
    is in the key of such a library only."""
    source = "int mmplan_t_one(void) { return 1; }\n"
    native, plain = ("-O2", "-march=native"), ("-O2",)
    here = cg._library(source, "t", native), cg._library(source, "t", plain)
    monkeypatch.setattr(cg, "host", lambda: "another-cpu")
    assert cg._library(source, "t", native) != here[0]
    assert cg._library(source, "t", plain) == here[1]
    assert cg.native_flags(native) and not cg.native_flags(plain)


def test_a_compiler_that_rejects_a_flag_gets_the_fallback_flags(
    cache: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A compiler that rejects -march=native (an older Apple clang): the library is built with
    the fallback flags instead of leaving the caller on CasADi's virtual machine, computes the
    same, and a later call takes it from the cache without a build (the source is not even
    made again)."""
    real = cg.compiler()
    assert real is not None
    cc = tmp_path / "picky-cc"
    cc.write_text('#!/bin/sh\nfor a in "$@"; do [ "$a" = -march=native ] && exit 1; done\n'
                  f'exec {real} "$@"\n')  # fmt: skip
    cc.chmod(0o755)
    monkeypatch.setenv("CC", str(cc))
    x = ca.SX.sym("x", 2)
    f = ca.Function("mmplan_t_picky", [x], [ca.sin(x[0]) * x[1] + x[1] ** 2])
    native, plain = ("-O2", "-march=native"), ("-O2",)
    assert cg.compile_library([f], "t", native) is None  # no fallback: as before
    path = cg.compile_library([f], "t", native, key="picky", fallback=plain)
    assert path is not None and Path(path) == cg._library("picky", "t", plain)
    (g,) = cg.load(["mmplan_t_picky"], path)
    for v in np.random.default_rng(2).normal(size=(5, 2)):
        assert float(g(v)) == float(f(v))

    def never() -> list[ca.Function]:
        raise AssertionError("made again")

    assert cg.compile_library(never, "t", native, key="picky", fallback=plain) == path


def test_the_describer_takes_any_function_name_and_refuses_what_it_cannot_call(
    cache: Path,
) -> None:
    """Functions named like the describer's own parameters or a C library function get
    their own address (review: ``out`` got the parameter's; a segfault), a function without
    outputs or with a sparse input is a ValueError (no crash, nothing checked out)."""
    x = ca.SX.sym("x", 2)
    named = [ca.Function(n, [x], [x * (i + 2)]) for i, n in enumerate(("out", "cap", "name",
                                                                       "strcmp"))]
    none = ca.Function("mmplan_test_none", [x], [])
    s = ca.SX.sym("s", ca.Sparsity.diag(2))
    sparse_in = ca.Function("mmplan_test_sparse_in", [s], [ca.densify(s)])
    library = cg.compile_library([*named, none, sparse_in], "t", ("-O0",))
    assert library is not None
    for i, fn in enumerate(named):
        native = cg.NativeFunction(library, fn.name())
        native.x[:] = [1.0, -3.0]
        np.testing.assert_array_equal(native(), [i + 2.0, -3.0 * (i + 2)])
    with pytest.raises(ValueError, match="no output"):
        cg.NativeFunction(library, "mmplan_test_none")
    with pytest.raises(ValueError, match="input 0 is not dense"):
        cg.NativeFunction(library, "mmplan_test_sparse_in")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ELF symbol interposition")
def test_a_library_calls_its_own_function_whatever_is_loaded_globally(cache: Path) -> None:
    """With another library that exports the same name loaded globally, the describer still
    hands out this library's function (review: it handed out the other's before the link
    flag, codegen.LINK_FLAGS)."""
    import ctypes
    import os

    x = ca.SX.sym("x", 1)
    two = cg.compile_library([ca.Function("mmplan_test_same", [x], [2 * x])], "ta", ("-O0",))
    three = cg.compile_library([ca.Function("mmplan_test_same", [x], [3 * x])], "tb", ("-O0",))
    assert two is not None and three is not None
    ctypes.CDLL(two, mode=os.RTLD_NOW | os.RTLD_GLOBAL)
    native = cg.NativeFunction(three, "mmplan_test_same")
    native.x[:] = [1.0]
    np.testing.assert_array_equal(native(), [3.0])


def test_a_cc_that_is_not_found_is_no_compiler_and_says_so(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A new user's ``CC=/nonexistent`` compiled with cc, and the endogenous planner's and the
    arm IK's functions fell back to the virtual machine without a word."""
    monkeypatch.setenv("CC", "/nonexistent/cc")
    assert cg.compiler() is None
    x = ca.SX.sym("x")
    f = ca.Function("mmplan_test_no_cc", [x], [2 * x])
    same, backend = cg.compile_function(f)
    assert backend == "vm" and same is f
    err = capsys.readouterr().err
    assert "$CC = /nonexistent/cc was not found" in err and "mmplan_test_no_cc" in err
    monkeypatch.delenv("CC")
    assert cg.compiler() == (shutil.which("gcc") or shutil.which("cc"))
    monkeypatch.setenv("CC", "ccache gcc")  # arguments: not passed on, gcc or cc as unset
    assert cg.compiler() == (shutil.which("gcc") or shutil.which("cc"))
