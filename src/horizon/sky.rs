//! Sky light and sun shadows from a horizon map (Stewart 1998 §VI), per
//! point, without recomputing the horizons.
//!
//! Input: the horizon planes (k, H, W) of a grid (plane-major, as
//! [`super::compute`] returns them), the upper unit normals N (H, W, 3) and
//! the heights (NaN = no data). Every quantity is an integral over the
//! visible sky V(x) of the point, in the sector model of §III: within
//! sector i (azimuths [2πi/s, 2π(i+1)/s]) the sky is visible above
//! e'_i = max(e_i, tangent plane at the centre azimuth φ_i), where the
//! tangent plane's elevation is atan(−(N_u cos φ_i + N_v sin φ_i)/N_w).
//!
//! * sky-view factor D = (1/π)∫_V N·u dΩ (Stewart–Langer's D), in closed
//!   form per sector: with u = (cos θ cos φ, cos θ sin φ, sin θ) and
//!   dΩ = cos θ dθ dφ,
//!   ∫∫ N·u dΩ = N_w·½cos²e'·Δφ + (N_u·Δsin φ − N_v·Δcos φ)·(π/4 − e'/2 − sin 2e'/4);
//! * direct primary illumination I = ∫_V L(u) N·u dΩ for a sky tabulated
//!   on s × 256 equal-area regions (§VI-A: each sector split by sin θ in
//!   256 equal steps), the region cut by the horizon counted in proportion
//!   of its moments; e' is clipped to [0, π/2] (the table covers the upper
//!   hemisphere only);
//! * Stewart–Langer approximate radiosity (§VI-A, the last equation):
//!   R = ρ·(I/π) / (1 − ρ(1 − D));
//! * sun shadows: the visible fraction of the sun. A point sun is visible
//!   when its elevation exceeds the horizon of the sector holding its
//!   azimuth (a border azimuth goes to the sector it opens). A sun of
//!   angular radius r is a disc in the sun's local tangent plane
//!   (x = Δazimuth·cos(elevation), y = Δelevation) and its visible fraction
//!   is the area of the disc above the piecewise-constant horizon over
//!   πr². This flat model suits real suns (r ≈ 0.27°) away from the
//!   zenith; a disc reaching past the zenith or wider than a half-turn of
//!   azimuth is clipped to one turn of azimuth, so it may not reach 1.
//! * the sun term: visible fraction × max(0, N·s).
//!
//! Results are f64, NaN at no-data points (and where a normal is NaN);
//! each point sums its sectors in index order, so the output does not
//! depend on the number of threads.

use crate::cancel::Cancel;
use crate::error::{FcolError, Result};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// Number of equal-area elevation bands of a sky table (§VI-A).
pub const BANDS: usize = 256;

/// A horizon elevation stored as f32 (as computed) or f64.
pub trait Elevation: Copy + Send + Sync {
    fn get(self) -> f64;
}
impl Elevation for f32 {
    #[inline]
    fn get(self) -> f64 {
        self as f64
    }
}
impl Elevation for f64 {
    #[inline]
    fn get(self) -> f64 {
        self
    }
}

/// The horizon planes of a grid and what they sit on.
#[derive(Debug, Clone, Copy)]
pub struct Planes<'a, T> {
    /// (k, rows, cols) elevations, plane-major, radians.
    pub elevation: &'a [T],
    /// The sector index of each plane.
    pub sector_indices: &'a [usize],
    /// s, the number of sectors of the full circle.
    pub sectors: usize,
    pub rows: usize,
    pub cols: usize,
    /// (rows, cols) heights; a non-finite height is no data (NaN out).
    pub z: &'a [f64],
}

impl<T: Elevation> Planes<'_, T> {
    fn n(&self) -> usize {
        self.rows * self.cols
    }

    fn validate(&self) -> Result<()> {
        if self.sectors < 3 {
            return Err(FcolError::value(
                "sectors",
                format!("must be at least 3, got {}", self.sectors),
            ));
        }
        let k = self.sector_indices.len();
        if k == 0 || self.elevation.len() != k * self.n() {
            return Err(FcolError::value(
                "elevation",
                format!(
                    "expected {} planes of {}x{} values, got {} values",
                    k,
                    self.rows,
                    self.cols,
                    self.elevation.len()
                ),
            ));
        }
        if let Some(&bad) = self.sector_indices.iter().find(|&&i| i >= self.sectors) {
            return Err(FcolError::value(
                "sector_indices",
                format!("sector {bad} is out of range 0..{}", self.sectors),
            ));
        }
        if self.z.len() != self.n() {
            return Err(FcolError::value("z", "must have the grid's shape"));
        }
        Ok(())
    }

    /// The sky integrals need every sector, in order.
    fn require_full(&self) -> Result<()> {
        if self.sector_indices.len() != self.sectors
            || self.sector_indices.iter().enumerate().any(|(a, &b)| a != b)
        {
            return Err(FcolError::value(
                "sectors_subset",
                "this needs the horizon of every sector; compute without sectors_subset",
            ));
        }
        Ok(())
    }

    /// The checks of every whole-sky integral: valid planes, every sector
    /// present, one normal per point.
    fn check_full(&self, normals: &[f64]) -> Result<()> {
        self.validate()?;
        self.require_full()?;
        check_normals(normals, self.n())
    }

    /// Row `r` of plane `k`.
    #[inline]
    fn row(&self, k: usize, r: usize) -> &[T] {
        let start = k * self.n() + r * self.cols;
        &self.elevation[start..start + self.cols]
    }

    fn plane_of(&self, sector: usize) -> Option<usize> {
        self.sector_indices.iter().position(|&i| i == sector)
    }
}

fn check_normals(normals: &[f64], n: usize) -> Result<()> {
    if normals.len() != 3 * n {
        return Err(FcolError::value(
            "normals",
            "expected an (H, W, 3) array of normals over the grid",
        ));
    }
    Ok(())
}

/// NumPy's `maximum`: NaN if either is NaN.
#[inline]
fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Per-sector constants: centre azimuth φ_i and the border differences
/// Δsin φ = sin φ_{i+1} − sin φ_i, −Δcos φ = cos φ_i − cos φ_{i+1}.
struct SectorGeom {
    cos_c: Vec<f64>,
    sin_c: Vec<f64>,
    cx: Vec<f64>,
    cy: Vec<f64>,
    dphi: f64,
}

impl SectorGeom {
    fn new(s: usize) -> SectorGeom {
        let sf = s as f64;
        let centre = |i: usize| 2.0 * PI * (i as f64 + 0.5) / sf;
        let border = |i: usize| 2.0 * PI * i as f64 / sf;
        SectorGeom {
            cos_c: (0..s).map(|i| centre(i).cos()).collect(),
            sin_c: (0..s).map(|i| centre(i).sin()).collect(),
            cx: (0..s)
                .map(|i| border(i + 1).sin() - border(i).sin())
                .collect(),
            cy: (0..s)
                .map(|i| border(i).cos() - border(i + 1).cos())
                .collect(),
            dphi: 2.0 * PI / sf,
        }
    }

    /// Lower limit e' of the visible sky in sector i, the horizon e or the
    /// tangent plane at the centre azimuth, whichever is higher, with its
    /// sine and cosine: (e', sin e', cos e'); NaN if either is NaN.
    ///
    /// The plane's elevation is atan t with t = −(N_u cos φ + N_v sin φ)/N_w,
    /// so e > atan t ⇔ sin e > t cos e for |e| < π/2, and when the plane
    /// wins sin and cos follow from t without more transcendentals.
    #[inline]
    fn effective(&self, i: usize, e: f64, n: &[f64]) -> (f64, f64, f64) {
        let nz = nan_max(n[2], 1e-12);
        let t = -(n[0] * self.cos_c[i] + n[1] * self.sin_c[i]) / nz;
        if e.is_nan() || t.is_nan() {
            return (f64::NAN, f64::NAN, f64::NAN);
        }
        if e >= FRAC_PI_2 {
            let (s, c) = sin_cos(e);
            return (e, s, c);
        }
        if e > -FRAC_PI_2 {
            let (s, c) = sin_cos(e);
            if s > t * c {
                return (e, s, c);
            }
        }
        let q = 1.0 / (1.0 + t * t).sqrt();
        (t.atan(), t * q, q)
    }
}

/// sin and cos of x by their Taylor series to x²¹ and x²² (truncation
/// below 2e-18 for |x| ≤ 1.6, the range of elevations); libm beyond.
#[inline]
fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() > 1.6 || x.is_nan() {
        return (x.sin(), x.cos());
    }
    // (−1)^k/(2k+1)! and (−1)^k/(2k)!
    const SIN: [f64; 11] = [
        1.0,
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5040.0,
        1.0 / 362880.0,
        -1.0 / 39916800.0,
        1.0 / 6227020800.0,
        -1.0 / 1307674368000.0,
        1.0 / 355687428096000.0,
        -1.0 / 1.21645100408832e+17,
        1.0 / 5.109094217170944e+19,
    ];
    const COS: [f64; 12] = [
        1.0,
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40320.0,
        -1.0 / 3628800.0,
        1.0 / 479001600.0,
        -1.0 / 87178291200.0,
        1.0 / 20922789888000.0,
        -1.0 / 6402373705728000.0,
        1.0 / 2.43290200817664e+18,
        -1.0 / 1.1240007277776077e+21,
    ];
    let x2 = x * x;
    let mut s = SIN[10];
    for k in (0..10).rev() {
        s = SIN[k] + x2 * s;
    }
    let mut c = COS[11];
    for k in (0..11).rev() {
        c = COS[k] + x2 * c;
    }
    (x * s, c)
}

/// Run `f(row, out_row)` over the rows in parallel, checking for Ctrl-C.
fn per_row(
    rows: usize,
    cols: usize,
    cancel: &Cancel,
    f: impl Fn(usize, &mut [f64]) + Sync,
) -> Result<Vec<f64>> {
    let mut out = vec![0.0; rows * cols];
    if cols == 0 {
        return Ok(out);
    }
    out.par_chunks_mut(cols)
        .enumerate()
        .try_for_each(|(r, row)| {
            cancel.check()?;
            f(r, row);
            Ok(())
        })?;
    Ok(out)
}

/// Sky-view factor D of every point (1 on an open plane).
pub fn sky_view_factor<T: Elevation>(
    p: &Planes<'_, T>,
    normals: &[f64],
    cancel: &Cancel,
) -> Result<Vec<f64>> {
    p.check_full(normals)?;
    let g = SectorGeom::new(p.sectors);
    per_row(p.rows, p.cols, cancel, |r, out| {
        svf_row(p, &g, normals, r, out);
    })
}

fn svf_row<T: Elevation>(
    p: &Planes<'_, T>,
    g: &SectorGeom,
    normals: &[f64],
    r: usize,
    out: &mut [f64],
) {
    let w = p.cols;
    let nrow = &normals[3 * r * w..3 * (r + 1) * w];
    let mut sz = vec![0.0; w];
    let mut sx = vec![0.0; w];
    let mut sy = vec![0.0; w];
    for i in 0..p.sectors {
        for (j, &e) in p.row(i, r).iter().enumerate() {
            let (e, se, ce) = g.effective(i, e.get(), &nrow[3 * j..3 * j + 3]);
            sz[j] += 0.5 * (ce * ce) * g.dphi;
            // sin 2e = 2 sin e cos e
            let hh = PI / 4.0 - e / 2.0 - (2.0 * se * ce) / 4.0;
            sx[j] += g.cx[i] * hh;
            sy[j] += g.cy[i] * hh;
        }
    }
    for j in 0..w {
        let n = &nrow[3 * j..3 * j + 3];
        out[j] = (n[2] * sz[j] + n[0] * sx[j] + n[1] * sy[j]) / PI;
    }
}

/// Cumulative moments of a sky table, from the zenith down (§VI-A's lookup
/// tables indexed by sector and horizon elevation).
struct SkyTable<'a> {
    table: &'a [f64],
    /// ½ sin²θ_k Δφ and θ_k/2 + sin 2θ_k/4 at the band borders θ_k =
    /// asin(k/256): antiderivatives of cos θ sin θ and cos²θ.
    hz: Vec<f64>,
    hh: Vec<f64>,
    /// Σ_{k' ≥ k} L_{i,k'}·(moment of band k'), (s, 257).
    tz: Vec<f64>,
    th: Vec<f64>,
}

impl<'a> SkyTable<'a> {
    fn new(table: &'a [f64], s: usize) -> Result<SkyTable<'a>> {
        if table.len() != s * BANDS {
            return Err(FcolError::value(
                "sky",
                format!("expected a table of shape ({s}, {BANDS})"),
            ));
        }
        if table.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(FcolError::value(
                "sky",
                "radiances must be finite and non-negative",
            ));
        }
        let dphi = 2.0 * PI / s as f64;
        let theta: Vec<f64> = (0..=BANDS)
            .map(|k| (k as f64 / BANDS as f64).asin())
            .collect();
        let hz: Vec<f64> = theta
            .iter()
            .map(|t| {
                let st = t.sin();
                0.5 * (st * st) * dphi
            })
            .collect();
        let hh: Vec<f64> = theta
            .iter()
            .map(|t| t / 2.0 + (2.0 * t).sin() / 4.0)
            .collect();
        let m = BANDS + 1;
        let mut tz = vec![0.0; s * m];
        let mut th = vec![0.0; s * m];
        for i in 0..s {
            let (mut az, mut ah) = (0.0, 0.0);
            for k in (0..BANDS).rev() {
                let l = table[i * BANDS + k];
                az += l * (hz[k + 1] - hz[k]);
                ah += l * (hh[k + 1] - hh[k]);
                tz[i * m + k] = az;
                th[i * m + k] = ah;
            }
        }
        Ok(SkyTable {
            table,
            hz,
            hh,
            tz,
            th,
        })
    }

    /// (∫ L sinθ cosθ dθ dφ, ∫ L cos²θ dθ) of sector i above elevation e
    /// (given with its sine and cosine; clipped to [0, π/2]; NaN: nothing).
    #[inline]
    fn above(&self, i: usize, (e, se, ce): (f64, f64, f64), dphi: f64) -> (f64, f64) {
        let (e, se, ce) = if e.is_nan() || e >= PI / 2.0 {
            (PI / 2.0, 1.0, 0.0)
        } else if e <= 0.0 {
            (0.0, 0.0, 1.0)
        } else {
            (e, se, ce)
        };
        let k = ((se * BANDS as f64) as usize).min(BANDS - 1);
        let l = self.table[i * BANDS + k];
        let m = BANDS + 1;
        let part_z = l * (self.hz[k + 1] - 0.5 * (se * se) * dphi);
        let part_h = l * (self.hh[k + 1] - (e / 2.0 + (2.0 * se * ce) / 4.0));
        (
            self.tz[i * m + k + 1] + part_z,
            self.th[i * m + k + 1] + part_h,
        )
    }
}

fn illumination_row<T: Elevation>(
    p: &Planes<'_, T>,
    g: &SectorGeom,
    sky: &SkyTable<'_>,
    normals: &[f64],
    r: usize,
    out: &mut [f64],
) {
    let w = p.cols;
    let nrow = &normals[3 * r * w..3 * (r + 1) * w];
    out.fill(0.0);
    for i in 0..p.sectors {
        for (j, &e) in p.row(i, r).iter().enumerate() {
            let n = &nrow[3 * j..3 * j + 3];
            let (iz, ih) = sky.above(i, g.effective(i, e.get(), n), g.dphi);
            out[j] += n[2] * iz + (n[0] * g.cx[i] + n[1] * g.cy[i]) * ih;
        }
    }
    for (o, z) in out.iter_mut().zip(&p.z[r * w..(r + 1) * w]) {
        if !z.is_finite() {
            *o = f64::NAN;
        }
    }
}

/// Direct primary illumination I = ∫_V L N·u dΩ for the sky table `table`
/// ((s, 256) radiances, row-major).
pub fn illumination<T: Elevation>(
    p: &Planes<'_, T>,
    normals: &[f64],
    table: &[f64],
    cancel: &Cancel,
) -> Result<Vec<f64>> {
    p.check_full(normals)?;
    let sky = SkyTable::new(table, p.sectors)?;
    let g = SectorGeom::new(p.sectors);
    per_row(p.rows, p.cols, cancel, |r, out| {
        illumination_row(p, &g, &sky, normals, r, out);
    })
}

/// Stewart–Langer approximate radiosity R = ρ(I/π)/(1 − ρ(1 − D)).
pub fn radiosity<T: Elevation>(
    p: &Planes<'_, T>,
    normals: &[f64],
    table: &[f64],
    albedo: f64,
    cancel: &Cancel,
) -> Result<Vec<f64>> {
    if !(0.0..1.0).contains(&albedo) {
        return Err(FcolError::value(
            "albedo",
            format!("must lie in [0, 1), got {albedo}"),
        ));
    }
    p.check_full(normals)?;
    let sky = SkyTable::new(table, p.sectors)?;
    let g = SectorGeom::new(p.sectors);
    per_row(p.rows, p.cols, cancel, |r, out| {
        let mut d = vec![0.0; p.cols];
        svf_row(p, &g, normals, r, &mut d);
        illumination_row(p, &g, &sky, normals, r, out);
        for (o, d) in out.iter_mut().zip(d) {
            *o = albedo * (*o / PI) / (1.0 - albedo * (1.0 - d));
        }
    })
}

/// A sun position (radians; azimuth counter-clockwise from +u towards +v)
/// and its angular radius (0: a point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sun {
    pub azimuth: f64,
    pub elevation: f64,
    pub radius: f64,
}

impl Sun {
    fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("sun_azimuth", self.azimuth),
            ("sun_elevation", self.elevation),
            ("sun_radius", self.radius),
        ] {
            if !v.is_finite() {
                return Err(FcolError::value(name, format!("must be finite, got {v}")));
            }
        }
        if self.radius < 0.0 {
            return Err(FcolError::value(
                "sun_radius",
                format!("must be >= 0, got {}", self.radius),
            ));
        }
        Ok(())
    }

    /// Unit direction towards the sun.
    pub fn direction(&self) -> [f64; 3] {
        let (ce, se) = (self.elevation.cos(), self.elevation.sin());
        [ce * self.azimuth.cos(), ce * self.azimuth.sin(), se]
    }
}

/// Python's `x % m` for m > 0 (the result takes the sign of m).
#[inline]
fn py_mod(x: f64, m: f64) -> f64 {
    let r = x % m;
    if r != 0.0 && r < 0.0 {
        r + m
    } else if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// Index of the sector holding `azimuth` (a border azimuth goes to the
/// sector it opens).
pub fn sector_of(azimuth: f64, s: usize) -> usize {
    let t = 2.0 * PI;
    let x = (py_mod(azimuth, t) * s as f64 / t).floor();
    (x as i64).rem_euclid(s as i64) as usize
}

/// Antiderivative of sqrt(r² − x²), x clipped to [−r, r].
#[inline]
fn disc_g(x: f64, r: f64) -> f64 {
    let x = x.clamp(-r, r);
    0.5 * (x * (r * r - x * x).max(0.0).sqrt() + r * r * (x / r).asin())
}

/// Area of the disc x² + y² ≤ r² within x0 ≤ x ≤ x1 and y ≥ y0 (NaN y0:
/// no obstruction).
pub fn disc_strip_above(x0: f64, x1: f64, y0: f64, r: f64) -> f64 {
    let y0 = if y0.is_nan() { f64::NEG_INFINITY } else { y0 };
    let integral = |lo: f64, hi: f64| {
        let (lo, hi) = (lo.max(x0), hi.min(x1));
        if hi > lo {
            disc_g(hi, r) - disc_g(lo, r)
        } else {
            0.0
        }
    };
    if y0 >= r {
        return 0.0;
    }
    if y0 <= -r {
        return 2.0 * integral(-r, r);
    }
    let yc = y0.clamp(-r, r);
    let a = (r * r - yc * yc).max(0.0).sqrt();
    let inner = integral(-a, a) - yc * (a.min(x1) - (-a).max(x0)).max(0.0);
    if yc < 0.0 {
        inner + 2.0 * (integral(-r, -a) + integral(a, r))
    } else {
        inner
    }
}

/// One sector strip of the sun's disc: the plane holding its horizon and
/// its x range in the disc's plane.
struct Strip {
    plane: usize,
    x0: f64,
    x1: f64,
}

/// The sectors the sun's disc covers.
fn strips<T: Elevation>(p: &Planes<'_, T>, sun: &Sun) -> Result<Vec<Strip>> {
    let s = p.sectors;
    let missing = |i: usize| {
        FcolError::value(
            "sectors_subset",
            format!("the sun needs sector {i}, which was not computed"),
        )
    };
    if sun.radius == 0.0 {
        let i = sector_of(sun.azimuth, s);
        let plane = p.plane_of(i).ok_or_else(|| missing(i))?;
        return Ok(vec![Strip {
            plane,
            x0: 0.0,
            x1: 0.0,
        }]);
    }
    let cs = sun.elevation.cos().max(1e-9);
    let half = (sun.radius / cs).min(PI);
    let w = 2.0 * PI / s as f64;
    let mut out = Vec::new();
    for i in 0..s {
        let lo = py_mod(2.0 * PI * i as f64 / s as f64 - sun.azimuth + PI, 2.0 * PI) - PI;
        let hi = lo + w;
        if hi < -half || lo > half {
            continue;
        }
        let plane = p.plane_of(i).ok_or_else(|| missing(i))?;
        out.push(Strip {
            plane,
            x0: lo * cs,
            x1: hi * cs,
        });
    }
    Ok(out)
}

/// Visible fraction of the sun at every point, in [0, 1] (NaN at no data),
/// times max(0, N·s) when `normals` are given (the direct sun term for a
/// sun of radiance 1 per unit of cos). Needs only the sectors the disc
/// covers.
pub fn sun<T: Elevation>(
    p: &Planes<'_, T>,
    sun: &Sun,
    normals: Option<&[f64]>,
    cancel: &Cancel,
) -> Result<Vec<f64>> {
    sun.validate()?;
    p.validate()?;
    if let Some(n) = normals {
        check_normals(n, p.n())?;
    }
    let strips = strips(p, sun)?;
    let d = sun.direction();
    let r = sun.radius;
    let disc = PI * r * r;
    per_row(p.rows, p.cols, cancel, |row, out| {
        if r == 0.0 {
            for (o, &e) in out.iter_mut().zip(p.row(strips[0].plane, row)) {
                *o = if sun.elevation > e.get() { 1.0 } else { 0.0 };
            }
        } else {
            out.fill(0.0);
            for st in &strips {
                for (o, &e) in out.iter_mut().zip(p.row(st.plane, row)) {
                    *o += disc_strip_above(st.x0, st.x1, e.get() - sun.elevation, r);
                }
            }
            for o in out.iter_mut() {
                *o = (*o / disc).clamp(0.0, 1.0);
            }
        }
        let w = p.cols;
        for (o, z) in out.iter_mut().zip(&p.z[row * w..(row + 1) * w]) {
            if !z.is_finite() {
                *o = f64::NAN;
            }
        }
        if let Some(nn) = normals {
            for (j, o) in out.iter_mut().enumerate() {
                let n = &nn[3 * (row * w + j)..3 * (row * w + j) + 3];
                let c = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                *o *= nan_max(c, 0.0);
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn uniform(e0: f32, s: usize, rows: usize, cols: usize) -> (Vec<f32>, Vec<usize>, Vec<f64>) {
        (
            vec![e0; s * rows * cols],
            (0..s).collect(),
            vec![0.0; rows * cols],
        )
    }

    fn up(n: usize) -> Vec<f64> {
        (0..n).flat_map(|_| [0.0, 0.0, 1.0]).collect()
    }

    #[test]
    fn svf_of_a_uniform_horizon_is_cos_squared() {
        for e0 in [0.0f32, 0.3, 1.0] {
            let (el, idx, z) = uniform(e0, 32, 2, 3);
            let p = Planes {
                elevation: &el,
                sector_indices: &idx,
                sectors: 32,
                rows: 2,
                cols: 3,
                z: &z,
            };
            let d = sky_view_factor(&p, &up(6), &Cancel::new()).unwrap();
            let want = (e0 as f64).cos().powi(2);
            assert!(
                d.iter().all(|x| (x - want).abs() < 1e-12),
                "{d:?} vs {want}"
            );
        }
    }

    #[test]
    fn uniform_sky_gives_pi_times_svf_and_radiosity_formula() {
        let (el, idx, z) = uniform(0.4, 16, 1, 2);
        let p = Planes {
            elevation: &el,
            sector_indices: &idx,
            sectors: 16,
            rows: 1,
            cols: 2,
            z: &z,
        };
        let table = vec![1.0; 16 * BANDS];
        let n = up(2);
        let i = illumination(&p, &n, &table, &Cancel::new()).unwrap();
        let d = sky_view_factor(&p, &n, &Cancel::new()).unwrap();
        assert!((i[0] - PI * d[0]).abs() < 1e-12);
        let r = radiosity(&p, &n, &table, 0.3, &Cancel::new()).unwrap();
        let want = 0.3 * (i[0] / PI) / (1.0 - 0.3 * (1.0 - d[0]));
        assert!((r[0] - want).abs() < 1e-15);
        assert!(radiosity(&p, &n, &table, 1.0, &Cancel::new()).is_err());
    }

    #[test]
    fn series_sin_cos_match_libm() {
        let mut x = -1.6;
        while x <= 1.6 {
            let (s, c) = sin_cos(x);
            assert!((s - x.sin()).abs() <= 4e-16, "sin {x}");
            assert!((c - x.cos()).abs() <= 4e-16, "cos {x}");
            x += 1.0 / 1024.0 + 1e-9;
        }
        let e = std::f32::consts::FRAC_PI_2 as f64; // an empty sector's −π/2 in f32
        assert!((sin_cos(-e).1 - (-e).cos()).abs() <= 1e-16);
    }

    #[test]
    fn disc_strip_areas() {
        let r = 0.5;
        let full = PI * r * r;
        assert!((disc_strip_above(-1.0, 1.0, f64::NAN, r) - full).abs() < 1e-15);
        assert!((disc_strip_above(-1.0, 1.0, 0.0, r) - full / 2.0).abs() < 1e-15);
        assert_eq!(disc_strip_above(-1.0, 1.0, r, r), 0.0);
        // the left and right halves of the lower half-disc add up
        let a = disc_strip_above(-1.0, 0.0, -0.2, r) + disc_strip_above(0.0, 1.0, -0.2, r);
        assert!((a - disc_strip_above(-1.0, 1.0, -0.2, r)).abs() < 1e-15);
    }

    #[test]
    fn sector_of_border_azimuths() {
        assert_eq!(sector_of(0.0, 8), 0);
        assert_eq!(sector_of(-1e-300, 8), 0); // rounds up to a full turn
        assert_eq!(sector_of(PI / 4.0, 8), 1);
        assert_eq!(sector_of(-PI / 4.0, 8), 7);
        assert_eq!(sector_of(2.0 * PI, 8), 0);
    }

    #[test]
    fn missing_sector_is_an_error() {
        let el = vec![0.0f32; 4];
        let z = vec![0.0; 4];
        let p = Planes {
            elevation: &el,
            sector_indices: &[3],
            sectors: 8,
            rows: 2,
            cols: 2,
            z: &z,
        };
        let sun0 = Sun {
            azimuth: 0.1,
            elevation: 0.2,
            radius: 0.0,
        };
        assert!(sun(&p, &sun0, None, &Cancel::new()).is_err());
        let sun3 = Sun {
            azimuth: 3.5 * PI / 4.0,
            ..sun0
        };
        let v = sun(&p, &sun3, None, &Cancel::new()).unwrap();
        assert!(v.iter().all(|&x| x == 1.0));
        assert!(sky_view_factor(&p, &up(4), &Cancel::new()).is_err());
    }
}
