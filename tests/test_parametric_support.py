"""Shapes in NumPy and an independent ray-cast reference for the parametric
scan-line tests (trimesh + embreex on two tessellations, every hit refined
by Newton on the exact surface). Nothing here calls fcol's renderer or
camera: pixels and rays come from ``fcol.testing.spec_camera``."""

from __future__ import annotations

import numpy as np
import trimesh
from fcol.testing.spec_camera import SpecCamera

PI = np.pi


def _sphere(u, v):
    cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
    P = np.stack([cv * cu, cv * su, sv], -1)
    Pu = np.stack([-cv * su, cv * cu, 0 * u], -1)
    Pv = np.stack([-sv * cu, -sv * su, cv], -1)
    return P, Pu, Pv


def _torus(u, v, a=1.0, b=0.4):
    cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
    w = a + b * cv
    P = np.stack([w * cu, w * su, b * sv], -1)
    Pu = np.stack([-w * su, w * cu, 0 * u], -1)
    Pv = np.stack([-b * sv * cu, -b * sv * su, b * cv], -1)
    return P, Pu, Pv


def _monkey(u, v):
    P = np.stack([u, v, u**3 - 3 * u * v**2], -1)
    Pu = np.stack([1 + 0 * u, 0 * u, 3 * u**2 - 3 * v**2], -1)
    Pv = np.stack([0 * u, 1 + 0 * u, -6 * u * v], -1)
    return P, Pu, Pv


def _helicoid(u, v, c=0.15):
    cu, su = np.cos(u), np.sin(u)
    P = np.stack([v * cu, v * su, c * u], -1)
    Pu = np.stack([-v * su, v * cu, c + 0 * u], -1)
    Pv = np.stack([cu, su, 0 * u], -1)
    return P, Pu, Pv


def _enneper(u, v):
    P = np.stack([u - u**3 / 3 + u * v**2, v - v**3 / 3 + v * u**2, u**2 - v**2], -1)
    Pu = np.stack([1 - u**2 + v**2, 2 * u * v, 2 * u], -1)
    Pv = np.stack([2 * u * v, 1 - v**2 + u**2, -2 * v], -1)
    return P, Pu, Pv


_H = np.array([[0.0, 0.6, -0.4, 0.2], [0.5, 1.6, -1.2, 0.0], [-0.3, -1.0, 1.8, 0.6], [0.1, 0.4, 0.2, -0.5]])


def _bern(t):
    s = 1 - t
    b = np.stack([s**3, 3 * t * s**2, 3 * t**2 * s, t**3], -1)
    d = np.stack([-3 * s**2, 3 * s**2 - 6 * t * s, 6 * t * s - 3 * t**2, 3 * t**2], -1)
    return b, d


def _bezier(u, v):
    C = np.zeros((4, 4, 3))
    for i in range(4):
        for j in range(4):
            C[i, j] = (i - 1.5, j - 1.5, _H[i, j])
    bu, du = _bern(u)
    bv, dv = _bern(v)
    P = np.einsum("...i,...j,ijk->...k", bu, bv, C)
    Pu = np.einsum("...i,...j,ijk->...k", du, bv, C)
    Pv = np.einsum("...i,...j,ijk->...k", bu, dv, C)
    return P, Pu, Pv


SHAPES = {
    "sphere": (_sphere, ((0, 2 * PI), (-PI / 2, PI / 2))),
    "torus": (_torus, ((0, 2 * PI), (0, 2 * PI))),
    "monkey_saddle": (_monkey, ((-1, 1), (-1, 1))),
    "helicoid": (_helicoid, ((0, 3 * PI), (-1, 1))),
    "enneper": (_enneper, ((-2, 2), (-2, 2))),
    "bezier": (_bezier, ((0, 1), (0, 1))),
}


def camera(view, width, height):
    proj = view.projection
    if proj == "perspective":
        return SpecCamera(view.elevation, view.azimuth, "perspective", view.target,
                          distance=view.distance, fov=view.fov, width=width, height=height)
    return SpecCamera(view.elevation, view.azimuth, "orthographic", view.target,
                      view_height=view.view_height, width=width, height=height)


def _newton_ray(f, dom, u, v, t, o, d, iters=14):
    """Solve P(u, v) = o + t d for (u, v, t), vectorised; returns converged mask."""
    (u0, u1), (v0, v1) = dom
    ok = np.ones(u.shape, bool)
    for _ in range(iters):
        P, Pu, Pv = f(u, v)
        r = P - (o + t[:, None] * d)
        A = np.stack([Pu, Pv, -d], -1)
        with np.errstate(all="ignore"):
            step = np.linalg.solve(A + 0.0, -r[..., None])[..., 0]
        bad = ~np.all(np.isfinite(step), -1)
        step[bad] = 0
        ok &= ~bad
        u, v, t = u + step[:, 0], v + step[:, 1], t + step[:, 2]
    P, _, _ = f(u, v)
    res = np.linalg.norm(P - (o + t[:, None] * d), axis=-1)
    tol = 1e-9 * (1 + np.abs(t) + np.linalg.norm(o, axis=-1))
    eps = 1e-9 * max(u1 - u0, v1 - v0)
    inside = (u >= u0 - eps) & (u <= u1 + eps) & (v >= v0 - eps) & (v <= v1 + eps)
    return u, v, t, ok & (res < tol) & inside


def _cast(f, dom, cam, n):
    (u0, u1), (v0, v1) = dom
    us, vs = np.linspace(u0, u1, n), np.linspace(v0, v1, n)
    U, V = np.meshgrid(us, vs)
    P, _, _ = f(U, V)
    verts = P.reshape(-1, 3)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, e = idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, e], -1).reshape(-1, 3)])
    mesh = trimesh.Trimesh(verts, faces, process=False)
    inter = trimesh.ray.ray_pyembree.RayMeshIntersector(mesh)
    O, D = cam.rays()
    O = np.ascontiguousarray(O.reshape(-1, 3))
    D = np.ascontiguousarray(D.reshape(-1, 3))
    # Orthographic rays are whole lines: start them far behind.
    back = 0.0 if cam.persp else 1e3 * (1 + np.abs(verts).max())
    Os = O - back * D
    tri, ray, loc = inter.intersects_id(Os, D, multiple_hits=True, return_locations=True)
    uvv = np.stack([U.ravel(), V.ravel()], -1)
    bary = trimesh.triangles.points_to_barycentric(mesh.triangles[tri], loc)
    uv = np.einsum("ni,nij->nj", bary, uvv[faces[tri]])
    t = np.einsum("nj,nj->n", loc - O[ray], D[ray])
    return O, D, ray, uv, t


_REFS: dict = {}


def reference(shape, view, width, height, tessellations=(64, 128)):
    """Nearest exact hit per pixel: dict with mask, depth, normal, uv, side,
    trusted, pixel_size (SPEC camera). Computed once per argument set in a
    test session (the exact and the sampled X scan tests share them)."""
    key = (shape, repr(view), width, height, tuple(tessellations))
    if key not in _REFS:
        _REFS[key] = _reference(shape, view, width, height, tessellations)
    return _REFS[key]


def _reference(shape, view, width, height, tessellations):
    f, dom = SHAPES[shape]
    cam = camera(view, width, height)
    npx = width * height
    results = []
    for n in tessellations:
        O, D, ray, uv, t = _cast(f, dom, cam, n)
        uu, vv, tt, ok = _newton_ray(f, dom, uv[:, 0], uv[:, 1], t, O[ray], D[ray])
        P, Pu, Pv = f(uu, vv)
        _, _, z = cam.screen(P)
        ok &= (tt > 0) if cam.persp else np.ones_like(ok)
        best_z = np.full(npx, np.inf)
        best_uv = np.full((npx, 2), np.nan)
        order = np.argsort(-np.where(ok, z, -np.inf))  # far first; nearest written last
        sel = order[ok[order]]
        best_z[ray[sel]] = z[sel]
        best_uv[ray[sel]] = np.stack([uu[sel], vv[sel]], -1)
        # Re-seed misses and outliers from the 8 neighbours (folds, crests).
        for _ in range(2):
            Z = best_z.reshape(height, width)
            UV = best_uv.reshape(height, width, 2)
            Zp = np.pad(Z, 1, constant_values=np.inf)
            nbmin = np.min([Zp[1 + di:1 + di + height, 1 + dj:1 + dj + width]
                            for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)], axis=0)
            pixz = (Z / cam.F) if cam.persp else cam.p
            with np.errstate(invalid="ignore"):
                cand = np.isfinite(nbmin) & ~(Z - nbmin <= 3 * np.where(np.isfinite(pixz), pixz, np.inf))
            cand = cand.ravel()
            if not cand.any():
                break
            for di in (-1, 0, 1):
                for dj in (-1, 0, 1):
                    if di == dj == 0:
                        continue
                    nb_uv = np.roll(UV, (di, dj), (0, 1)).reshape(-1, 2)
                    k = np.nonzero(cand & np.isfinite(nb_uv[:, 0]))[0]
                    if not len(k):
                        continue
                    Pn, _, _ = f(nb_uv[k, 0], nb_uv[k, 1])
                    t0 = np.einsum("nj,nj->n", Pn - O[k], D[k])
                    uu2, vv2, tt2, ok2 = _newton_ray(f, dom, nb_uv[k, 0], nb_uv[k, 1], t0, O[k], D[k])
                    if cam.persp:
                        ok2 &= tt2 > 0
                    P2, _, _ = f(uu2, vv2)
                    _, _, z2 = cam.screen(P2)
                    better = ok2 & (z2 < best_z[k] - 1e-9 * (1 + np.abs(z2)))
                    best_z[k[better]] = z2[better]
                    best_uv[k[better]] = np.stack([uu2[better], vv2[better]], -1)
        results.append((best_z, best_uv))
    (z1, uv1), (z2, uv2) = results[0], results[-1]
    mask = np.isfinite(z2)
    pix = np.ones(npx)
    if cam.persp:
        pix = np.where(mask, z2 / cam.F, np.nan)
    else:
        pix[:] = cam.p
    with np.errstate(invalid="ignore"):
        trusted = (np.isfinite(z1) == mask) & (~mask | (np.abs(z1 - z2) < 1e-6 * pix))
    depth = np.where(mask, z2, np.nan)
    uvf = uv2
    P, Pu, Pv = f(np.nan_to_num(uvf[:, 0]), np.nan_to_num(uvf[:, 1]))
    N = np.cross(Pu, Pv)
    N /= np.linalg.norm(N, axis=-1, keepdims=True)
    O, D = cam.rays()
    to_eye = -D.reshape(-1, 3)
    side = np.where(np.einsum("nj,nj->n", N, to_eye) >= 0, 1, -1).astype(np.int8)
    side[~mask] = 0
    N[~mask] = np.nan
    sh = (height, width)
    return dict(mask=mask.reshape(sh), depth=depth.reshape(sh), normal=N.reshape(sh + (3,)),
                uv=uvf.reshape(sh + (2,)), side=side.reshape(sh), trusted=trusted.reshape(sh),
                pixel_size=np.broadcast_to(pix, npx).reshape(sh))


def _band(mask):
    """Pixels whose 3×3 neighbourhood is not all equal (the 1-pixel band)."""
    m = np.pad(mask, 1, mode="edge")
    H, W = mask.shape
    stack = np.stack([m[1 + di:1 + di + H, 1 + dj:1 + dj + W] for di in (-1, 0, 1) for dj in (-1, 0, 1)])
    return stack.any(0) & ~stack.all(0)


def compare(img, ref):
    """Metrics of SPEC §5 against the reference."""
    out = {}
    rm = ref["mask"]
    band = _band(rm)
    out["mask_bad"] = int(((img.mask != rm) & ~band).sum())
    H, W = rm.shape
    depth = ref["depth"]
    # Depth discontinuities: a neighbour more than 2 px deeper or missing.
    disc = band.copy()
    dp = np.pad(depth, 1, constant_values=np.nan)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            nb = dp[1 + di:1 + di + H, 1 + dj:1 + dj + W]
            with np.errstate(invalid="ignore"):
                disc |= np.abs(nb - depth) / ref["pixel_size"] > 3
    sel = rm & img.mask & ref["trusted"] & ~disc
    out["n_compared"] = int(sel.sum())
    if hasattr(img, "depth") and img.depth is not None:
        e = np.abs(img.depth.astype(np.float64) - depth)[sel] / ref["pixel_size"][sel]
        out["depth_px_median"] = float(np.median(e))
        out["depth_px_p99"] = float(np.percentile(e, 99))
        # Farther sheet than the nearest: more than a pixel deeper anywhere.
        full = rm & img.mask & ref["trusted"]
        with np.errstate(invalid="ignore"):
            out["farther_sheet"] = int(((img.depth - depth) / ref["pixel_size"] > 1.0)[full & ~band].sum())
    if hasattr(img, "normal") and img.normal is not None:
        a = img.normal.astype(np.float64)[sel]
        b = ref["normal"][sel]
        c = np.clip(np.abs(np.einsum("nj,nj->n", a, b)), 0, 1)
        ang = np.degrees(np.arccos(c))
        out["normal_deg_median"] = float(np.median(ang))
        out["normal_deg_p99"] = float(np.percentile(ang, 99))
    return out


def shade(ref, view, width, height, ambient=0.12, diffuse=0.88, upper=(235, 200, 120), under=(110, 150, 230),
          background=(255, 255, 255)):
    """The default two-sided headlight of SPEC §2 applied to the reference."""
    cam = camera(view, width, height)
    _, D = cam.rays()
    to_eye = -D
    n = ref["normal"]
    c = np.abs(np.einsum("...j,...j->...", n, to_eye))
    inten = ambient + diffuse * c
    base = np.where((ref["side"] >= 0)[..., None], np.array(upper, float), np.array(under, float))
    rgb = np.clip(np.round(base * np.nan_to_num(inten)[..., None]), 0, 255).astype(np.uint8)
    rgb[~ref["mask"]] = background
    return np.where(ref["mask"], inten, np.nan), rgb


def ssim(a, b):
    from skimage.metrics import structural_similarity
    return float(structural_similarity(a, b, channel_axis=2, data_range=255))
