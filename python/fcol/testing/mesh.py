"""The mesh approach users have today, as a baseline for benchmarks:
tessellate the surface, build a BVH, cast one ray per pixel with trimesh +
embreex, and interpolate vertex normals with the barycentric coordinates of
the hit. No refinement on the exact surface (that is what
:mod:`fcol.testing.reference` adds). Every stage is timed.

>>> import numpy as np, fcol
>>> from fcol.testing.mesh import mesh_height, cast_height_mesh
>>> m = mesh_height(lambda u, v: 0.1 * u, ((-1, 1), (-1, 1)), 8)
>>> ref, t = cast_height_mesh(m, fcol.View(90, 0, view_height=2.0), 8, 8)
>>> bool(ref.mask.all()), sorted(t)
(True, ['build', 'cast', 'normals', 'rays', 'total'])
"""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from .reference import Reference, _as_domain, _empty, _xyz, _jac, camera_of

__all__ = ["mesh_height", "cast_height_mesh", "mesh_parametric", "cast_parametric_mesh", "build_intersector"]


def _grid_faces(n: int, ok: np.ndarray) -> np.ndarray:
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    # (u, v) counter-clockwise seen from +w: face normals point up.
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    return faces[ok[faces].all(1)]


def mesh_height(f: Callable, domain: Any, n: int, grad: Callable | None = None) -> Any:
    """An n × n vertex grid mesh of w = f(u, v) over ``domain`` (NaN
    vertices dropped with their triangles). With ``grad``, exact vertex
    normals are stored in ``metadata["vertex_normals"]``. The time taken is
    in ``metadata["tessellate_s"]``."""
    import trimesh

    t0 = time.perf_counter()
    u0, u1, v0, v1 = _as_domain(domain)
    uu, vv = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n))
    with np.errstate(all="ignore"):
        ww = np.broadcast_to(np.asarray(f(uu, vv), float), uu.shape)
    ok = np.isfinite(ww).reshape(-1)
    verts = np.stack([uu, vv, np.where(np.isfinite(ww), ww, 0.0)], -1).reshape(-1, 3)
    mesh = trimesh.Trimesh(vertices=verts, faces=_grid_faces(n, ok), process=False)
    if grad is not None:
        with np.errstate(all="ignore"):
            fu, fv = grad(uu, vv)
        nrm = np.stack(np.broadcast_arrays(-np.asarray(fu, float), -np.asarray(fv, float), np.ones_like(uu)), -1).reshape(-1, 3)
        mesh.metadata["vertex_normals"] = nrm / np.linalg.norm(nrm, axis=-1, keepdims=True)
    mesh.metadata["tessellate_s"] = time.perf_counter() - t0
    mesh.metadata["kind"] = "height"
    return mesh


def mesh_parametric(xyz: Callable, domain: Any, n: int, jac: Callable | None = None) -> Any:
    """An n × n vertex grid mesh of P(u, v); vertex (u, v) kept in
    ``metadata["uv"]``; with ``jac``, normals P_u × P_v at the vertices in
    ``metadata["vertex_normals"]``."""
    import trimesh

    t0 = time.perf_counter()
    u0, u1, v0, v1 = _as_domain(domain)
    uu, vv = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n))
    P = _xyz(xyz, uu, vv).reshape(-1, 3)
    ok = np.isfinite(P).all(-1)
    mesh = trimesh.Trimesh(vertices=np.where(ok[:, None], P, 0.0), faces=_grid_faces(n, ok), process=False)
    mesh.metadata["uv"] = np.stack([uu, vv], -1).reshape(-1, 2)
    if jac is not None:
        Pu, Pv = _jac(jac, uu, vv)
        nrm = np.cross(Pu, Pv).reshape(-1, 3)
        with np.errstate(all="ignore"):
            mesh.metadata["vertex_normals"] = nrm / np.linalg.norm(nrm, axis=-1, keepdims=True)
    mesh.metadata["tessellate_s"] = time.perf_counter() - t0
    mesh.metadata["kind"] = "parametric"
    return mesh


def build_intersector(mesh: Any) -> Any:
    """trimesh's embreex intersector with its BVH built."""
    from trimesh.ray.ray_pyembree import RayMeshIntersector

    it = RayMeshIntersector(mesh)
    _ = it._scene  # builds the embree scene
    return it


def _cast(mesh: Any, view: Any, width: int, height: int, intersector: Any) -> tuple[Reference, dict, Any]:
    t_all = time.perf_counter()
    W, H = int(width), int(height)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if intersector is None:
        intersector = build_intersector(mesh)
    timings["build"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    cam = camera_of(view, W, H)
    O, D = cam.rays()
    O = O.reshape(-1, 3)
    D = np.ascontiguousarray(D.reshape(-1, 3))
    if not cam.persp:
        lo, hi = mesh.bounds
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        back = float(((corners - cam.T) @ cam.d).min()) - 1e-3 * float((hi - lo).max())
        O = O + back * D
    timings["rays"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    loc, ir, it = intersector.intersects_location(O, D, multiple_hits=False)
    timings["cast"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    import trimesh

    N = W * H
    out = _empty(H, W)
    flat = {k: x.reshape((N,) + x.shape[2:]) for k, x in out.items()}
    bary = trimesh.triangles.points_to_barycentric(mesh.triangles[it], loc)
    vn = mesh.metadata.get("vertex_normals")
    if vn is None:
        vn = mesh.vertex_normals
    nrm = np.einsum("ij,ijk->ik", bary, vn[mesh.faces[it]])
    with np.errstate(all="ignore"):
        nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    if mesh.metadata.get("kind") == "parametric":
        uv = np.einsum("ij,ijk->ik", bary, mesh.metadata["uv"][mesh.faces[it]])
    else:
        uv = loc[:, :2]
    depth = (loc - cam.origin) @ cam.d
    flat["mask"][ir] = True
    flat["depth"][ir] = depth
    flat["normal"][ir] = nrm
    flat["uv"][ir] = uv
    flat["side"][ir] = np.where(np.sum(nrm * D[ir], -1) < 0, 1, -1).astype(np.int8)
    flat["point"][ir] = loc
    pix = np.full(N, np.nan)
    pix[ir] = cam.pixel_size(depth)
    timings["normals"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_all
    ref = Reference(trusted=np.ones((H, W), bool), pixel_size=pix.reshape(H, W), stats=dict(timings), **out)
    return ref, timings, intersector


def cast_height_mesh(mesh: Any, view: Any, width: int, height: int, grad: Callable | None = None,
                     *, intersector: Any = None) -> tuple[Reference, dict]:
    """Ray cast a height-field mesh (from :func:`mesh_height`): one ray per
    pixel, first hit, normals interpolated from the vertex normals (exact
    ones from ``grad`` if given, else trimesh's area-weighted ones).
    Pass a prebuilt ``intersector`` (:func:`build_intersector`) to leave the
    BVH build out. Returns (Reference, timings in seconds: build, rays,
    cast, normals, total)."""
    if grad is not None and "vertex_normals" not in mesh.metadata:
        u, v = mesh.vertices[:, 0], mesh.vertices[:, 1]
        fu, fv = grad(u, v)
        nrm = np.stack(np.broadcast_arrays(-np.asarray(fu, float), -np.asarray(fv, float), np.ones_like(u)), -1)
        mesh.metadata["vertex_normals"] = nrm / np.linalg.norm(nrm, axis=-1, keepdims=True)
    ref, timings, _ = _cast(mesh, view, width, height, intersector)
    return ref, timings


def cast_parametric_mesh(mesh: Any, view: Any, width: int, height: int, *, intersector: Any = None) -> tuple[Reference, dict]:
    """Ray cast a parametric mesh (from :func:`mesh_parametric`), as
    :func:`cast_height_mesh`; uv interpolated from the vertex parameters."""
    ref, timings, _ = _cast(mesh, view, width, height, intersector)
    return ref, timings
