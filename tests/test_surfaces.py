"""Surface sources: height grids (against SciPy and an independent NumPy
Keys kernel), Python callables (batching, finite differences, errors),
parametric surfaces, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

import fcol
from fcol import _fcol
from ref_interp import bicubic as ref_bicubic

DOM = ((-2.0, 2.0), (-1.0, 3.0))


# --------------------------------------------------------------------------
# HeightGrid


def rand_grid(ny=7, nx=9, seed=0):
    return np.random.default_rng(seed).normal(size=(ny, nx))


def points_inside(g, n=400, seed=1):
    (u0, u1), (v0, v1) = g.domain
    rng = np.random.default_rng(seed)
    return rng.uniform(u0, u1, n), rng.uniform(v0, v1, n)


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.float16, np.int16, np.uint8, np.int64])
def test_bilinear_matches_scipy(dtype):
    z = (rand_grid() * 20 + 50).astype(dtype)
    u_nodes = np.linspace(-1.0, 3.0, z.shape[1])
    v_nodes = np.linspace(10.0, 12.0, z.shape[0])
    g = fcol.HeightGrid(z, extent=(-1.0, 3.0, 10.0, 12.0))
    u, v = points_inside(g)
    ref = RegularGridInterpolator((v_nodes, u_nodes), z.astype(np.float64), method="linear")
    np.testing.assert_allclose(g(u, v), ref(np.stack([v, u], -1)), rtol=1e-12, atol=1e-12)
    # exact at the nodes
    uu, vv = np.meshgrid(u_nodes, v_nodes)
    np.testing.assert_allclose(g(uu, vv), z.astype(np.float64), rtol=1e-13, atol=1e-12)


def fd_of_interpolant(g, u, v, h):
    fu = (g(u + h, v) - g(u - h, v)) / (2 * h)
    fv = (g(u, v + h) - g(u, v - h)) / (2 * h)
    return fu, fv


def away_from_lines(x, x0, dx, margin):
    s = (x - x0) / dx
    return np.abs(s - np.round(s)) > margin


@pytest.mark.parametrize("interp", ["bilinear", "bicubic"])
def test_gradient_is_the_interpolants(interp):
    z = rand_grid(6, 8)
    g = fcol.HeightGrid(z, spacing=(0.5, -0.25), origin=(1.0, 2.0), interpolation=interp)
    u, v = points_inside(g, 500)
    ok = away_from_lines(u, 1.0, 0.5, 1e-3) & away_from_lines(v, 2.0, -0.25, 1e-3)
    u, v = u[ok], v[ok]
    fu, fv = g.gradient(u, v)
    rfu, rfv = fd_of_interpolant(g, u, v, 1e-6)
    np.testing.assert_allclose(fu, rfu, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(fv, rfv, rtol=1e-6, atol=1e-6)


def test_bicubic_matches_numpy_keys_kernel():
    z = rand_grid(7, 9, seed=4)
    u0, du, v0, dv = -1.0, 0.3, 5.0, -0.2
    g = fcol.HeightGrid(z, spacing=(du, dv), origin=(u0, v0), interpolation="bicubic")
    u, v = points_inside(g, 600)
    f, fu, fv = ref_bicubic(z, u0, du, v0, dv, u, v)
    np.testing.assert_allclose(g(u, v), f, rtol=1e-12, atol=1e-12)
    gu, gv = g.gradient(u, v)
    np.testing.assert_allclose(gu, fu, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(gv, fv, rtol=1e-11, atol=1e-11)
    # interpolating: exact at the nodes
    jj, ii = np.meshgrid(np.arange(9), np.arange(7))
    np.testing.assert_allclose(g(u0 + jj * du, v0 + ii * dv), z, atol=1e-12)


def test_bicubic_is_c1_across_cell_edges():
    z = rand_grid(5, 5, seed=7)
    g = fcol.HeightGrid(z, extent=(0, 4, 0, 4), interpolation="bicubic")
    e = 1e-9
    for x in [1.0, 2.0, 3.0]:
        v = np.linspace(0.1, 3.9, 11)
        a = g.gradient(x - e, v)[0]
        b = g.gradient(x + e, v)[0]
        np.testing.assert_allclose(a, b, atol=1e-6)


def test_north_up_raster_conventions():
    z = rand_grid(5, 6, seed=2)
    north_up = fcol.HeightGrid(z, extent=(0.0, 5.0, 4.0, 0.0))  # row 0 is v = 4 (north)
    south_up = fcol.HeightGrid(z[::-1], extent=(0.0, 5.0, 0.0, 4.0))
    neg = fcol.HeightGrid(z, spacing=(1.0, -1.0), origin=(0.0, 4.0))
    u, v = points_inside(south_up)
    assert north_up.domain == south_up.domain == ((0.0, 5.0), (0.0, 4.0))
    np.testing.assert_allclose(north_up(u, v), south_up(u, v), atol=1e-13)
    np.testing.assert_allclose(neg(u, v), south_up(u, v), atol=1e-13)
    np.testing.assert_allclose(north_up.gradient(u, v), south_up.gradient(u, v), atol=1e-12)
    # z[0, 0] sits at (u0, v0) = (0, 4)
    assert north_up(0.0, 4.0) == z[0, 0]
    assert north_up(5.0, 0.0) == z[-1, -1]


def test_non_contiguous_views():
    big = rand_grid(20, 30, seed=3)
    view = big[::3, ::-2]
    g = fcol.HeightGrid(view, extent=(0, 1, 0, 1))
    h = fcol.HeightGrid(np.ascontiguousarray(view), extent=(0, 1, 0, 1))
    u, v = points_inside(g)
    np.testing.assert_array_equal(g(u, v), h(u, v))
    g32 = fcol.HeightGrid(big.astype(np.float32).T[::2], extent=(0, 1, 0, 1), interpolation="bicubic")
    assert g32.shape == (15, 20)


def test_nan_holes_bilinear():
    z = np.arange(36, dtype=float).reshape(6, 6)
    z[2, 3] = np.nan
    g = fcol.HeightGrid(z, extent=(0, 5, 0, 5))
    # cells (rows 1-2, cols 2-3) touch the NaN at (u=3, v=2): a hole
    for u, v in [(2.5, 1.5), (3.5, 1.5), (2.5, 2.5), (3.5, 2.5), (3.0, 2.0)]:
        assert np.isnan(g(u, v)) and np.isnan(g.gradient(u, v)[0]), (u, v)
    for u, v in [(1.5, 1.5), (4.5, 2.5), (3.5, 3.5), (2.5, 0.5), (0.0, 0.0)]:
        assert np.isfinite(g(u, v)), (u, v)
        assert np.all(np.isfinite(g.gradient(u, v))), (u, v)


def test_nan_holes_bicubic_rule():
    z = np.add.outer(np.arange(8.0), np.arange(8.0) ** 2)
    z[4, 4] = np.nan
    g = fcol.HeightGrid(z, extent=(0, 7, 0, 7), interpolation="bicubic")
    us = np.arange(7) + 0.5
    uu, vv = np.meshgrid(us, us)
    hole = np.isnan(g(uu, vv))
    # cell (i, j) covers samples i-1..i+2, j-1..j+2: touches (4, 4) for i, j in 2..5
    expect = np.zeros((7, 7), bool)
    expect[2:6, 2:6] = True
    np.testing.assert_array_equal(hole, expect)
    # inf is no data too
    z2 = z.copy()
    z2[4, 4] = np.inf
    np.testing.assert_array_equal(np.isnan(fcol.HeightGrid(z2, extent=(0, 7, 0, 7), interpolation="bicubic")(uu, vv)), expect)


@pytest.mark.parametrize("interp", ["bilinear", "bicubic"])
def test_tiny_grids(interp):
    row = fcol.HeightGrid(np.array([[1.0, 3.0, 2.0]]), extent=(0, 2, 5, 6), interpolation=interp)
    assert row.domain == ((0.0, 2.0), (5.0, 6.0))
    v = np.linspace(5, 6, 5)
    np.testing.assert_allclose(row(0.5, v), row(0.5, 5.0))
    assert np.all(row.gradient(0.5, v)[1] == 0)
    col = fcol.HeightGrid(np.array([[1.0], [3.0]]), spacing=(2.0, 1.0), interpolation=interp)
    assert col.domain == ((0.0, 2.0), (0.0, 1.0))
    assert col(1.3, 0.5) == pytest.approx(2.0)
    one = fcol.HeightGrid(np.array([[7]], np.int32), spacing=(1.0, 1.0), interpolation=interp)
    assert one(0.5, 0.5) == 7.0 and one.gradient(0.2, 0.9) == (0.0, 0.0)
    sq = fcol.HeightGrid(np.array([[0.0, 1.0], [2.0, 3.0]]), extent=(0, 1, 0, 1), interpolation=interp)
    assert sq(0.5, 0.5) == pytest.approx(1.5)
    np.testing.assert_allclose(sq.gradient(0.3, 0.6), (1.0, 2.0), atol=1e-12)


def test_outside_is_nan_and_edges_are_inside():
    g = fcol.HeightGrid(rand_grid(), extent=(0, 1, 0, 1))
    assert np.isnan(g(1.01, 0.5)) and np.isnan(g(0.5, -0.01))
    assert np.isfinite(g(1.0, 1.0)) and np.isfinite(g(0.0, 0.0))


@pytest.mark.parametrize(
    "kwargs, exc, words",
    [
        (dict(z=np.zeros((3, 3), complex), extent=(0, 1, 0, 1)), TypeError, "z"),
        (dict(z=np.zeros((3, 3), object), extent=(0, 1, 0, 1)), TypeError, "z"),
        (dict(z=np.zeros((3, 3), bool), extent=(0, 1, 0, 1)), TypeError, "z"),
        (dict(z=np.zeros((3, 3, 3)), extent=(0, 1, 0, 1)), ValueError, "z"),
        (dict(z=np.zeros(3), extent=(0, 1, 0, 1)), ValueError, "z"),
        (dict(z=np.zeros((0, 3)), extent=(0, 1, 0, 1)), ValueError, "z"),
        (dict(z=np.zeros((3, 3))), ValueError, "extent"),
        (dict(z=np.zeros((3, 3)), extent=(0, 1, 0, 1), spacing=(1, 1)), ValueError, "extent"),
        (dict(z=np.zeros((3, 3)), extent=(0, 0, 0, 1)), ValueError, "extent"),
        (dict(z=np.zeros((3, 3)), extent=(0, np.nan, 0, 1)), ValueError, "extent"),
        (dict(z=np.zeros((3, 3)), extent=(0, 1)), TypeError, "extent"),
        (dict(z=np.zeros((3, 3)), spacing=(0.0, 1.0)), ValueError, "spacing"),
        (dict(z=np.zeros((3, 3)), spacing=(np.inf, 1.0)), ValueError, "spacing"),
        (dict(z=np.zeros((3, 3)), extent=(0, 1, 0, 1), origin=(0, 0)), ValueError, "origin"),
        (dict(z=np.zeros((3, 3)), extent=(0, 1, 0, 1), interpolation="cubic"), ValueError, "interpolation"),
        (dict(z="abc", extent=(0, 1, 0, 1)), TypeError, "z"),
    ],
)
def test_grid_bad_input(kwargs, exc, words):
    z = kwargs.pop("z")
    with pytest.raises(exc, match=words):
        fcol.HeightGrid(z, **kwargs)


def test_grid_through_the_renderer_path():
    g = fcol.HeightGrid(rand_grid(), extent=(0, 1, 0, 1), interpolation="bicubic")
    u, v = points_inside(g, 1000)
    f, fu, fv = _fcol._eval_height(g, u, v, chunk=64)
    np.testing.assert_array_equal(f, g(u, v))
    np.testing.assert_array_equal(np.stack([fu, fv]), np.stack(g.gradient(u, v)))


# --------------------------------------------------------------------------
# Function from a callable


def counted(fn):
    def wrapper(*a, **k):
        wrapper.calls += 1
        wrapper.sizes.append(np.shape(a[0]))
        return fn(*a, **k)

    wrapper.calls = 0
    wrapper.sizes = []
    return wrapper


def test_callable_batches_and_central_differences():
    f = counted(lambda u, v: 3 * np.sin(u * np.cos(v)))
    F = fcol.Function(f, domain=DOM)
    f.calls = 0
    u = np.linspace(-2, 2, 1000)
    v = np.linspace(-1, 3, 1000)
    w = F(u, v)
    assert f.calls == 1 and F.calls == 1
    np.testing.assert_allclose(w, 3 * np.sin(u * np.cos(v)), rtol=1e-15)
    fu, fv = F.gradient(u, v)
    assert f.calls == 2  # one call for the value and the four neighbours
    c = np.cos(u * np.cos(v))
    np.testing.assert_allclose(fu, 3 * c * np.cos(v), atol=1e-8)
    np.testing.assert_allclose(fv, -3 * c * u * np.sin(v), atol=1e-8)


def test_callable_with_gradient_t_and_params():
    f = counted(lambda u, v, t, a: a * u * v + t)
    g = counted(lambda u, v, t, a: (a * v, a * u))
    F = fcol.Function(f, grad=g, domain=DOM, params={"a": 2.0}, t=0.5)
    f.calls = g.calls = 0
    fu, fv = F.gradient([1.0, 2.0], [3.0, 4.0])
    assert (f.calls, g.calls) == (1, 1)
    np.testing.assert_array_equal(fu, [6.0, 8.0])
    G = F.with_params(a=1.0, t=2.0)
    assert G(1.0, 3.0) == 5.0 and F(1.0, 3.0) == 6.5
    assert G.params == {"a": 1.0} and G.t == 2.0
    with pytest.raises(ValueError, match="b"):
        F.with_params(b=1.0)


def test_callable_through_worker_threads():
    f = counted(lambda u, v: u**2 - v)
    F = fcol.Function(f, domain=DOM)
    f.calls = 0
    u = np.linspace(-2, 2, 1000)
    v = np.zeros(1000)
    w, fu, fv = _fcol._eval_height(F, u, v, chunk=100)
    assert f.calls == 10  # one call per batch, never per sample
    np.testing.assert_allclose(w, u**2)
    np.testing.assert_allclose(fu, 2 * u, atol=1e-8)
    np.testing.assert_allclose(fv, -1.0, atol=1e-8)


def test_callable_errors():
    def boom(u, v):
        if np.size(u) > 5 * 5:  # fine on the construction probe, fails later
            raise ZeroDivisionError("boom")
        return u + v

    F = fcol.Function(boom, domain=DOM)
    with pytest.raises(ZeroDivisionError):
        F(np.zeros(100), 0.0)
    with pytest.raises(ZeroDivisionError):
        _fcol._eval_height(F, np.zeros(100), np.zeros(100))
    # after the first failing batch of a render, the others are holes
    # without calling Python again; the error is re-raised after the render
    F2 = fcol.Function(counted(boom), domain=DOM)
    for _ in range(2):
        before = F2.calls
        with pytest.raises(ZeroDivisionError):
            _fcol._eval_height(F2, np.zeros(2000), np.zeros(2000), chunk=30)
        assert 1 <= F2.calls - before < 10
    with pytest.raises(ValueError, match="shape"):
        fcol.Function(lambda u, v: np.zeros(3), domain=DOM)
    with pytest.raises(TypeError, match="real"):
        fcol.Function(lambda u, v: u + 1j, domain=DOM)
    with pytest.raises(TypeError, match="grad"):
        fcol.Function(lambda u, v: u, grad=lambda u, v: u, domain=DOM)
    with pytest.raises(TypeError, match="grad"):
        fcol.Function(lambda u, v: u, grad=3, domain=DOM)
    with pytest.raises(TypeError):
        fcol.Function(lambda u: u, domain=DOM)
    # a constant returned as a scalar broadcasts
    assert fcol.Function(lambda u, v: 2.0, domain=DOM)(np.zeros(4), 0).tolist() == [2.0] * 4


@pytest.mark.parametrize(
    "domain, exc",
    [
        (((1, 0), (0, 1)), ValueError),
        (((0, 1), (0, 0)), ValueError),
        (((0, np.nan), (0, 1)), ValueError),
        (((0, np.inf), (0, 1)), ValueError),
        ((0, 1, 0, 1), TypeError),
        ("x", TypeError),
        (None, ValueError),
    ],
)
def test_bad_domain(domain, exc):
    with pytest.raises(exc, match="domain"):
        fcol.Function("u", domain=domain)
    with pytest.raises(exc, match="domain"):
        fcol.Parametric("u", "v", "0", domain=domain)


def test_sequences_of_any_kind():
    f = fcol.Function("u*v", domain=[[0, 1], np.array([2.0, 3.0])])
    assert f.domain == ((0.0, 1.0), (2.0, 3.0))
    g = fcol.HeightGrid(np.eye(3), extent=np.array([0, 1, 0, 1]))
    h = fcol.HeightGrid(np.eye(3), spacing=[0.5, 0.5], origin=[1, 1])
    assert g.extent == (0, 1, 0, 1) and h.extent == (1.0, 2.0, 1.0, 2.0)
    with pytest.raises(TypeError, match="domain"):
        fcol.Function("u", domain=((0, 1), (0, 1, 2)))
    with pytest.raises(TypeError, match="spacing"):
        fcol.HeightGrid(np.eye(3), spacing="ab")
    with pytest.raises(ValueError, match="t="):
        fcol.Function("t*u", domain=DOM, params={"t": 1.0})


def test_bad_function_arguments():
    with pytest.raises(TypeError, match="f"):
        fcol.Function(3.0, domain=DOM)
    with pytest.raises(ValueError, match="grad"):
        fcol.Function("u", grad=lambda u, v: (u, v), domain=DOM)
    with pytest.raises(TypeError, match="params"):
        fcol.Function("u", domain=DOM, params=[1, 2])


def test_expression_through_worker_threads_is_identical():
    F = fcol.Function("3*sin(u*cos(v)) + hypot(u, v)", domain=DOM)
    rng = np.random.default_rng(0)
    u, v = rng.uniform(-2, 2, 3000), rng.uniform(-1, 3, 3000)
    a = _fcol._eval_height(F, u, v, chunk=7)
    b = _fcol._eval_height(F, u, v, chunk=1000)
    fu, fv = F.gradient(u, v)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(a[0], F(u, v))
    np.testing.assert_array_equal(a[1], fu)


def test_surface_type_error():
    with pytest.raises(TypeError, match="surface"):
        _fcol._eval_height("u*v", [0.0], [0.0])


# --------------------------------------------------------------------------
# Parametric

SPHERE = ("cos(u)*cos(v)", "sin(u)*cos(v)", "sin(v)")


def sphere_ref(u, v):
    P = np.stack([np.cos(u) * np.cos(v), np.sin(u) * np.cos(v), np.sin(v)], -1)
    Pu = np.stack([-np.sin(u) * np.cos(v), np.cos(u) * np.cos(v), 0 * u], -1)
    Pv = np.stack([-np.cos(u) * np.sin(v), -np.sin(u) * np.sin(v), np.cos(v)], -1)
    Puu = np.stack([-np.cos(u) * np.cos(v), -np.sin(u) * np.cos(v), 0 * u], -1)
    Puv = np.stack([np.sin(u) * np.sin(v), -np.cos(u) * np.sin(v), 0 * u], -1)
    Pvv = np.stack([-np.cos(u) * np.cos(v), -np.sin(u) * np.cos(v), -np.sin(v)], -1)
    return P, Pu, Pv, Puu, Puv, Pvv


PDOM = ((0.0, 2 * np.pi), (-1.5, 1.5))


def check_sphere(S, rtol1, rtol2):
    rng = np.random.default_rng(5)
    u, v = rng.uniform(0, 2 * np.pi, 50), rng.uniform(-1.5, 1.5, 50)
    P, Pu, Pv, Puu, Puv, Pvv = sphere_ref(u, v)
    np.testing.assert_allclose(np.stack(S(u, v), -1), P, atol=1e-15)
    pu, pv = S.jacobian(u, v)
    np.testing.assert_allclose(pu, Pu, atol=rtol1)
    np.testing.assert_allclose(pv, Pv, atol=rtol1)
    puu, puv, pvv = S.hessian(u, v)
    np.testing.assert_allclose(puu, Puu, atol=rtol2)
    np.testing.assert_allclose(puv, Puv, atol=rtol2)
    np.testing.assert_allclose(pvv, Pvv, atol=rtol2)


def test_parametric_expressions_exact():
    S = fcol.Parametric(*SPHERE, domain=PDOM)
    check_sphere(S, 1e-15, 1e-15)
    assert S.exprs == SPHERE and S.calls == 0
    assert S.jacobian(np.zeros((2, 3)), 0.0)[0].shape == (2, 3, 3)


def test_parametric_callables_finite_differences():
    fx = counted(lambda u, v: np.cos(u) * np.cos(v))
    fy = counted(lambda u, v: np.sin(u) * np.cos(v))
    fz = counted(lambda u, v: np.sin(v))
    S = fcol.Parametric(fx, fy, fz, domain=PDOM)
    fx.calls = 0
    check_sphere(S, 1e-8, 1e-5)
    assert fx.calls == 1 + 2 + 2  # one call per method and batch: __call__, jacobian, hessian


def test_parametric_callables_with_jacobian():
    def jac(u, v):
        _, Pu, Pv, *_ = sphere_ref(u, v)
        return Pu, Pv

    S = fcol.Parametric(
        lambda u, v: np.cos(u) * np.cos(v), lambda u, v: np.sin(u) * np.cos(v), lambda u, v: np.sin(v),
        domain=PDOM, jac=jac,
    )
    check_sphere(S, 1e-15, 1e-6)


def test_parametric_params_and_errors():
    T = fcol.Parametric("(R + r*cos(v))*cos(u)", "(R + r*cos(v))*sin(u)", "r*sin(v)",
                        domain=PDOM, params={"R": 2.0, "r": 0.5})
    assert T(0.0, 0.0)[0] == 2.5
    assert T.with_params(R=3.0)(0.0, 0.0)[0] == 3.5
    assert T.params == {"R": 2.0, "r": 0.5}
    with pytest.raises(ValueError, match="q"):
        T.with_params(q=1.0)
    with pytest.raises(TypeError, match="all"):
        fcol.Parametric("u", lambda u, v: v, "0", domain=PDOM)
    with pytest.raises(ValueError, match="jac"):
        fcol.Parametric("u", "v", "0", domain=PDOM, jac=lambda u, v: (u, v))
    with pytest.raises(fcol.ExpressionError, match="z: .*column 5"):
        fcol.Parametric("u", "v", "u + w", domain=PDOM)


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
@pytest.mark.parametrize("interp", ["bilinear", "bicubic"])
def test_grid_at_tiny_and_huge_scales(scale, interp):
    z = rand_grid(6, 7, seed=9)
    base = fcol.HeightGrid(z, extent=(0, 1, 0, 1), interpolation=interp)
    off = 3 * scale
    g = fcol.HeightGrid(z * scale, extent=(off, off + scale, -off, -off + scale), interpolation=interp)
    u, v = points_inside(base, 200)
    np.testing.assert_allclose(g(off + u * scale, -off + v * scale) / scale, base(u, v), rtol=1e-7, atol=1e-7)
    gu, gv = g.gradient(off + u * scale, -off + v * scale)
    bu, bv = base.gradient(u, v)
    np.testing.assert_allclose(gu, bu, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(gv, bv, rtol=1e-6, atol=1e-6)


def test_integer_dem_plateaus_are_flat():
    z = np.full((6, 6), 120, np.int16)
    z[3:, :] = 130
    for interp in ["bilinear", "bicubic"]:
        g = fcol.HeightGrid(z, spacing=(30.0, 30.0), interpolation=interp)
        u = np.linspace(0, 150, 31)
        fu, fv = g.gradient(u, 15.0)  # inside the low plateau, away from the step's kernel
        assert np.all(fu == 0) and np.all(fv == 0)
        assert np.all(g(u, 15.0) == 120)
