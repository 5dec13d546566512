//! The sampling geometry of Gordon 2001 §3, derived for the SPEC §1 camera.
//!
//! Horizontal coordinates relative to an origin O (the eye for perspective,
//! the target for orthographic): `s` along screen right r (r is horizontal),
//! `t` along e, the unit horizontal direction of d (sign chosen so that
//! d·e ≥ 0: increasing t runs front to back, §4.1), and w' = w − O_w. The
//! seed's r, s, t system is this one with its tilt α of the opposite sign.
//!
//! Camera coordinates of a point (s, t, w'): x = s, y = t·up_t + w'·up_w,
//! z = t·d_t + w'·d_w (the other components of up and d vanish).
//!
//! Pixel column j (x_pix its centre) is a plane of rays, §3.2/§3.3:
//! * orthographic: x = x_pix·p, a vertical plane: s = x_pix·p for every t, so
//!   the column's sampling line in (u, v) is fixed and every sample is one
//!   evaluation (eq. 3 with the SPEC camera);
//! * perspective: F·x = x_pix·z, a plane through the eye that is vertical only
//!   for α = 0 or the centre column: s = a·t + κ·w' with a = x_pix·d_t/F and
//!   κ = x_pix·d_w/F. The seed (eq. 9) takes w' = 0 here, which puts samples
//!   off the column by x_pix·w'·d_w/z pixels; we solve s = a·t + κ·f(s, t)
//!   instead (Newton on w', predicted from the previous sample, usually a
//!   single evaluation), so each sample lies in the column's plane. Where
//!   the plane is tangent to the surface (1 − κ f_s = 0) the section folds
//!   and is no graph over t; the floating horizon (which needs constant-t
//!   planes) keeps this sampler there, while the floating column sweeps
//!   perspective views in vertical planes instead (see `radial`).

use crate::camera::Camera;
use crate::surface::{Domain, HeightField, HeightSample};
use glam::{DVec2, DVec3};

/// View-dependent constants shared by all columns.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    pub origin: DVec3,
    pub rh: DVec2,
    pub eh: DVec2,
    pub d_t: f64,
    pub d_w: f64,
    pub up_t: f64,
    pub up_w: f64,
    pub persp: bool,
    pub pixel: f64,
    pub focal: f64,
    pub half_w: f64,
    pub half_h: f64,
    pub near: f64,
    pub domain: Domain,
    /// Is a span revealed upwards on the screen the upper side (§4.2)?
    pub upper_if_upward: bool,
}

impl Frame {
    pub fn new(cam: &Camera, domain: Domain) -> Frame {
        let rh = DVec2::new(cam.r.x, cam.r.y);
        let mut eh = DVec2::new(-rh.y, rh.x); // r × w rotated: (sin β, cos β)
        if eh.dot(DVec2::new(cam.d.x, cam.d.y)) < 0.0 {
            eh = -eh;
        }
        let d_t = eh.dot(DVec2::new(cam.d.x, cam.d.y)).max(0.0);
        let up_t = eh.dot(DVec2::new(cam.up.x, cam.up.y));
        let upper_if_upward = cam.up.z > 0.0 || (cam.up.z == 0.0 && cam.d.z < 0.0);
        Frame {
            origin: cam.eye,
            rh,
            eh,
            d_t,
            d_w: cam.d.z,
            up_t,
            up_w: cam.up.z,
            persp: cam.perspective,
            pixel: cam.pixel,
            focal: cam.focal,
            half_w: 0.5 * cam.width as f64,
            half_h: 0.5 * cam.height as f64,
            near: cam.near,
            domain,
            upper_if_upward,
        }
    }

    /// World (u, v) of horizontal coordinates (s, t).
    #[inline]
    pub fn uv(&self, s: f64, t: f64) -> DVec2 {
        DVec2::new(self.origin.x, self.origin.y) + s * self.rh + t * self.eh
    }

    /// Horizontal coordinates (s, t) of a world (u, v).
    #[inline]
    pub fn st(&self, u: f64, v: f64) -> (f64, f64) {
        let q = DVec2::new(u - self.origin.x, v - self.origin.y);
        (q.dot(self.rh), q.dot(self.eh))
    }

    /// x_pix of the centre of pixel column j.
    #[inline]
    pub fn xpix(&self, j: f64) -> f64 {
        j + 0.5 - self.half_w
    }

    /// The line of column x_pix (continuous).
    pub fn column(&self, xpix: f64) -> ColumnLine {
        if self.persp {
            ColumnLine {
                s0: 0.0,
                a: xpix * self.d_t / self.focal,
                kappa: xpix * self.d_w / self.focal,
            }
        } else {
            ColumnLine {
                s0: xpix * self.pixel,
                a: 0.0,
                kappa: 0.0,
            }
        }
    }

    /// Unit normal of column `col`'s plane of rays (orthographic: r;
    /// perspective: F·r − x_pix·d, §3.3's (A, B, C) in the SPEC frame).
    pub fn plane_normal(&self, cam: &Camera, col: f64) -> DVec3 {
        if self.persp {
            (self.focal * cam.r - self.xpix(col) * cam.d).normalize()
        } else {
            cam.r
        }
    }

    /// World size of a pixel at depth z (the lateral footprint).
    #[inline]
    pub fn footprint(&self, z: f64) -> f64 {
        if self.persp {
            z.abs().max(self.near) / self.focal
        } else {
            self.pixel
        }
    }

    /// Continuous row of camera (y, z); NaN behind the near bound.
    #[inline]
    pub fn row(&self, y: f64, z: f64) -> f64 {
        if self.persp {
            if z <= self.near {
                f64::NAN
            } else {
                self.half_h - 0.5 - self.focal * y / z
            }
        } else {
            self.half_h - 0.5 - y / self.pixel
        }
    }

    /// Unit direction from a surface point towards the viewer.
    #[inline]
    pub fn to_eye(&self, p: DVec3, d: DVec3) -> DVec3 {
        if self.persp {
            (self.origin - p).normalize()
        } else {
            -d
        }
    }

    /// The s-interval of the domain on the line t = const (empty: None).
    pub fn domain_s_range(&self, t: f64) -> Option<(f64, f64)> {
        // (u, v) = o + s·rh + t·eh must satisfy the four bounds.
        domain_range(&self.domain, self.uv(0.0, t), self.rh)
    }

    /// The t-interval where the line s = s0 crosses the domain.
    pub fn domain_t_range_at_s(&self, s: f64) -> Option<(f64, f64)> {
        domain_range(&self.domain, self.uv(s, 0.0), self.eh)
    }

    /// The t-range of the whole domain.
    pub fn domain_t_range(&self) -> (f64, f64) {
        let d = &self.domain;
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for (u, v) in [(d.u0, d.v0), (d.u1, d.v0), (d.u0, d.v1), (d.u1, d.v1)] {
            let (_, t) = self.st(u, v);
            lo = lo.min(t);
            hi = hi.max(t);
        }
        (lo, hi)
    }
}

/// The interval of x where base + x·dir lies in the domain (empty: None).
pub(super) fn domain_range(domain: &Domain, base: DVec2, dir: DVec2) -> Option<(f64, f64)> {
    let mut lo = f64::NEG_INFINITY;
    let mut hi = f64::INFINITY;
    for (b, dir, a0, a1) in [
        (base.x, dir.x, domain.u0, domain.u1),
        (base.y, dir.y, domain.v0, domain.v1),
    ] {
        if dir.abs() < 1e-300 {
            if b < a0 || b > a1 {
                return None;
            }
        } else {
            let (p, q) = ((a0 - b) / dir, (a1 - b) / dir);
            lo = lo.max(p.min(q));
            hi = hi.min(p.max(q));
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// A pixel column's plane: s = s0 + a·t + κ·w'.
#[derive(Debug, Clone, Copy)]
pub struct ColumnLine {
    pub s0: f64,
    pub a: f64,
    pub kappa: f64,
}

/// One surface sample on a column's curve.
#[derive(Debug, Clone, Copy, Default)]
pub struct Sample {
    pub t: f64,
    /// w − O_w.
    pub wr: f64,
    pub uv: DVec2,
    /// Unit upper-side normal.
    pub n: DVec3,
    /// Continuous row and camera depth.
    pub rho: f64,
    pub z: f64,
    /// d(row)/dt and dw'/dt along the column's curve.
    pub drho_dt: f64,
    pub dw_dt: f64,
    /// Stored shading intensity (Gouraud mode), also used by the §5 tests.
    pub inten: f64,
    /// L·N and L × N for the §5 problem tests.
    pub ldotn: f64,
    pub lxn: DVec3,
    /// 1 − κ f_s small or negative: the column's curve folds (perspective).
    pub fold: bool,
}

impl Sample {
    #[inline]
    pub fn world(&self, frame: &Frame) -> DVec3 {
        DVec3::new(self.uv.x, self.uv.y, self.wr + frame.origin.z)
    }
}

/// A point evaluated ahead: its derived quantities are computed only if the
/// sweep takes it ([`Sampler::finish`]).
#[derive(Debug, Clone, Copy)]
pub struct Raw {
    pub t: f64,
    pub s: f64,
    pub uv: DVec2,
    pub h: HeightSample,
}

/// Reusable buffers of a batched evaluation.
#[derive(Debug, Default)]
pub struct Scratch {
    pub u: Vec<f64>,
    pub v: Vec<f64>,
    pub hs: Vec<HeightSample>,
}

impl Scratch {
    pub fn clear(&mut self) {
        self.u.clear();
        self.v.clear();
        self.hs.clear();
    }
}

/// Evaluates samples on one column's curve, counting function evaluations.
pub struct Sampler<'a> {
    pub frame: &'a Frame,
    pub field: &'a dyn HeightField,
    pub line: ColumnLine,
    pub evals: u64,
    pub folds: u64,
    /// Lateral tolerance (pixels) of the perspective in-plane solve.
    pub lateral_tol: f64,
    pub d: DVec3,
    pub shading: &'a crate::shade::Shading,
    /// Compute the sample's intensity and its §5 products (Gouraud mode or
    /// problem detection); otherwise they are left at 0.
    pub shade: bool,
}

impl<'a> Sampler<'a> {
    #[inline]
    fn eval(&mut self, uv: DVec2) -> HeightSample {
        self.evals += 1;
        self.field.eval(uv.x, uv.y)
    }

    #[inline]
    fn inside(&self, uv: DVec2) -> bool {
        let d = &self.frame.domain;
        let eu = 1e-12 * (d.u1 - d.u0).abs().max(d.u0.abs().max(d.u1.abs()));
        let ev = 1e-12 * (d.v1 - d.v0).abs().max(d.v0.abs().max(d.v1.abs()));
        uv.x >= d.u0 - eu && uv.x <= d.u1 + eu && uv.y >= d.v0 - ev && uv.y <= d.v1 + ev
    }

    /// Samples at every t of `ts` with one batched evaluation, for columns
    /// whose plane is vertical (κ = 0: every sample is one evaluation, so
    /// the batch gives exactly what [`Self::sample`] gives point by point).
    /// Points outside the domain are `None` and not evaluated. (The sweeps
    /// evaluate their look-ahead points, [`Self::point`], batched over
    /// several columns, and give them their values with [`set_values`];
    /// the tests check the two against [`Self::sample`].)
    #[cfg(test)]
    pub(crate) fn sample_many(
        &mut self,
        ts: &[f64],
        out: &mut Vec<Option<Raw>>,
        scratch: &mut Scratch,
    ) {
        scratch.clear();
        out.clear();
        let b = self.bounds();
        for &t in ts {
            let r = self.point(t, &b);
            if let Some(x) = &r {
                scratch.u.push(x.uv.x);
                scratch.v.push(x.uv.y);
            }
            out.push(r);
        }
        scratch.hs.resize(scratch.u.len(), HeightSample::default());
        self.field
            .eval_batch(&scratch.u, &scratch.v, &mut scratch.hs);
        self.evals += scratch.u.len() as u64;
        set_values(out, &scratch.hs);
    }

    /// The domain with its rounding margin (as in `inside`): u0, u1, v0, v1.
    #[inline]
    pub(super) fn bounds(&self) -> [f64; 4] {
        let d = &self.frame.domain;
        let eu = 1e-12 * (d.u1 - d.u0).abs().max(d.u0.abs().max(d.u1.abs()));
        let ev = 1e-12 * (d.v1 - d.v0).abs().max(d.v0.abs().max(d.v1.abs()));
        [d.u0 - eu, d.u1 + eu, d.v0 - ev, d.v1 + ev]
    }

    /// The sample at t of a column whose plane is vertical (κ = 0), its
    /// values `h` still to be evaluated, if inside the domain `b`
    /// ([`Self::bounds`]).
    #[inline]
    fn point(&self, t: f64, b: &[f64; 4]) -> Option<Raw> {
        debug_assert!(self.line.kappa == 0.0);
        let s = self.line.s0 + self.line.a * t;
        let uv = self.frame.uv(s, t);
        (uv.x >= b[0] && uv.x <= b[1] && uv.y >= b[2] && uv.y <= b[3]).then_some(Raw {
            t,
            s,
            uv,
            h: HeightSample::default(),
        })
    }

    /// The surface point of the column's curve at t, starting the in-plane
    /// solve from the predicted height `w_pred` (relative to O). `None` where
    /// there is no surface (outside the domain, a hole, behind the eye).
    pub fn sample(&mut self, t: f64, w_pred: f64) -> Option<Sample> {
        let fr = *self.frame;
        let l = self.line;
        let mut wp = if w_pred.is_finite() { w_pred } else { 0.0 };
        let mut s = l.s0 + l.a * t + l.kappa * wp;
        let mut uv = fr.uv(s, t);
        if !self.inside(uv) {
            return None;
        }
        let mut h = self.eval(uv);
        if !h.is_finite() {
            return None;
        }
        let mut fold = false;
        if l.kappa != 0.0 {
            // Newton on G(w') = w' − (f(s(w'), t) − O_w), G' = 1 − κ f_s.
            for _ in 0..8 {
                let w = h.f - fr.origin.z;
                let fs = h.fu * fr.rh.x + h.fv * fr.rh.y;
                let g1 = 1.0 - l.kappa * fs;
                let wn = if g1 > 0.05 { wp - (wp - w) / g1 } else { w };
                fold |= g1 <= 0.05;
                // Lateral miss of the evaluated point, in pixels.
                let z = t * fr.d_t + w * fr.d_w;
                let miss = (l.kappa * (wn - wp)).abs() * fr.focal / z.abs().max(fr.near);
                if miss <= self.lateral_tol {
                    break;
                }
                wp = wn;
                s = l.s0 + l.a * t + l.kappa * wp;
                uv = fr.uv(s, t);
                if !self.inside(uv) {
                    return None;
                }
                h = self.eval(uv);
                if !h.is_finite() {
                    return None;
                }
            }
        }
        let mut smp = self.finish(t, s, uv, h, fold);
        if l.kappa != 0.0 && smp.z > fr.near {
            // Off the column's plane (the solve did not converge): the same
            // treatment as a fold.
            let x = fr.focal * s / smp.z;
            let xpix = if fr.d_t.abs() > 0.0 {
                l.a * fr.focal / fr.d_t
            } else {
                x
            };
            if fr.d_t.abs() > 0.0 && (x - xpix).abs() > 0.25 {
                smp.fold = true;
            }
        }
        if smp.fold {
            self.folds += 1;
        }
        Some(smp)
    }

    /// Fill in the derived quantities of a sample at (s, t) with values h.
    pub fn finish(&self, t: f64, s: f64, uv: DVec2, h: HeightSample, fold: bool) -> Sample {
        let _ = s;
        let mut smp = Sample::default();
        self.finish_into(t, uv, h, fold, &mut smp);
        smp
    }

    /// [`Self::finish`] written in place.
    #[inline(always)]
    pub fn finish_into(&self, t: f64, uv: DVec2, h: HeightSample, fold: bool, out: &mut Sample) {
        let fr = self.frame;
        let l = self.line;
        let wr = h.f - fr.origin.z;
        let y = t * fr.up_t + wr * fr.up_w;
        let z = t * fr.d_t + wr * fr.d_w;
        let rho = fr.row(y, z);
        // dw'/dt along the curve: f_s·ds/dt + f_t with ds/dt = a + κ dw'/dt.
        let fs = h.fu * fr.rh.x + h.fv * fr.rh.y;
        let ft = h.fu * fr.eh.x + h.fv * fr.eh.y;
        let g1 = 1.0 - l.kappa * fs;
        let dw_dt = if g1.abs() > 1e-9 {
            (fs * l.a + ft) / g1
        } else {
            f64::INFINITY
        };
        let dy = fr.up_t + fr.up_w * dw_dt;
        let drho_dt = if fr.persp {
            let dz = fr.d_t + fr.d_w * dw_dt;
            -fr.focal * (dy * z - y * dz) / (z * z)
        } else {
            -dy / fr.pixel
        };
        let n = h.normal();
        let (ldotn, inten, lxn) = if self.shade {
            let p = DVec3::new(uv.x, uv.y, h.f);
            let l_vec = fr.to_eye(p, self.d);
            (
                l_vec.dot(n),
                self.shading.intensity(n, l_vec),
                l_vec.cross(n),
            )
        } else {
            (0.0, 0.0, DVec3::ZERO)
        };
        *out = Sample {
            t,
            wr,
            uv,
            n,
            rho,
            z,
            drho_dt,
            dw_dt,
            inten,
            ldotn,
            lxn,
            fold,
        };
    }
}

/// Give the points `smps` inside the domain (in order) their values `hs`;
/// those whose values are not finite become `None`.
fn set_values(smps: &mut [Option<Raw>], hs: &[HeightSample]) {
    let mut hs = hs.iter();
    for r in smps.iter_mut() {
        if let Some(x) = r {
            match hs.next() {
                Some(h) if h.is_finite() => x.h = *h,
                _ => *r = None,
            }
        }
    }
}

/// Speculative look-ahead of a sweep: the next few samples along the sweep,
/// evaluated in one batch at a constant step (batched evaluation costs a
/// fraction of point-by-point evaluation). The sweep takes the farthest
/// buffered sample within the step it wants, and refills when none fits;
/// samples skipped or discarded were evaluated all the same and are counted.
#[derive(Debug)]
pub struct Ahead {
    taus: Vec<f64>,
    smps: Vec<Option<Raw>>,
    pos: usize,
    k: usize,
    /// Most samples evaluated ahead in one batch.
    max: usize,
    /// Sweep parameter → sampling parameter of each new batch.
    pub ts: Vec<f64>,
}

/// Most samples evaluated ahead in one batch, by default.
pub const AHEAD_MAX: usize = 8;

/// The same for a perspective bin's sweep ([`Ahead::with_max`]): its
/// samples up to 8 local pixels apart, fewer of a batch of 8 are taken
/// (bench view, 480 × 477: 12 % fewer samples evaluated at 4, the same
/// pixels against the exact hit and on the edge views; an orthographic
/// column's edge views lose pixels to shorter batches, whose samples lie
/// elsewhere).
pub const AHEAD_MAX_RADIAL: usize = 4;

impl Default for Ahead {
    fn default() -> Self {
        Ahead {
            taus: Vec::new(),
            smps: Vec::new(),
            pos: 0,
            k: 4,
            max: AHEAD_MAX,
            ts: Vec::new(),
        }
    }
}

impl Ahead {
    /// A look-ahead of batches up to `max` samples.
    pub fn with_max(max: usize) -> Self {
        let max = max.max(1);
        Ahead {
            max,
            k: Ahead::default().k.min(max),
            ..Ahead::default()
        }
    }

    /// Back to the state of a new sweep (keeping the buffers).
    pub fn reset(&mut self) {
        self.taus.clear();
        self.smps.clear();
        self.pos = 0;
        self.k = Ahead::default().k.min(self.max);
    }

    /// The farthest buffered sample with sweep parameter in (lo, hi].
    pub fn take(&mut self, lo: f64, hi: f64) -> Option<(f64, Option<Raw>)> {
        let mut best = None;
        let mut j = self.pos;
        while j < self.taus.len() && self.taus[j] <= hi {
            if self.taus[j] > lo {
                best = Some(j);
            }
            j += 1;
        }
        let j = best?;
        self.pos = j + 1;
        Some((self.taus[j], self.smps[j]))
    }

    /// Sweep parameters of a new batch: τ + m·h for m = 1, 2, … (at most the
    /// adaptive batch size), the last one snapped to `limit`. The batch
    /// grows while batches are used up and shrinks when one is abandoned.
    pub fn plan(&mut self, tau: f64, h: f64, limit: f64, snap: f64) -> &[f64] {
        if self.pos < self.taus.len() {
            self.k = (self.k / 2).max(1);
        } else if !self.taus.is_empty() {
            self.k = (2 * self.k).min(self.max);
        }
        self.taus.clear();
        self.pos = 0;
        // (m a u32: one instruction to convert to f64, a usize several)
        for m in 1..=self.k as u32 {
            let mut t = tau + f64::from(m) * h;
            if t >= limit - snap {
                t = limit;
            }
            self.taus.push(t);
            if t >= limit {
                break;
            }
        }
        &self.taus
    }

    /// [`Self::plan`] for a column whose plane is vertical (κ = 0, `tt`
    /// the sampling parameter of a sweep parameter): the batch's points
    /// inside the domain are appended to `u` and `v`, to be evaluated (with
    /// other columns' points) for [`Self::fill_points`]; `b` the sampler's
    /// [`Sampler::bounds`] (set up once per column). Returns how many.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    pub fn plan_points(
        &mut self,
        sampler: &Sampler<'_>,
        tau: f64,
        h: f64,
        limit: f64,
        snap: f64,
        tt: impl Fn(f64) -> f64,
        b: &[f64; 4],
        u: &mut Vec<f64>,
        v: &mut Vec<f64>,
    ) -> usize {
        self.plan(tau, h, limit, snap);
        let n0 = u.len();
        self.smps.clear();
        for &x in &self.taus {
            let r = sampler.point(tt(x), b);
            if let Some(p) = &r {
                u.push(p.uv.x);
                v.push(p.uv.y);
            }
            self.smps.push(r);
        }
        u.len() - n0
    }

    /// Give the points of the batch of [`Self::plan_points`] their values
    /// `hs` (counted as the sampler's evaluations) and take the first.
    pub fn fill_points(
        &mut self,
        sampler: &mut Sampler<'_>,
        hs: &[HeightSample],
    ) -> (f64, Option<Raw>) {
        sampler.evals += hs.len() as u64;
        set_values(&mut self.smps, hs);
        self.pos = 1;
        (self.taus[0], self.smps[0])
    }

    /// Store the samples of the planned batch and take the first.
    pub fn fill(&mut self, smps: &mut Vec<Option<Raw>>) -> (f64, Option<Raw>) {
        std::mem::swap(&mut self.smps, smps);
        self.pos = 1;
        (self.taus[0], self.smps[0])
    }
}
