"""fcol.raster.triangles against trimesh + embreex ray casting."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh
from matplotlib.path import Path
from trimesh.ray.ray_pyembree import RayMeshIntersector

import fcol
from fcol import raster


def _torus(sections: tuple[int, int] = (40, 20)) -> trimesh.Trimesh:
    return trimesh.creation.torus(
        major_radius=1.0, minor_radius=0.45, major_sections=sections[0], minor_sections=sections[1]
    )


def _dist_to_triangle_edges(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance of points p (K, 2) to the outline of triangles tri (K, 3, 2)."""
    best = np.full(len(p), np.inf)
    for i in range(3):
        a, b = tri[:, i], tri[:, (i + 1) % 3]
        ab = b - a
        t = np.clip(((p - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-300), 0, 1)
        best = np.minimum(best, np.hypot(*(p - a - t[:, None] * ab).T))
    return best


def _check_against_rays(
    face: np.ndarray, depth: np.ndarray, ref_face: np.ndarray, ref_depth: np.ndarray, tri2d: np.ndarray
) -> None:
    """Identical coverage and face away from 1-pixel bands at edges; depth
    within 1e-5 relative where both see the same face."""
    h, w = face.shape
    same = (face == ref_face) & (face >= 0)
    np.testing.assert_allclose(depth[same], ref_depth[same], rtol=1e-5, atol=0)
    assert np.all(np.isnan(depth[face < 0]))
    diff = np.argwhere(face != ref_face)
    if len(diff):
        p = diff[:, ::-1].astype(float)  # (col, row) like tri2d
        near = np.full(len(diff), np.inf)
        for buf in (face, ref_face):
            k = buf[diff[:, 0], diff[:, 1]]
            has = k >= 0
            near[has] = np.minimum(near[has], _dist_to_triangle_edges(p[has], tri2d[k[has]]))
        assert np.all(near <= 1.0), f"{np.sum(near > 1)} pixels differ away from edges"
    covered = (ref_face >= 0).sum()
    assert covered > 0.1 * h * w  # the comparison is not vacuous
    assert same.sum() >= 0.98 * covered


def _embree_screen(vertices: np.ndarray, faces: np.ndarray, h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Rays along +depth through every pixel centre of the screen-space mesh."""
    pts = vertices[:, [1, 0, 2]]  # (col, row, depth) as (x, y, z)
    ri = RayMeshIntersector(trimesh.Trimesh(pts, faces, process=False))
    jj, ii = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    orig = np.stack([jj.ravel(), ii.ravel(), np.full(h * w, pts[:, 2].min() - 1.0)], 1)
    dirs = np.tile([0.0, 0.0, 1.0], (h * w, 1))
    loc, ray, tri = ri.intersects_location(orig, dirs, multiple_hits=False)
    face = np.full(h * w, -1, np.int64)
    face[ray] = tri
    depth = np.full(h * w, np.nan)
    depth[ray] = loc[:, 2]
    return face.reshape(h, w), depth.reshape(h, w)


@pytest.mark.parametrize("view", [(35.0, 20.0), (0.0, 0.0), (89.9, 45.0), (-30.0, 200.0)])
def test_orthographic_torus_matches_embree(view: tuple[float, float]) -> None:
    mesh = _torus()
    h, w = 120, 160
    v = fcol.View(*view, view_height=3.2)
    rows, cols = v.project(mesh.vertices, w, h)
    z = v.depth(mesh.vertices, w, h) + 10.0  # positive depths: relative error is meaningful
    verts = np.stack([rows, cols, z], 1)
    depth, vals, face = raster.triangles(verts, mesh.faces, z, (h, w), return_face=True)
    ref_face, ref_depth = _embree_screen(verts, mesh.faces, h, w)
    _check_against_rays(face, depth, ref_face, ref_depth, verts[:, [1, 0]][mesh.faces])
    # Gouraud values of the depth itself reproduce the depth.
    assert vals is not None and vals.shape == (h, w)
    np.testing.assert_allclose(vals, depth, rtol=1e-12, equal_nan=True)


def test_perspective_correct_matches_world_space_rays() -> None:
    """With perspective_correct, depth is the exact view-space z of the
    surface point seen through the pixel centre, and interpolated world
    coordinates are the exact hit points."""
    mesh = _torus()
    h, w = 100, 140
    v = fcol.View(40, 30, "perspective", distance=4.0, fov=45.0)
    rows, cols = v.project(mesh.vertices, w, h)
    z = v.depth(mesh.vertices, w, h)
    verts = np.stack([rows, cols, z], 1)
    depth, xyz, face = raster.triangles(
        verts, mesh.faces, mesh.vertices, (h, w), perspective_correct=True, return_face=True
    )
    assert xyz is not None and xyz.shape == (h, w, 3)
    o, d = v.rays(w, h)
    loc, ray, tri = RayMeshIntersector(mesh).intersects_location(
        o.reshape(-1, 3), d.reshape(-1, 3), multiple_hits=False
    )
    ref_face = np.full(h * w, -1, np.int64)
    ref_face[ray] = tri
    ref_face = ref_face.reshape(h, w)
    ref_xyz = np.full((h * w, 3), np.nan)
    ref_xyz[ray] = loc
    ref_xyz = ref_xyz.reshape(h, w, 3)
    fwd, _, _ = v.basis()
    ref_depth = (ref_xyz - np.asarray(v.eye)) @ np.asarray(fwd)
    _check_against_rays(face, depth, ref_face, ref_depth, verts[:, [1, 0]][mesh.faces])
    same = (face == ref_face) & (face >= 0)
    np.testing.assert_allclose(xyz[same], ref_xyz[same], rtol=0, atol=1e-5 * 3)
    # Without the correction depth is interpolated linearly on screen: a
    # different (approximate) value inside faces, the same at vertices.
    lin, _ = raster.triangles(verts, mesh.faces, None, (h, w))
    assert np.nanmax(np.abs(lin - depth)) > 1e-4


def test_backface_culling_on_a_closed_mesh() -> None:
    mesh = _torus()
    h, w = 90, 90
    v = fcol.View(25, 60, view_height=3.2)
    rows, cols = v.project(mesh.vertices, w, h)
    verts = np.stack([rows, cols, v.depth(mesh.vertices, w, h)], 1)
    d_all, _, f_all = raster.triangles(verts, mesh.faces, None, (h, w), return_face=True)
    d_cull, _, f_cull = raster.triangles(verts, mesh.faces, None, (h, w), cull_backfaces=True, return_face=True)
    # The first hit on a closed surface faces the viewer: culling changes nothing.
    np.testing.assert_array_equal(d_cull, d_all)
    np.testing.assert_array_equal(f_cull, f_all)
    # Flipped faces: culling now keeps the far side only.
    d_flip, _ = raster.triangles(verts, mesh.faces[:, ::-1], None, (h, w), cull_backfaces=True)
    both = ~np.isnan(d_flip) & ~np.isnan(d_all)
    assert np.all(d_flip[both] >= d_all[both])
    assert np.mean(d_flip[both] > d_all[both] + 1e-3) > 0.5


def test_top_left_rule_and_watertight_fan() -> None:
    rng = np.random.default_rng(5)
    checked = 0
    for _ in range(40):
        c = rng.uniform(10, 20, 2)
        m = int(rng.integers(3, 17))
        t = np.sort(rng.uniform(0, 2 * np.pi, m))
        ring = c + rng.uniform(3, 9, (m, 1)) * np.stack([np.sin(t), np.cos(t)], 1)
        verts = np.concatenate([[[*c, 1.0]], np.c_[ring, np.ones(m)]])
        faces = np.array([[0, 1 + k, 1 + (k + 1) % m] for k in range(m)])
        if not np.all(np.diff(np.r_[t, t[0] + 2 * np.pi]) < np.pi):
            continue  # the fan folds over itself: faces overlap
        count = np.zeros((32, 32), int)
        for f in faces:
            d, _ = raster.triangles(verts, f[None], None, (32, 32))
            count += ~np.isnan(d)
        assert count.max() <= 1  # no pixel covered twice along shared edges
        d, _ = raster.triangles(verts, faces, None, (32, 32))
        np.testing.assert_array_equal(~np.isnan(d), count == 1)
        # No crack either: the union is exactly the star-shaped polygon of
        # the ring (centres inside it by matplotlib's point-in-polygon test;
        # none lies on the outline).
        rr, cc = np.mgrid[0:32, 0:32]
        inside = Path(ring[:, ::-1]).contains_points(np.c_[cc.ravel(), rr.ravel()]).reshape(32, 32)
        np.testing.assert_array_equal(~np.isnan(d), inside)
        checked += 1
    assert checked >= 5
    # A square [0, 4]^2 split in two: top and left borders in, bottom and right out.
    sq = np.array([[0, 0, 1], [0, 4, 1], [4, 4, 1], [4, 0, 1.0]])
    d, _ = raster.triangles(sq, [[0, 1, 2], [0, 2, 3]], None, (6, 6))
    expect = np.zeros((6, 6), bool)
    expect[:4, :4] = True
    np.testing.assert_array_equal(~np.isnan(d), expect)


def test_nearest_wins_ties_go_to_the_first_face() -> None:
    a = np.array([[0, 0, 2.0], [0, 10, 2.0], [10, 0, 2.0]])
    b = a.copy()
    verts = np.concatenate([a, b])
    _, _, f = raster.triangles(verts, [[0, 1, 2], [3, 4, 5]], None, (10, 10), return_face=True)
    assert set(np.unique(f)) == {-1, 0}
    verts[3:, 2] = 1.0
    _, _, f = raster.triangles(verts, [[0, 1, 2], [3, 4, 5]], None, (10, 10), return_face=True)
    assert set(np.unique(f)) == {-1, 1}


def test_nan_vertices_are_holes() -> None:
    verts = np.array([[0, 0, 1], [0, 9, 1], [9, 0, 1], [9, 9, np.nan]], float)
    d, v, f = raster.triangles(verts, [[0, 1, 2], [1, 3, 2]], [0, 1, 2, 3.0], (10, 10), return_face=True)
    assert set(np.unique(f)) == {-1, 0}
    assert np.all(np.isnan(d[f < 0])) and np.all(np.isfinite(d[f >= 0]))
    assert v is not None and np.all(np.isnan(v[f < 0]))


def test_thread_count_does_not_change_the_result(tmp_path) -> None:  # type: ignore[no-untyped-def]
    mesh = _torus((60, 30))
    v = fcol.View(30, 10, view_height=3.2)
    h, w = 257, 301
    r, c = v.project(mesh.vertices, w, h)
    np.savez(tmp_path / "m.npz", v=np.stack([r, c, v.depth(mesh.vertices, w, h)], 1), f=mesh.faces, x=mesh.vertices)
    code = (
        "import sys, hashlib, numpy as np, fcol\n"
        "m = np.load(sys.argv[1])\n"
        f"d, x, f = fcol.raster.triangles(m['v'], m['f'], m['x'], ({h}, {w}), return_face=True)\n"
        "print(hashlib.sha256(d.tobytes() + x.tobytes() + f.tobytes()).hexdigest())\n"
    )
    out = []
    for n in ("1", "2"):
        env = dict(os.environ, RAYON_NUM_THREADS=n)
        res = subprocess.run(
            [sys.executable, "-c", code, str(tmp_path / "m.npz")], env=env, capture_output=True, text=True, check=True
        )
        out.append(res.stdout.strip())
    assert len(out[0]) == 64 and out[0] == out[1]


def test_values_shapes_and_dtypes() -> None:
    verts = np.array([[0, 0, 1], [0, 8, 1], [8, 0, 1]], np.float32)
    d, v = raster.triangles(verts, np.array([[0, 1, 2]], np.uint16), None, (4, 5))
    assert d.dtype == np.float64 and d.shape == (4, 5) and v is None
    _, v = raster.triangles(verts, [[0, 1, 2]], np.eye(3), (4, 5))
    assert v is not None and v.shape == (4, 5, 3)
    np.testing.assert_allclose(np.nansum(v, axis=2)[~np.isnan(d)], 1.0)  # partition of unity
    # Non-contiguous inputs are fine.
    big = np.zeros((3, 6))
    big[:, ::2] = verts
    d2, _ = raster.triangles(big[:, ::2], [[0, 1, 2]], None, (4, 5))
    np.testing.assert_array_equal(d2, d)
    # No faces: an empty image.
    d3, _ = raster.triangles(verts, np.zeros((0, 3), int), None, (4, 5))
    assert np.all(np.isnan(d3))


def test_triangles_bad_input() -> None:
    verts = np.array([[0, 0, 1], [0, 8, 1], [8, 0, 1.0]])
    tri = [[0, 1, 2]]
    with pytest.raises(ValueError, match="vertices"):
        raster.triangles(verts[:, :2], tri, None, (4, 4))
    with pytest.raises(TypeError, match="vertices"):
        raster.triangles(verts.astype(complex), tri, None, (4, 4))
    with pytest.raises(TypeError, match="faces"):
        raster.triangles(verts, [[0.0, 1.0, 2.0]], None, (4, 4))
    with pytest.raises(ValueError, match="faces"):
        raster.triangles(verts, [[0, 1]], None, (4, 4))
    with pytest.raises(ValueError, match="faces"):
        raster.triangles(verts, [[0, 1, 3]], None, (4, 4))
    with pytest.raises(ValueError, match="faces"):
        raster.triangles(verts, [[0, -1, 2]], None, (4, 4))
    with pytest.raises(ValueError, match="values"):
        raster.triangles(verts, tri, [1.0, 2.0], (4, 4))
    with pytest.raises(ValueError, match="shape"):
        raster.triangles(verts, tri, None, (100_000, 100_000))
    with pytest.raises(ValueError, match="shape"):
        raster.triangles(verts, tri, None, (0, 4))
    with pytest.raises(TypeError, match="shape"):
        raster.triangles(verts, tri, None)
    with pytest.raises(ValueError, match="depth"):
        raster.triangles(verts - [0, 0, 1], tri, None, (4, 4), perspective_correct=True)
    # inf coordinates: the face is a hole, not a crash.
    bad = verts.copy()
    bad[0, 0] = np.inf
    d, _ = raster.triangles(bad, tri, None, (4, 4))
    assert np.all(np.isnan(d))
