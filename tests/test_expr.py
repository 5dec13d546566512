"""The expression language: parsing, precedence, every function, error
columns, parameters, and exact derivatives checked against high-precision
(mpmath, 40 digits) numerical differentiation of the same formula."""

from __future__ import annotations

import re

import mpmath
import numpy as np
import pytest

import fcol

DOM = ((-5.0, 5.0), (-5.0, 5.0))

# The language is a subset of Python's: the same string evaluated by Python
# with NumPy (or mpmath) functions is an independent reference.
NP = dict(
    sin=np.sin, cos=np.cos, tan=np.tan, asin=np.arcsin, acos=np.arccos, atan=np.arctan,
    atan2=np.arctan2, sinh=np.sinh, cosh=np.cosh, tanh=np.tanh, exp=np.exp, log=np.log,
    log10=np.log10, sqrt=np.sqrt, abs=np.abs, min=np.minimum, max=np.maximum,
    floor=np.floor, ceil=np.ceil, sign=np.sign, hypot=np.hypot, pi=np.pi, e=np.e,
)
MP = dict(
    sin=mpmath.sin, cos=mpmath.cos, tan=mpmath.tan, asin=mpmath.asin, acos=mpmath.acos,
    atan=mpmath.atan, atan2=mpmath.atan2, sinh=mpmath.sinh, cosh=mpmath.cosh,
    tanh=mpmath.tanh, exp=mpmath.exp, log=mpmath.log, log10=mpmath.log10,
    sqrt=mpmath.sqrt, abs=abs, min=min, max=max, floor=mpmath.floor, ceil=mpmath.ceil,
    sign=mpmath.sign, hypot=mpmath.hypot, pi=mpmath.pi, e=mpmath.e,
)


def np_eval(src, u, v, **params):
    return eval(src, {"__builtins__": {}}, dict(NP, u=u, v=v, **params))


def column(excinfo) -> int:
    m = re.search(r"at column (\d+)", str(excinfo.value))
    assert m, str(excinfo.value)
    return int(m.group(1))


@pytest.mark.parametrize(
    "src",
    [
        "-u**2", "2**-u", "u**v**2", "(u**v)**2", "u-v-1", "u/v/2", "-u*v", "+u", "--u",
        "1e-3*u + .5*v - 2.", "2*u+3*v*u-1/v", "u*-v", "-2**2", "2**3**0.5", "1E+2*u",
        "(((u)))", "u - -v", "pi*e*u", "3*sin(u*cos(v))",
    ],
)
def test_precedence_matches_python(src):
    rng = np.random.default_rng(1)
    u = rng.uniform(0.2, 1.5, 50)
    v = rng.uniform(0.2, 1.5, 50)
    f = fcol.Function(src, domain=DOM)
    np.testing.assert_allclose(f(u, v), np_eval(src, u, v), rtol=1e-14, atol=0)


# Each function inside an expression of u and v, on points where it is
# defined and smooth (away from kinks), with its domain of sampling.
FUNCS = {
    "sin": "sin(u*v + u)",
    "cos": "cos(u*v - 2*v)",
    "tan": "tan(u*v)",
    "asin": "asin(0.5*u*v)",
    "acos": "acos(0.5*u*v - 0.1)",
    "atan": "atan(u*v*3)",
    "atan2": "atan2(u*v - 0.7, v + u*u)",
    "sinh": "sinh(u - v*v)",
    "cosh": "cosh(u*v + 0.3)",
    "tanh": "tanh(2*u - v)",
    "exp": "exp(u*v - u)",
    "log": "log(u*v + u)",
    "log10": "log10(u*u + v)",
    "sqrt": "sqrt(u*v + 0.1)",
    "abs": "abs(u*v - 0.9)*v",
    "min": "min(u*v, u + v - 1)",
    "max": "max(u*v, 3*u - v)",
    "floor": "floor(3*u*v) + u*v",
    "ceil": "ceil(3*u*v)*v",
    "sign": "sign(u*v - 0.9)*u",
    "hypot": "hypot(u*v, u - 2*v)",
    "pow_const": "u**3.7 + v**-2 + u**3",
    "pow_var": "u**v + 2**(u*v)",
    "div": "(u + v)/(u*v + 0.3)",
    "const": "pi*u + e*v",
}


def mp_derivs(src, u, v, order):
    """Exact-ish partial derivatives by mpmath's numerical differentiation at
    40 significant digits."""
    with mpmath.workdps(40):
        f = lambda uu, vv: eval(src, {"__builtins__": {}}, dict(MP, u=uu, v=vv))  # noqa: E731
        pt = (mpmath.mpf(u), mpmath.mpf(v))
        if order == 1:
            return [float(mpmath.diff(f, pt, n)) for n in [(1, 0), (0, 1)]]
        return [float(mpmath.diff(f, pt, n)) for n in [(2, 0), (1, 1), (0, 2)]]


def sample_points(src, n=6, seed=0):
    """Random points in [0.2, 1.2]² at least 1e-3 away from every kink of
    abs/min/max/floor/ceil/sign (checked numerically: the kink functions'
    arguments do not change branch within ±1e-3)."""
    rng = np.random.default_rng(seed)
    pts = []
    while len(pts) < n:
        u, v = rng.uniform(0.2, 1.2, 2)
        vals = [np_eval(src, u + du, v + dv) for du in (-1e-3, 0, 1e-3) for dv in (-1e-3, 0, 1e-3)]
        g = [np_eval(src, u + 1e-3, v) - np_eval(src, u, v), np_eval(src, u, v) - np_eval(src, u - 1e-3, v)]
        if all(np.isfinite(vals)) and abs(g[0] - g[1]) < 1e-3 * (abs(g[0]) + 1e-2):
            pts.append((u, v))
    return np.array(pts)


@pytest.mark.parametrize("name", sorted(FUNCS))
def test_first_derivatives_against_mpmath(name):
    src = FUNCS[name]
    f = fcol.Function(src, domain=DOM)
    pts = sample_points(src)
    w = f(pts[:, 0], pts[:, 1])
    fu, fv = f.gradient(pts[:, 0], pts[:, 1])
    np.testing.assert_allclose(w, np_eval(src, pts[:, 0], pts[:, 1]), rtol=1e-13, atol=1e-14)
    for (u, v), a, b in zip(pts, fu, fv):
        du, dv = mp_derivs(src, u, v, 1)
        np.testing.assert_allclose([a, b], [du, dv], rtol=1e-10, atol=1e-12, err_msg=f"{src} at {(u, v)}")


@pytest.mark.parametrize("name", sorted(FUNCS))
def test_second_derivatives_against_mpmath(name):
    src = FUNCS[name]
    p = fcol.Parametric(src, "u", "v", domain=DOM)
    pts = sample_points(src, n=4, seed=1)
    puu, puv, pvv = p.hessian(pts[:, 0], pts[:, 1])
    pu, pv = p.jacobian(pts[:, 0], pts[:, 1])
    for k, (u, v) in enumerate(pts):
        ref2 = mp_derivs(src, u, v, 2)
        got2 = [puu[k, 0], puv[k, 0], pvv[k, 0]]
        np.testing.assert_allclose(got2, ref2, rtol=1e-9, atol=1e-10, err_msg=f"{src} at {(u, v)}")
        ref1 = mp_derivs(src, u, v, 1)
        np.testing.assert_allclose([pu[k, 0], pv[k, 0]], ref1, rtol=1e-10, atol=1e-12)
        # the other components are u and v themselves
        np.testing.assert_array_equal(pu[k, 1:], [1.0, 0.0])
        np.testing.assert_array_equal(puu[k, 1:], [0.0, 0.0])


def test_kink_conventions():
    f = fcol.Function("abs(u) + min(u, v) + max(u, 2*v) + floor(u) + ceil(v) + sign(u)", domain=DOM)
    fu, fv = f.gradient(np.array([0.0, 1.0, -1.0]), np.array([0.0, 1.0, 0.5]))
    # at (0, 0): abs' = sign(0) = 0; min takes u (u <= v); max takes u (u >= 2v)
    assert (fu[0], fv[0]) == (0.0 + 1 + 1, 0.0)
    # at (1, 1): abs' = 1; min(1, 1) takes u; max(1, 2) takes 2v
    assert (fu[1], fv[1]) == (1.0 + 1, 0.0 + 2)
    # at (-1, .5): abs' = -1; min takes u; max(-1, 1) takes 2v
    assert (fu[2], fv[2]) == (-1.0 + 1, 2.0)


def test_every_function_value_matches_numpy():
    rng = np.random.default_rng(3)
    u = rng.uniform(-3, 3, 200)
    v = rng.uniform(-3, 3, 200)
    for name, src in FUNCS.items():
        f = fcol.Function(src, domain=DOM)
        with np.errstate(all="ignore"):
            ref = np_eval(src, u, v)
        got = f(u, v)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(ref), err_msg=name)
        ok = np.isfinite(ref)
        np.testing.assert_allclose(got[ok], ref[ok], rtol=1e-12, atol=1e-13, err_msg=name)


def test_nan_and_inf_are_values_not_errors():
    f = fcol.Function("log(u) + 1/v", domain=DOM)
    w = f(np.array([-1.0, 1.0, 1.0]), np.array([1.0, 0.0, 1.0]))
    assert np.isnan(w[0]) and np.isinf(w[1]) and w[2] == 1.0
    g = fcol.Function("sqrt(u)", domain=DOM)
    fu, fv = g.gradient(-1.0, 0.0)
    assert np.isnan(fu)


@pytest.mark.parametrize(
    "src, col, words",
    [
        ("u +* v", 4, "expected"),
        ("sin(u", 6, ")"),
        ("u $ v", 3, "unexpected character"),
        ("2u", 2, "2*u"),
        ("u)", 2, ")"),
        ("u^2", 2, "**"),
        ("", 1, "empty"),
        ("u + foo", 5, "foo"),
        ("3*bar(u)", 3, "bar"),
        ("sin(u, v)", 1, "1 argument"),
        ("atan2(u)", 1, "2 arguments"),
        ("u + sin", 5, "function"),
        ("1e", 2, "exponent"),
        ("(u + v", 7, ")"),
        ("u v", 3, "operator"),
        ("sin()", 5, "argument"),
    ],
)
def test_error_columns(src, col, words):
    with pytest.raises(fcol.ExpressionError) as ei:
        fcol.Function(src, domain=DOM)
    assert column(ei) == col
    assert words in str(ei.value)
    assert isinstance(ei.value, ValueError)


def test_parametric_errors_name_the_component():
    with pytest.raises(fcol.ExpressionError, match=r"y: .*at column 3"):
        fcol.Parametric("u", "u $", "v", domain=DOM)


def test_params_bind_without_reparsing_and_validate():
    f = fcol.Function("a*sin(b*u) + t*v", domain=DOM, params={"a": 2.0, "b": 0.5}, t=1.5)
    u, v = np.linspace(-1, 1, 7), np.linspace(0, 2, 7)
    np.testing.assert_allclose(f(u, v), 2 * np.sin(0.5 * u) + 1.5 * v, rtol=1e-15)
    g = f.with_params(a=-1.0, t=0.0)
    np.testing.assert_allclose(g(u, v), -np.sin(0.5 * u), rtol=1e-15)
    np.testing.assert_allclose(g.gradient(u, v)[0], -0.5 * np.cos(0.5 * u), rtol=1e-15)
    assert g.params == {"a": -1.0, "b": 0.5} and g.t == 0.0
    assert f.params == {"a": 2.0, "b": 0.5} and f.t == 1.5  # unchanged
    assert g.expr == f.expr
    with pytest.raises(ValueError, match='"c"'):
        f.with_params(c=1.0)
    with pytest.raises(fcol.ExpressionError, match='"b"'):
        fcol.Function("a*b*u", domain=DOM, params={"a": 1.0})
    with pytest.raises(ValueError, match='"zz"'):
        fcol.Function("a*u", domain=DOM, params={"a": 1.0, "zz": 2.0})
    with pytest.raises(ValueError, match="reserved"):
        fcol.Function("u", domain=DOM, params={"sin": 1.0})
    with pytest.raises(ValueError, match="finite"):
        fcol.Function("a*u", domain=DOM, params={"a": float("nan")})
    with pytest.raises(TypeError, match="params"):
        fcol.Function("a*u", domain=DOM, params={"a": "x"})


def test_broadcasting_and_dtypes():
    f = fcol.Function("u + 10*v", domain=DOM)
    w = f(np.arange(3)[None, :], np.arange(2)[:, None])
    assert w.shape == (2, 3) and w.dtype == np.float64
    np.testing.assert_array_equal(w, [[0, 1, 2], [10, 11, 12]])
    assert isinstance(f(1, 2), float)
    assert f(np.float32(0.5), 0.0) == 0.5
    assert f(np.zeros((0,)), 0.0).shape == (0,)
    with pytest.raises(ValueError, match="broadcast"):
        f(np.zeros(3), np.zeros(4))
    with pytest.raises(TypeError, match="u"):
        f(np.zeros(3, complex), 0.0)


def test_long_expression_and_deep_nesting():
    src = "+".join(f"sin({k}*u + v)" for k in range(60))
    f = fcol.Function(src, domain=DOM)
    u, v = np.array([0.3]), np.array([0.7])
    np.testing.assert_allclose(f(u, v), np_eval(src, u, v), rtol=1e-13)
    deep = "u" + "*1.0001+u" * 300
    assert np.isfinite(fcol.Function(deep, domain=DOM)(0.5, 0.5))
    nested = "sin(" * 200 + "u" + ")" * 200
    g = fcol.Function(nested, domain=DOM)
    assert np.isfinite(g.gradient(0.5, 0.5)[0])
