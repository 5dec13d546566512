//! Horizon maps of a terrain (Stewart 1998, "Fast horizon computation at all
//! points of a terrain with visibility and shading applications").
//!
//! # Definitions (Stewart §III)
//! The terrain is a set of sample points p = (x, y, z) (here x = u, y = v;
//! a grid `z[i, j]` puts its sample at (j·du, i·dv)). Around each point the
//! plane is cut into `s` sectors; sector σ_i holds every direction whose
//! azimuth, counted counter-clockwise from +u towards +v, lies in the
//! **closed** range [2πi/s, 2π(i+1)/s], so adjacent sectors share their
//! border rays. Let r_i be the unit horizontal vector of the sector's centre
//! azimuth 2π(i+½)/s and π_i the vertical plane holding r_i. The elevation of
//! a point q in sector σ_i of p is the angle, in π_i, between r_i and the
//! projection of pq onto π_i, signed like its z component:
//!
//! Θ = atan2(z_q − z_p, w_q − w_p),  w = (x, y)·r_i  (the coordinate along r_i).
//!
//! The horizon e_i of p is the maximum of Θ over **all** sample points in
//! σ_i (not only those on the centre line), and −π/2 when σ_i holds no point.
//! Requires s ≥ 3, so that every sector is narrower than a half-turn and
//! w_q − w_p > 0 for each q in it.
//!
//! # Sector membership (Stewart §IV, a⊥–b⊥ coordinates)
//! With a, b the sector's border directions and a⊥, b⊥ those vectors turned a
//! quarter-turn clockwise, q lies in σ_i(p) exactly when A_q ≤ A_p and
//! B_q ≥ B_p with A = a⊥·(x, y), B = b⊥·(x, y) (and q ≠ p). The keys are
//! computed once per point; border directions that are multiples of 45° use
//! the exact vectors (1, 0), (1, 1), … so that grid points lying exactly on a
//! border are classified exactly; on a grid the keys are computed from the
//! sample indices scaled by 1/|du| (the same positive scale for every point,
//! so membership is unchanged), which puts diagonal samples exactly on the
//! 45° borders when |du| = |dv| whatever the rounding of j·du and i·dv.
//! `brute` and `stewart` share these keys and
//! the exact orientation predicate of [`exact`], which is why they agree bit
//! for bit: the winner of each sector is chosen by exact comparison of the
//! elevations (ties: the nearer point along r_i) and its angle is evaluated
//! once with the same expression.
//!
//! # Earth curvature and refraction
//! A point at distance t appears lowered by c·t², c = (1 − k)/(2R). The
//! distance used is the one in the sector's plane π_i (t = w_q − w_p; exact
//! on the centre line): then the apparent height difference is
//! (Z_q − Z_p) + 2c·w_p·(w_q − w_p) with Z = z − c·w², so the maximum is the
//! same hull-tangent problem on the heights Z and `stewart` runs unchanged.
//!
//! # Border of the grid
//! There is no terrain beyond the samples: nothing outside the grid casts a
//! horizon, and a sector that holds no sample (e.g. one looking off the grid
//! from a border point) reports −π/2. NaN (or ±inf) heights are no data:
//! never a horizon source, and their own horizons are NaN.

pub mod brute;
pub mod cms;
pub mod exact;
pub mod sky;
pub mod stewart;
pub mod sweep;

use crate::cancel::Cancel;
use crate::error::{FcolError, Result};
use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Which algorithm computes the horizons.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Stewart §IV: hull tree per sector, O(s n (log² n + s)).
    Stewart,
    /// Max / Cabral–Max–Springmeyer: sampling along each sector's centre line.
    Cms,
    /// The O(n²) definition.
    Brute,
    /// Exact horizon along each centre direction on digital lines (grids).
    Sweep,
}

impl Method {
    pub fn parse(s: &str) -> Result<Method> {
        Ok(match s {
            "stewart" => Method::Stewart,
            "cms" => Method::Cms,
            "brute" => Method::Brute,
            "sweep" => Method::Sweep,
            _ => {
                return Err(FcolError::value(
                    "method",
                    format!(
                        "unknown method {s:?}; choose \"stewart\", \"cms\", \"brute\" or \"sweep\""
                    ),
                ))
            }
        })
    }
}

/// A terrain: scattered points, or a grid (which also gives its points).
#[derive(Debug, Clone)]
pub struct Terrain {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    /// Coordinates for the sector-membership keys: (x, y) itself for
    /// scattered points; for a grid, (j·du, i·dv)/|du| computed from the
    /// indices, so that with |du| = |dv| samples on a diagonal are exactly
    /// on the 45° borders whatever the spacing's rounding (a common
    /// positive scale does not change membership).
    pub kx: Vec<f64>,
    pub ky: Vec<f64>,
    /// (rows, cols, du, dv) when the points are the grid z[i, j] at (j·du, i·dv),
    /// stored row-major.
    pub grid: Option<(usize, usize, f64, f64)>,
    /// Whether every height is finite (no point without data), as the
    /// constructors found it.
    pub finite: bool,
}

/// Whether every value is finite (a pass that vectorises: no early exit).
fn all_finite(z: &[f64]) -> bool {
    z.chunks(4096)
        .all(|c| c.iter().fold(true, |a, v| a & v.is_finite()))
}

impl Terrain {
    pub fn from_grid(z: Vec<f64>, rows: usize, cols: usize, du: f64, dv: f64) -> Result<Terrain> {
        if rows == 0 || cols == 0 || z.len() != rows * cols {
            return Err(FcolError::value("z", "must be a non-empty 2-D array"));
        }
        for (name, d) in [("spacing du", du), ("spacing dv", dv)] {
            if !d.is_finite() || d == 0.0 {
                return Err(FcolError::value(
                    name,
                    format!("must be finite and non-zero, got {d}"),
                ));
            }
        }
        let mut x = Vec::with_capacity(z.len());
        let mut y = Vec::with_capacity(z.len());
        let mut kx = Vec::with_capacity(z.len());
        let mut ky = Vec::with_capacity(z.len());
        let (su, sv) = (du / du.abs(), dv / du.abs());
        for i in 0..rows {
            for j in 0..cols {
                x.push(j as f64 * du);
                y.push(i as f64 * dv);
                kx.push(j as f64 * su);
                ky.push(i as f64 * sv);
            }
        }
        Ok(Terrain {
            x,
            y,
            kx,
            ky,
            grid: Some((rows, cols, du, dv)),
            finite: all_finite(&z),
            z,
        })
    }

    pub fn from_points(x: Vec<f64>, y: Vec<f64>, z: Vec<f64>) -> Result<Terrain> {
        if x.len() != y.len() || x.len() != z.len() {
            return Err(FcolError::value("x, y, z", "must have the same length"));
        }
        if x.iter().chain(y.iter()).any(|v| !v.is_finite()) {
            return Err(FcolError::value("x, y", "must be finite"));
        }
        Ok(Terrain {
            kx: x.clone(),
            ky: y.clone(),
            x,
            y,
            grid: None,
            finite: all_finite(&z),
            z,
        })
    }

    pub fn len(&self) -> usize {
        self.z.len()
    }

    pub fn is_empty(&self) -> bool {
        self.z.is_empty()
    }

    /// Whether point q has data (a finite height); the others are no data,
    /// NaN in every plane.
    #[inline]
    pub fn has_data(&self, q: usize) -> bool {
        self.z[q].is_finite()
    }

    /// The points with data, ascending, into `ids` (cleared first), and NaN
    /// in `plane` at every other point.
    pub fn split_no_data(&self, plane: &mut [f32], ids: &mut Vec<usize>) {
        ids.clear();
        for (q, v) in plane.iter_mut().enumerate() {
            if self.has_data(q) {
                ids.push(q);
            } else {
                *v = f32::NAN;
            }
        }
    }
}

/// Options shared by every method.
#[derive(Debug, Clone)]
pub struct Options {
    pub sectors: usize,
    pub method: Method,
    /// Only these sectors (indices into 0..sectors), in this order.
    pub subset: Option<Vec<usize>>,
    /// Horizontal distance limit (None: the whole terrain).
    pub max_distance: Option<f64>,
    /// Curvature coefficient c = (1 − k)/(2R) (0: flat Earth).
    pub curvature: f64,
    /// Stewart §IV-E: add centre-line samples near the vertex (grids only).
    pub near_vertex: bool,
}

impl Options {
    pub fn new(sectors: usize, method: Method) -> Options {
        Options {
            sectors,
            method,
            subset: None,
            max_distance: None,
            curvature: 0.0,
            near_vertex: false,
        }
    }

    pub fn sector_list(&self) -> Vec<usize> {
        match &self.subset {
            Some(v) => v.clone(),
            None => (0..self.sectors).collect(),
        }
    }
}

/// Geometry of sector i of s: border key vectors and centre direction.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// a⊥ and b⊥ (possibly unnormalised, exact for multiples of 45°).
    pub aperp: (f64, f64),
    pub bperp: (f64, f64),
    /// Unit centre direction r_i.
    pub r: (f64, f64),
    /// Centre azimuth (radians).
    pub azimuth: f64,
}

fn border_dir(i: usize, s: usize) -> (f64, f64) {
    let i = i % s;
    if (8 * i) % s == 0 {
        const EXACT: [(f64, f64); 8] = [
            (1.0, 0.0),
            (1.0, 1.0),
            (0.0, 1.0),
            (-1.0, 1.0),
            (-1.0, 0.0),
            (-1.0, -1.0),
            (0.0, -1.0),
            (1.0, -1.0),
        ];
        EXACT[8 * i / s]
    } else {
        let t = 2.0 * PI * i as f64 / s as f64;
        (t.cos(), t.sin())
    }
}

impl Frame {
    pub fn new(i: usize, s: usize) -> Frame {
        let a = border_dir(i, s);
        let b = border_dir(i + 1, s);
        let g = 2.0 * PI * (i as f64 + 0.5) / s as f64;
        Frame {
            aperp: (a.1, -a.0),
            bperp: (b.1, -b.0),
            r: (g.cos(), g.sin()),
            azimuth: g,
        }
    }
    #[inline]
    pub fn key_a(&self, x: f64, y: f64) -> f64 {
        self.aperp.0 * x + self.aperp.1 * y
    }
    #[inline]
    pub fn key_b(&self, x: f64, y: f64) -> f64 {
        self.bperp.0 * x + self.bperp.1 * y
    }
    #[inline]
    pub fn w(&self, x: f64, y: f64) -> f64 {
        self.r.0 * x + self.r.1 * y
    }
}

/// The projected point (w, Z) of a sample in plane π_i (Z = z − c·w²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proj {
    pub w: f64,
    pub zz: f64,
}

#[inline]
pub fn project(f: &Frame, x: f64, y: f64, z: f64, c: f64) -> Proj {
    let w = f.w(x, y);
    Proj {
        w,
        zz: if c == 0.0 { z } else { z - c * w * w },
    }
}

/// Is `cand` a strictly better horizon point for `p` than `cur` (higher
/// elevation, or the same elevation and nearer along r)? Exact.
#[inline]
pub fn better(p: Proj, cur: Proj, cand: Proj) -> bool {
    let (a, b, c) = ((p.w, p.zz), (cur.w, cur.zz), (cand.w, cand.zz));
    match exact::orient_filtered(a, b, c) {
        Some(s) => s,
        None => better_near(a, b, c),
    }
}

/// [`better`] when the orientation filters cannot decide: the exact sign,
/// a tie to the nearer point.
#[cold]
#[inline(never)]
pub(super) fn better_near(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> bool {
    match exact::orient(a, b, c) {
        1 => true,
        0 => c.0 < b.0,
        _ => false,
    }
}

/// The elevation of q seen from p (Stewart §III, with curvature).
#[inline]
pub fn elevation(p: Proj, q: Proj, c: f64) -> f32 {
    let dw = q.w - p.w;
    let dz = if c == 0.0 {
        q.zz - p.zz
    } else {
        (q.zz - p.zz) + 2.0 * c * p.w * dw
    };
    atan2_f32(dz, dw)
}

/// Coefficients of atan(u) ≈ u·P(u²) on 0 ≤ u ≤ 1 (interpolation at 14
/// Chebyshev nodes in u²); relative error below 2e-12, measured against a
/// 40-digit arctangent.
const ATAN_P: [f64; 14] = [
    0.9999999999981967,
    -0.333333332624797,
    0.19999995340385063,
    -0.14285592394282529,
    0.11109428364330506,
    -0.09076798876650477,
    0.07614250199003121,
    -0.06366092236096826,
    0.050455577528416146,
    -0.03526772086942244,
    0.01993744283625617,
    -0.008241899893996813,
    0.002162794422156479,
    -0.00026660196719267425,
];

/// `y.atan2(x) as f32`, bit for bit, faster for x > 0: a polynomial
/// arctangent r, kept when every value within a relative 1e-10 of r (fifty
/// times its error bound, so also the libm value) rounds to the same f32,
/// which is then the libm value's rounding too (rounding is monotone).
/// Otherwise (a few in a thousand, next to an f32 rounding boundary, or x
/// not positive and finite) the libm arctangent itself.
#[inline]
pub fn atan2_f32(y: f64, x: f64) -> f32 {
    let ay = y.abs();
    if !(x > 0.0 && x <= f64::MAX && ay <= f64::MAX) {
        return y.atan2(x) as f32;
    }
    let steep = ay > x;
    // (one division of the chosen operands: with a choice of quotients the
    // compiler computed both)
    let (num, den) = if steep { (x, ay) } else { (ay, x) };
    let u = num / den;
    let s = u * u;
    // P(s) by Estrin's scheme (pairs, then pairs of pairs): a chain of five
    // dependent steps instead of Horner's thirteen; its rounding differs
    // from Horner's by a few ulps, far inside the 1e-10 margin below.
    let c = &ATAN_P;
    let s2 = s * s;
    let s4 = s2 * s2;
    let s8 = s4 * s4;
    let q = |i: usize| c[i] + c[i + 1] * s;
    let lo = (q(0) + q(2) * s2) + (q(4) + q(6) * s2) * s4;
    let hi = (q(8) + q(10) * s2) + q(12) * s4;
    let p = lo + hi * s8;
    let mut r = u * p;
    if steep {
        r = std::f64::consts::FRAC_PI_2 - r;
    }
    let r = r.copysign(y);
    let f = r as f32;
    let d = r.abs() * 1e-10;
    if (r - d) as f32 == f && (r + d) as f32 == f {
        f
    } else {
        y.atan2(x) as f32
    }
}

/// Value of a sector holding no point.
pub const EMPTY: f32 = -std::f32::consts::FRAC_PI_2;

/// Progress counter shared with the caller (units: point-sectors done).
#[derive(Debug, Default)]
pub struct Progress {
    pub done: AtomicUsize,
    pub total: AtomicUsize,
}

impl Progress {
    pub fn add(&self, n: usize) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }
}

/// Validate options against the terrain.
pub fn validate(t: &Terrain, o: &Options) -> Result<()> {
    if o.sectors < 3 {
        return Err(FcolError::value(
            "sectors",
            format!(
                "must be at least 3 (each sector narrower than a half-turn), got {}",
                o.sectors
            ),
        ));
    }
    if o.sectors > 1 << 16 {
        return Err(FcolError::value("sectors", "must be at most 65536"));
    }
    if let Some(sub) = &o.subset {
        if sub.is_empty() {
            return Err(FcolError::value(
                "sectors_subset",
                "must name at least one sector",
            ));
        }
        if let Some(&bad) = sub.iter().find(|&&i| i >= o.sectors) {
            return Err(FcolError::value(
                "sectors_subset",
                format!("sector {bad} is out of range 0..{}", o.sectors),
            ));
        }
        // Each requested sector is one output plane; a repeat would be a
        // second plane of the same sector (and the methods fill a sector's
        // plane once).
        let mut seen = vec![false; o.sectors];
        for &i in sub {
            if std::mem::replace(&mut seen[i], true) {
                return Err(FcolError::value(
                    "sectors_subset",
                    format!("sector {i} is named twice"),
                ));
            }
        }
    }
    if let Some(d) = o.max_distance {
        if d.is_nan() || d <= 0.0 {
            return Err(FcolError::value(
                "max_distance",
                format!("must be positive, got {d}"),
            ));
        }
    }
    if !o.curvature.is_finite() || o.curvature < 0.0 {
        return Err(FcolError::value(
            "earth_curvature",
            "curvature coefficient must be finite and >= 0",
        ));
    }
    if t.grid.is_none() {
        if matches!(o.method, Method::Cms | Method::Sweep) {
            return Err(FcolError::value(
                "method",
                "\"cms\" and \"sweep\" need a grid; scattered points take \"stewart\" or \"brute\"",
            ));
        }
        if o.near_vertex {
            return Err(FcolError::value("near_vertex", "needs a grid terrain"));
        }
    }
    Ok(())
}

/// Compute the horizon map: `k` planes (one per requested sector) of
/// `t.len()` values each, plane-major.
pub fn compute(t: &Terrain, o: &Options, cancel: &Cancel, progress: &Progress) -> Result<Vec<f32>> {
    validate(t, o)?;
    let mut out = vec![0.0f32; o.sector_list().len() * t.len()];
    compute_into(t, o, cancel, progress, &mut out)?;
    Ok(out)
}

/// [`compute`] into `out` (`k · t.len()` values, any contents: every value
/// is written), e.g. a buffer reused over many calls, whose pages are then
/// already in memory.
pub fn compute_into(
    t: &Terrain,
    o: &Options,
    cancel: &Cancel,
    progress: &Progress,
    out: &mut [f32],
) -> Result<()> {
    use rayon::prelude::*;
    validate(t, o)?;
    let list = o.sector_list();
    let n = t.len();
    if out.len() != list.len() * n {
        return Err(FcolError::value(
            "out",
            format!(
                "holds {} values, expected {} ({} sectors of {n} points)",
                out.len(),
                list.len() * n,
                list.len()
            ),
        ));
    }
    progress.total.store(list.len() * n, Ordering::Relaxed);
    if n == 0 {
        return Ok(());
    }
    if o.method == Method::Brute {
        brute::all(t, o, out, cancel, progress)?;
        if o.near_vertex {
            out.par_chunks_mut(n)
                .zip(list.par_iter())
                .try_for_each(|(plane, &i)| {
                    cms::near_vertex(t, &Frame::new(i, o.sectors), o, plane, cancel)
                })?;
        }
        return Ok(());
    }
    let res =
        out.par_chunks_mut(n)
            .zip(list.par_iter())
            .try_for_each(|(plane, &i)| -> Result<()> {
                // Each plane is written whole by its task: its pages, fresh
                // memory unless the caller reuses a buffer, are faulted in
                // by one call per plane (in parallel).
                crate::scratch::populate_write(plane);
                let f = Frame::new(i, o.sectors);
                match o.method {
                    Method::Brute => unreachable!(),
                    Method::Stewart => stewart::sector_pooled(t, &f, o, plane, cancel, progress)?,
                    Method::Cms => cms::sector(t, &f, o, plane, cancel, progress)?,
                    Method::Sweep => sweep::sector(t, &f, o, plane, cancel, progress)?,
                }
                if o.near_vertex && o.method == Method::Stewart {
                    cms::near_vertex(t, &f, o, plane, cancel)?;
                }
                Ok(())
            });
    if o.method == Method::Stewart {
        rayon::broadcast(|_| stewart::release());
        stewart::release();
    }
    res
}

#[cfg(test)]
mod tests;
