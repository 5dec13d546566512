//! Height grids: samples z[i, j] at (u0 + j·du, v0 + i·dv) (SPEC §1: rows
//! along v, row 0 at v0; a negative du or dv flips the axis, e.g. a
//! north-up raster), interpolated bilinearly or by bicubic convolution, with
//! derivatives of the interpolant itself.
//!
//! * Bilinear: the tensor product of linear interpolation in each cell. A
//!   cell with a non-finite corner is a hole.
//! * Bicubic: Keys' cubic convolution with a = −0.5 (the Catmull-Rom
//!   spline; Keys 1981), separable, C¹ across cells. Beyond the borders the
//!   grid is extended by Keys' boundary rule z₋₁ = 3z₀ − 3z₁ + z₂ (linear
//!   extrapolation 2z₀ − z₁ when an axis has only two samples), so the
//!   interpolant stays cubic-exact to the edge. A cell is a hole when any
//!   of the 16 samples its kernel touches is non-finite: a no-data sample
//!   makes a hole one cell wider on each side than under bilinear.
//! * An axis with a single sample (a 1×N grid) is constant along that axis
//!   over the extent given, or over one spacing.
//! * Outside the grid's rectangle (beyond 1e-9 cell of rounding slack) the
//!   surface does not exist: evaluation returns NaN.

use crate::error::{FcolError, Result};
use crate::surface::{Domain, HeightField, HeightSample};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    Bilinear,
    Bicubic,
}

impl Interpolation {
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "bilinear" => Ok(Interpolation::Bilinear),
            "bicubic" => Ok(Interpolation::Bicubic),
            _ => Err(FcolError::value(
                "interpolation",
                format!("must be \"bilinear\" or \"bicubic\", got {s:?}"),
            )),
        }
    }
    pub fn name(&self) -> &'static str {
        match self {
            Interpolation::Bilinear => "bilinear",
            Interpolation::Bicubic => "bicubic",
        }
    }
}

/// One axis: n samples at x0 + k·dx (dx ≠ 0, either sign).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axis {
    pub x0: f64,
    pub dx: f64,
    pub n: usize,
}

impl Axis {
    /// (lo, hi) of the covered interval.
    fn range(&self) -> (f64, f64) {
        let a = self.x0;
        let b = self.x0 + (self.n - 1) as f64 * self.dx;
        (a.min(b), a.max(b))
    }

    /// An interval of coordinates in cells (ascending, cell k from k to
    /// k + 1).
    fn local(&self, (x0, x1): (f64, f64)) -> (f64, f64) {
        let (s0, s1) = ((x0 - self.x0) / self.dx, (x1 - self.x0) / self.dx);
        (s0.min(s1), s0.max(s1))
    }

    /// Cell index (0..n−2) and fraction in [0, 1] of coordinate x, or None
    /// outside.
    #[inline]
    fn locate(&self, x: f64) -> Option<(usize, f64)> {
        let s = (x - self.x0) / self.dx;
        let top = (self.n - 1) as f64;
        if !(s >= -1e-9 && s <= top + 1e-9) {
            return None;
        }
        let s = s.clamp(0.0, top);
        let j = (s.floor() as usize).min(self.n - 2);
        Some((j, s - j as f64))
    }
}

/// A height grid with its interpolant.
#[derive(Debug, Clone)]
pub struct HeightGrid {
    /// Samples, row-major (ny rows along v, nx columns along u); non-finite
    /// values are stored as NaN.
    z: Vec<f64>,
    u: Axis,
    v: Axis,
    interp: Interpolation,
    /// Bicubic only: the samples extended by one on each side,
    /// (ny + 2) × (nx + 2).
    ext: Vec<f64>,
    /// The original shape (before a single row/column is doubled).
    shape: (usize, usize),
    domain: Domain,
    /// Bounds of the interpolant (see [`HeightGrid::value_range`]).
    range: Option<(f64, f64)>,
    /// Upper bounds of the interpolant over blocks of cells (see
    /// [`MaxPyramid`]), and upper bounds of its negative (lower bounds).
    maxes: MaxPyramid,
    neg_mins: MaxPyramid,
}

/// Level k holds, for each block of 2^k × 2^k cells, an upper bound of the
/// interpolant over it (−∞ where no cell has a finite value): level 0 a
/// cell's corners' maximum (bilinear) or the bound of its 16 kernel samples
/// (bicubic, as [`HeightGrid::value_range`]), each level the maximum of the
/// four blocks below.
#[derive(Debug, Clone, Default)]
struct MaxPyramid {
    levels: Vec<(usize, usize, Vec<f64>)>,
}

impl MaxPyramid {
    /// The pyramid over the cells' bounds `base` (`ny` × `nx`, row-major).
    fn build(ny: usize, nx: usize, base: Vec<f64>) -> Self {
        let mut levels = vec![(ny, nx, base)];
        while levels.last().is_some_and(|(h, w, _)| *h > 1 || *w > 1) {
            let (h, w, m) = levels.last().expect("a level");
            let (h2, w2) = (h.div_ceil(2), w.div_ceil(2));
            let mut up = vec![f64::NEG_INFINITY; h2 * w2];
            for i in 0..*h {
                for j in 0..*w {
                    let x = &mut up[(i / 2) * w2 + j / 2];
                    *x = x.max(m[i * w + j]);
                }
            }
            levels.push((h2, w2, up));
        }
        MaxPyramid { levels }
    }

    /// The bound over cells [i0, i1] × [j0, j1] (inclusive, rows × columns).
    fn max(&self, i0: usize, i1: usize, j0: usize, j1: usize) -> f64 {
        // The lowest level at which the range spans at most four blocks
        // along each axis (at most 16 look-ups).
        let mut k = 0;
        while k + 1 < self.levels.len() && ((i1 >> k) - (i0 >> k) > 3 || (j1 >> k) - (j0 >> k) > 3)
        {
            k += 1;
        }
        let (ny, nx, m) = &self.levels[k];
        let mut best = f64::NEG_INFINITY;
        for i in (i0 >> k)..=((i1 >> k).min(ny - 1)) {
            for j in (j0 >> k)..=((j1 >> k).min(nx - 1)) {
                best = best.max(m[i * nx + j]);
            }
        }
        best
    }
}

fn extend_line(line: &[f64]) -> (f64, f64) {
    let n = line.len();
    if n >= 3 {
        (
            3.0 * line[0] - 3.0 * line[1] + line[2],
            3.0 * line[n - 1] - 3.0 * line[n - 2] + line[n - 3],
        )
    } else {
        (2.0 * line[0] - line[1], 2.0 * line[1] - line[0])
    }
}

impl HeightGrid {
    /// `z` row-major with `ny` rows and `nx` columns; sample (i, j) at
    /// (u0 + j·du, v0 + i·dv). An axis with one sample spans [x0, x0 + dx].
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        z: Vec<f64>,
        ny: usize,
        nx: usize,
        u0: f64,
        du: f64,
        v0: f64,
        dv: f64,
        interp: Interpolation,
    ) -> Result<Self> {
        if nx == 0 || ny == 0 {
            return Err(FcolError::value(
                "z",
                format!("must have at least one row and one column, got shape ({ny}, {nx})"),
            ));
        }
        if z.len() != nx * ny {
            return Err(FcolError::value("z", "length does not match its shape"));
        }
        for (name, x) in [("u0", u0), ("v0", v0)] {
            if !x.is_finite() {
                return Err(FcolError::value(name, format!("must be finite, got {x}")));
            }
        }
        for (name, d) in [("du", du), ("dv", dv)] {
            if !d.is_finite() || d == 0.0 {
                return Err(FcolError::value(
                    "spacing",
                    format!("{name} must be finite and non-zero, got {d}"),
                ));
            }
        }
        let mut z: Vec<f64> = z
            .into_iter()
            .map(|x| if x.is_finite() { x } else { f64::NAN })
            .collect();
        // Double a single column / row so every axis has two samples.
        let (mut nx2, mut ny2) = (nx, ny);
        if nx == 1 {
            z = z.iter().flat_map(|&x| [x, x]).collect();
            nx2 = 2;
        }
        if ny == 1 {
            let row = z.clone();
            z.extend_from_slice(&row);
            ny2 = 2;
        }
        let u = Axis {
            x0: u0,
            dx: du,
            n: nx2,
        };
        let v = Axis {
            x0: v0,
            dx: dv,
            n: ny2,
        };
        let (ua, ub) = u.range();
        let (va, vb) = v.range();
        let domain = Domain::new(ua, ub, va, vb).map_err(|_| {
            FcolError::value(
                "extent",
                format!("the grid spans a degenerate or non-finite rectangle [{ua}, {ub}] × [{va}, {vb}]"),
            )
        })?;
        let mut g = HeightGrid {
            z,
            u,
            v,
            interp,
            ext: Vec::new(),
            shape: (ny, nx),
            domain,
            range: None,
            maxes: MaxPyramid::default(),
            neg_mins: MaxPyramid::default(),
        };
        if interp == Interpolation::Bicubic {
            g.build_ext();
        }
        g.range = g.value_range();
        (g.maxes, g.neg_mins) = g.bound_pyramids();
        Ok(g)
    }

    fn build_ext(&mut self) {
        let (nx, ny) = (self.u.n, self.v.n);
        let w = nx + 2;
        let mut e = vec![0.0; w * (ny + 2)];
        for i in 0..ny {
            let row = &self.z[i * nx..(i + 1) * nx];
            let (a, b) = extend_line(row);
            let r = &mut e[(i + 1) * w..(i + 2) * w];
            r[0] = a;
            r[1..=nx].copy_from_slice(row);
            r[nx + 1] = b;
        }
        for j in 0..w {
            let col: Vec<f64> = (0..ny).map(|i| e[(i + 1) * w + j]).collect();
            let (a, b) = extend_line(&col);
            e[j] = a;
            e[(ny + 1) * w + j] = b;
        }
        self.ext = e;
    }

    pub fn shape(&self) -> (usize, usize) {
        self.shape
    }
    pub fn interpolation(&self) -> Interpolation {
        self.interp
    }
    /// (u0, du, v0, dv).
    pub fn geometry(&self) -> (f64, f64, f64, f64) {
        (self.u.x0, self.u.dx, self.v.x0, self.v.dx)
    }

    #[inline]
    fn sample(&self, u: f64, v: f64, grad: bool) -> HeightSample {
        const NAN: HeightSample = HeightSample {
            f: f64::NAN,
            fu: f64::NAN,
            fv: f64::NAN,
        };
        let (Some((j, s)), Some((i, t))) = (self.u.locate(u), self.v.locate(v)) else {
            return NAN;
        };
        let r = match self.interp {
            Interpolation::Bilinear => {
                let nx = self.u.n;
                let k = i * nx + j;
                let (z00, z01, z10, z11) =
                    (self.z[k], self.z[k + 1], self.z[k + nx], self.z[k + nx + 1]);
                let a = z00 + s * (z01 - z00);
                let b = z10 + s * (z11 - z10);
                let f = a + t * (b - a);
                if grad {
                    let fs = (1.0 - t) * (z01 - z00) + t * (z11 - z10);
                    let ft = b - a;
                    HeightSample {
                        f,
                        fu: fs / self.u.dx,
                        fv: ft / self.v.dx,
                    }
                } else {
                    HeightSample {
                        f,
                        fu: 0.0,
                        fv: 0.0,
                    }
                }
            }
            Interpolation::Bicubic => {
                let w = self.u.n + 2;
                let (wu, du) = keys(s);
                let (wv, dv) = keys(t);
                // Extended index of sample (i−1, j−1) is (i, j). Sums are
                // taken relative to the centre sample (the weights sum to 1,
                // their derivatives to 0), so constants come out exact.
                let mut r = [0.0; 4];
                let mut rs = [0.0; 4];
                for a in 0..4 {
                    let row = &self.ext[(i + a) * w + j..(i + a) * w + j + 4];
                    let c = row[1];
                    let d = [row[0] - c, 0.0, row[2] - c, row[3] - c];
                    r[a] = c + (wu[0] * d[0] + wu[2] * d[2] + wu[3] * d[3]);
                    if grad {
                        rs[a] = du[0] * d[0] + du[2] * d[2] + du[3] * d[3];
                    }
                }
                let c = r[1];
                let d = [r[0] - c, 0.0, r[2] - c, r[3] - c];
                let f = c + (wv[0] * d[0] + wv[2] * d[2] + wv[3] * d[3]);
                let (mut fs, mut ft) = (0.0, 0.0);
                if grad {
                    fs = wv[0] * rs[0] + wv[1] * rs[1] + wv[2] * rs[2] + wv[3] * rs[3];
                    ft = dv[0] * d[0] + dv[2] * d[2] + dv[3] * d[3];
                }
                HeightSample {
                    f,
                    fu: fs / self.u.dx,
                    fv: ft / self.v.dx,
                }
            }
        };
        if r.f.is_nan() {
            NAN
        } else {
            r
        }
    }
}

/// Keys' cubic convolution weights (a = −0.5) of samples −1, 0, 1, 2 at
/// fraction t, and their derivatives in t.
#[inline]
pub fn keys(t: f64) -> ([f64; 4], [f64; 4]) {
    let t2 = t * t;
    let t3 = t2 * t;
    (
        [
            -0.5 * t3 + t2 - 0.5 * t,
            1.5 * t3 - 2.5 * t2 + 1.0,
            -1.5 * t3 + 2.0 * t2 + 0.5 * t,
            0.5 * t3 - 0.5 * t2,
        ],
        [
            -1.5 * t2 + 2.0 * t - 0.5,
            4.5 * t2 - 5.0 * t,
            -4.5 * t2 + 4.0 * t + 0.5,
            1.5 * t2 - t,
        ],
    )
}

/// Cells rows i0..=i1, columns j0..=j1 of a grid: (i0, i1, j0, j1).
type Cells = (usize, usize, usize, usize);

/// The power-basis coefficients (of s⁰ … s³) of Σ_b w_b(s) z_b, Keys'
/// weights ([`keys`]) applied to four samples.
#[inline]
fn keys_poly(z: &[f64; 4]) -> [f64; 4] {
    [
        z[1],
        0.5 * (z[2] - z[0]),
        z[0] - 2.5 * z[1] + 2.0 * z[2] - 0.5 * z[3],
        0.5 * (-z[0] + 3.0 * z[1] - 3.0 * z[2] + z[3]),
    ]
}

/// The cubic with power coefficients `c` on [s0, s0 + h], as a cubic in
/// x ∈ [0, 1] (s = s0 + h·x): its Taylor coefficients at s0 times hᵏ.
#[inline]
fn shifted(c: [f64; 4], s0: f64, h: f64) -> [f64; 4] {
    [
        ((c[3] * s0 + c[2]) * s0 + c[1]) * s0 + c[0],
        ((3.0 * c[3] * s0 + 2.0 * c[2]) * s0 + c[1]) * h,
        (3.0 * c[3] * s0 + c[2]) * h * h,
        c[3] * h * h * h,
    ]
}

/// A cubic's Bernstein coefficients on [0, 1] from its power ones.
#[inline]
fn to_bernstein(a: [f64; 4]) -> [f64; 4] {
    [
        a[0],
        a[0] + a[1] / 3.0,
        a[0] + 2.0 * a[1] / 3.0 + a[2] / 3.0,
        a[0] + a[1] + a[2] + a[3],
    ]
}

/// Bounds of an interpolant whose samples span [lo, hi]: bilinear values
/// are convex combinations of them; a bicubic value is Σ wᵢ zᵢ with Σ wᵢ = 1
/// and Σ |wᵢ| ≤ 1.25² (Keys' weights at a = −0.5: the two negative ones add
/// up to −t(1 − t)/2 ≥ −1/8 per axis), so within 1.5625·R/2 of the middle
/// of their range R. Widened by 1e-12 of the magnitude for rounding.
fn interpolant_bound(lo: f64, hi: f64, interp: Interpolation) -> (f64, f64) {
    let (lo, hi) = if interp == Interpolation::Bicubic {
        let (c, r) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        (c - 1.5625 * r, c + 1.5625 * r)
    } else {
        (lo, hi)
    };
    let m = 1e-12 * lo.abs().max(hi.abs()) + f64::MIN_POSITIVE;
    (lo - m, hi + m)
}

/// (min, max) of the finite values (lo > hi: none).
fn finite_range<'a>(xs: impl Iterator<Item = &'a f64>) -> (f64, f64) {
    xs.filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        })
}

impl HeightGrid {
    /// Bounds of the interpolant over the whole grid ([`interpolant_bound`]
    /// of its samples, the extended ones for bicubic). None: no finite
    /// sample.
    fn value_range(&self) -> Option<(f64, f64)> {
        let src = if self.interp == Interpolation::Bicubic {
            &self.ext
        } else {
            &self.z
        };
        let (lo, hi) = finite_range(src.iter());
        if lo > hi {
            return None;
        }
        let (lo, hi) = interpolant_bound(lo, hi, self.interp);
        (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
    }

    /// The pyramids of the interpolant's upper bounds and of its lower
    /// bounds' negatives.
    fn bound_pyramids(&self) -> (MaxPyramid, MaxPyramid) {
        let (nx, ny) = (self.u.n - 1, self.v.n - 1);
        let mut base = vec![f64::NEG_INFINITY; nx * ny];
        let mut neg = vec![f64::NEG_INFINITY; nx * ny];
        let mut kernel = Vec::with_capacity(16);
        for i in 0..ny {
            for j in 0..nx {
                // The samples the cell's interpolant combines.
                kernel.clear();
                if self.interp == Interpolation::Bicubic {
                    let w = self.u.n + 2;
                    for a in 0..4 {
                        kernel.extend_from_slice(&self.ext[(i + a) * w + j..(i + a) * w + j + 4]);
                    }
                } else {
                    let k = i * self.u.n + j;
                    kernel.extend_from_slice(&self.z[k..k + 2]);
                    kernel.extend_from_slice(&self.z[k + self.u.n..k + self.u.n + 2]);
                }
                // (a NaN among them: the cell is a hole)
                if kernel.iter().any(|x| x.is_nan()) {
                    continue;
                }
                let (lo, hi) = finite_range(kernel.iter());
                let (blo, bhi) = interpolant_bound(lo, hi, self.interp);
                base[i * nx + j] = bhi;
                neg[i * nx + j] = -blo;
            }
        }
        (
            MaxPyramid::build(ny, nx, base),
            MaxPyramid::build(ny, nx, neg),
        )
    }

    /// The cells rows i0..=i1, columns j0..=j1 (`cells`) that the box `u` ×
    /// `v` touches, each with the box's part of it in cell coordinates:
    /// (i, j, (s0, s1), (t0, t1)), s along u and t along v, each in [0, 1].
    fn cell_parts(
        &self,
        (i0, i1, j0, j1): Cells,
        u: (f64, f64),
        v: (f64, f64),
    ) -> impl Iterator<Item = (usize, usize, (f64, f64), (f64, f64))> {
        let ((su0, su1), (sv0, sv1)) = (self.u.local(u), self.v.local(v));
        let part = |a: f64, b: f64, k: usize| {
            (
                (a - k as f64).clamp(0.0, 1.0),
                (b - k as f64).clamp(0.0, 1.0),
            )
        };
        (i0..=i1)
            .flat_map(move |i| (j0..=j1).map(move |j| (i, j, part(su0, su1, j), part(sv0, sv1, i))))
    }

    /// The bilinear interpolant's range over the box `u` × `v`, which
    /// touches cells rows i0..=i1, columns j0..=j1 (None: one of them is a
    /// hole). Over each cell's part of the box a bilinear function takes
    /// its extremes at that part's corners (it is linear along each edge,
    /// its one critical point a saddle), so the range is exact, widened
    /// only for rounding (of the values, and of positions by 1e-12 of a
    /// cell).
    fn bilinear_range_in(&self, cells: Cells, u: (f64, f64), v: (f64, f64)) -> Option<(f64, f64)> {
        let nx = self.u.n;
        let (mut lo, mut hi, mut step) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
        for (i, j, ss, ts) in self.cell_parts(cells, u, v) {
            let k = i * nx + j;
            let (z00, z01, z10, z11) =
                (self.z[k], self.z[k + 1], self.z[k + nx], self.z[k + nx + 1]);
            if [z00, z01, z10, z11].iter().any(|x| x.is_nan()) {
                return None;
            }
            step = step.max(
                (z01 - z00)
                    .abs()
                    .max((z11 - z10).abs())
                    .max((z10 - z00).abs()),
            );
            for s in [ss.0, ss.1] {
                for t in [ts.0, ts.1] {
                    let a = z00 + s * (z01 - z00);
                    let b = z10 + s * (z11 - z10);
                    let f = a + t * (b - a);
                    (lo, hi) = (lo.min(f), hi.max(f));
                }
            }
        }
        let m = 1e-12 * (lo.abs().max(hi.abs()) + step) + 1e-9 * (hi - lo) + f64::MIN_POSITIVE;
        Some((lo - m, hi + m))
    }

    /// The bicubic interpolant's bounds over the box `u` × `v`, which
    /// touches cells rows i0..=i1, columns j0..=j1 (None: one of them is a
    /// hole). Over each cell's part of the box the interpolant is a
    /// polynomial of degree 3 in each axis: written in the Bernstein basis
    /// of that part, it lies within the range of its 16 coefficients (the
    /// convex hull property), which holds its values at the part's corners
    /// and closes in on its range as the part shrinks (the excess falls
    /// with the square of the part's size). Widened for rounding (of the
    /// values, and of positions by 1e-12 of a cell).
    fn bicubic_range_in(&self, cells: Cells, u: (f64, f64), v: (f64, f64)) -> Option<(f64, f64)> {
        let w = self.u.n + 2;
        let (mut lo, mut hi, mut size) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
        for (i, j, (s0, s1), (t0, t1)) in self.cell_parts(cells, u, v) {
            // The kernel relative to its centre sample (as `sample` sums
            // it: the weights sum to 1, so constants stay exact).
            let c = self.ext[(i + 1) * w + j + 1];
            let mut k = [[0.0; 4]; 4];
            for (a, row) in k.iter_mut().enumerate() {
                let src = &self.ext[(i + a) * w + j..(i + a) * w + j + 4];
                for (b, x) in row.iter_mut().enumerate() {
                    *x = src[b] - c;
                    if x.is_nan() {
                        return None;
                    }
                    size = size.max(x.abs());
                }
            }
            // Along u: each kernel row's cubic in s, on [s0, s1] as a cubic
            // in x ∈ [0, 1]; then along v the same for each power of x.
            let px: [[f64; 4]; 4] = std::array::from_fn(|a| shifted(keys_poly(&k[a]), s0, s1 - s0));
            // by[p][q]: the coefficient of x^p, in the Bernstein basis in y.
            let by: [[f64; 4]; 4] = std::array::from_fn(|p| {
                let col = std::array::from_fn(|a| px[a][p]);
                to_bernstein(shifted(keys_poly(&col), t0, t1 - t0))
            });
            let coef = (0..4).flat_map(|q| to_bernstein(std::array::from_fn(|p| by[p][q])));
            for x in coef {
                (lo, hi) = (lo.min(c + x), hi.max(c + x));
            }
            size = size.max(c.abs());
        }
        let m = 1e-11 * (lo.abs().max(hi.abs()) + size) + 1e-9 * (hi - lo) + f64::MIN_POSITIVE;
        Some((lo - m, hi + m))
    }

    /// The cells [k0, k1] of an axis that a coordinate interval can touch
    /// (with 1e-6 of a cell of slack each way for rounding: a point within
    /// it of a cell's edge may be evaluated in the cell beside).
    fn cells(a: &Axis, x0: f64, x1: f64) -> Option<(usize, usize)> {
        let (s0, s1) = a.local((x0, x1));
        if !(s0.is_finite() && s1.is_finite()) {
            return None;
        }
        let top = (a.n - 2) as f64;
        let k0 = (s0 - 1e-6).floor().clamp(0.0, top) as usize;
        let k1 = (s1 + 1e-6).floor().clamp(0.0, top) as usize;
        Some((k0, k1))
    }
}

impl HeightField for HeightGrid {
    fn domain(&self) -> Domain {
        self.domain
    }
    fn height_bound(&self) -> Option<(f64, f64)> {
        self.range
    }
    fn height_max_in(&self, u0: f64, u1: f64, v0: f64, v1: f64) -> Option<f64> {
        let (j0, j1) = Self::cells(&self.u, u0, u1)?;
        let (i0, i1) = Self::cells(&self.v, v0, v1)?;
        Some(self.maxes.max(i0, i1, j0, j1))
    }
    fn height_range_in(&self, u0: f64, u1: f64, v0: f64, v1: f64) -> Option<(f64, f64)> {
        self.range?;
        let (j0, j1) = Self::cells(&self.u, u0, u1)?;
        let (i0, i1) = Self::cells(&self.v, v0, v1)?;
        if i1 - i0 < 4 && j1 - j0 < 4 {
            let cells = (i0, i1, j0, j1);
            let r = match self.interp {
                Interpolation::Bilinear => self.bilinear_range_in(cells, (u0, u1), (v0, v1)),
                Interpolation::Bicubic => self.bicubic_range_in(cells, (u0, u1), (v0, v1)),
            };
            if let Some(r) = r {
                return Some(r);
            }
        }
        // (no finite cell there: +∞ > −∞, "nothing")
        Some((
            -self.neg_mins.max(i0, i1, j0, j1),
            self.maxes.max(i0, i1, j0, j1),
        ))
    }
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [HeightSample]) {
        for ((o, &u), &v) in out.iter_mut().zip(u).zip(v) {
            *o = self.sample(u, v, true);
        }
    }
    #[inline]
    fn eval(&self, u: f64, v: f64) -> HeightSample {
        self.sample(u, v, true)
    }
    fn eval_value_batch(&self, u: &[f64], v: &[f64], out: &mut [f64]) {
        for ((o, &u), &v) in out.iter_mut().zip(u).zip(v) {
            *o = self.sample(u, v, false).f;
        }
    }
    #[inline]
    fn eval_value(&self, u: f64, v: f64) -> f64 {
        self.sample(u, v, false).f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bounds over parts of the domain (what the sweeps step over
    /// stretches by): every value sampled in a box lies inside its bound;
    /// bilinear bounds over boxes within a few cells are the interpolant's
    /// own range (to rounding), bicubic ones close in on it with the square
    /// of the box, larger boxes take those of the block pyramids; a box over
    /// a hole falls back to the pyramids.
    #[test]
    fn local_bounds_hold_and_are_tight_for_small_boxes() {
        let (nx, ny) = (23, 17);
        let mut rnd = crate::test_rng::uniform(5);
        let mut z: Vec<f64> = (0..nx * ny).map(|_| 4.0 * rnd() - 1.0).collect();
        z[8 * nx + 9] = f64::NAN;
        for interp in [Interpolation::Bilinear, Interpolation::Bicubic] {
            let g = HeightGrid::new(z.clone(), ny, nx, -1.0, 0.25, 2.0, -0.5, interp).unwrap();
            let d = g.domain();
            let (mut exact, mut tried, mut close) = (0, 0, 0);
            for size in [3.0, 0.4, 0.01, 1e-7] {
                for _ in 0..60 {
                    let u0 = d.u0 + (d.u1 - d.u0 - size) * rnd();
                    let v0 = d.v0 + (d.v1 - d.v0 - size) * rnd();
                    let (u1, v1) = (u0 + size * rnd(), v0 + size * rnd());
                    let (lo, hi) = g.height_range_in(u0, u1, v0, v1).unwrap();
                    let (mut fmin, mut fmax) = (f64::INFINITY, f64::NEG_INFINITY);
                    for a in 0..=8 {
                        for b in 0..=8 {
                            let u = u0 + (u1 - u0) * a as f64 / 8.0;
                            let v = v0 + (v1 - v0) * b as f64 / 8.0;
                            let f = g.eval_value(u, v);
                            if f.is_finite() {
                                assert!(lo <= f && f <= hi, "{interp:?}: {f} outside [{lo}, {hi}]");
                                (fmin, fmax) = (fmin.min(f), fmax.max(f));
                            }
                        }
                    }
                    // Within a cell, the 9 × 9 samples include the box's
                    // corners, the extremes: the bound is the range.
                    let one_cell = ((u0 + 1.0) / 0.25).floor() == ((u1 + 1.0) / 0.25).floor()
                        && ((2.0 - v0) / 0.5).floor() == ((2.0 - v1) / 0.5).floor();
                    if interp == Interpolation::Bicubic && one_cell && fmin <= fmax && size <= 0.01
                    {
                        // The Bernstein bound closes in with the square of
                        // the box (in cells; the samples span 4).
                        let h = ((u1 - u0) / 0.25).max((v1 - v0) / 0.5);
                        let excess = (fmin - lo).max(hi - fmax);
                        let tol = 1e-9 * (1.0 + fmax.abs()) + 4.0 * h * h;
                        assert!(
                            excess <= tol,
                            "bicubic box of {h} cells: {excess} over the range"
                        );
                        close += 1;
                    }
                    if interp == Interpolation::Bilinear && one_cell && fmin <= fmax {
                        tried += 1;
                        let tol = 1e-9 * (1.0 + fmax.abs());
                        if fmin - lo <= tol && hi - fmax <= tol {
                            exact += 1;
                        }
                    }
                }
            }
            if interp == Interpolation::Bilinear {
                // (all but boxes beside the hole, where the pyramid's
                // bound stands in)
                assert!(
                    tried > 60 && exact as f64 >= 0.9 * tried as f64,
                    "{exact} of {tried} exact"
                );
            } else {
                assert!(close > 60, "{close} small bicubic boxes within a cell");
            }
        }
    }

    #[test]
    fn bicubic_reproduces_cubics_to_the_edge() {
        // Keys' kernel with the boundary rule reproduces quadratics exactly
        // (and is O(h³) for smooth data).
        let (nx, ny) = (6, 5);
        let f = |x: f64, y: f64| 0.5 * x * x - x * y + 2.0 * y * y + 3.0 * x - 1.0;
        let mut z = Vec::new();
        for i in 0..ny {
            for j in 0..nx {
                z.push(f(j as f64 * 0.5, 1.0 - i as f64 * 0.25));
            }
        }
        let g = HeightGrid::new(z, ny, nx, 0.0, 0.5, 1.0, -0.25, Interpolation::Bicubic).unwrap();
        for &(u, v) in &[(0.1, 0.95), (2.49, 0.0), (1.3, 0.5), (0.0, 1.0), (2.5, 0.0)] {
            let s = g.eval(u, v);
            assert!(
                (s.f - f(u, v)).abs() < 1e-12,
                "{u} {v}: {} vs {}",
                s.f,
                f(u, v)
            );
            assert!((s.fu - (u - v + 3.0)).abs() < 1e-11);
            assert!((s.fv - (-u + 4.0 * v)).abs() < 1e-11);
        }
        assert!(g.eval(2.6, 0.5).f.is_nan());
    }

    #[test]
    fn single_row_is_constant_along_v() {
        let g = HeightGrid::new(
            vec![1.0, 3.0],
            1,
            2,
            0.0,
            1.0,
            5.0,
            2.0,
            Interpolation::Bilinear,
        )
        .unwrap();
        let s = g.eval(0.25, 6.0);
        assert_eq!((s.f, s.fu, s.fv), (1.5, 2.0, 0.0));
        assert_eq!(g.domain(), Domain::new(0.0, 1.0, 5.0, 7.0).unwrap());
    }

    /// Every finite value of the interpolant, sampled densely (cell
    /// corners, edges and centres included), lies within the height bound,
    /// also for the pattern that makes Keys' overshoot largest (±1 in pairs
    /// along both axes), which bicubic interpolation takes past 1.5 in
    /// magnitude.
    #[test]
    fn height_bound_holds_and_is_tight_for_bicubic() {
        let pairs = |k: usize| if (k / 2) % 2 == 0 { -1.0 } else { 1.0 };
        let n = 12;
        let mut worst = Vec::new();
        let mut rough = Vec::new();
        for i in 0..n {
            for j in 0..n {
                worst.push(pairs(i + 1) * pairs(j + 1));
                let x = ((i * 7 + j * 13) % 11) as f64 - 5.0;
                rough.push(if (i, j) == (5, 6) {
                    f64::NAN
                } else {
                    x * x * 0.1
                });
            }
        }
        for (z, tight) in [(&worst, true), (&rough, false)] {
            for interp in [Interpolation::Bilinear, Interpolation::Bicubic] {
                let g = HeightGrid::new(z.clone(), n, n, 0.0, 1.0, 0.0, 1.0, interp).unwrap();
                let (lo, hi) = g.height_bound().unwrap();
                let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
                let m = 8 * (n - 1);
                for p in 0..=m {
                    for q in 0..=m {
                        let f = g.eval(q as f64 / 8.0, p as f64 / 8.0).f;
                        if f.is_finite() {
                            assert!(lo <= f && f <= hi, "{interp:?}: {f} outside [{lo}, {hi}]");
                            a = a.min(f);
                            b = b.max(f);
                        }
                    }
                }
                if tight && interp == Interpolation::Bilinear {
                    assert!(
                        (hi - 1.0).abs() < 1e-9 && (lo + 1.0).abs() < 1e-9,
                        "{lo} {hi}"
                    );
                }
                if tight && interp == Interpolation::Bicubic {
                    // Inside, Keys' weights overshoot the samples' range by
                    // up to 1.25² (reached at cell centres); the border's
                    // extrapolated samples (3z₀ − 3z₁ + z₂) widen it further.
                    assert!(b > 1.5 && a < -1.5, "{interp:?}: sampled [{a}, {b}]");
                }
            }
        }
        let g = HeightGrid::new(
            vec![f64::NAN; 4],
            2,
            2,
            0.0,
            1.0,
            0.0,
            1.0,
            Interpolation::Bilinear,
        );
        assert_eq!(g.unwrap().height_bound(), None);
    }

    /// The local bound over random boxes holds for every finite value
    /// sampled densely inside them, and is at most the global bound.
    #[test]
    fn local_height_bounds_hold() {
        let (nx, ny) = (37, 29);
        let mut z = Vec::new();
        for i in 0..ny {
            for j in 0..nx {
                let x = (i * 31 + j * 17) % 23;
                z.push(if (i, j) == (10, 12) {
                    f64::NAN
                } else {
                    (x as f64 * 0.37).sin() * 5.0
                });
            }
        }
        let mut rnd = crate::test_rng::uniform(12345);
        for interp in [Interpolation::Bilinear, Interpolation::Bicubic] {
            // A north-up grid (negative dv) too.
            for (v0, dv) in [(0.0, 0.5), (14.0, -0.5)] {
                let g = HeightGrid::new(z.clone(), ny, nx, -3.0, 0.25, v0, dv, interp).unwrap();
                let d = g.domain();
                let (_, hi_all) = g.height_bound().unwrap();
                for _ in 0..200 {
                    let (a, b) = (d.u0 + (d.u1 - d.u0) * rnd(), d.u0 + (d.u1 - d.u0) * rnd());
                    let (c, e) = (d.v0 + (d.v1 - d.v0) * rnd(), d.v0 + (d.v1 - d.v0) * rnd());
                    let (u0, u1, w0, w1) = (a.min(b), a.max(b), c.min(e), c.max(e));
                    let m = g.height_max_in(u0, u1, w0, w1).unwrap();
                    assert!(m <= hi_all);
                    for p in 0..=20 {
                        for q in 0..=20 {
                            let u = u0 + (u1 - u0) * q as f64 / 20.0;
                            let v = w0 + (w1 - w0) * p as f64 / 20.0;
                            let f = g.eval(u, v).f;
                            assert!(
                                f.is_nan() || f <= m,
                                "{interp:?}: f({u}, {v}) = {f} above {m}"
                            );
                        }
                    }
                }
            }
        }
    }
}
