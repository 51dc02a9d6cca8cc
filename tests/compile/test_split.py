"""Generated C cut into translation units (mmplan.compile.split) and built by parallel compiler
processes (mmplan.compile.codegen): the same functions, the same bits, the same exports."""

from __future__ import annotations

import ctypes
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from mmplan.compile import codegen as cg
from mmplan.compile.split import Unit, items, split

NATIVE = ("-O2", "-march=native", *cg.FIXED_FLAGS)


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    return tmp_path


def _functions() -> list[ca.Function]:
    """An MX function calling two SX functions (generated as separate C functions) and a
    function nothing calls."""
    x = ca.SX.sym("x", 3)
    g = ca.Function("mmplan_t_g", [x], [ca.vertcat(x[0] * x[1] + x[2], ca.sin(x[1]) * x[0])])
    h = ca.Function("mmplan_t_h", [x], [ca.exp(x[2]) * x[1] + x[0] * x[0]])
    xm = ca.MX.sym("x", 3)
    y = g(xm)
    f = ca.Function("mmplan_t_f", [xm], [ca.vertcat(y[0] * h(xm) + y[1], h(2 * xm) - y[0])])
    c = ca.Function("mmplan_t_c", [x], [ca.cos(x[0]) * x[2] - x[1] / (1 + x[0] ** 2)])
    return [f, g, h, c]


def _values(library: Path, name: str, inputs: np.ndarray) -> np.ndarray:
    fn = cg.NativeFunction(str(library), name)
    out = []
    for x in inputs:
        fn.x[:] = x
        out.append(fn().copy())
    return np.array(out)


def test_units_compute_what_the_one_file_build_computes(tmp_path: Path) -> None:
    cc = cg.compiler()
    assert cc is not None
    source = cg._source(_functions())
    units = split(source, 3)
    assert len(units) == 3 and all("static int casadi_f" not in u.text for u in units)
    cold = split(source, 1, ["mmplan_t_c", "mmplan_t_h"])  # c's code alone, unoptimised
    assert [u.cold for u in cold] == [False, True]  # (h's code is f's too)
    assert cold[1].text.count("int mem) {") == 1  # one function defined: c's
    one, three, warm = tmp_path / "one.so", tmp_path / "three.so", tmp_path / "warm.so"
    assert cg._compile(cc, [Unit(source)], one, NATIVE)
    assert cg._compile(cc, units, three, NATIVE)
    assert cg._compile(cc, cold, warm, NATIVE)
    inputs = np.random.default_rng(3).normal(size=(50, 3))
    for library in (one, three, warm):
        for vm in _functions():
            expected = np.array([np.asarray(vm(x)).ravel() for x in inputs])
            np.testing.assert_array_equal(_values(library, vm.name(), inputs), expected)
        lib = ctypes.CDLL(str(library))
        assert hasattr(lib, "mmplan_t_h") and hasattr(lib, "mmplan_gen_casadi_int_size")
        assert not hasattr(lib, "mmplan_gen_f0")  # the generated functions stay internal
        # CasADi's helpers are static in a cut source (inlined, not called through the PLT)
        assert hasattr(lib, "mmplan_gen_sq") == (library == one)
    assert "static casadi_real casadi_sq(" in split(source, 1)[0].text  # also left whole


def test_no_fused_multiply_add_even_for_the_native_architecture(cache: Path) -> None:
    """x0 x1 + x2 rounded twice, as CasADi's virtual machine does (with -march=native gcc
    fuses it on a machine with FMA unless told not to: then about a quarter of these
    differ in the last bit)."""
    x = ca.SX.sym("x", 3)
    f = ca.Function("mmplan_t_fma", [x], [x[0] * x[1] + x[2]])
    library = cg.compile_library([f], "t", ("-O2", "-march=native"))
    assert library is not None
    inputs = np.random.default_rng(1).normal(size=(200, 3))
    expected = np.array([np.asarray(f(x)).ravel() for x in inputs])
    np.testing.assert_array_equal(_values(Path(library), "mmplan_t_fma", inputs), expected)


def test_a_large_library_is_built_in_units(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cg, "UNIT_BYTES", 2_000)
    monkeypatch.setattr(cg.os, "sched_getaffinity", lambda pid: {0, 1, 2}, raising=False)
    monkeypatch.setattr(cg.os, "getloadavg", lambda: (1.0, 1.0, 1.0))  # this process alone
    source = cg._source(_functions())
    assert len(cg._units(source)) == 3
    assert [u.cold for u in cg._units(source, ["mmplan_t_c"])] == [False, False, False, True]
    monkeypatch.setattr(cg.os, "getloadavg", lambda: (3.0, 3.0, 3.0))  # two cores busy
    assert [u.cold for u in cg._units(source, ["mmplan_t_c"])] == [False, True]
    library = cg.compile_library(_functions(), "t", ("-O1",), cold=["mmplan_t_c"])
    assert library is not None
    inputs = np.random.default_rng(4).normal(size=(20, 3))
    for vm in _functions():
        expected = np.array([np.asarray(vm(x)).ravel() for x in inputs])
        np.testing.assert_array_equal(_values(Path(library), vm.name(), inputs), expected)


HAND_WRITTEN = r"""
#include <math.h>
#define SQ(x) \
    ((x) * (x))
typedef struct { double a, b; } pair;  // a comment with a brace {
static double half(double x) { return 0.5 * x; }
int mmplan_run(const double* x, double* y) { y[0] = SQ(half(x[0])); return '}' == 0; }
"""


def test_other_c_is_left_whole() -> None:
    kinds = [kind for kind, _ in items(HAND_WRITTEN)]
    assert kinds == ["line", "line", "decl", "line", "func", "func"]
    assert split(HAND_WRITTEN, 4) == [Unit(HAND_WRITTEN)]  # no generated functions to deal out
    source = cg._source(_functions())
    guarded = source.replace("static int casadi_f1(", "#if 1\nstatic int casadi_f1(", 1)
    guarded = guarded.replace("\n/* mmplan_t_h", "#endif\n/* mmplan_t_h", 1)
    (whole,) = split(guarded, 2)  # a function inside an #if block: nothing moved, ...
    local = ("casadi_real casadi_sq(", "void casadi_copy(")
    made_static = guarded
    for head in local:  # ... only CasADi's helpers made static
        assert f"static {head}" not in guarded
        made_static = made_static.replace(head, f"static {head}", 1)
    assert whole == Unit(made_static)
    assert split(source[:-200], 2) == [Unit(source[:-200])]  # unbalanced: not C to cut
