//! Z-buffered Gouraud triangles (notes, "z-Buffer Algorithm"), parallel over
//! bands of rows.

use crate::cancel::Cancel;
use crate::error::{check_size, FcolError, Result};
use rayon::prelude::*;

/// Options of [`triangles`].
#[derive(Debug, Clone, Copy, Default)]
pub struct TriangleOptions {
    /// Drop faces whose vertices run clockwise on screen (row axis down):
    /// with counter-clockwise faces seen from outside, those face away.
    pub cull_backfaces: bool,
    /// Interpolate 1/depth and value/depth linearly on screen (exact for the
    /// perspective projection of a planar triangle) instead of depth and
    /// value.
    pub perspective_correct: bool,
}

/// The buffers of [`triangles`], row-major `height × width`.
#[derive(Debug, Clone)]
pub struct Triangles {
    pub height: usize,
    pub width: usize,
    /// Depth of the nearest face; NaN where no face covers the pixel.
    pub depth: Vec<f64>,
    /// Index of the nearest face; −1 where none.
    pub face: Vec<i32>,
    /// `channels` interpolated values per pixel; NaN where no face.
    pub values: Option<Vec<f64>>,
    pub channels: usize,
}

/// Rows per parallel band.
const BAND: usize = 16;

/// An edge function `E(P) = s·((qx − ox)(Py − oy) − (qy − oy)(Px − ox))`,
/// positive inside. The origin `o` is the lexicographically smaller end of
/// the edge, so the two triangles sharing an edge evaluate the same
/// products bit for bit (with opposite `s`) and the top-left rule leaves
/// neither a gap nor a double hit along it. For a fixed row the rounded
/// `E` is monotone in the column (each rounding step is monotone), so the
/// covered columns of each edge form one interval.
#[derive(Debug, Clone, Copy)]
struct EdgeFn {
    ox: f64,
    oy: f64,
    ex: f64,
    ey: f64,
    s: f64,
    /// Pixels exactly on the edge belong to the triangle: the top-left rule.
    top_left: bool,
}

impl EdgeFn {
    fn new(p: [f64; 2], q: [f64; 2]) -> EdgeFn {
        // Oriented edge p -> q of a triangle with positive orientation in
        // (x = col, y = row): interior on the right of the direction of travel
        // as seen on screen. Left edges run upward (dy < 0), top edges run
        // rightward (dy = 0, dx > 0).
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        let top_left = dy < 0.0 || (dy == 0.0 && dx > 0.0);
        let (o, t, s) = if (p[0], p[1]) <= (q[0], q[1]) {
            (p, q, 1.0)
        } else {
            (q, p, -1.0)
        };
        EdgeFn {
            ox: o[0],
            oy: o[1],
            ex: t[0] - o[0],
            ey: t[1] - o[1],
            s,
            top_left,
        }
    }
    /// The row part `s·(qx − ox)(y − oy)`, and the slope sign.
    #[inline]
    fn row(&self, y: f64) -> f64 {
        self.ex * (y - self.oy)
    }
    #[inline]
    fn eval_with(&self, a: f64, x: f64) -> f64 {
        self.s * (a - self.ey * (x - self.ox))
    }
    #[inline]
    fn inside_with(&self, a: f64, x: f64) -> bool {
        let e = self.eval_with(a, x);
        e > 0.0 || (e == 0.0 && self.top_left)
    }
    #[inline]
    fn eval(&self, x: f64, y: f64) -> f64 {
        self.eval_with(self.row(y), x)
    }
}

/// Per-face set-up: edge functions, depth plane, bounds.
#[derive(Debug, Clone, Copy)]
struct Setup {
    /// Vertex indices in positive orientation.
    idx: [usize; 3],
    edges: [EdgeFn; 3],
    /// Interpolated quantity (depth, or 1/depth when perspective-correct)
    /// as a plane: q = q0 + qx·(x − x0) + qy·(y − y0), clamped to [qmin, qmax]
    /// (a convex combination of the vertices' values).
    x0: f64,
    y0: f64,
    q0: f64,
    qx: f64,
    qy: f64,
    qmin: f64,
    qmax: f64,
    r0: usize,
    r1: usize,
    c0: usize,
    c1: usize,
}

fn setup(
    v: &[[f64; 3]],
    f: [usize; 3],
    h: usize,
    w: usize,
    opt: &TriangleOptions,
) -> Option<Setup> {
    let p = |i: usize| [v[f[i]][1], v[f[i]][0]]; // (x = col, y = row)
    let (a, b, c) = (p(0), p(1), p(2));
    if !(a.iter().chain(&b).chain(&c).all(|x| x.is_finite())
        && f.iter().all(|&i| v[i][2].is_finite()))
    {
        return None; // a hole, never a smear
    }
    let area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    if area2 == 0.0 || area2.is_nan() {
        return None;
    }
    // Front faces run counter-clockwise on screen: negative area2 here.
    if opt.cull_backfaces && area2 > 0.0 {
        return None;
    }
    let idx = if area2 > 0.0 {
        [f[0], f[1], f[2]]
    } else {
        [f[0], f[2], f[1]]
    };
    let pts = [p_of(v, idx[0]), p_of(v, idx[1]), p_of(v, idx[2])];
    let edges = [
        EdgeFn::new(pts[0], pts[1]),
        EdgeFn::new(pts[1], pts[2]),
        EdgeFn::new(pts[2], pts[0]),
    ];
    // Pixel bounds (centres at integers), clipped to the image.
    let (xmin, xmax) = min_max([pts[0][0], pts[1][0], pts[2][0]]);
    let (ymin, ymax) = min_max([pts[0][1], pts[1][1], pts[2][1]]);
    if xmax < 0.0 || ymax < 0.0 || xmin > (w - 1) as f64 || ymin > (h - 1) as f64 {
        return None;
    }
    let c0 = xmin.max(0.0).ceil() as usize;
    let c1 = xmax.min((w - 1) as f64).floor() as usize;
    let r0 = ymin.max(0.0).ceil() as usize;
    let r1 = ymax.min((h - 1) as f64).floor() as usize;
    if c0 > c1 || r0 > r1 {
        return None;
    }
    let q = |i: usize| {
        let z = v[idx[i]][2];
        if opt.perspective_correct {
            1.0 / z
        } else {
            z
        }
    };
    let (q0, q1, q2) = (q(0), q(1), q(2));
    // Plane through the three (x, y, q): gradient by Cramer's rule.
    let (ux, uy, uq) = (pts[1][0] - pts[0][0], pts[1][1] - pts[0][1], q1 - q0);
    let (wx, wy, wq) = (pts[2][0] - pts[0][0], pts[2][1] - pts[0][1], q2 - q0);
    let det = ux * wy - uy * wx; // = area2 (positive)
    let qx = (uq * wy - uy * wq) / det;
    let qy = (ux * wq - uq * wx) / det;
    let (qmin, qmax) = min_max([q0, q1, q2]);
    Some(Setup {
        idx,
        edges,
        x0: pts[0][0],
        y0: pts[0][1],
        q0,
        qx,
        qy,
        qmin,
        qmax,
        r0,
        r1,
        c0,
        c1,
    })
}

#[inline]
fn p_of(v: &[[f64; 3]], i: usize) -> [f64; 2] {
    [v[i][1], v[i][0]]
}

fn min_max(a: [f64; 3]) -> (f64, f64) {
    (a[0].min(a[1]).min(a[2]), a[0].max(a[1]).max(a[2]))
}

/// The covered columns `[lo, hi]` of row `y` (empty when lo > hi).
#[inline]
fn span(s: &Setup, y: f64) -> (usize, usize) {
    let (mut lo, mut hi) = (s.c0 as i64, s.c1 as i64);
    for e in &s.edges {
        let a = e.row(y);
        let slope = -e.s * e.ey; // dE/dx
        if slope == 0.0 {
            if !e.inside_with(a, 0.0) {
                return (1, 0);
            }
            continue;
        }
        // Root of E on this row; then settle the exact boundary with the
        // exact (monotone) test so the span agrees with `inside_with`.
        let root = e.ox + a / e.ey;
        if slope > 0.0 {
            // inside for x >= boundary: smallest inside column in [lo, hi]
            let mut c = (root.ceil() as i64).clamp(lo, hi + 1);
            while c > lo && e.inside_with(a, (c - 1) as f64) {
                c -= 1;
            }
            while c <= hi && !e.inside_with(a, c as f64) {
                c += 1;
            }
            lo = c;
        } else {
            // inside for x <= boundary: largest inside column in [lo, hi]
            let mut c = (root.floor() as i64).clamp(lo - 1, hi);
            while c < hi && e.inside_with(a, (c + 1) as f64) {
                c += 1;
            }
            while c >= lo && !e.inside_with(a, c as f64) {
                c -= 1;
            }
            hi = c;
        }
        if lo > hi {
            return (1, 0);
        }
    }
    (lo as usize, hi as usize)
}

/// Z-buffered rasterisation of the triangles `faces` (vertex indices) with
/// vertices `(row, col, depth)` in continuous pixel coordinates (pixel
/// centres at integers) into a `height × width` image.
///
/// A pixel belongs to a face when its centre is inside, or on a top or left
/// edge (the top-left rule: faces sharing an edge never both cover, nor both
/// miss, a pixel on it). The nearest face (smallest depth) wins; at equal
/// depth the face listed first. `values` (`channels` per vertex) are
/// interpolated with the same barycentric weights as the depth (Gouraud),
/// only for the visible face of each pixel. Faces with a non-finite vertex
/// are holes. The work runs in parallel over bands of rows; every band
/// visits its faces in order, so the result does not depend on the number
/// of threads.
#[allow(clippy::too_many_arguments)]
pub fn triangles(
    vertices: &[[f64; 3]],
    faces: &[[usize; 3]],
    values: Option<(&[f64], usize)>,
    height: usize,
    width: usize,
    opt: &TriangleOptions,
    cancel: &Cancel,
) -> Result<Triangles> {
    check_size(width, height)?;
    if faces.len() > i32::MAX as usize {
        return Err(FcolError::value("faces", "more than 2^31 − 1 faces"));
    }
    for (k, f) in faces.iter().enumerate() {
        if let Some(&i) = f.iter().find(|&&i| i >= vertices.len()) {
            return Err(FcolError::value(
                "faces",
                format!(
                    "face {k} refers to vertex {i}, but there are only {} vertices",
                    vertices.len()
                ),
            ));
        }
    }
    if let Some((v, k)) = values {
        if k == 0 || v.len() != vertices.len() * k {
            return Err(FcolError::value(
                "values",
                format!(
                    "need one value (or one row of channels) per vertex: {} vertices",
                    vertices.len()
                ),
            ));
        }
    }
    if opt.perspective_correct {
        for f in faces {
            for &i in f {
                let z = vertices[i][2];
                if z <= 0.0 {
                    return Err(FcolError::value(
                        "vertices",
                        format!("perspective_correct needs positive depths (view-space z), vertex {i} has depth {z}"),
                    ));
                }
            }
        }
    }
    let setups: Vec<Option<Setup>> = faces
        .par_iter()
        .map(|&f| setup(vertices, f, height, width, opt))
        .collect();
    cancel.check()?;

    // Bin faces into bands of rows, in face order.
    let nbands = height.div_ceil(BAND);
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); nbands];
    for (k, s) in setups.iter().enumerate() {
        if let Some(s) = s {
            for bin in &mut bins[s.r0 / BAND..=s.r1 / BAND] {
                bin.push(k as u32);
            }
        }
    }

    let n = width * height;
    // The depth buffer holds the z-buffer key while rasterising (depth, or
    // −1/depth when perspective-correct: smaller is nearer), +inf for none.
    let mut depth = vec![f64::INFINITY; n];
    let mut face = vec![-1i32; n];
    let persp = opt.perspective_correct;
    depth
        .par_chunks_mut(BAND * width)
        .zip(face.par_chunks_mut(BAND * width))
        .zip(bins.par_iter())
        .enumerate()
        .try_for_each(|(band, ((dbuf, fbuf), bin))| -> Result<()> {
            let zb = dbuf;
            let row0 = band * BAND;
            let rows = zb.len() / width;
            for (count, &k) in bin.iter().enumerate() {
                if count % 4096 == 4095 {
                    cancel.check()?;
                }
                let s = setups[k as usize]
                    .as_ref()
                    .expect("binned faces have a set-up");
                let ra = s.r0.max(row0);
                let rb = s.r1.min(row0 + rows - 1);
                for r in ra..=rb {
                    let y = r as f64;
                    let (lo, hi) = span(s, y);
                    if lo > hi {
                        continue;
                    }
                    let qrow = s.q0 + s.qy * (y - s.y0);
                    let base = (r - row0) * width;
                    for c in lo..=hi {
                        let q = (qrow + s.qx * (c as f64 - s.x0)).clamp(s.qmin, s.qmax);
                        // Nearest wins: smallest depth, or largest 1/depth.
                        let key = if persp { -q } else { q };
                        let slot = &mut zb[base + c];
                        if key < *slot {
                            *slot = key;
                            fbuf[base + c] = k as i32;
                        }
                    }
                }
            }
            for z in zb.iter_mut() {
                *z = if *z == f64::INFINITY {
                    f64::NAN
                } else if persp {
                    -1.0 / *z
                } else {
                    *z
                };
            }
            Ok(())
        })?;
    cancel.check()?;

    // Deferred Gouraud: interpolate values only for the visible face.
    let out_values = values.map(|(vals, k)| {
        let mut out = vec![f64::NAN; n * k];
        out.par_chunks_mut(width * k)
            .zip(face.par_chunks(width))
            .enumerate()
            .for_each(|(r, (orow, frow))| {
                let y = r as f64;
                for (c, &fi) in frow.iter().enumerate() {
                    if fi < 0 {
                        continue;
                    }
                    let s = setups[fi as usize]
                        .as_ref()
                        .expect("visible faces have a set-up");
                    let x = c as f64;
                    // Barycentric weights from the edge functions, clamped
                    // to the triangle (pixels on an edge may round outside).
                    let mut l = [
                        s.edges[1].eval(x, y).max(0.0),
                        s.edges[2].eval(x, y).max(0.0),
                        s.edges[0].eval(x, y).max(0.0),
                    ];
                    if persp {
                        for (li, &vi) in l.iter_mut().zip(&s.idx) {
                            *li /= vertices[vi][2];
                        }
                    }
                    let sum = l[0] + l[1] + l[2];
                    let l = if sum > 0.0 {
                        [l[0] / sum, l[1] / sum, l[2] / sum]
                    } else {
                        [1.0 / 3.0; 3]
                    };
                    for ch in 0..k {
                        orow[c * k + ch] = l[0] * vals[s.idx[0] * k + ch]
                            + l[1] * vals[s.idx[1] * k + ch]
                            + l[2] * vals[s.idx[2] * k + ch];
                    }
                }
            });
        out
    });
    let channels = values.map_or(0, |(_, k)| k);
    Ok(Triangles {
        height,
        width,
        depth,
        face,
        values: out_values,
        channels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(v: &[[f64; 3]], f: &[[usize; 3]], h: usize, w: usize) -> Triangles {
        triangles(
            v,
            f,
            None,
            h,
            w,
            &TriangleOptions::default(),
            &Cancel::new(),
        )
        .unwrap()
    }

    #[test]
    fn shared_edges_are_watertight() {
        // A fan of triangles around a centre at an arbitrary position: every
        // pixel of the union is covered exactly once.
        let (cy, cx) = (15.3, 16.7);
        let mut v = vec![[cy, cx, 1.0]];
        let m = 13;
        for k in 0..m {
            let t = 2.0 * std::f64::consts::PI * k as f64 / m as f64 + 0.1;
            v.push([cy + 12.0 * t.sin(), cx + 12.0 * t.cos(), 1.0]);
        }
        let f: Vec<[usize; 3]> = (0..m).map(|k| [0, 1 + k, 1 + (k + 1) % m]).collect();
        let mut count = vec![0u32; 32 * 32];
        for tri in &f {
            let t = run(&v, &[*tri], 32, 32);
            for (c, &fi) in count.iter_mut().zip(&t.face) {
                *c += (fi >= 0) as u32;
            }
        }
        assert!(count.iter().all(|&c| c <= 1));
        let all = run(&v, &f, 32, 32);
        let covered = all.face.iter().filter(|&&x| x >= 0).count();
        assert_eq!(covered, count.iter().filter(|&&c| c == 1).count());
        // The centre pixel is covered (no crack at the shared vertex).
        assert!(all.face[15 * 32 + 17] >= 0);
    }

    #[test]
    fn nearest_wins_and_depth_is_planar() {
        let v = [
            [0.0, 0.0, 5.0],
            [0.0, 20.0, 5.0],
            [20.0, 0.0, 5.0],
            [0.0, 0.0, 1.0],
            [0.0, 20.0, 2.0],
            [20.0, 0.0, 3.0],
        ];
        let t = run(&v, &[[0, 1, 2], [3, 4, 5]], 20, 20);
        assert_eq!(t.face[2 * 20 + 3], 1);
        let d = t.depth[2 * 20 + 3];
        assert!((d - (1.0 + 3.0 / 20.0 + 2.0 * 2.0 / 20.0)).abs() < 1e-12);
        assert!(t.depth[19 * 20 + 19].is_nan());
    }

    #[test]
    fn top_left_rule_on_a_square() {
        // Two triangles tiling [0, 4] x [0, 4] (pixel-centre coordinates):
        // the top and left borders are in, the bottom and right out.
        let v = [
            [0.0, 0.0, 1.0],
            [0.0, 4.0, 1.0],
            [4.0, 4.0, 1.0],
            [4.0, 0.0, 1.0],
        ];
        let t = run(&v, &[[0, 1, 2], [0, 2, 3]], 6, 6);
        for r in 0..6 {
            for c in 0..6 {
                assert_eq!(t.face[r * 6 + c] >= 0, r < 4 && c < 4, "pixel {r},{c}");
            }
        }
    }

    #[test]
    fn spans_equal_the_per_pixel_edge_test() {
        // The span search relies on the monotonicity of the rounded edge
        // functions; check it against testing every pixel of the box.
        let mut rnd = crate::test_rng::uniform(12345);
        for k in 0..2000 {
            let scale = if k % 3 == 0 { 4.0 } else { 40.0 };
            let mut v = [[0.0; 3]; 3];
            for p in &mut v {
                *p = [rnd() * scale - 2.0, rnd() * scale - 2.0, 1.0];
                if k % 5 == 0 {
                    p[0] = p[0].round(); // integer coordinates: many ties
                    p[1] = p[1].round();
                }
            }
            let Some(s) = setup(&v, [0, 1, 2], 40, 40, &TriangleOptions::default()) else {
                continue;
            };
            for r in s.r0..=s.r1 {
                let y = r as f64;
                let (lo, hi) = span(&s, y);
                for c in s.c0..=s.c1 {
                    let x = c as f64;
                    let inside = s.edges.iter().all(|e| e.inside_with(e.row(y), x));
                    assert_eq!(inside, lo <= c && c <= hi, "triangle {v:?} pixel {r},{c}");
                }
            }
        }
    }
}
