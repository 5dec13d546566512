"""Ground truth for pictures of surfaces, built without fcol's renderers.

Each pixel ray of SPEC §1 (from :class:`fcol.testing.spec_camera.SpecCamera`,
which reads only the numbers of an ``fcol.View``) is cast with trimesh +
embreex against a fine tessellation, and every hit is then refined on the
exact surface:

* height fields w = f(u, v): the first root of g(s) = P_w(s) − f(P_u(s), P_v(s))
  along the ray, inside the domain box.  A fine mesh misses grazing crests, so
  the ray is also marched from where it enters the domain with samples of g
  and of its exact derivative g'; intervals where the cubic Hermite model of
  g comes close to zero are bisected until they are either bracketed or
  shorter than a thousandth of a pixel.  The root is then polished by
  safeguarded Newton / bisection.
* parametric surfaces P(u, v): every mesh hit is refined by Newton on
  P(u, v) = O + s·dir in (u, v, s); the nearest converged root wins; pixels
  that miss or are much deeper than a neighbour are re-seeded from their
  neighbours' solutions.  Two tessellations are refined independently and
  the reference is *trusted* where they agree.

:func:`compare` measures a render against a reference with the metrics of
SPEC §5; :func:`shade` applies fcol's shading model (a NumPy port) to a
reference so colour images can be compared by SSIM.

>>> import numpy as np, fcol
>>> from fcol.testing.reference import height_reference
>>> view = fcol.View(90, 0, view_height=2.0)
>>> ref = height_reference(lambda u, v: 0 * u + 0.25, lambda u, v: (0 * u, 0 * v),
...                        ((-1, 1), (-1, 1)), view, 8, 8, mesh=8)
>>> bool(ref.mask.all()), round(float(ref.depth[0, 0]), 12), int(ref.side[0, 0])
(True, -0.25, 1)
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .spec_camera import SpecCamera

__all__ = [
    "Reference",
    "height_reference",
    "parametric_reference",
    "shade",
    "compare",
    "correction_effect",
    "oiio_compare",
    "camera_of",
    "grid_bilinear",
    "silhouette_band",
    "discontinuity_band",
    "angle_deg",
]


@dataclass
class Reference:
    """Per-pixel ground truth (see the module docstring)."""

    mask: np.ndarray  # (H, W) bool
    depth: np.ndarray  # (H, W) float64, NaN background
    normal: np.ndarray  # (H, W, 3) float64
    uv: np.ndarray  # (H, W, 2) float64
    side: np.ndarray  # (H, W) int8
    trusted: np.ndarray  # (H, W) bool
    pixel_size: np.ndarray  # (H, W) float64
    point: np.ndarray | None = None  # (H, W, 3) world point of the hit
    stats: dict[str, Any] = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        return self.mask.shape  # type: ignore[return-value]


def camera_of(view: Any, width: int, height: int) -> SpecCamera:
    return SpecCamera.from_view(view, int(width), int(height))


_CACHE_VERSION = "fcol-reference-1"


def _fingerprint(fn: Any) -> str:
    """A stable description of a callable for cache keys: its code (byte
    code, constants, names), defaults and closure values. Globals it reads
    are not included: pass ``cache_key`` when they vary."""
    import hashlib

    h = hashlib.sha256()

    def code(c: Any) -> None:
        h.update(c.co_code)
        h.update(repr(c.co_names).encode())
        for k in c.co_consts:
            if hasattr(k, "co_code"):
                code(k)
            else:
                h.update(repr(k).encode())

    f = getattr(fn, "__func__", fn)
    if hasattr(f, "__code__"):
        code(f.__code__)
        # Plain values among the globals it names (constants, arrays).
        g = getattr(f, "__globals__", {})
        for name in f.__code__.co_names:
            val = g.get(name)
            if isinstance(val, np.ndarray):
                h.update(val.tobytes())
            elif isinstance(val, (int, float, complex, str, bytes, tuple)):
                h.update(repr((name, val)).encode())
            elif callable(val) and hasattr(val, "__code__") and val is not f:
                code(val.__code__)
        h.update(repr(getattr(f, "__defaults__", None)).encode())
        for cell in getattr(f, "__closure__", None) or ():
            try:
                v = cell.cell_contents
            except ValueError:
                continue
            if hasattr(v, "__code__"):
                h.update(_fingerprint(v).encode())
            elif isinstance(v, np.ndarray):
                h.update(v.tobytes())
            else:
                h.update(repr(v).encode())
    else:
        h.update(repr(fn).encode())
    return h.hexdigest()


def _view_numbers(view: Any) -> tuple:
    return tuple(getattr(view, k, None) for k in ("elevation", "azimuth", "projection", "target", "view_height", "distance", "fov"))


def _cached(cache: Any, parts: tuple, compute: Callable[[], "Reference"]) -> "Reference":
    """Load a reference from ``cache`` (a directory) keyed by a hash of
    ``parts``, or compute and store it."""
    import os

    if cache is None:
        cache = os.environ.get("FCOL_REFERENCE_CACHE") or None
    if cache is None:
        return compute()
    import hashlib
    import pickle

    key = hashlib.sha256(repr((_CACHE_VERSION,) + parts).encode()).hexdigest()[:32]
    os.makedirs(cache, exist_ok=True)
    path = os.path.join(os.fspath(cache), f"ref-{key}.pkl")
    if os.path.exists(path):
        try:
            with open(path, "rb") as fh:
                ref = pickle.load(fh)
            if isinstance(ref, Reference):
                ref.stats["cached"] = True
                return ref
        except Exception:
            pass
    ref = compute()
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "wb") as fh:
        pickle.dump(ref, fh, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(tmp, path)
    return ref


def _as_domain(domain: Any) -> tuple[float, float, float, float]:
    (u0, u1), (v0, v1) = domain
    u0, u1, v0, v1 = float(u0), float(u1), float(v0), float(v1)
    if not all(np.isfinite([u0, u1, v0, v1])) or u0 == u1 or v0 == v1:
        raise ValueError(f"domain: expected ((u0, u1), (v0, v1)) with finite, distinct bounds, got {domain!r}")
    return min(u0, u1), max(u0, u1), min(v0, v1), max(v0, v1)


def _empty(H: int, W: int) -> dict[str, np.ndarray]:
    return dict(
        mask=np.zeros((H, W), bool),
        depth=np.full((H, W), np.nan),
        normal=np.full((H, W, 3), np.nan),
        uv=np.full((H, W, 2), np.nan),
        side=np.zeros((H, W), np.int8),
        point=np.full((H, W, 3), np.nan),
    )


def _slab(O: np.ndarray, D: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parameter interval [s_in, s_out] of rays O + s·D inside the box lo..hi."""
    s_in = np.full(O.shape[0], -np.inf)
    s_out = np.full(O.shape[0], np.inf)
    for k in range(3):
        if not (np.isfinite(lo[k]) and np.isfinite(hi[k])):
            continue
        dk = D[:, k]
        par = np.abs(dk) < 1e-300
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (lo[k] - O[:, k]) / dk
            t2 = (hi[k] - O[:, k]) / dk
        a = np.where(par, -np.inf, np.minimum(t1, t2))
        b = np.where(par, np.inf, np.maximum(t1, t2))
        outside = par & ((O[:, k] < lo[k]) | (O[:, k] > hi[k]))
        a[outside] = np.inf
        b[outside] = -np.inf
        s_in = np.maximum(s_in, a)
        s_out = np.minimum(s_out, b)
    return s_in, s_out


def _first_hit_embree(vertices: np.ndarray, faces: np.ndarray, O: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First triangle hit per ray with trimesh + embreex, and the ray
    parameter of that hit recomputed in float64 (Möller–Trumbore)."""
    import trimesh
    from trimesh.ray.ray_pyembree import RayMeshIntersector

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    tri = np.full(O.shape[0], -1, np.int64)
    if len(faces) and O.shape[0]:
        tri = np.asarray(RayMeshIntersector(mesh).intersects_first(O, D), np.int64)
    s = np.full(O.shape[0], np.inf)
    hit = tri >= 0
    if hit.any():
        t = faces[tri[hit]]
        a, b, c = vertices[t[:, 0]], vertices[t[:, 1]], vertices[t[:, 2]]
        e1, e2 = b - a, c - a
        d = D[hit]
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        q = O[hit] - a
        with np.errstate(divide="ignore", invalid="ignore"):
            qq = np.cross(q, e1)
            s[hit] = np.einsum("ij,ij->i", e2, qq) / det
        s[~np.isfinite(s)] = np.inf
    return tri, s


# --------------------------------------------------------------------------
# Height fields


class _HeightRays:
    """g(s) = P_w − f(P_u, P_v) and g'(s) along a set of rays."""

    def __init__(self, f: Callable, grad: Callable, O: np.ndarray, D: np.ndarray, box: tuple[float, float, float, float]):
        self.f, self.grad, self.O, self.D, self.box = f, grad, O, D, box
        self.evals = 0

    def fg(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        u0, u1, v0, v1 = self.box
        u = np.clip(u, u0, u1)
        v = np.clip(v, v0, v1)
        with np.errstate(all="ignore"):
            w = np.broadcast_to(np.asarray(self.f(u, v), float), u.shape)
            gu, gv = self.grad(u, v)
            gu = np.broadcast_to(np.asarray(gu, float), u.shape)
            gv = np.broadcast_to(np.asarray(gv, float), u.shape)
        self.evals += u.size
        return w, gu, gv

    def g(self, rid: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """g and g' at ray parameters s; rid has the shape of s, or s has
        one more (trailing) axis than rid (several samples per ray)."""
        O, D = self.O[rid], self.D[rid]
        if s.ndim > rid.ndim:
            O, D = O[..., None, :], D[..., None, :]
        pu = O[..., 0] + s * D[..., 0]
        pv = O[..., 1] + s * D[..., 1]
        pw = O[..., 2] + s * D[..., 2]
        w, gu, gv = self.fg(pu, pv)
        with np.errstate(all="ignore"):
            g = pw - w
            gp = D[..., 2] - gu * D[..., 0] - gv * D[..., 1]
        return g, gp


def _hermite_min(ga, gb, gpa, gpb, h, sigma):
    """Minimum over t in (0, 1) of sigma·p(t), p the cubic Hermite model of g
    on an interval of length h (sampled at 15 interior points)."""
    t = np.linspace(0.0, 1.0, 17)[1:-1]
    t2, t3 = t * t, t * t * t
    h00 = 2 * t3 - 3 * t2 + 1
    h10 = t3 - 2 * t2 + t
    h01 = -2 * t3 + 3 * t2
    h11 = t3 - t2
    p = (ga[:, None] * h00 + (h * gpa)[:, None] * h10 + gb[:, None] * h01 + (h * gpb)[:, None] * h11)
    return (sigma[:, None] * p).min(axis=1)


def _dangerous(ga, gb, gpa, gpb, h):
    """Same-sign intervals where the Hermite model of g dips (below both
    ends) close to zero or across it: a crest the ray may graze or cross
    twice between the two samples."""
    sigma = np.sign(ga)
    with np.errstate(invalid="ignore"):
        ends = np.minimum(sigma * ga, sigma * gb)
        slope = h * (np.abs(gpa) + np.abs(gpb))
        # Hermite basis: h00 + h01 = 1 and |h10|, |h11| <= 4/27 on [0, 1].
        cand = (ga * gb > 0) & (ends < (4.0 / 27.0 + 0.05) * slope)
        out = np.zeros(ga.shape, bool)
        i = np.nonzero(cand)[0]
        if i.size:
            m = _hermite_min(ga[i], gb[i], gpa[i], gpb[i], h[i], sigma[i])
            out[i] = (m < 0) | ((m < ends[i]) & (m < 0.05 * slope[i]))
        # g turning back (towards zero at a, away from it at b): a crest of
        # f between the samples, possibly kinked (the ridge of a bilinear
        # grid), which the Hermite model does not see. Keep the interval
        # unless a Lipschitz bound from the end slopes excludes a root, or,
        # where g is convex, the tangent lines at both ends (a lower bound)
        # stay on the same side.
        turn = (ga * gb > 0) & (sigma * gpa < 0) & (sigma * gpb > 0)
        j = np.nonzero(turn & ~out)[0]
        if j.size:
            lip = np.abs(ga[j]) + np.abs(gb[j]) < h[j] * np.maximum(np.abs(gpa[j]), np.abs(gpb[j]))
            t = np.clip((gb[j] - ga[j] - gpb[j] * h[j]) / (gpa[j] - gpb[j]), 0.0, h[j])
            out[j] = lip | (sigma[j] * (ga[j] + gpa[j] * t) < 0)
    # One end in a hole (NaN) of f: the edge of the defined region lies
    # inside; bisect to find the surface up to that edge.
    return out | (np.isfinite(ga) != np.isfinite(gb))


def _polish(rays: _HeightRays, rid, a, b, ga, gb, iters: int = 80):
    """Safeguarded Newton/bisection for the root of g in [a, b] (g(a), g(b)
    of opposite signs or one of them zero)."""
    a, b, ga, gb = a.copy(), b.copy(), ga.copy(), gb.copy()
    x = np.where(ga == 0, a, np.where(gb == 0, b, 0.5 * (a + b)))
    done = (ga == 0) | (gb == 0)
    ok = done.copy()
    for _ in range(iters):
        live = ~done
        if not live.any():
            break
        idx = np.nonzero(live)[0]
        gx, gpx = rays.g(rid[idx], x[idx])
        bad = ~np.isfinite(gx)
        zero = gx == 0
        same_a = np.sign(gx) == np.sign(ga[idx])
        na = np.where(same_a & ~bad, x[idx], a[idx])
        nb = np.where(~same_a & ~bad, x[idx], b[idx])
        nga = np.where(same_a & ~bad, gx, ga[idx])
        ngb = np.where(~same_a & ~bad, gx, gb[idx])
        # A NaN inside the bracket: keep the half before it (the first root).
        nb = np.where(bad, x[idx], nb)
        a[idx], b[idx], ga[idx], gb[idx] = na, nb, nga, ngb
        with np.errstate(all="ignore"):
            xn = x[idx] - gx / gpx
        inside = np.isfinite(xn) & (xn > na) & (xn < nb)
        xn = np.where(inside, xn, 0.5 * (na + nb))
        width = nb - na
        scale = np.maximum(np.abs(na), np.abs(nb)) + 1e-300
        conv = zero | (width <= 4e-16 * scale)
        # Newton steps that have become tiny also mean convergence.
        conv |= inside & (np.abs(xn - x[idx]) <= 1e-15 * scale)
        x[idx] = np.where(zero, x[idx], xn)
        ok[idx] |= conv & ~bad
        done[idx] |= conv
    return x, ok


def height_reference(
    f: Callable,
    grad: Callable,
    domain: Any,
    view: Any,
    width: int,
    height: int,
    *,
    mesh: int = 256,
    march_cells: float = 2.0,
    chunk: int = 16,
    cache: Any = None,
    cache_key: str | None = None,
) -> Reference:
    """The exact first hit of every pixel ray of ``view`` with w = f(u, v)
    over ``domain`` (no surface outside it).

    ``f(u, v)`` and ``grad(u, v) -> (f_u, f_v)`` are NumPy-vectorised.
    ``mesh`` is the tessellation (mesh × mesh vertices) cast with embreex;
    ``march_cells`` the marching step in mesh cells (projected on the (u, v)
    plane) of the guard march that finds crests the mesh misses.
    ``stats`` holds timings, evaluations and how many first hits lie more
    than one pixel before the mesh hit (crests the mesh missed).

    ``cache``: a directory where references are stored (default: the
    ``FCOL_REFERENCE_CACHE`` environment variable, else no cache), keyed by a
    hash of every input: the callables by their code, closure values and the
    plain values (numbers, strings, arrays) and functions they name as
    globals, or by ``cache_key`` if given (pass one when a callable depends
    on anything else that may change).

    Pixels are trusted except rays whose bracket closed on a jump of f (the
    vertical wall of a step: hit kept, ``stats["walls"]``) and misses next
    to an unresolved graze thinner than 1e-3 pixel.
    """
    parts = ("height", cache_key or (_fingerprint(f), _fingerprint(grad)), repr(domain), _view_numbers(view),
             int(width), int(height), mesh, march_cells)
    return _cached(cache, parts, lambda: _height_reference(f, grad, domain, view, width, height, mesh, march_cells, chunk))


def _height_reference(f, grad, domain, view, width, height, mesh, march_cells, chunk) -> Reference:
    t_start = time.perf_counter()
    u0, u1, v0, v1 = _as_domain(domain)
    W, H = int(width), int(height)
    cam = camera_of(view, W, H)
    O, D = cam.rays()
    O = np.ascontiguousarray(O.reshape(-1, 3), dtype=float)
    D = np.ascontiguousarray(D.reshape(-1, 3), dtype=float)
    N = O.shape[0]
    stats: dict[str, Any] = {}

    # Tessellation; its height range bounds the slab the rays are marched in.
    n = max(int(mesh), 2)
    uu, vv = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n))
    with np.errstate(all="ignore"):
        ww = np.broadcast_to(np.asarray(f(uu, vv), float), uu.shape).copy()
    finite = np.isfinite(ww)
    out = _empty(H, W)
    pix_all = np.full((H, W), np.nan)
    if not finite.any():
        return Reference(trusted=np.ones((H, W), bool), pixel_size=pix_all, stats=stats, **out)
    wlo, whi = float(ww[finite].min()), float(ww[finite].max())
    scale = max(abs(u1 - u0), abs(v1 - v0), abs(wlo), abs(whi))
    # Between vertices f may rise above the sampled range by at most about
    # |grad|·cell (a spike between vertices): widen the slab by that too.
    with np.errstate(all="ignore"):
        gu, gv = grad(uu, vv)
        gabs = np.abs(np.stack(np.broadcast_arrays(np.asarray(gu, float), np.asarray(gv, float))))
    gabs = gabs[np.isfinite(gabs)]
    gmax = float(gabs.max()) if gabs.size else 0.0
    cell0 = max(u1 - u0, v1 - v0) / (n - 1)
    margin = 0.05 * (whi - wlo) + gmax * cell0 + 1e-9 * scale + 1e-300
    lo = np.array([u0, v0, wlo - margin])
    hi = np.array([u1, v1, whi + margin])
    s_in, s_out = _slab(O, D, lo, hi)
    if cam.persp:
        s_in = np.maximum(s_in, cam.near / (D @ cam.d))
    live = s_in < s_out
    stats["t_setup"] = time.perf_counter() - t_start

    # Mesh cast: from just before the slab entry (orthographic rays are
    # whole lines, so their origins are moved back to the slab).
    t0 = time.perf_counter()
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d_ = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    faces = np.concatenate([np.stack([a, b, d_], -1).reshape(-1, 3), np.stack([a, d_, c], -1).reshape(-1, 3)])
    fok = finite.reshape(-1)
    faces = faces[fok[faces].all(axis=1)]
    verts = np.stack([uu, vv, np.where(finite, ww, 0.0)], -1).reshape(-1, 3)
    back = 1e-3 * (hi - lo).max()
    li = np.nonzero(live)[0]
    s_mesh = np.full(N, np.inf)
    if li.size:
        start = s_in[li] - back
        if cam.persp:
            start = np.maximum(start, 0.0)
        _, sm = _first_hit_embree(verts, faces, O[li] + start[:, None] * D[li], D[li])
        s_mesh[li] = start + sm
    stats["t_mesh"] = time.perf_counter() - t0

    # Guard march along each ray from its slab entry (sign changes bracket a
    # root; same-sign intervals the Hermite model puts near zero are kept for
    # bisection).
    t0 = time.perf_counter()
    rays = _HeightRays(f, grad, O, D, (u0, u1, v0, v1))
    cell = min(u1 - u0, v1 - v0) / (n - 1)
    duv = np.hypot(D[:, 0], D[:, 1])
    with np.errstate(divide="ignore"):
        h = np.minimum(march_cells * cell / duv, (s_out - s_in) / 4.0)
    depth_in = (O + np.where(np.isfinite(s_in), s_in, 0)[:, None] * D - cam.origin) @ cam.d
    pix_in = cam.pixel_size(np.abs(depth_in)) if cam.persp else np.full(N, cam.p)
    hmin = 1e-3 * np.maximum(pix_in, 1e-300) / np.maximum(D @ cam.d, 1e-3)

    br_a = np.full(N, np.inf)  # earliest bracket [br_a, br_b]
    br_b = np.full(N, np.inf)
    br_ga = np.full(N, np.nan)
    br_gb = np.full(N, np.nan)
    pend: list[tuple[np.ndarray, ...]] = []  # dangerous intervals

    act = np.nonzero(live)[0]
    s_cur = s_in[act].copy()
    g_cur, gp_cur = rays.g(act, s_cur)
    while act.size:
        k = np.arange(1, chunk + 1)
        S = np.minimum(s_cur[:, None] + k[None, :] * h[act, None], s_out[act, None])
        G, GP = rays.g(act, S)
        Sa = np.concatenate([s_cur[:, None], S[:, :-1]], 1)
        Ga = np.concatenate([g_cur[:, None], G[:, :-1]], 1)
        GPa = np.concatenate([gp_cur[:, None], GP[:, :-1]], 1)
        nonempty = S > Sa
        with np.errstate(invalid="ignore"):
            sc = nonempty & (((Ga > 0) & (G <= 0)) | ((Ga < 0) & (G >= 0)) | (Ga == 0))
        has = sc.any(1)
        first = np.where(has, sc.argmax(1), chunk)
        rows = np.nonzero(has)[0]
        r_ = act[rows]
        cfirst = first[rows]
        br_a[r_] = Sa[rows, cfirst]
        br_b[r_] = S[rows, cfirst]
        br_ga[r_] = Ga[rows, cfirst]
        br_gb[r_] = G[rows, cfirst]
        before = nonempty & (k[None, :] - 1 < first[:, None])
        ii, jj = np.nonzero(before)
        if ii.size:
            dang = _dangerous(Ga[ii, jj], G[ii, jj], GPa[ii, jj], GP[ii, jj], S[ii, jj] - Sa[ii, jj])
            ii, jj = ii[dang], jj[dang]
            if ii.size:
                pend.append((act[ii], Sa[ii, jj], S[ii, jj], Ga[ii, jj], G[ii, jj], GPa[ii, jj], GP[ii, jj]))
        keep = ~has & (S[:, -1] < s_out[act])
        act, s_cur, g_cur, gp_cur = act[keep], S[keep, -1], G[keep, -1], GP[keep, -1]

    # Mesh hits well before the march's bracket (thin features between march
    # samples): re-examine a window around the mesh hit finely.
    mh = np.nonzero(live & np.isfinite(s_mesh) & (s_mesh < br_a - 0.25 * h))[0]
    stats["mesh_windows"] = int(mh.size)
    if mh.size:
        m = 32
        a0 = np.maximum(s_mesh[mh] - h[mh], s_in[mh])
        b0 = np.minimum(s_mesh[mh] + h[mh], s_out[mh])
        T = a0[:, None] + (b0 - a0)[:, None] * np.linspace(0, 1, m + 1)[None, :]
        G, GP = rays.g(mh, T)
        rr = np.repeat(mh, m)
        pend.append((rr, T[:, :-1].ravel(), T[:, 1:].ravel(), G[:, :-1].ravel(), G[:, 1:].ravel(), GP[:, :-1].ravel(), GP[:, 1:].ravel()))
    stats["t_march"] = time.perf_counter() - t0

    # Bisection of the dangerous intervals, all rays at once, level by level.
    t0 = time.perf_counter()
    unresolved = np.zeros(N, bool)
    if pend:
        rid, A, B, GA, GB, GPA, GPB = (np.concatenate(x) for x in zip(*pend))
        forced = np.zeros(rid.size, bool)
        if mh.size:
            forced[-mh.size * 32:] = True
        levels = 0
        while rid.size and levels < 200:
            levels += 1
            with np.errstate(invalid="ignore"):
                sc = (B > A) & (((GA > 0) & (GB <= 0)) | ((GA < 0) & (GB >= 0)) | (GA == 0))
            # Record brackets (earliest per ray).
            if sc.any():
                r = rid[sc]
                order = np.lexsort((A[sc], r))
                r, o = r[order], np.nonzero(sc)[0][order]
                firsts = np.r_[True, r[1:] != r[:-1]]
                r, o = r[firsts], o[firsts]
                better = A[o] < br_a[r]
                r, o = r[better], o[better]
                br_a[r], br_b[r], br_ga[r], br_gb[r] = A[o], B[o], GA[o], GB[o]
            L = B - A
            dang = ~sc & (forced | _dangerous(GA, GB, GPA, GPB, L)) & (A < br_a[rid])
            small = dang & (L <= hmin[rid])
            # A graze thinner than hmin (not the edge of a NaN hole).
            unresolved[rid[small & np.isfinite(GA) & np.isfinite(GB)]] = True
            dang &= ~small
            forced = np.zeros(0, bool)
            if not dang.any():
                break
            rid, A, B, GA, GB, GPA, GPB = (x[dang] for x in (rid, A, B, GA, GB, GPA, GPB))
            M = 0.5 * (A + B)
            GM, GPM = rays.g(rid, M)
            rid = np.concatenate([rid, rid])
            A, B = np.concatenate([A, M]), np.concatenate([M, B])
            GA, GB = np.concatenate([GA, GM]), np.concatenate([GM, GB])
            GPA, GPB = np.concatenate([GPA, GPM]), np.concatenate([GPM, GPB])
            forced = np.zeros(rid.size, bool)
        stats["bisection_levels"] = levels
    stats["t_bisect"] = time.perf_counter() - t0

    # Polish the earliest bracket of every ray.
    t0 = time.perf_counter()
    hitr = np.nonzero(np.isfinite(br_a))[0]
    s_hit, ok = _polish(rays, hitr, br_a[hitr], br_b[hitr], br_ga[hitr], br_gb[hitr])
    stats["t_polish"] = time.perf_counter() - t0

    P = O[hitr] + s_hit[:, None] * D[hitr]
    u = np.clip(P[:, 0], u0, u1)
    v = np.clip(P[:, 1], v0, v1)
    w, fu, fv = rays.fg(u, v)
    nrm = np.stack([-fu, -fv, np.ones_like(fu)], -1)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    good = ok & np.isfinite(nrm).all(1) & np.isfinite(w)
    # A residual that did not vanish: the bracket closed on a jump of f (a
    # step), not on a root. The ray meets the wall there; keep the hit but do
    # not trust its normal and depth.
    gx, _ = rays.g(hitr, s_hit)
    pix_hit = cam.pixel_size(np.abs((O[hitr] + s_hit[:, None] * D[hitr] - cam.origin) @ cam.d)) if cam.persp else np.full(hitr.size, cam.p)
    wall = ~(np.abs(gx) <= 1e-4 * pix_hit + 1e-12 * scale)
    stats["walls"] = int(np.sum(wall & good))
    wall = wall[good]
    hitr, P, u, v, nrm, s_hit = hitr[good], P[good], u[good], v[good], nrm[good], s_hit[good]
    side = np.where(br_ga[hitr] > 0, 1, np.where(br_ga[hitr] < 0, -1, np.where(br_gb[hitr] < 0, 1, -1)))
    P[:, 0], P[:, 1], P[:, 2] = u, v, w[good]
    depth = (P - cam.origin) @ cam.d

    flat = {k: v_.reshape((N,) + v_.shape[2:]) for k, v_ in out.items()}
    flat["mask"][hitr] = True
    flat["depth"][hitr] = depth
    flat["normal"][hitr] = nrm
    flat["uv"][hitr] = np.stack([u, v], -1)
    flat["side"][hitr] = side.astype(np.int8)
    flat["point"][hitr] = P
    pix = pix_all.reshape(-1)
    pix[hitr] = cam.pixel_size(depth)
    trusted = np.ones(N, bool)
    trusted[hitr[wall]] = False
    trusted[unresolved & ~flat["mask"]] = False  # a graze thinner than 1e-3 px
    trusted[np.isfinite(br_a) & ~flat["mask"]] = False  # bracket that did not polish
    # Crests the mesh missed: first hit more than a pixel before the mesh hit.
    pix_hit = pix[hitr]
    stats["crests_missed_by_mesh"] = int(np.sum(s_hit * (D[hitr] @ cam.d) < (s_mesh[hitr] * (D[hitr] @ cam.d) - pix_hit)))
    stats["mesh_hits_without_surface"] = int(np.sum(np.isfinite(s_mesh) & ~flat["mask"]))
    stats["evaluations"] = rays.evals
    stats["elapsed"] = time.perf_counter() - t_start
    return Reference(trusted=trusted.reshape(H, W), pixel_size=pix_all, stats=stats, **out)


# --------------------------------------------------------------------------
# Shading (NumPy port of fcol's shading model) and comparison


def _to_eye(cam: SpecCamera, point: np.ndarray) -> np.ndarray:
    if cam.persp:
        v = cam.E - point
        with np.errstate(invalid="ignore", divide="ignore"):
            return v / np.linalg.norm(v, axis=-1, keepdims=True)
    return np.broadcast_to(-cam.d, point.shape)


def _points(ref: Reference, cam: SpecCamera) -> np.ndarray:
    if ref.point is not None:
        return ref.point
    O, D = cam.rays()
    s = ref.depth / (D @ cam.d) if cam.persp else ref.depth
    return O + s[..., None] * D


def shade(
    ref: Reference,
    view: Any,
    *,
    light: Any = None,
    ambient: float = 0.12,
    diffuse: float = 0.88,
    specular: float = 0.0,
    shininess: float = 32.0,
    upper_color: Any = (235, 200, 120),
    under_color: Any = (110, 150, 230),
    background: Any = (255, 255, 255),
) -> tuple[np.ndarray, np.ndarray]:
    """fcol's two-sided shading model applied to a reference:
    intensity = ambient + diffuse·max(0, N·L) + specular·max(0, R·V)^shininess
    with N turned towards the viewer, L the headlight (towards the eye) or the
    unit ``light`` direction (u, v, w) towards a directional light, V towards
    the eye, R = 2(N·L)N − L; colour = round(base·intensity) clamped to 0–255,
    base by ``ref.side``. Returns (intensity (H, W) float64 with NaN
    background, rgb (H, W, 3) uint8)."""
    H, W = ref.mask.shape
    cam = camera_of(view, W, H)
    P = _points(ref, cam)
    V = _to_eye(cam, P)
    n = ref.normal
    with np.errstate(invalid="ignore"):
        n = np.where((np.sum(n * V, -1) < 0)[..., None], -n, n)
        if light is None:
            L = V
        else:
            L = np.asarray(light, float)
            L = np.broadcast_to(L / np.linalg.norm(L), n.shape)
        nl = np.sum(n * L, -1)
        inten = ambient + diffuse * np.maximum(nl, 0.0)
        if specular > 0:
            R = 2 * nl[..., None] * n - L
            spec = specular * np.maximum(np.sum(R * V, -1), 0.0) ** shininess
            inten = inten + np.where(nl > 0, spec, 0.0)
    inten = np.where(ref.mask, inten, np.nan)
    base = np.where((ref.side >= 0)[..., None], np.asarray(upper_color, float), np.asarray(under_color, float))
    with np.errstate(invalid="ignore"):
        # Rust's f64::round (half away from zero) on non-negative values.
        c = np.clip(np.floor(base * inten[..., None] + 0.5), 0, 255)
    rgb = np.where(ref.mask[..., None], np.nan_to_num(c), np.asarray(background, float)).astype(np.uint8)
    return inten, rgb


def _neighbour_pairs(H: int, W: int):
    """Index slices (a, b) of the 4 neighbour directions right, down,
    down-right, down-left (8-neighbourhood, each pair once)."""
    return [
        ((slice(None), slice(0, W - 1)), (slice(None), slice(1, W))),
        ((slice(0, H - 1), slice(None)), (slice(1, H), slice(None))),
        ((slice(0, H - 1), slice(0, W - 1)), (slice(1, H), slice(1, W))),
        ((slice(0, H - 1), slice(1, W)), (slice(1, H), slice(0, W - 1))),
    ]


def silhouette_band(mask: np.ndarray) -> np.ndarray:
    """Pixels within one pixel of the silhouette: those with an
    8-neighbour on the other side of the mask (both sides of the curve).
    The image frame is not a silhouette."""
    H, W = mask.shape
    band = np.zeros((H, W), bool)
    for a, b in _neighbour_pairs(H, W):
        diff = mask[a] != mask[b]
        band[a] |= diff
        band[b] |= diff
    return band


def discontinuity_band(ref: Reference, view: Any, tol_px: float = 3.0) -> np.ndarray:
    """Pixels at either end of a depth discontinuity between 8-neighbours.

    Between neighbouring surface pixels a and b, the depth of b is predicted
    from the tangent plane at a's hit (intersected with b's ray) and the other
    way round; the pair is a discontinuity when both predictions miss by
    more than ``tol_px`` pixel sizes (an occluding crest, a fold, a step, or a
    surface so grazing that its depth is ill-posed)."""
    H, W = ref.mask.shape
    cam = camera_of(view, W, H)
    O, D = cam.rays()
    P = _points(ref, cam)
    n = ref.normal
    band = np.zeros((H, W), bool)

    def predict(Pa, na, Ob, Db):
        with np.errstate(all="ignore"):
            t = np.sum((Pa - Ob) * na, -1) / np.sum(Db * na, -1)
            return (Ob + t[..., None] * Db - cam.origin) @ cam.d

    for a, b in _neighbour_pairs(H, W):
        both = ref.mask[a] & ref.mask[b]
        with np.errstate(invalid="ignore"):
            eb = np.abs(predict(P[a], n[a], O[b], D[b]) - ref.depth[b]) / ref.pixel_size[b]
            ea = np.abs(predict(P[b], n[b], O[a], D[a]) - ref.depth[a]) / ref.pixel_size[a]
            smooth = np.minimum(ea, eb) <= tol_px
        disc = both & ~smooth
        band[a] |= disc
        band[b] |= disc
    return band


def _image_mask(image: Any) -> np.ndarray | None:
    if getattr(image, "mask", None) is not None:
        return np.asarray(image.mask, bool)
    if getattr(image, "depth", None) is not None:
        return np.isfinite(np.asarray(image.depth))
    if getattr(image, "side", None) is not None:
        return np.asarray(image.side) != 0
    if getattr(image, "normal", None) is not None:
        return np.isfinite(np.asarray(image.normal)).all(-1)
    return None


def angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle in degrees between vectors (..., 3), accurate for tiny angles."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        a = a / np.linalg.norm(a, axis=-1, keepdims=True)
        b = b / np.linalg.norm(b, axis=-1, keepdims=True)
        return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, -1)))


def compare(image: Any, ref: Reference, view: Any, *, shading: dict | None = None, disc_tol_px: float = 3.0,
            valid: np.ndarray | None = None) -> dict:
    """Errors of a render against a reference (SPEC §5), on whatever
    buffers ``image`` holds.

    * ``mask_bad``: pixels whose mask differs from the reference outside the
      1-pixel band of the true silhouette (:func:`silhouette_band`), on
      trusted reference pixels; ``mask_bad_at``: the first ten (row, col);
    * ``depth_px_median``, ``depth_px_p99``, ``depth_px_max``: |depth − ref|
      divided by the world size of one pixel at the hit;
    * ``normal_deg_median``, ``normal_deg_p99``, ``normal_deg_max``: angle
      between normals;
    * ``uv_err_median``: distance in (u, v);
    * ``side_bad``: compared pixels whose side differs;
    * ``farther_sheet``: compared pixels more than one pixel deeper than the
      reference (a farther sheet taken for the nearest);
    * ``intensity_err_median``, ``_p99``, ``_max``: |intensity − intensity of
      :func:`shade` of the reference|;
    * ``ssim``: skimage's structural similarity of ``rgb`` against
      :func:`shade` of the reference (``shading`` = its keyword options);
    * ``n_compared``: pixels compared — trusted reference pixels where both
      have surface, away from the silhouette band and from the 1-pixel bands
      at depth discontinuities (:func:`discontinuity_band`), and inside
      ``valid`` (an optional (H, W) bool mask) when given.
    """
    H, W = ref.mask.shape
    res: dict[str, Any] = {}
    sil = silhouette_band(ref.mask)
    disc = discontinuity_band(ref, view, disc_tol_px)
    m = _image_mask(image)
    if m is not None:
        bad = (m != ref.mask) & ~sil & ref.trusted
        res["mask_bad"] = int(bad.sum())
        res["mask_bad_at"] = [tuple(int(x) for x in p) for p in np.argwhere(bad)[:10]]
        both = m & ref.mask
    else:
        both = ref.mask.copy()
    cmp = both & ref.trusted & ~sil & ~disc
    if valid is not None:
        cmp &= np.asarray(valid, bool)
    res["n_compared"] = int(cmp.sum())

    def stats(name: str, err: np.ndarray) -> None:
        e = err[np.isfinite(err)]
        if e.size:
            res[name + "_median"] = float(np.median(e))
            res[name + "_p99"] = float(np.percentile(e, 99))
            res[name + "_max"] = float(e.max())

    if getattr(image, "depth", None) is not None:
        dz = (np.asarray(image.depth, float) - ref.depth) / ref.pixel_size
        dz = np.where(cmp, dz, np.nan)
        stats("depth_px", np.abs(dz))
        res["farther_sheet"] = int(np.sum(dz > 1.0))
    if getattr(image, "normal", None) is not None:
        ang = angle_deg(image.normal, ref.normal)
        stats("normal_deg", np.where(cmp, ang, np.nan))
    if getattr(image, "uv", None) is not None:
        e = np.linalg.norm(np.asarray(image.uv, float) - ref.uv, axis=-1)[cmp]
        e = e[np.isfinite(e)]
        if e.size:
            res["uv_err_median"] = float(np.median(e))
    if getattr(image, "side", None) is not None:
        res["side_bad"] = int(np.sum((np.asarray(image.side) != ref.side) & cmp))
    shaded = None
    if getattr(image, "intensity", None) is not None:
        shaded = shade(ref, view, **(shading or {}))
        stats("intensity_err", np.where(cmp, np.abs(np.asarray(image.intensity, float) - shaded[0]), np.nan))
    if getattr(image, "rgb", None) is not None:
        from skimage.metrics import structural_similarity

        _, rgb = shaded or shade(ref, view, **(shading or {}))
        res["ssim"] = float(structural_similarity(np.asarray(image.rgb), rgb, channel_axis=2, data_range=255))
    return res


def correction_effect(base: Any, corrected: Any, ref: Reference, view: Any, *, shading: dict | None = None,
                      disc_tol_px: float = 3.0) -> dict:
    """What a local correction did, measured against a reference: two
    renders of one view, ``base`` without the correction and ``corrected``
    with it, each holding ``intensity`` and ``mask`` (and ``depth`` for the
    depth figures).

    * ``changed``: pixels whose intensity the correction changed, among
      the pixels :func:`compare` compares (trusted, surface in the
      reference and in both renders, away from the 1-pixel silhouette and
      depth-discontinuity bands, where which surface a pixel shows is a
      sub-pixel matter);
    * ``intensity_mean_before`` / ``_after``, ``intensity_p99_before`` /
      ``_after``, ``intensity_max_before`` / ``_after``: |intensity −
      intensity of :func:`shade` of the reference| on those pixels;
    * ``mask_diff_before`` / ``_after``: pixels whose mask differs from the
      reference anywhere (the silhouette band included: a crest outline
      drawn at the wrong row shows there first);
    * ``depth_max_before`` / ``_after``: the largest |depth − reference| in
      pixels over the compared pixels (a crest's top cut off between two
      samples shows here).

    A correction that removes an artifact lowers the figures it is aimed at
    (the shading ones for triangular patches and bumps, the mask and depth
    ones for a corrugated crest) and leaves the others about equal.
    """
    inten = shade(ref, view, **(shading or {}))[0]
    keep = ref.mask & ref.trusted & ~silhouette_band(ref.mask) & ~discontinuity_band(ref, view, disc_tol_px)
    mb, mc = _image_mask(base), _image_mask(corrected)
    if mb is None or mc is None:
        raise ValueError("correction_effect needs renders with a mask (or depth) buffer")
    ib = np.asarray(base.intensity, float)
    ic = np.asarray(corrected.intensity, float)
    both = keep & mb & mc & np.isfinite(ib) & np.isfinite(ic)
    changed = both & (np.abs(ic - ib) > 1e-6)
    res: dict[str, Any] = {"changed": int(changed.sum())}
    for tag, img, m, i in (("before", base, mb, ib), ("after", corrected, mc, ic)):
        e = np.abs(i - inten)[changed]
        res[f"intensity_mean_{tag}"] = float(e.mean()) if e.size else 0.0
        res[f"intensity_p99_{tag}"] = float(np.percentile(e, 99)) if e.size else 0.0
        res[f"intensity_max_{tag}"] = float(e.max()) if e.size else 0.0
        res[f"mask_diff_{tag}"] = int(np.sum((m != ref.mask) & ref.trusted))
        if getattr(img, "depth", None) is not None:
            dz = np.abs(np.asarray(img.depth, float) - ref.depth) / ref.pixel_size
            dz = dz[keep & m & np.isfinite(dz)]
            res[f"depth_max_{tag}"] = float(dz.max()) if dz.size else 0.0
    return res


def oiio_compare(a: np.ndarray, b: np.ndarray, failthresh: float = 1e-6, warnthresh: float = 1e-6) -> dict:
    """OpenImageIO's ``ImageBufAlgo.compare`` of two arrays (H, W) or
    (H, W, C) (uint8 compared in 0–1 units): meanerror, rms_error, PSNR,
    maxerror, maxx, maxy, nwarn, nfail."""
    import OpenImageIO as oiio

    def buf(x: np.ndarray):
        x = np.asarray(x)
        if x.dtype == np.bool_:
            x = x.astype(np.float32)
        elif x.dtype != np.uint8:
            x = x.astype(np.float32)
        if x.ndim == 2:
            x = x[:, :, None]
        x = np.ascontiguousarray(x)
        spec = oiio.ImageSpec(x.shape[1], x.shape[0], x.shape[2], oiio.UINT8 if x.dtype == np.uint8 else oiio.FLOAT)
        ib = oiio.ImageBuf(spec)
        ib.set_pixels(oiio.ROI(), x)
        return ib

    r = oiio.ImageBufAlgo.compare(buf(a), buf(b), failthresh, warnthresh)
    return {k: (float(getattr(r, k)) if k not in ("maxx", "maxy", "nwarn", "nfail") else int(getattr(r, k)))
            for k in ("meanerror", "rms_error", "PSNR", "maxerror", "maxx", "maxy", "nwarn", "nfail")}


# --------------------------------------------------------------------------
# Parametric surfaces


def _xyz(xyz: Callable, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        X, Y, Z = xyz(u, v)
    return np.stack(np.broadcast_arrays(np.asarray(X, float), np.asarray(Y, float), np.asarray(Z, float)), -1)


def _jac(jac: Callable, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    with np.errstate(all="ignore"):
        Pu, Pv = jac(u, v)
    shape = u.shape + (3,)
    return np.broadcast_to(np.asarray(Pu, float), shape), np.broadcast_to(np.asarray(Pv, float), shape)


class _ParamSolver:
    def __init__(self, xyz, jac, O, D, box, periodic, tol, cam):
        self.xyz, self.jac, self.O, self.D, self.box = xyz, jac, O, D, box
        self.periodic, self.tol, self.cam = periodic, tol, cam
        self.evals = 0
        self.reseeded = 0
        self.times: dict[str, float] = {}

    def wrap(self, u, v):
        u0, u1, v0, v1 = self.box
        if self.periodic[0]:
            u = u0 + np.mod(u - u0, u1 - u0)
        else:
            u = np.clip(u, u0, u1)
        if self.periodic[1]:
            v = v0 + np.mod(v - v0, v1 - v0)
        else:
            v = np.clip(v, v0, v1)
        return u, v

    def newton(self, rid, u, v, s, iters=40):
        """Newton on P(u, v) − O − s·D = 0 from (u, v, s); returns the
        solution and whether it converged (residual below tol)."""
        O, D = self.O[rid], self.D[rid]
        u, v = self.wrap(np.asarray(u, float).copy(), np.asarray(v, float).copy())
        s = np.asarray(s, float).copy()
        ok = np.zeros(rid.size, bool)
        i = np.arange(rid.size)
        su = 0.5 * (self.box[1] - self.box[0])
        sv = 0.5 * (self.box[3] - self.box[2])

        def cross(a, b):
            return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

        def dot(a, b):
            return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]

        for _ in range(iters):
            if not i.size:
                break
            P = _xyz(self.xyz, u[i], v[i])
            Oi, Di = O[i], D[i]
            F = P - Oi - s[i, None] * Di
            res = np.sqrt(np.einsum("ij,ij->i", F, F))
            conv = res <= self.tol
            ok[i[conv]] = True
            keep = ~conv & np.isfinite(res)
            i, F, Di = i[keep], F[keep], Di[keep]
            if not i.size:
                break
            Pu, Pv = _jac(self.jac, u[i], v[i])
            pu, pv, c2, b = Pu.T, Pv.T, (-Di).T, (-F).T
            with np.errstate(all="ignore"):
                pv_c2 = cross(pv, c2)
                det = dot(pu, pv_c2)
                du = dot(b, pv_c2) / det
                dv = dot(pu, cross(b, c2)) / det
                ds = dot(pu, cross(pv, b)) / det
                # Damp huge parameter steps (keep the direction).
                k = np.minimum(1.0, 0.5 / np.maximum(np.abs(du) / su, np.abs(dv) / sv))
            k = np.where(np.isfinite(k), k, 0.0)
            good = np.isfinite(du) & np.isfinite(dv) & np.isfinite(ds)
            i, k, du, dv, ds = i[good], k[good], du[good], dv[good], ds[good]
            u[i], v[i] = self.wrap(u[i] + k * du, v[i] + k * dv)
            s[i] = s[i] + k * ds
            self.evals += i.size
        if self.cam.persp:
            ok &= (s * (D @ self.cam.d)) > self.cam.near
        return u, v, s, ok


def _param_single(solver: _ParamSolver, n: int, H: int, W: int, s_back: np.ndarray, reseed_px: float, passes: int):
    import trimesh

    u0, u1, v0, v1 = solver.box
    O, D = solver.O, solver.D
    N = O.shape[0]
    uu, vv = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n))
    P = _xyz(solver.xyz, uu, vv)
    fin = np.isfinite(P).all(-1).reshape(-1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d_ = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    faces = np.concatenate([np.stack([a, b, d_], -1).reshape(-1, 3), np.stack([a, d_, c], -1).reshape(-1, 3)])
    faces = faces[fin[faces].all(1)]
    verts = np.where(fin[:, None], P.reshape(-1, 3), 0.0)
    uvv = np.stack([uu, vv], -1).reshape(-1, 2)
    # Drop degenerate (zero-area) triangles, e.g. at poles.
    tri = verts[faces]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=-1)
    faces = faces[area > 1e-14 * max(np.ptp(verts, axis=0).max(), 1e-300) ** 2]

    best_s = np.full(N, np.inf)
    best_u = np.full(N, np.nan)
    best_v = np.full(N, np.nan)
    if len(faces):
        from trimesh.ray.ray_pyembree import RayMeshIntersector

        mesh = trimesh.Trimesh(vertices=verts, faces=faces, process=False)
        start = O + s_back[:, None] * D
        t0 = time.perf_counter()
        it, ir, loc = RayMeshIntersector(mesh).intersects_id(start, D, multiple_hits=True, max_hits=16, return_locations=True)
        solver.times["cast"] = solver.times.get("cast", 0.0) + time.perf_counter() - t0
        t0 = time.perf_counter()
        if it.size:
            tri = verts[faces[it]]
            bary = trimesh.triangles.points_to_barycentric(tri, loc)
            uv0 = np.einsum("ij,ijk->ik", bary, uvv[faces[it]])
            s0 = np.sum((loc - O[ir]) * D[ir], -1)
            u, v, s, ok = solver.newton(ir, uv0[:, 0], uv0[:, 1], s0)
            _keep_nearest(best_s, best_u, best_v, ir[ok], s[ok], u[ok], v[ok])
        solver.times["newton"] = solver.times.get("newton", 0.0) + time.perf_counter() - t0

    # Re-seed from neighbours where a pixel misses or is much deeper than one.
    cam = solver.cam
    changed = np.isfinite(best_s).reshape(H, W)  # neighbours worth seeding from
    t0 = time.perf_counter()
    for _ in range(passes):
        depth = np.where(np.isfinite(best_s), best_s * (D @ cam.d) + (O - cam.origin) @ cam.d, np.nan).reshape(H, W)
        pix = cam.pixel_size(np.abs(depth)) if cam.persp else np.full((H, W), cam.p)
        hit = np.isfinite(depth)
        rid_l, src_l = [], []
        depth_p = np.pad(depth, 1, constant_values=np.nan)
        changed_p = np.pad(changed, 1, constant_values=False)
        index_p = np.pad(np.arange(N).reshape(H, W), 1, constant_values=-1)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                if di == 0 and dj == 0:
                    continue
                win = (slice(1 + di, 1 + di + H), slice(1 + dj, 1 + dj + W))
                nd = depth_p[win]
                with np.errstate(invalid="ignore"):
                    need = changed_p[win] & np.isfinite(nd) & (~hit | (depth > nd + reseed_px * pix))
                r = np.flatnonzero(need)
                rid_l.append(r)
                src_l.append(index_p[win].reshape(-1)[r])
        rid = np.concatenate(rid_l)
        src = np.concatenate(src_l)
        if not rid.size:
            break
        # Start from the neighbour's parameters, at the depth of its hit.
        s_seed = best_s[src] * (D[src] @ cam.d) / (D[rid] @ cam.d) + ((O[src] - O[rid]) @ cam.d) / (D[rid] @ cam.d)
        u, v, s, ok = solver.newton(rid, best_u[src], best_v[src], s_seed, iters=25)
        before = best_s.copy()
        _keep_nearest(best_s, best_u, best_v, rid[ok], s[ok], u[ok], v[ok])
        changed = (best_s != before).reshape(H, W)
        solver.reseeded += rid.size
        if not changed.any():
            break
    solver.times["reseed"] = solver.times.get("reseed", 0.0) + time.perf_counter() - t0
    return best_s, best_u, best_v


def _keep_nearest(best_s, best_u, best_v, rid, s, u, v):
    if not rid.size:
        return
    order = np.lexsort((s, rid))
    rid, s, u, v = rid[order], s[order], u[order], v[order]
    first = np.r_[True, rid[1:] != rid[:-1]]
    rid, s, u, v = rid[first], s[first], u[first], v[first]
    better = s < best_s[rid]
    rid, s, u, v = rid[better], s[better], u[better], v[better]
    best_s[rid], best_u[rid], best_v[rid] = s, u, v


def parametric_reference(
    xyz: Callable,
    jac: Callable,
    domain: Any,
    view: Any,
    width: int,
    height: int,
    *,
    tessellations: tuple[int, ...] = (64, 128),
    periodic: tuple[bool, bool] = (False, False),
    reseed_px: float = 4.0,
    passes: int = 8,
    agree_px: float = 1e-6,
    cache: Any = None,
    cache_key: str | None = None,
) -> Reference:
    """The exact nearest hit of every pixel ray with P(u, v) = (X, Y, Z).

    ``xyz(u, v) -> (X, Y, Z)`` and ``jac(u, v) -> (P_u, P_v)`` (each (..., 3))
    are NumPy-vectorised. For every tessellation (n × n vertices) the mesh
    hits (all of them along each ray) are refined by Newton in (u, v, s);
    then pixels that miss, or are more than ``reseed_px`` pixels deeper than
    a neighbour, are re-seeded from their neighbours' solutions (``passes``
    rounds). The result keeps the nearest root any tessellation found;
    ``trusted`` marks pixels where every tessellation found the same hit
    (or the same miss) within ``agree_px`` pixels. ``periodic`` wraps u / v
    instead of clamping them during Newton (sphere, torus). ``cache`` and
    ``cache_key`` as for :func:`height_reference`.
    """
    parts = ("parametric", cache_key or (_fingerprint(xyz), _fingerprint(jac)), repr(domain), _view_numbers(view),
             int(width), int(height), tuple(tessellations), tuple(periodic), reseed_px, passes, agree_px)
    return _cached(cache, parts, lambda: _parametric_reference(xyz, jac, domain, view, width, height, tessellations,
                                                               periodic, reseed_px, passes, agree_px))


def _parametric_reference(xyz, jac, domain, view, width, height, tessellations, periodic, reseed_px, passes,
                          agree_px) -> Reference:
    t_start = time.perf_counter()
    u0, u1, v0, v1 = _as_domain(domain)
    W, H = int(width), int(height)
    cam = camera_of(view, W, H)
    O, D = cam.rays()
    O = np.ascontiguousarray(O.reshape(-1, 3), dtype=float)
    D = np.ascontiguousarray(D.reshape(-1, 3), dtype=float)
    N = O.shape[0]
    # Bounding box of the surface from a dense sample: starting point of
    # the (orthographic, whole-line) rays and the scale of the tolerance.
    m = 4 * max(tessellations)
    Ps = _xyz(xyz, *np.meshgrid(np.linspace(u0, u1, m), np.linspace(v0, v1, m)))
    Ps = Ps[np.isfinite(Ps).all(-1)]
    if Ps.size == 0:
        out = _empty(H, W)
        return Reference(trusted=np.ones((H, W), bool), pixel_size=np.full((H, W), np.nan), stats={}, **out)
    lo, hi = Ps.min(0), Ps.max(0)
    ext = float((hi - lo).max()) or 1.0
    scale = max(ext, float(np.abs(Ps).max()))
    if cam.persp:
        s_back = np.zeros(N)
    else:
        # Origins moved back beyond the bounding box along d.
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        s_back = np.full(N, float(((corners - cam.T) @ cam.d).min()) - 0.05 * ext)
    solver = _ParamSolver(xyz, jac, O, D, (u0, u1, v0, v1), periodic, 1e-12 * scale, cam)
    runs = []
    times = []
    for n in tessellations:
        t0 = time.perf_counter()
        runs.append(_param_single(solver, int(n), H, W, s_back, reseed_px, passes))
        times.append(time.perf_counter() - t0)
    S = np.stack([r[0] for r in runs])
    best = np.argmin(S, 0)
    ar = np.arange(N)
    s = S[best, ar]
    u = np.stack([r[1] for r in runs])[best, ar]
    v = np.stack([r[2] for r in runs])[best, ar]
    hit = np.isfinite(s)
    out = _empty(H, W)
    flat = {k: x.reshape((N,) + x.shape[2:]) for k, x in out.items()}
    P = O[hit] + s[hit, None] * D[hit]
    Pu, Pv = _jac(jac, u[hit], v[hit])
    nrm = np.cross(Pu, Pv)
    with np.errstate(invalid="ignore", divide="ignore"):
        nrm = nrm / np.linalg.norm(nrm, axis=-1, keepdims=True)
    depth = (P - cam.origin) @ cam.d
    flat["mask"][hit] = True
    flat["depth"][hit] = depth
    flat["normal"][hit] = nrm
    flat["uv"][hit] = np.stack([u[hit], v[hit]], -1)
    flat["side"][hit] = np.where(np.sum(nrm * D[hit], -1) < 0, 1, -1).astype(np.int8)
    flat["point"][hit] = P
    pix = np.full(N, np.nan)
    pix[hit] = cam.pixel_size(depth)
    # Trusted: every tessellation found this hit (or all missed).
    all_hit = np.isfinite(S).all(0)
    none_hit = ~np.isfinite(S).any(0)
    dd = np.zeros(N)
    with np.errstate(invalid="ignore"):
        dd[all_hit] = (S[:, all_hit].max(0) - S[:, all_hit].min(0)) * (D[all_hit] @ cam.d) / pix[all_hit]
    trusted = none_hit | (all_hit & (dd <= agree_px) & np.isfinite(flat["normal"]).all(-1))
    stats = {
        "elapsed": time.perf_counter() - t_start,
        "t_tessellations": times,
        "evaluations": solver.evals,
        "reseeded": solver.reseeded,
        **{"t_" + k: v for k, v in solver.times.items()},
        "disagree": int(np.sum(~trusted)),
        "found_by_one_tessellation": int(np.sum(np.isfinite(S).any(0) & ~all_hit)),
    }
    return Reference(trusted=trusted.reshape(H, W), pixel_size=pix.reshape(H, W), stats=stats, **out)



def grid_bilinear(z: Any, extent: Any) -> tuple[Callable, Callable]:
    """(f, grad) of the bilinear interpolant of a height grid, for
    :func:`height_reference`: ``z[i, j]`` is the height at
    u_j = u0 + j·du, v_i = v0 + i·dv over ``extent = (u0, u1, v0, v1)``
    (SPEC §1 grids; v0 > v1 for north-up rasters). A cell with a NaN corner
    is a hole. The gradient is that of the interpolant (one-sided on cell
    edges, taken from the cell the point falls in).

    >>> f, g = grid_bilinear([[0.0, 1.0], [2.0, 3.0]], (0, 1, 0, 1))
    >>> float(f(0.5, 0.5)), tuple(float(x) for x in g(0.5, 0.5))
    (1.5, (1.0, 2.0))
    """
    z = np.asarray(z, float)
    if z.ndim != 2 or min(z.shape) < 2:
        raise ValueError(f"z: expected a 2-D grid of at least 2x2, got shape {z.shape}")
    u0, u1, v0, v1 = (float(x) for x in extent)
    ny, nx = z.shape
    du, dv = (u1 - u0) / (nx - 1), (v1 - v0) / (ny - 1)

    def locate(u, v):
        x = (np.asarray(u, float) - u0) / du
        y = (np.asarray(v, float) - v0) / dv
        j = np.clip(np.floor(x), 0, nx - 2).astype(np.intp)
        i = np.clip(np.floor(y), 0, ny - 2).astype(np.intp)
        return x - j, y - i, i, j

    def corners(i, j):
        return z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]

    def f(u, v):
        tx, ty, i, j = locate(u, v)
        a, b, c, d = corners(i, j)
        return (a * (1 - tx) + b * tx) * (1 - ty) + (c * (1 - tx) + d * tx) * ty

    def grad(u, v):
        tx, ty, i, j = locate(u, v)
        a, b, c, d = corners(i, j)
        fu = ((b - a) * (1 - ty) + (d - c) * ty) / du
        fv = ((c - a) * (1 - tx) + (d - b) * tx) / dv
        return fu, fv

    return f, grad
