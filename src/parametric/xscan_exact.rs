//! The exact X scan (Blinn 1978 §3.3).
//!
//! Between two consecutive edge trackers along a level curve y = y_scan,
//! x is monotonic (its extrema along the curve are the silhouette points,
//! where J = x_u y_v − x_v y_u = 0, and the curve ends on boundary edges).
//! Each such piece is scanned from its left end: for every pixel centre x_p
//! it covers, bivariate Newton on (y − y_scan, x − x_p) from the solution
//! of the previous pixel (seed predicted by the linearisation) gives the
//! exact (u, v), hence depth; the nearest depth over all pieces wins.
//!
//! Along the tangent t = (−y_v, y_u) of the level curve dx/ds = −J, so the
//! direction of increasing x is known at every tracker. Near the right end
//! of a piece (a silhouette, where J → 0 and Newton's basin shrinks) and
//! wherever a Newton step fails its checks (no convergence, the wrong sign
//! of J, an implausible jump), the scan falls back to predictor–corrector
//! continuation along the level curve in steps of about a pixel, which
//! brackets the pixel and refines it by Newton or bisection, or finds the
//! end of the piece (x turns back, or the curve leaves the patch).

use super::screen::{Screen, ScreenSample};
use super::trackers::{Kind, Tracker};
use glam::DVec3;

/// The visible point of one pixel so far.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    pub z: f64,
    pub u: f64,
    pub v: f64,
    pub jac: f64,
    /// World point.
    pub p: DVec3,
    /// Unit normal, or zero when it is P_u × P_v normalised (see `pn`).
    pub n: DVec3,
    /// P_u × P_v (exact scan).
    pub pn: DVec3,
}

#[derive(Debug, Clone, Default)]
pub struct XStats {
    /// Level-curve pieces scanned.
    pub pieces: u64,
    /// Pixels solved by Newton from the previous pixel.
    pub pixel_solves: u64,
    pub pixel_iters: u64,
    /// Pixels solved through the continuation fallback.
    pub fallback_solves: u64,
    pub continuation_steps: u64,
    /// Continuations that gave up (step budget, corrector failure).
    pub continuation_failures: u64,
    /// Folds without a silhouette tracker, walked through.
    pub fold_walks: u64,
    /// Pieces brought from off-screen left to the image border without a
    /// left-border tracker.
    pub border_walks: u64,
    /// Sampled X scan: samples placed, of which added for the error
    /// bound, and turn points of the normal angle (§4.3).
    pub samples: u64,
    pub refined: u64,
    pub turns: u64,
    /// Newton solves made to place and check samples.
    pub sample_solves: u64,
    /// Sampled X scan: normal-angle tracker updates from the previous scan
    /// line (from the previous position: plain; from the §3.5
    /// extrapolation) and the Newton corrections they made.
    pub theta_updates: u64,
    pub theta_iters: u64,
    pub theta_updates_ex: u64,
    pub theta_iters_ex: u64,
    /// Normal-angle trackers whose update failed (deleted, §3.2.3), deleted
    /// as unused or duplicate, and created (sideways iteration §4.2 or
    /// refinement).
    pub theta_lost: u64,
    pub theta_deleted: u64,
    pub theta_created: u64,
    /// Middle-pixel tests of spans, and spans taken from the previous
    /// scan line's links without a test.
    pub span_tests: u64,
    pub links_kept: u64,
    /// Carried samples found on another arc, and samples made by the
    /// sideways iteration.
    pub wrong_arc: u64,
    pub sideways: u64,
    /// Sampled X scan: first pixels of pieces solved from the second-order
    /// start at their fold (no continuation walk).
    pub fold_starts: u64,
}

impl XStats {
    pub fn add(&mut self, o: &XStats) {
        self.pieces += o.pieces;
        self.pixel_solves += o.pixel_solves;
        self.pixel_iters += o.pixel_iters;
        self.fallback_solves += o.fallback_solves;
        self.continuation_steps += o.continuation_steps;
        self.continuation_failures += o.continuation_failures;
        self.fold_walks += o.fold_walks;
        self.border_walks += o.border_walks;
        self.samples += o.samples;
        self.refined += o.refined;
        self.turns += o.turns;
        self.sample_solves += o.sample_solves;
        self.theta_updates += o.theta_updates;
        self.theta_iters += o.theta_iters;
        self.theta_updates_ex += o.theta_updates_ex;
        self.theta_iters_ex += o.theta_iters_ex;
        self.theta_lost += o.theta_lost;
        self.theta_deleted += o.theta_deleted;
        self.theta_created += o.theta_created;
        self.span_tests += o.span_tests;
        self.links_kept += o.links_kept;
        self.wrong_arc += o.wrong_arc;
        self.sideways += o.sideways;
        self.fold_starts += o.fold_starts;
    }
}

/// Why a piece or a continuation stopped.
#[derive(Debug, Clone)]
pub(crate) enum End {
    /// The level curve left the patch.
    Boundary,
    /// x turned back (a silhouette); the last point before the fold.
    Fold(Box<ScreenSample>),
    /// The right border of the image.
    Done,
    /// Numerical failure (counted).
    Failed,
}

pub struct XScan<'a> {
    pub sc: &'a Screen<'a>,
    pub width: usize,
    pub ext: f64,
    /// Sampled X scan (§4) parameters; `None` for the exact scan.
    pub sampled: Option<super::xscan_sampled::Params>,
    /// Saddle points of y (a scan line through one needs the branches of
    /// its level curve started there).
    pub saddles: Vec<ScreenSample>,
    /// Checked every few dozen pixels (slow surfaces: Python callables).
    pub cancel: Option<&'a crate::cancel::Cancel>,
    /// Sampled X scan: depth unit (the pixel size at the view distance) of
    /// the cross-section angle, and the normal-angle trackers of the band.
    pub zs: f64,
    pub pool: std::cell::RefCell<super::xscan_sampled::Pool>,
    /// Evaluate pixel solves to first order only (nothing downstream of
    /// them reads second derivatives, except the span starts of the
    /// sampled scan, which complete their sample).
    pub first_order: bool,
    /// Solve runs of pixels together, one evaluation batch per Newton round
    /// (surfaces whose single-point evaluation is dear: Python callables).
    pub batch: bool,
    /// The pixels [lo, hi) given a hit since the last
    /// [`take_touched`](Self::take_touched).
    touched: std::cell::Cell<(usize, usize)>,
}

/// The outcome of one step of a pixel solve.
enum PixelStep {
    /// Converged or stalled; whether the residual is within the tolerance.
    Done(bool),
    Fail,
    /// The next (u, v).
    Next(f64, f64),
}

impl<'a> XScan<'a> {
    pub fn new(sc: &'a Screen<'a>, width: usize) -> Self {
        let d = sc.dom;
        XScan {
            sc,
            width,
            ext: (d.u1 - d.u0).max(d.v1 - d.v0),
            sampled: None,
            saddles: Vec::new(),
            cancel: None,
            zs: 1.0,
            pool: Default::default(),
            batch: !sc.surf.cheap_point_eval(),
            first_order: false,
            touched: std::cell::Cell::new((usize::MAX, 0)),
        }
    }

    /// The range of pixels given a hit since the last call (empty if none).
    pub fn take_touched(&self) -> std::ops::Range<usize> {
        let (lo, hi) = self.touched.replace((usize::MAX, 0));
        lo.min(hi)..hi
    }

    #[inline]
    pub fn xpix(&self, j: usize) -> f64 {
        j as f64 + 0.5 - 0.5 * self.width as f64
    }

    /// First pixel whose centre is at or right of x.
    #[inline]
    pub(crate) fn first_pixel(&self, x: f64) -> usize {
        let j = (x - 0.5 + 0.5 * self.width as f64).ceil();
        if j <= 0.0 {
            0
        } else if j >= self.width as f64 {
            self.width
        } else {
            j as usize
        }
    }

    /// The evaluation of pixel solves (first order in the exact scan).
    #[inline]
    fn ev(&self, u: f64, v: f64) -> Option<ScreenSample> {
        if self.first_order {
            self.sc.eval_first(u, v)
        } else {
            self.sc.eval(u, v)
        }
    }

    /// Bivariate Newton on (y − ys, x − xp) from (u, v) (§3.3).
    pub fn newton(
        &self,
        u: f64,
        v: f64,
        ys: f64,
        xp: f64,
        iters: &mut u64,
    ) -> Option<ScreenSample> {
        self.newton_tol(u, v, ys, xp, 1e-9, iters)
    }

    /// [`newton`](Self::newton) stopping once |y − ys| and |x − xp| are
    /// below `tol` pixels.
    pub fn newton_tol(
        &self,
        u: f64,
        v: f64,
        ys: f64,
        xp: f64,
        tol: f64,
        iters: &mut u64,
    ) -> Option<ScreenSample> {
        let d = self.sc.dom;
        let (mut u, mut v) = (u.clamp(d.u0, d.u1), v.clamp(d.v0, d.v1));
        for _ in 0..12 {
            let s = self.ev(u, v)?;
            match self.pixel_step(&s, u, v, ys, xp, tol) {
                PixelStep::Done(ok) => return ok.then_some(s),
                PixelStep::Fail => return None,
                PixelStep::Next(nu, nv) => {
                    *iters += 1;
                    if (nu, nv) == (u, v) {
                        return None;
                    }
                    (u, v) = (nu, nv);
                }
            }
        }
        None
    }

    /// One step of the pixel solve at sample `s` of (u, v): bivariate
    /// Newton on (y − ys, x − xp) (§3.3), clamped to the domain.
    #[inline]
    fn pixel_step(
        &self,
        s: &ScreenSample,
        u: f64,
        v: f64,
        ys: f64,
        xp: f64,
        tol: f64,
    ) -> PixelStep {
        let d = self.sc.dom;
        let (f, g, det) = (s.y - ys, s.x - xp, s.jac());
        // [x_u x_v; y_u y_v] (du, dv) = −(g, f)
        let du = -(g * s.yv - s.xv * f) / det;
        let dv = -(s.xu * f - s.yu * g) / det;
        if !(du.is_finite() && dv.is_finite()) {
            return PixelStep::Fail;
        }
        if (f.abs() < tol && g.abs() < tol) || du.abs().max(dv.abs()) <= 1e-14 * self.ext {
            let ok = tol.max(1e-6);
            return PixelStep::Done(f.abs() < ok && g.abs() < ok);
        }
        if du.abs().max(dv.abs()) > 0.25 * self.ext {
            return PixelStep::Fail;
        }
        PixelStep::Next((u + du).clamp(d.u0, d.u1), (v + dv).clamp(d.v0, d.v1))
    }

    /// [`newton_tol`](Self::newton_tol) for many (u, v, x_p) of scan line
    /// ys at once: every round evaluates all unfinished points in one
    /// batch.
    pub fn newton_many(
        &self,
        starts: &[(f64, f64, f64)],
        ys: f64,
        tol: f64,
        iters: &mut u64,
    ) -> Vec<Option<ScreenSample>> {
        let d = self.sc.dom;
        let mut out = vec![None; starts.len()];
        let active = starts
            .iter()
            .enumerate()
            .map(|(i, &(u, v, _))| (u.clamp(d.u0, d.u1), v.clamp(d.v0, d.v1), i))
            .collect();
        self.sc
            .lockstep(active, 12, self.first_order, |_, s, u, v, i| {
                match self.pixel_step(s, u, v, ys, starts[i].2, tol) {
                    PixelStep::Done(ok) => {
                        if ok {
                            out[i] = Some(*s);
                        }
                        None
                    }
                    PixelStep::Fail => None,
                    PixelStep::Next(nu, nv) => {
                        *iters += 1;
                        ((nu, nv) != (u, v)).then_some((nu, nv, i))
                    }
                }
            });
        out
    }

    /// Project (u, v) onto the level curve y = ys along ∇y.
    fn project(&self, mut u: f64, mut v: f64, ys: f64) -> Option<ScreenSample> {
        let d = self.sc.dom;
        for _ in 0..10 {
            let s = self.ev(u, v)?;
            let f = s.y - ys;
            let g2 = s.yu * s.yu + s.yv * s.yv;
            if f.abs() < 1e-10 {
                return Some(s);
            }
            if g2.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            let (du, dv) = (-f * s.yu / g2, -f * s.yv / g2);
            if du.abs().max(dv.abs()) > 0.05 * self.ext {
                return None;
            }
            let (nu, nv) = ((u + du).clamp(d.u0, d.u1), (v + dv).clamp(d.v0, d.v1));
            if (nu, nv) == (u, v) {
                return (f.abs() < 1e-6).then_some(s);
            }
            u = nu;
            v = nv;
        }
        let s = self.ev(u, v)?;
        ((s.y - ys).abs() < 1e-6).then_some(s)
    }

    /// Solve pixel xp on the arc between a and b (a.x < xp ≤ b.x), both on
    /// the level curve of the same piece.
    fn bracket(
        &self,
        a: &ScreenSample,
        b: &ScreenSample,
        ys: f64,
        xp: f64,
        sigma: f64,
        st: &mut XStats,
    ) -> Option<ScreenSample> {
        let t = ((xp - a.x) / (b.x - a.x)).clamp(0.0, 1.0);
        let (su, sv) = (a.u + t * (b.u - a.u), a.v + t * (b.v - a.v));
        let span = (b.u - a.u).abs().max((b.v - a.v).abs());
        if let Some(s) = self.newton(su, sv, ys, xp, &mut st.pixel_iters) {
            let near = (s.u - su).abs().max((s.v - sv).abs()) <= span + 1e-12 * self.ext;
            if near && s.jac() * sigma >= 0.0 {
                return Some(s);
            }
        }
        // Bisection along the arc (x is monotonic on it).
        let (mut lo, mut hi) = (*a, *b);
        for _ in 0..60 {
            let m = self.project(0.5 * (lo.u + hi.u), 0.5 * (lo.v + hi.v), ys)?;
            if m.x < xp {
                lo = m;
            } else {
                hi = m;
            }
            if hi.x - lo.x < 1e-9 {
                break;
            }
        }
        Some(if xp - lo.x < hi.x - xp { lo } else { hi })
    }

    /// One predictor–corrector step along the level curve from q in the
    /// direction s·(−y_v, y_u), about a pixel long (shorter where the
    /// tangent turns by more than ~25°: the corrector's check).
    fn advance(
        &self,
        q: &ScreenSample,
        s: f64,
        ys: f64,
        st: &mut XStats,
    ) -> Result<ScreenSample, End> {
        let d = self.sc.dom;
        let cam = self.sc.cam;
        st.continuation_steps += 1;
        let (tu, tv) = (-s * q.yv, s * q.yu);
        let l = tu.hypot(tv);
        if l.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            st.continuation_failures += 1;
            return Err(End::Failed);
        }
        let (tu, tv) = (tu / l, tv / l);
        let speed = (q.p.pu * tu + q.p.pv * tv).length() / cam.pixel_size_at(q.z);
        let mut h = if speed > 0.0 {
            1.0 / speed
        } else {
            f64::INFINITY
        };
        h = h.min(0.02 * self.ext);
        // Clip to the patch: the piece ends where the curve leaves it.
        let mut hb = f64::INFINITY;
        if tu > 0.0 {
            hb = hb.min((d.u1 - q.u) / tu);
        } else if tu < 0.0 {
            hb = hb.min((d.u0 - q.u) / tu);
        }
        if tv > 0.0 {
            hb = hb.min((d.v1 - q.v) / tv);
        } else if tv < 0.0 {
            hb = hb.min((d.v0 - q.v) / tv);
        }
        if hb <= 1e-13 * self.ext {
            return Err(End::Boundary);
        }
        let at_boundary = h >= hb;
        h = h.min(hb);
        for _ in 0..24 {
            if let Some(n) = self.project(q.u + h * tu, q.v + h * tv, ys) {
                let moved = (n.u - q.u).hypot(n.v - q.v);
                // The tangent may turn by at most ~25° per step, so that the
                // walk cannot hop to another branch near a saddle.
                let (nu, nv) = (-s * n.yv, s * n.yu);
                let nl = nu.hypot(nv);
                let turn_ok = nl > 0.0 && (nu * tu + nv * tv) >= 0.9 * nl;
                if moved <= 2.0 * h && moved > 0.0 && turn_ok {
                    return Ok(n);
                }
            }
            h *= 0.5;
        }
        if at_boundary {
            return Err(End::Boundary);
        }
        st.continuation_failures += 1;
        Err(End::Failed)
    }

    /// Walk along the level curve from q in the direction s·(−y_v, y_u)
    /// (x increasing, J of sign sigma) until x reaches xp.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn continuation(
        &self,
        q0: &ScreenSample,
        s: f64,
        sigma: f64,
        ys: f64,
        xp: f64,
        st: &mut XStats,
    ) -> Result<ScreenSample, End> {
        let mut q = *q0;
        for _ in 0..20_000 {
            let n = self.advance(&q, s, ys, st)?;
            if n.jac() * sigma <= 0.0 || n.x < q.x {
                // x turned back: a silhouette ends the piece (the pixel, if
                // right of q, lies beyond the fold within this step).
                if n.x >= xp && q.x < xp {
                    if let Some(b) = self.bracket(&q, &n, ys, xp, sigma, st) {
                        return Ok(b);
                    }
                }
                return Err(End::Fold(Box::new(q)));
            }
            if n.x >= xp {
                st.fallback_solves += 1;
                return self.bracket(&q, &n, ys, xp, sigma, st).ok_or(End::Failed);
            }
            q = n;
        }
        st.continuation_failures += 1;
        Err(End::Failed)
    }

    /// From a fold where x turned back, walk on along the level curve over
    /// the piece where x decreases to the next fold, where x increases
    /// again; `None` if the curve leaves the patch first.
    fn walk_decreasing(
        &self,
        q0: &ScreenSample,
        s: f64,
        ys: f64,
        st: &mut XStats,
    ) -> Option<ScreenSample> {
        let sigma = -s;
        let mut q = *q0;
        let mut seen_back = false;
        for _ in 0..20_000 {
            let n = self.advance(&q, s, ys, st).ok()?;
            let back = n.jac() * sigma <= 0.0 || n.x < q.x;
            if back {
                seen_back = true;
            } else if seen_back {
                return Some(n);
            }
            q = n;
        }
        st.continuation_failures += 1;
        None
    }

    /// Newton for pixel xp from the previous solution `cur` of the same
    /// piece, with the checks that keep it on that piece.
    pub(crate) fn try_newton(
        &self,
        cur: &ScreenSample,
        sigma: f64,
        ys: f64,
        xp: f64,
        st: &mut XStats,
    ) -> Option<ScreenSample> {
        self.try_newton_tol(cur, sigma, ys, xp, 1e-9, st)
    }

    /// The linear prediction (du, dv) of the step from `cur` to pixel xp
    /// of scan line ys; `None` where J has the wrong sign or nearly
    /// vanishes (the end of the piece is near).
    fn predict(&self, cur: &ScreenSample, sigma: f64, ys: f64, xp: f64) -> Option<(f64, f64)> {
        let jc = cur.jac();
        let jscale = (cur.xu * cur.yv).abs() + (cur.xv * cur.yu).abs();
        if jc * sigma <= 1e-3 * jscale {
            return None;
        }
        let (g, f) = (xp - cur.x, ys - cur.y);
        Some((
            (g * cur.yv - cur.xv * f) / jc,
            (cur.xu * f - cur.yu * g) / jc,
        ))
    }

    /// The checks of [`try_newton`](Self::try_newton) that keep a solution
    /// q for pixel xp on the piece of its predecessor `cur`.
    fn on_piece(&self, cur: &ScreenSample, q: &ScreenSample, sigma: f64, ys: f64, xp: f64) -> bool {
        let Some((pu, pv)) = self.predict(cur, sigma, ys, xp) else {
            return false;
        };
        let jump = (q.u - cur.u).abs().max((q.v - cur.v).abs());
        let pred = pu.abs().max(pv.abs());
        q.jac() * sigma > 0.0 && jump <= 3.0 * pred + 1e-12 * self.ext
    }

    /// Pixels j, j+1, … (at most `k`) of a piece solved together from
    /// `cur`: starts predicted linearly from `cur`, Newton for all of them
    /// in lockstep ([`newton_many`](Self::newton_many)), then accepted in
    /// order while each passes the checks of
    /// [`try_newton`](Self::try_newton) against its predecessor. Returns
    /// the accepted solutions.
    fn run_of_pixels(
        &self,
        cur: &ScreenSample,
        j: usize,
        k: usize,
        sigma: f64,
        ys: f64,
        st: &mut XStats,
    ) -> Vec<ScreenSample> {
        let mut starts = Vec::with_capacity(k);
        for i in 0..k {
            let xp = self.xpix(j + i);
            let Some((pu, pv)) = self.predict(cur, sigma, ys, xp) else {
                return Vec::new();
            };
            starts.push((cur.u + pu, cur.v + pv, xp));
        }
        let sols = self.newton_many(&starts, ys, 1e-9, &mut st.pixel_iters);
        let mut out: Vec<ScreenSample> = Vec::with_capacity(k);
        let mut prev = *cur;
        for (i, q) in sols.into_iter().enumerate() {
            let Some(q) = q else { break };
            if !self.on_piece(&prev, &q, sigma, ys, self.xpix(j + i)) {
                break;
            }
            out.push(q);
            prev = q;
        }
        out
    }

    /// [`try_newton`](Self::try_newton) to a tolerance of `tol` pixels.
    pub(crate) fn try_newton_tol(
        &self,
        cur: &ScreenSample,
        sigma: f64,
        ys: f64,
        xp: f64,
        tol: f64,
        st: &mut XStats,
    ) -> Option<ScreenSample> {
        // Linear prediction from the previous solution.
        let (pu, pv) = self.predict(cur, sigma, ys, xp)?;
        let q = self.newton_tol(cur.u + pu, cur.v + pv, ys, xp, tol, &mut st.pixel_iters)?;
        let jump = (q.u - cur.u).abs().max((q.v - cur.v).abs());
        let pred = pu.abs().max(pv.abs());
        (q.jac() * sigma > 0.0 && jump <= 3.0 * pred + 1e-12 * self.ext).then_some(q)
    }

    /// Record a candidate for pixel j (nearest depth wins).
    #[inline]
    pub(crate) fn record(&self, hits: &mut [Option<Hit>], j: usize, h: Hit) {
        let better = match &hits[j] {
            Some(o) => h.z < o.z,
            None => true,
        };
        if better {
            hits[j] = Some(h);
            let (lo, hi) = self.touched.get();
            self.touched.set((lo.min(j), hi.max(j + 1)));
        }
    }

    /// Scan pixels j, j+1, … of a piece exactly from `cur`.
    pub(crate) fn exact_from(
        &self,
        mut cur: ScreenSample,
        mut j: usize,
        s: f64,
        ys: f64,
        hits: &mut [Option<Hit>],
        st: &mut XStats,
    ) -> End {
        let sigma = -s;
        let mut run = 4usize;
        let mut polled = j;
        while j < self.width {
            if (j % 32 == 0 || j >= polled + 32) && self.cancel.is_some_and(|c| c.is_cancelled()) {
                return End::Failed;
            }
            polled = j;
            if self.batch && self.width - j >= 2 {
                let k = run.min(self.width - j);
                let got = self.run_of_pixels(&cur, j, k, sigma, ys, st);
                let n = got.len();
                for q in got {
                    self.record(hits, j, Self::exact_hit(&q));
                    st.pixel_solves += 1;
                    cur = q;
                    j += 1;
                }
                run = if n == k {
                    (2 * run).min(32)
                } else {
                    (run / 2).max(2)
                };
                if n == k {
                    continue;
                }
                if j >= self.width {
                    break;
                }
            }
            let xp = self.xpix(j);
            let q = match self.try_newton(&cur, sigma, ys, xp, st) {
                Some(q) => {
                    st.pixel_solves += 1;
                    q
                }
                None => match self.continuation(&cur, s, sigma, ys, xp, st) {
                    Ok(q) => q,
                    Err(e) => return e,
                },
            };
            self.record(hits, j, Self::exact_hit(&q));
            cur = q;
            j += 1;
        }
        End::Done
    }

    /// The hit of an exactly solved pixel.
    fn exact_hit(q: &ScreenSample) -> Hit {
        Hit {
            z: q.z,
            u: q.u,
            v: q.v,
            jac: q.jac(),
            p: q.p.p,
            n: DVec3::ZERO,
            pn: q.p.pu.cross(q.p.pv),
        }
    }

    /// Scan one piece from `start` in direction s (x increasing).
    fn piece(
        &self,
        start: &ScreenSample,
        s: f64,
        ys: f64,
        hits: &mut [Option<Hit>],
        st: &mut XStats,
    ) -> End {
        let j = self.first_pixel(start.x);
        if j >= self.width {
            return End::Done;
        }
        st.pieces += 1;
        match self.sampled {
            None => self.exact_from(*start, j, s, ys, hits, st),
            Some(p) => self.sampled_from(*start, j, s, ys, p, hits, st),
        }
    }

    /// Scan a piece and, where it ends at a fold that no silhouette tracker
    /// accounts for (Newton for the tracker can fail near a saddle of y),
    /// walk on over the next x-decreasing piece and scan the one after it.
    #[allow(clippy::too_many_arguments)]
    fn piece_chain(
        &self,
        start: &ScreenSample,
        s: f64,
        ys: f64,
        trackers: &[Tracker],
        hits: &mut [Option<Hit>],
        st: &mut XStats,
    ) {
        let known = |f: &ScreenSample| {
            trackers.iter().any(|t| {
                t.kind == Kind::Sil
                    && (t.s.x - f.x).abs() < 1.0
                    && (t.s.u - f.u).abs().max((t.s.v - f.v).abs()) < 0.02 * self.ext
            })
        };
        let mut end = self.piece(start, s, ys, hits, st);
        for _ in 0..16 {
            let End::Fold(f) = end else { return };
            if known(&f) {
                return;
            }
            st.fold_walks += 1;
            let Some(g) = self.walk_decreasing(&f, s, ys, st) else {
                return;
            };
            if known(&g) {
                return;
            }
            end = self.piece(&g, s, ys, hits, st);
        }
    }

    /// Start the branches of a level curve that crosses itself at a
    /// stationary point q of y.
    fn saddle_starts(
        &self,
        q: &ScreenSample,
        ys: f64,
        trackers: &[Tracker],
        hits: &mut [Option<Hit>],
        st: &mut XStats,
    ) -> bool {
        let d = self.sc.dom;
        let (a, b, c) = (q.yuu, q.yuv, q.yvv);
        let disc = b * b - a * c;
        if disc.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return false; // near an extremum: the ordinary start applies
        }
        // Directions (du, dv) with a du² + 2b du dv + c dv² = 0.
        let dirs: [(f64, f64); 2] = if a.abs() >= c.abs() {
            [((-b + disc.sqrt()) / a, 1.0), ((-b - disc.sqrt()) / a, 1.0)]
        } else {
            [(1.0, (-b + disc.sqrt()) / c), (1.0, (-b - disc.sqrt()) / c)]
        };
        let cam = self.sc.cam;
        for (du, dv) in dirs {
            let l = du.hypot(dv);
            let (du, dv) = (du / l, dv / l);
            let speed = (q.p.pu * du + q.p.pv * dv).length() / cam.pixel_size_at(q.z);
            let h = if speed > 0.0 {
                (0.05 / speed).min(0.01 * self.ext)
            } else {
                1e-3 * self.ext
            };
            for sg in [1.0, -1.0] {
                let (u, v) = (q.u + sg * h * du, q.v + sg * h * dv);
                if !d.contains(u, v) {
                    continue;
                }
                let Some(p) = self.project(u, v, ys) else {
                    continue;
                };
                let j = p.jac();
                if j == 0.0 {
                    continue;
                }
                // Continue away from the saddle only if x increases that way.
                let s = -j.signum();
                let (tu, tv) = (-s * p.yv, s * p.yu);
                if tu * (p.u - q.u) + tv * (p.v - q.v) > 0.0 {
                    self.piece_chain(&p, s, ys, trackers, hits, st);
                }
            }
        }
        true
    }

    /// From a point of a piece left of the image, follow the piece to the
    /// left border x = −W/2 by Newton on (y − ys, x − x_target) with x_target
    /// stepping towards the border, the step doubled after each success and
    /// halved after each failure. `None` if the piece ends first.
    fn reach_left(
        &self,
        start: &ScreenSample,
        s: f64,
        ys: f64,
        st: &mut XStats,
    ) -> Option<ScreenSample> {
        let sigma = -s;
        let xl = -0.5 * self.width as f64;
        let mut cur = *start;
        let mut dx = 1.0_f64;
        for _ in 0..400 {
            let target = (cur.x + dx).min(xl);
            match self.try_newton(&cur, sigma, ys, target, st) {
                Some(q) => {
                    cur = q;
                    if cur.x >= xl - 1e-9 {
                        return Some(cur);
                    }
                    dx *= 2.0;
                }
                None => {
                    dx *= 0.5;
                    if dx < 1e-6 {
                        return None;
                    }
                }
            }
        }
        None
    }

    /// Scan one row from the trackers of its level curves.
    pub fn row(&self, trackers: &[Tracker], ys: f64, hits: &mut [Option<Hit>], st: &mut XStats) {
        // A scan line through (or within a hair of) a saddle of y: the
        // level curve crosses itself there and the trackers, whose Newton
        // is singular at the saddle, may not see the branches.
        for q in &self.saddles {
            if (q.y - ys).abs() <= 1e-3 {
                self.saddle_starts(q, ys, trackers, hits, st);
            }
        }
        let d = self.sc.dom;
        let xmax = self.xpix(self.width - 1);
        let xmin = -0.5 * self.width as f64;
        for t in trackers {
            let q = &t.s;
            if q.x > xmax {
                continue;
            }
            // Pieces starting left of the image are scanned from their
            // left-border tracker, or brought to the border below.
            let offscreen = t.kind != Kind::Left && q.x < xmin;
            let (tu, tv) = (-q.yv, q.yu);
            let jac = q.jac();
            // A stationary point of y on the scan line (a saddle passed
            // exactly, §3.2.2.4): the level curve crosses itself there and
            // its branches leave along the asymptotic directions of the
            // Hessian.
            let gscale = (q.xu.abs() + q.xv.abs()).max(1e-300);
            if tu.hypot(tv) <= 1e-4 * gscale && self.saddle_starts(q, ys, trackers, hits, st) {
                continue;
            }
            let mut dirs: [Option<f64>; 2] = [None, None];
            match t.kind {
                Kind::Edge(e) => {
                    let inward = match e {
                        0 => tu,
                        1 => -tu,
                        2 => tv,
                        _ => -tv,
                    };
                    let scale = tu.abs().max(tv.abs());
                    if inward.abs() <= 1e-12 * scale {
                        // Level curve tangent to the edge: try both ways.
                        dirs = [Some(1.0), Some(-1.0)];
                    } else {
                        let s = inward.signum();
                        // x increases along s·t iff s·(−J) > 0; at J ≈ 0 (a
                        // silhouette meeting the edge) try: the scan stops at
                        // once if x decreases.
                        let jscale = (q.xu * q.yv).abs() + (q.xv * q.yu).abs();
                        if s * -jac >= 0.0 || jac.abs() <= 1e-6 * jscale {
                            dirs[0] = Some(s);
                        }
                    }
                }
                Kind::Sil => dirs = [Some(1.0), Some(-1.0)],
                Kind::Left => {
                    if jac != 0.0 {
                        dirs[0] = Some(-jac.signum());
                    }
                }
            }
            let _ = d;
            for s in dirs.into_iter().flatten() {
                if offscreen {
                    // Newton with growing steps towards the left border
                    // (cheap however far off-screen the start lies); skipped
                    // when a left-border tracker already starts this piece.
                    let Some(b) = self.reach_left(q, s, ys, st) else {
                        continue;
                    };
                    let tol = 1e-6 * self.ext;
                    let known = trackers.iter().any(|t| {
                        t.kind == Kind::Left
                            && (t.s.u - b.u).abs() <= tol
                            && (t.s.v - b.v).abs() <= tol
                    });
                    if !known {
                        st.border_walks += 1;
                        self.piece_chain(&b, s, ys, trackers, hits, st);
                    }
                } else {
                    self.piece_chain(q, s, ys, trackers, hits, st);
                }
            }
        }
    }
}
