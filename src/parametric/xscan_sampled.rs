//! The sampled X scan (Blinn 1978 §4).
//!
//! The cross-section of the surface with the scan plane is drawn as a chain
//! of straight spans in the (x, depth) plane between sample points placed
//! at equal steps of the angle ϑ of the cross-section curve (§4.1). With
//! J = x_u y_v − x_v y_u and K = z_u y_v − z_v y_u, the tangent of the level
//! curve y = y_scan, t = (−y_v, y_u), moves the screen point by
//! (dx, dζ) = −(J, K/ζ₀) (ζ = depth/ζ₀ in pixels, ζ₀ the pixel size at the
//! view distance), so the sample of angle ϑ is a zero of
//!
//!   G_ϑ(u, v) = −J sin ϑ + (K/ζ₀) cos ϑ          (§4.1, Xn sin ϑ − Zn cos ϑ)
//!
//! on the level curve; ϑ = 90° is the silhouette J = 0. Samples are edge
//! trackers like the silhouette trackers of the Y scan: each is carried
//! from scan line to scan line by bivariate Newton on (y − y_scan, G_ϑ) from
//! its position extrapolated from the two previous scan lines (§3.2.1,
//! §3.5), and deleted when Newton fails or the scan no longer uses it.
//!
//! The X scan walks each x-increasing piece of the level curve from its
//! start (§3.3) and links the samples in the order met (§4.2): from a
//! sample a, the next one is the carried tracker ahead in x whose ϑ lies
//! within one table step of a's in the direction ϑ turns (the sign of the
//! turn function T, §4.3), checked to lie on the same arc by a Newton solve
//! at the span's middle pixel. A missing sample (a new curve below a
//! maximum, a chain broken at a saddle, the first line of a band) is made
//! by the §4.2 sideways iteration: a step along the level curve predicted
//! from dϑ/dx, then Newton on (y − y_scan, G_ϑ). Where ϑ turns back inside a
//! span, a turn point T = 0 (§4.3) becomes a sample (tracked by Newton on
//! (y − y_scan, T), ∇T by differences).
//!
//! Beyond the seed's fixed table (16 per turn): where the normal
//! interpolated (Phong) at the middle of a span is off by more than
//! `max_error`, or its depth by more than a pixel, a sample at the middle
//! table angle one level finer is added and carried like the others, up to
//! `LEVELS` halvings; spans of at most three pixels are then solved
//! exactly. Depth is interpolated by a cubic Hermite in x (slopes
//! dz/dx = K/J) where that beats the chord at the middle.

use super::screen::ScreenSample;
use super::xscan_exact::{End, Hit, XScan, XStats};
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// Finest refinement: the table step is halved at most this many times.
pub const LEVELS: u32 = 6;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// ϑ step in radians (2π / samples per turn).
    pub step: f64,
    /// Largest normal error accepted at a span's midpoint, radians.
    pub max_error: f64,
}

/// What defines a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SKind {
    /// G_ϑ = 0 with ϑ = k · step / 2^LEVELS.
    Theta(i64),
    /// Turn point T = 0 (§4.3).
    Turn,
    /// A silhouette tracker of the Y scan (the piece ends at a fold).
    Sil,
    /// A boundary-edge tracker of the Y scan (the piece leaves the patch).
    Edge,
    /// A pixel solved exactly (not carried).
    Pixel,
}

#[derive(Debug, Clone, Copy)]
pub struct Sample {
    pub kind: SKind,
    pub s: ScreenSample,
    /// Position on the previous scan line (§3.5 extrapolation).
    pub prev: Option<(f64, f64)>,
    /// ϑ of the cross-section at s, in (−π/2, π/2].
    pub phi: f64,
    /// Identity of a carried sample (0: none), the sample it was linked
    /// to on the previous scan line (§4.2), scan lines since that link was
    /// last tested, and whether its span takes the Hermite depth.
    pub id: u64,
    pub link: u64,
    pub age: u8,
    pub herm: bool,
}

impl Sample {
    fn new(kind: SKind, s: ScreenSample, phi: f64) -> Sample {
        Sample {
            kind,
            s,
            prev: None,
            phi,
            id: 0,
            link: 0,
            age: 0,
            herm: false,
        }
    }
}

/// Where a sample of the current scan line is stored.
#[derive(Debug, Clone, Copy)]
enum Loc {
    Cur(usize),
    Born(usize),
}

/// Candidate samples of a span (pool indices, at most six).
struct Cands {
    idx: [usize; 6],
    len: usize,
}

impl Cands {
    fn as_slice(&self) -> &[usize] {
        &self.idx[..self.len]
    }
    fn as_mut_slice(&mut self) -> &mut [usize] {
        &mut self.idx[..self.len]
    }
}

/// Scan lines a link is trusted without a new middle-pixel test.
const LINK_AGE: u8 = 4;

/// The samples of one band: those carried to the current scan line
/// (sorted by x) and those made on it.
#[derive(Debug, Default)]
pub struct Pool {
    pub cur: Vec<Sample>,
    pub used: Vec<bool>,
    pub born: Vec<Sample>,
    pub keep: Vec<Sample>,
    pub next_id: u64,
}

/// Angle difference wrapped to (−π/2, π/2] (ϑ is a line direction).
#[inline]
fn wrap(x: f64) -> f64 {
    // round(x/π) without the library call for the usual |x| < 1.5π (the
    // same value: halves round away from zero).
    let r = x / PI;
    let k = if r.abs() >= 1.5 {
        r.round()
    } else if r >= 0.5 {
        1.0
    } else if r <= -0.5 {
        -1.0
    } else {
        0.0
    };
    let w = x - PI * k;
    if w <= -FRAC_PI_2 {
        w + PI
    } else {
        w
    }
}

/// Unit normal P_u × P_v.
fn normal(s: &ScreenSample) -> DVec3 {
    s.p.pu.cross(s.p.pv).normalize_or_zero()
}

/// J, K and their gradients at s; d is the view direction (depth axis).
struct Jk {
    j: f64,
    k: f64,
    ju: f64,
    jv: f64,
    ku: f64,
    kv: f64,
}

fn jk(s: &ScreenSample, d: DVec3) -> Jk {
    let (ju, jv) = s.jac_grad();
    let (zuu, zuv, zvv) = (s.p.puu.dot(d), s.p.puv.dot(d), s.p.pvv.dot(d));
    let k = s.zu * s.yv - s.zv * s.yu;
    let ku = zuu * s.yv + s.zu * s.yuv - zuv * s.yu - s.zv * s.yuu;
    let kv = zuv * s.yv + s.zu * s.yvv - zvv * s.yu - s.zv * s.yuv;
    Jk {
        j: s.jac(),
        k,
        ju,
        jv,
        ku,
        kv,
    }
}

/// Outcome of one Newton step of a tracker.
enum Step {
    Done,
    Fail,
    Next(f64, f64),
}

/// Outcome of the middle-pixel test of a span.
enum Test {
    /// Interpolate (Hermite depth or not); whether the errors were within
    /// half the bounds (the link may then be kept untested for a while).
    Accept(bool, bool),
    /// b is not on a's arc (or the solve failed).
    WrongArc,
    /// ϑ turns back inside the span; the middle solution.
    Turn(ScreenSample),
    /// Too coarse for the error bound; the middle solution.
    Coarse(ScreenSample),
}

impl<'a> XScan<'a> {
    fn d(&self) -> DVec3 {
        self.sc.cam.d
    }

    /// ϑ of the cross-section at s, in (−π/2, π/2].
    pub(crate) fn phi(&self, s: &ScreenSample) -> f64 {
        let k = s.zu * s.yv - s.zv * s.yu;
        wrap((k / self.zs).atan2(s.jac()))
    }

    /// T = J K' − K J' (derivatives along t = (−y_v, y_u)), §4.3.
    fn turn_fn(&self, s: &ScreenSample) -> f64 {
        let q = jk(s, self.d());
        let kp = -s.yv * q.ku + s.yu * q.kv;
        let jp = -s.yv * q.ju + s.yu * q.jv;
        q.j * kp - q.k * jp
    }

    /// dϑ/dx along the level curve at s.
    fn dphi_dx(&self, s: &ScreenSample) -> f64 {
        let q = jk(s, self.d());
        let zs = self.zs;
        let t = self.turn_fn(s);
        let r2 = zs * (q.j * q.j + (q.k / zs) * (q.k / zs));
        if r2 == 0.0 || q.j == 0.0 {
            return 0.0;
        }
        -(t / r2) / q.j
    }

    /// One Newton step on (y − ys, G) for a sample of `kind` evaluated at
    /// s (and, for a turn point, at s shifted by h in u and in v).
    fn track_step(
        &self,
        kind: SKind,
        s: &ScreenSample,
        shifted: Option<(&ScreenSample, &ScreenSample)>,
        ys: f64,
    ) -> Step {
        let d = self.sc.dom;
        let f = s.y - ys;
        let (g, gu, gv) = match kind {
            SKind::Theta(k) => {
                let (sn, cs) = (k as f64 * self.fine_step()).sin_cos();
                let q = jk(s, self.d());
                let zs = self.zs;
                (
                    -q.j * sn + q.k / zs * cs,
                    -q.ju * sn + q.ku / zs * cs,
                    -q.jv * sn + q.kv / zs * cs,
                )
            }
            SKind::Turn => {
                let Some((su, sv)) = shifted else {
                    return Step::Fail;
                };
                let h = self.turn_h();
                let t = self.turn_fn(s);
                (t, (self.turn_fn(su) - t) / h, (self.turn_fn(sv) - t) / h)
            }
            _ => return Step::Fail,
        };
        let det = s.yu * gv - s.yv * gu;
        let du = -(f * gv - s.yv * g) / det;
        let dv = -(s.yu * g - f * gu) / det;
        if !(du.is_finite() && dv.is_finite()) {
            return Step::Fail;
        }
        let step_px = (s.xu * du + s.xv * dv)
            .abs()
            .max((s.yu * du + s.yv * dv).abs());
        if f.abs() <= 1e-6 && step_px <= 1e-4 {
            return Step::Done;
        }
        if du.abs().max(dv.abs()) > 0.1 * self.ext {
            return Step::Fail;
        }
        let (u, v) = (s.u + du, s.v + dv);
        if !d.contains(u, v) {
            return Step::Fail;
        }
        Step::Next(u, v)
    }

    /// Difference step of ∇T.
    fn turn_h(&self) -> f64 {
        1e-7 * self.ext
    }

    /// Newton on (y − ys, G) for a sample of `kind` from (u, v): the
    /// solution and the number of corrections.
    pub(crate) fn track(
        &self,
        kind: SKind,
        u: f64,
        v: f64,
        ys: f64,
    ) -> Option<(ScreenSample, u32)> {
        if !self.sc.dom.contains(u, v) {
            return None;
        }
        let (mut u, mut v) = (u, v);
        let h = self.turn_h();
        for iters in 0..16u32 {
            let s = self.sc.eval(u, v)?;
            let sh = if kind == SKind::Turn {
                Some((self.sc.eval(u + h, v)?, self.sc.eval(u, v + h)?))
            } else {
                None
            };
            match self.track_step(kind, &s, sh.as_ref().map(|(a, b)| (a, b)), ys) {
                Step::Done => return Some((s, iters)),
                Step::Fail => return None,
                Step::Next(nu, nv) => {
                    u = nu;
                    v = nv;
                }
            }
        }
        None
    }

    /// [`track`](Self::track) for many samples at once: every Newton round
    /// evaluates all unfinished samples in one batch (one call of a
    /// Python-callable surface per round).
    pub(crate) fn track_many(
        &self,
        items: &[(SKind, f64, f64)],
        ys: f64,
    ) -> Vec<Option<(ScreenSample, u32)>> {
        let d = self.sc.dom;
        let h = self.turn_h();
        let mut out: Vec<Option<(ScreenSample, u32)>> = vec![None; items.len()];
        let mut active: Vec<(usize, f64, f64)> = items
            .iter()
            .enumerate()
            .filter(|(_, &(_, u, v))| d.contains(u, v))
            .map(|(i, &(_, u, v))| (i, u, v))
            .collect();
        let (mut bu, mut bv) = (Vec::new(), Vec::new());
        for iters in 0..16u32 {
            if active.is_empty() {
                break;
            }
            bu.clear();
            bv.clear();
            for &(i, u, v) in &active {
                bu.push(u);
                bv.push(v);
                if items[i].0 == SKind::Turn {
                    bu.extend([u + h, u]);
                    bv.extend([v, v + h]);
                }
            }
            let ss = self.sc.eval_batch(&bu, &bv);
            let mut k = 0;
            let mut next = Vec::with_capacity(active.len());
            for &(i, _, _) in &active {
                let kind = items[i].0;
                let s = ss[k];
                let sh = if kind == SKind::Turn {
                    k += 3;
                    ss[k - 2].zip(ss[k - 1])
                } else {
                    k += 1;
                    None
                };
                let Some(s) = s else { continue };
                if kind == SKind::Turn && sh.is_none() {
                    continue;
                }
                match self.track_step(kind, &s, sh.as_ref().map(|(a, b)| (a, b)), ys) {
                    Step::Done => out[i] = Some((s, iters)),
                    Step::Fail => {}
                    Step::Next(u, v) => next.push((i, u, v)),
                }
            }
            active = next;
        }
        out
    }

    pub(crate) fn fine_step(&self) -> f64 {
        self.sampled.map_or(0.0, |p| p.step) / (1u64 << LEVELS) as f64
    }

    /// Carry the samples of the previous scan line to `ys` and add the
    /// Y-scan trackers that end pieces.
    pub(crate) fn sampled_begin(
        &self,
        ytrackers: &[super::trackers::Tracker],
        ys: f64,
        extrapolate: bool,
        st: &mut XStats,
    ) {
        use super::trackers::Kind;
        let mut pool = self.pool.borrow_mut();
        let old = std::mem::take(&mut pool.keep);
        let mut cur: Vec<Sample> = Vec::with_capacity(old.len() + ytrackers.len());
        // §3.5: guesses extrapolated from the two previous scan lines.
        let guess = |t: &Sample| match (extrapolate, t.prev) {
            (true, Some((pu, pv))) => (2.0 * t.s.u - pu, 2.0 * t.s.v - pv, true),
            _ => (t.s.u, t.s.v, false),
        };
        let items: Vec<(SKind, f64, f64)> = old
            .iter()
            .map(|t| {
                let (u, v, _) = guess(t);
                (t.kind, u, v)
            })
            .collect();
        let first = self.track_many(&items, ys);
        for (t, r) in old.iter().zip(first) {
            let (_, _, ex) = guess(t);
            let r = match r {
                Some(r) => Some(r),
                None if ex => self.track(t.kind, t.s.u, t.s.v, ys),
                None => None,
            };
            match r {
                Some((s, it)) => {
                    if ex {
                        st.theta_updates_ex += 1;
                        st.theta_iters_ex += it as u64;
                    } else {
                        st.theta_updates += 1;
                        st.theta_iters += it as u64;
                    }
                    cur.push(Sample {
                        s,
                        prev: Some((t.s.u, t.s.v)),
                        phi: self.phi(&s),
                        ..*t
                    });
                }
                None => st.theta_lost += 1,
            }
        }
        for t in ytrackers {
            let kind = match t.kind {
                Kind::Sil => SKind::Sil,
                Kind::Edge(_) => SKind::Edge,
                Kind::Left => continue,
            };
            cur.push(Sample::new(kind, t.s, self.phi(&t.s)));
        }
        // Sorted by (x, u, v), stably: the keys are sorted and the samples
        // moved once.
        let mut order: Vec<(f64, f64, f64, u32)> = cur
            .iter()
            .enumerate()
            .map(|(i, c)| (c.s.x, c.s.u, c.s.v, i as u32))
            .collect();
        order.sort_unstable_by(|a, b| {
            a.0.total_cmp(&b.0)
                .then(a.1.total_cmp(&b.1))
                .then(a.2.total_cmp(&b.2))
                .then(a.3.cmp(&b.3))
        });
        // Two trackers of the same angle that met (a minimum of y along
        // them): keep one.
        let tol = 1e-7 * self.ext;
        let mut out: Vec<Sample> = Vec::with_capacity(cur.len());
        for c in order.iter().map(|o| &cur[o.3 as usize]) {
            let dup = out.iter().rev().take(8).any(|o| {
                o.kind == c.kind
                    && matches!(c.kind, SKind::Theta(_) | SKind::Turn)
                    && (o.s.u - c.s.u).abs() <= tol
                    && (o.s.v - c.s.v).abs() <= tol
            });
            if dup {
                st.theta_deleted += 1;
            } else {
                out.push(*c);
            }
        }
        pool.used = vec![false; out.len()];
        pool.cur = out;
        pool.born.clear();
    }

    /// Keep the samples used on this scan line for the next one.
    pub(crate) fn sampled_end(&self, st: &mut XStats) {
        let mut pool = self.pool.borrow_mut();
        let pool = &mut *pool;
        let mut keep = std::mem::take(&mut pool.born);
        for (c, &u) in pool.cur.iter().zip(&pool.used) {
            if !matches!(c.kind, SKind::Theta(_) | SKind::Turn) {
                continue;
            }
            if u {
                keep.push(*c);
            } else {
                st.theta_deleted += 1;
            }
        }
        pool.cur.clear();
        pool.keep = keep;
    }

    /// Mark a sample as used on this scan line (a new one is stored and
    /// given an identity); where it is stored and its identity.
    fn mark_used(&self, idx: Option<usize>, b: &mut Sample, st: &mut XStats) -> Option<Loc> {
        let mut pool = self.pool.borrow_mut();
        match idx {
            Some(i) => {
                pool.used[i] = true;
                Some(Loc::Cur(i))
            }
            None => {
                if matches!(b.kind, SKind::Theta(_) | SKind::Turn) {
                    if b.kind == SKind::Turn {
                        st.turns += 1;
                    }
                    pool.next_id += 1;
                    b.id = pool.next_id;
                    b.link = 0;
                    pool.born.push(*b);
                    Some(Loc::Born(pool.born.len() - 1))
                } else {
                    None
                }
            }
        }
    }

    /// Record the link a → b (tested now when `age` is 0).
    fn set_link(&self, loc: Option<Loc>, b: &Sample, age: u8, herm: bool) {
        let Some(loc) = loc else { return };
        let mut pool = self.pool.borrow_mut();
        let a = match loc {
            Loc::Cur(i) => &mut pool.cur[i],
            Loc::Born(i) => &mut pool.born[i],
        };
        a.link = b.id;
        a.age = age;
        a.herm = herm;
    }

    /// Test the span a → b (b ahead in x) at its middle pixel.
    #[allow(clippy::too_many_arguments)]
    fn test_span(
        &self,
        a: &Sample,
        b: &Sample,
        sigma: f64,
        ys: f64,
        dir: f64,
        p: Params,
        st: &mut XStats,
    ) -> Test {
        let xm = 0.5 * (a.s.x + b.s.x);
        st.sample_solves += 1;
        // A thousandth of a pixel is plenty for a test point.
        let Some(m) = self.mid_solve(a, b, sigma, ys, xm, st) else {
            return Test::WrongArc;
        };
        let l = (b.s.u - a.s.u).abs().max((b.s.v - a.s.v).abs());
        let tol = 0.3 * l + 1e-9 * self.ext;
        if (m.u - 0.5 * (a.s.u + b.s.u)).abs() > tol || (m.v - 0.5 * (a.s.v + b.s.v)).abs() > tol {
            return Test::WrongArc;
        }
        let pm = self.phi(&m);
        let eps = 1e-9;
        if dir * wrap(pm - a.phi) < -eps || dir * wrap(b.phi - pm) < -eps {
            return Test::Turn(m);
        }
        let (na, nb, nm) = (normal(&a.s), normal(&b.s), normal(&m));
        let ni = (na + nb).normalize_or_zero();
        let err = ni.dot(nm).clamp(-1.0, 1.0).acos();
        let pix = self.sc.cam.pixel_size_at(m.z).abs();
        let zl = 0.5 * (a.s.z + b.s.z);
        let el = (zl - m.z).abs() / pix;
        let eh = self
            .hermite_mid(a, b)
            .map_or(f64::INFINITY, |zh| (zh - m.z).abs() / pix);
        if err <= p.max_error && el.min(eh) <= 1.0 {
            Test::Accept(eh < el, err <= 0.5 * p.max_error && el.min(eh) <= 0.5)
        } else {
            Test::Coarse(m)
        }
    }

    /// The middle point of the span a → b on a's arc (x = xm): Newton
    /// from the cubic Hermite interpolant in x of (u, v) between a and b,
    /// with d(u, v)/dx = (y_v, −y_u)/J along the level curve — one or two
    /// corrections where the linear step from a needs several. The checks
    /// are those of `try_newton_tol` from a.
    fn mid_solve(
        &self,
        a: &Sample,
        b: &Sample,
        sigma: f64,
        ys: f64,
        xm: f64,
        st: &mut XStats,
    ) -> Option<ScreenSample> {
        let (ja, jb) = (a.s.jac(), b.s.jac());
        let jscale = |s: &ScreenSample| (s.xu * s.yv).abs() + (s.xv * s.yu).abs();
        if !(ja * sigma > 1e-3 * jscale(&a.s) && jb * sigma > 1e-3 * jscale(&b.s)) {
            return self.try_newton_tol(&a.s, sigma, ys, xm, 1e-3, st);
        }
        let dx = b.s.x - a.s.x;
        let h = 0.125 * dx;
        let su = 0.5 * (a.s.u + b.s.u) + h * (a.s.yv / ja - b.s.yv / jb);
        let sv = 0.5 * (a.s.v + b.s.v) - h * (a.s.yu / ja - b.s.yu / jb);
        // The linear step from a (for the on-piece checks).
        let (g, f) = (xm - a.s.x, ys - a.s.y);
        let pu = (g * a.s.yv - a.s.xv * f) / ja;
        let pv = (a.s.xu * f - a.s.yu * g) / ja;
        let q = self.newton_tol(su, sv, ys, xm, 1e-3, &mut st.pixel_iters)?;
        let jump = (q.u - a.s.u).abs().max((q.v - a.s.v).abs());
        let pred = pu.abs().max(pv.abs());
        (q.jac() * sigma > 0.0 && jump <= 3.0 * pred + 1e-12 * self.ext).then_some(q)
    }

    /// dz/dx along the level curve (K/J), if finite.
    fn slope(&self, s: &ScreenSample) -> Option<f64> {
        let k = s.zu * s.yv - s.zv * s.yu;
        let r = k / s.jac();
        r.is_finite().then_some(r)
    }

    fn hermite_mid(&self, a: &Sample, b: &Sample) -> Option<f64> {
        let dx = b.s.x - a.s.x;
        let m0 = self.slope(&a.s)? * dx;
        let m1 = self.slope(&b.s)? * dx;
        Some(0.5 * (a.s.z + b.s.z) + 0.125 * (m0 - m1))
    }

    /// Fill the pixels with centres in (a.x, b.x] from j on.
    fn fill(&self, a: &Sample, b: &Sample, hermite: bool, j: &mut usize, hits: &mut [Option<Hit>]) {
        let (na, nb) = (normal(&a.s), normal(&b.s));
        let dx = b.s.x - a.s.x;
        let slopes = if hermite {
            self.slope(&a.s)
                .zip(self.slope(&b.s))
                .map(|(s0, s1)| (s0 * dx, s1 * dx))
        } else {
            None
        };
        while *j < self.width && self.xpix(*j) <= b.s.x {
            let t = ((self.xpix(*j) - a.s.x) / dx).clamp(0.0, 1.0);
            let lerp = |x: f64, y: f64| x + t * (y - x);
            let z = match slopes {
                Some((m0, m1)) => {
                    let (t2, t3) = (t * t, t * t * t);
                    (2.0 * t3 - 3.0 * t2 + 1.0) * a.s.z
                        + (t3 - 2.0 * t2 + t) * m0
                        + (-2.0 * t3 + 3.0 * t2) * b.s.z
                        + (t3 - t2) * m1
                }
                None => lerp(a.s.z, b.s.z),
            };
            // Hidden behind a nearer piece already scanned: nothing else
            // to interpolate (`record` would drop it).
            if hits[*j]
                .as_ref()
                .is_some_and(|o| z.partial_cmp(&o.z) != Some(std::cmp::Ordering::Less))
            {
                *j += 1;
                continue;
            }
            let n = (na * (1.0 - t) + nb * t).normalize_or_zero();
            self.put(
                hits,
                *j,
                z,
                lerp(a.s.u, b.s.u),
                lerp(a.s.v, b.s.v),
                a.s.p.p.lerp(b.s.p.p, t),
                n,
            );
            *j += 1;
        }
    }

    /// Candidates for the sample after a: carried samples ahead in x whose
    /// ϑ lies in the window (a.ϑ, a.ϑ + dir·w], farthest angle first.
    fn candidates(&self, a: &Sample, dir: f64, w: f64, sigma: f64) -> Cands {
        let pool = self.pool.borrow();
        let start = pool.cur.partition_point(|c| c.s.x <= a.s.x);
        let mut out = [(0usize, 0.0f64, 0.0f64); 6];
        let mut n = 0;
        for (i, c) in pool.cur.iter().enumerate().skip(start).take(96) {
            let dc = dir * wrap(c.phi - a.phi);
            let ok = match c.kind {
                SKind::Theta(_) => dc > 1e-12 && dc <= w + 1e-9 && c.s.jac() * sigma > 0.0,
                SKind::Turn => dc >= -1e-9 && dc <= w + 1e-9,
                SKind::Sil => dc >= -1e-9 && dc <= w + 1e-9,
                SKind::Edge => dc >= -1e-9 && dc <= w + 1e-9,
                SKind::Pixel => false,
            };
            if ok {
                out[n] = (i, dc, c.s.x);
                n += 1;
                if n >= 6 {
                    break;
                }
            }
        }
        // Farthest angle first (the coarsest span that passes is used).
        out[..n].sort_by(|a, b| b.1.total_cmp(&a.1).then(a.2.total_cmp(&b.2)));
        let mut c = Cands {
            idx: [0; 6],
            len: n,
        };
        for (o, e) in c.idx.iter_mut().zip(&out[..n]) {
            *o = e.0;
        }
        c
    }

    /// Sample at the fine table angle nearest the middle of a and b, made
    /// from the middle solution m; None at the finest level.
    /// A carried sample of that angle inside the span is taken instead of
    /// a new solve (with its pool index).
    fn refine(
        &self,
        a: &Sample,
        b: &Sample,
        m: &ScreenSample,
        ys: f64,
    ) -> Option<(Sample, Option<usize>)> {
        let fs = self.fine_step();
        let mid = a.phi + 0.5 * wrap(b.phi - a.phi);
        let k = (mid / fs).round() as i64;
        let ang = k as f64 * fs;
        // Not strictly between a and b: no finer table angle left.
        let da = wrap(ang - a.phi);
        let db = wrap(b.phi - ang);
        if da * db <= 0.0 || !(da * db).is_finite() || da.abs() < 0.25 * fs || db.abs() < 0.25 * fs
        {
            return None;
        }
        // The tracker of that angle carried from the previous scan line
        // (§4: samples are trackers), if it lies inside the span on its
        // arc: no new solve.
        if let Some(i) = self.carried_theta(k, a, b, m) {
            return Some((self.pool.borrow().cur[i], Some(i)));
        }
        let (s, _) = self.track(SKind::Theta(k), m.u, m.v, ys)?;
        (s.x > a.s.x && s.x < b.s.x).then(|| (Sample::new(SKind::Theta(k), s, self.phi(&s)), None))
    }

    /// A carried sample of table angle k strictly inside the span a → b
    /// (in x), within the (u, v) box of the span around its middle
    /// solution m (the arc test of [`test_span`](Self::test_span)).
    fn carried_theta(&self, k: i64, a: &Sample, b: &Sample, m: &ScreenSample) -> Option<usize> {
        let pool = self.pool.borrow();
        let start = pool.cur.partition_point(|c| c.s.x <= a.s.x);
        let l = (b.s.u - a.s.u).abs().max((b.s.v - a.s.v).abs());
        let tol = 0.3 * l + 1e-9 * self.ext;
        let sigma = m.jac().signum();
        pool.cur[start..]
            .iter()
            .take_while(|c| c.s.x < b.s.x)
            .position(|c| {
                c.kind == SKind::Theta(k)
                    && c.s.jac() * sigma > 0.0
                    && (c.s.u - m.u).abs() <= tol
                    && (c.s.v - m.v).abs() <= tol
            })
            .map(|p| start + p)
    }

    /// Solve the pixels with centres in (a.x, b.x] exactly from a; false if
    /// a solve fails.
    #[allow(clippy::too_many_arguments)]
    fn exact_fill(
        &self,
        a: &Sample,
        b: &Sample,
        sigma: f64,
        ys: f64,
        j: &mut usize,
        hits: &mut [Option<Hit>],
        st: &mut XStats,
    ) -> bool {
        let mut cur = a.s;
        let mut jj = *j;
        let mut sols = Vec::new();
        while jj < self.width && self.xpix(jj) <= b.s.x {
            let Some(q) = self.try_newton(&cur, sigma, ys, self.xpix(jj), st) else {
                return false;
            };
            st.pixel_solves += 1;
            sols.push((jj, q));
            cur = q;
            jj += 1;
        }
        for (jj, q) in sols {
            self.put_sample(hits, jj, &q);
        }
        *j = jj;
        true
    }

    /// Try to take one span from a: returns the next sample (and its pool
    /// index) after filling the pixels up to it.
    #[allow(clippy::too_many_arguments)]
    fn span(
        &self,
        a: &Sample,
        a_loc: Option<Loc>,
        dir: f64,
        sigma: f64,
        ys: f64,
        p: Params,
        j: &mut usize,
        hits: &mut [Option<Hit>],
        st: &mut XStats,
    ) -> Option<(Sample, Option<Loc>)> {
        let step = p.step;
        let q = a.phi / step;
        let target_idx = if dir > 0.0 {
            (q + 1e-9).floor() + 1.0
        } else {
            (q - 1e-9).ceil() - 1.0
        };
        let target = target_idx * step;
        let w = dir * (target - a.phi);
        let x_last = self.xpix(self.width - 1);
        let mut cands = self.candidates(a, dir, w, sigma);
        // 0. The link of the previous scan line (§4.2), re-tested every
        // few scan lines.
        if a.link != 0 && a.age < LINK_AGE {
            let found = {
                let pool = self.pool.borrow();
                cands
                    .as_slice()
                    .iter()
                    .find(|&&i| pool.cur[i].id == a.link)
                    .map(|&i| (i, pool.cur[i]))
            };
            if let Some((i, mut c)) = found {
                if c.s.x > a.s.x {
                    st.links_kept += 1;
                    self.fill(a, &c, a.herm, j, hits);
                    let loc = self.mark_used(Some(i), &mut c, st);
                    self.set_link(a_loc, &c, a.age + 1, a.herm);
                    st.samples += 1;
                    return Some((c, loc));
                }
            }
        }
        // 1. Carried samples.
        let mut first: Option<(Option<usize>, Sample)> = None;
        let mut known: Option<Test> = None;
        if a.link != 0 {
            let pool = self.pool.borrow();
            let c = cands.as_mut_slice();
            if let Some(k) = c.iter().position(|&i| pool.cur[i].id == a.link) {
                c[..=k].rotate_right(1);
            }
        }
        for (tries, &i) in cands.as_slice().iter().enumerate() {
            let c = self.pool.borrow().cur[i];
            if tries >= 3 {
                break;
            }
            st.span_tests += 1;
            match self.test_span(a, &c, sigma, ys, dir, p, st) {
                Test::WrongArc => {
                    st.wrong_arc += 1;
                    continue;
                }
                t => {
                    first = Some((Some(i), c));
                    known = Some(t);
                    break;
                }
            }
        }
        // 2. Sideways iteration (§4.2): step along the curve to the target
        // angle.
        if first.is_none() {
            let rate = self.dphi_dx(&a.s).abs();
            let mut dx = if rate > 0.0 { w / rate } else { f64::INFINITY };
            dx = dx.clamp(1.0, 128.0);
            for _ in 0..4 {
                let xb = (a.s.x + dx).min(x_last);
                if xb <= a.s.x {
                    return None;
                }
                st.sample_solves += 1;
                if let Some(pt) = self.try_newton_tol(&a.s, sigma, ys, xb, 1e-3, st) {
                    let pphi = self.phi(&pt);
                    let passed = dir * wrap(pphi - a.phi) > w;
                    let mut b = Sample::new(SKind::Pixel, pt, pphi);
                    if passed {
                        let k = (target / self.fine_step()).round() as i64;
                        if let Some((s, _)) = self.track(SKind::Theta(k), pt.u, pt.v, ys) {
                            if s.x > a.s.x && s.x <= pt.x && s.jac() * sigma > 0.0 {
                                b = Sample::new(SKind::Theta(k), s, self.phi(&s));
                                st.theta_created += 1;
                                st.sideways += 1;
                            }
                        }
                    }
                    first = Some((None, b));
                    break;
                }
                dx *= 0.5;
                if dx < 1.0 {
                    break;
                }
            }
        }
        let (mut idx, mut b) = first?;
        // 3. Test and refine.
        for _ in 0..(2 * LEVELS + 4) {
            let npix = self.count_pixels(a.s.x, b.s.x, *j);
            let t = match known.take() {
                Some(t) => t,
                None => {
                    st.span_tests += 1;
                    self.test_span(a, &b, sigma, ys, dir, p, st)
                }
            };
            match t {
                Test::Accept(hermite, slack) => {
                    if b.s.x <= a.s.x {
                        return None;
                    }
                    self.fill(a, &b, hermite, j, hits);
                    let loc = self.mark_used(idx, &mut b, st);
                    let age = if slack { 0 } else { LINK_AGE };
                    self.set_link(a_loc, &b, age, hermite);
                    st.samples += 1;
                    return Some((b, loc));
                }
                Test::WrongArc => return None,
                Test::Turn(m) => {
                    // §4.3: the turn point becomes a sample.
                    let tp = self.track(SKind::Turn, m.u, m.v, ys).and_then(|(s, _)| {
                        (s.x > a.s.x && s.x < b.s.x && s.jac() * sigma > 0.0)
                            .then(|| Sample::new(SKind::Turn, s, self.phi(&s)))
                    });
                    match tp {
                        Some(t) => {
                            idx = None;
                            b = t;
                        }
                        None => {
                            b = Sample::new(SKind::Pixel, m, self.phi(&m));
                            idx = None;
                        }
                    }
                }
                Test::Coarse(m) => {
                    if npix <= 3 {
                        if self.exact_fill(a, &b, sigma, ys, j, hits, st) {
                            let loc = self.mark_used(idx, &mut b, st);
                            st.samples += 1;
                            return Some((b, loc));
                        }
                        return None;
                    }
                    st.refined += 1;
                    match self.refine(a, &b, &m, ys) {
                        Some((r, i)) => {
                            if i.is_none() {
                                st.theta_created += 1;
                            }
                            b = r;
                            idx = i;
                        }
                        None => {
                            b = Sample::new(SKind::Pixel, m, self.phi(&m));
                            idx = None;
                        }
                    }
                }
            }
        }
        None
    }

    fn count_pixels(&self, xa: f64, xb: f64, j: usize) -> usize {
        let mut n = 0;
        let mut jj = j;
        while jj < self.width && self.xpix(jj) <= xb && n < 8 {
            if self.xpix(jj) > xa {
                n += 1;
            }
            jj += 1;
        }
        n
    }

    /// First pixel xp of a piece that starts at a fold (J ≈ 0 at q, where
    /// the linear step of `try_newton` is undefined): along the unit
    /// tangent t of the level curve, x(σ) ≈ x_q + x_t σ + ½ x_tt σ² with
    /// the curve's second-order term c'' = −(tᵀH_y t) ∇y/|∇y|² (as for the
    /// left-border starts of the Y scan), so Newton starts σ along the
    /// curve, σ the positive root. `None` (the continuation walks there
    /// instead) unless it lands ahead of q on the piece, within three
    /// times the predicted step.
    fn fold_start(
        &self,
        q: &ScreenSample,
        s: f64,
        sigma: f64,
        ys: f64,
        xp: f64,
        st: &mut XStats,
    ) -> Option<ScreenSample> {
        let g2 = q.yu * q.yu + q.yv * q.yv;
        let l = g2.sqrt();
        if !(l > 0.0 && q.xuu.is_finite() && xp > q.x) {
            return None;
        }
        let (tu, tv) = (-s * q.yv / l, s * q.yu / l);
        let quad = |a: f64, b: f64, c: f64| a * tu * tu + 2.0 * b * tu * tv + c * tv * tv;
        let ky = -quad(q.yuu, q.yuv, q.yvv) / g2;
        let (cu, cv) = (ky * q.yu, ky * q.yv);
        let xt = q.xu * tu + q.xv * tv;
        let xtt = quad(q.xuu, q.xuv, q.xvv) + q.xu * cu + q.xv * cv;
        let dx = xp - q.x;
        // ½ x_tt σ² + x_t σ − dx = 0, the positive root (stable form).
        let disc = xt * xt + 2.0 * xtt * dx;
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let step = 2.0 * dx / (xt + disc.sqrt());
        if !(step.is_finite() && step > 0.0) {
            return None;
        }
        let (du, dv) = (
            step * tu + 0.5 * step * step * cu,
            step * tv + 0.5 * step * step * cv,
        );
        if du.abs().max(dv.abs()) > 0.1 * self.ext {
            return None;
        }
        let n = self.newton(q.u + du, q.v + dv, ys, xp, &mut st.pixel_iters)?;
        let (mu, mv) = (n.u - q.u, n.v - q.v);
        let ahead = mu * tu + mv * tv > 0.0;
        let near = mu.abs().max(mv.abs()) <= 3.0 * du.abs().max(dv.abs()) + 1e-12 * self.ext;
        (ahead && near && n.jac() * sigma > 0.0).then(|| {
            st.fold_starts += 1;
            n
        })
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn sampled_from(
        &self,
        start: ScreenSample,
        j0: usize,
        s: f64,
        ys: f64,
        p: Params,
        hits: &mut [Option<Hit>],
        st: &mut XStats,
    ) -> End {
        let sigma = -s;
        // The first pixel exactly (it may need the continuation).
        let xp0 = self.xpix(j0);
        let first = match self
            .try_newton(&start, sigma, ys, xp0, st)
            .or_else(|| self.fold_start(&start, s, sigma, ys, xp0, st))
        {
            Some(q) => q,
            None => match self.continuation(&start, s, sigma, ys, xp0, st) {
                Ok(q) => q,
                Err(e) => return e,
            },
        };
        st.pixel_solves += 1;
        self.put_sample(hits, j0, &first);
        let mut a = Sample::new(SKind::Pixel, first, self.phi(&first));
        let mut j = j0 + 1;
        let mut dir = 1.0;
        let mut n = 0usize;
        let mut stall = 0u32;
        let mut a_loc: Option<Loc> = None;
        while j < self.width {
            n += 1;
            if n % 16 == 0 && self.cancel.is_some_and(|c| c.is_cancelled()) {
                return End::Failed;
            }
            // Pixel solves are first order; dϑ/dx at a span's start needs
            // the second derivatives (the same values a second-order solve
            // would have given: the first-order fields agree bit for bit).
            if a.s.xuu.is_nan() {
                if let Some(f) = self.sc.eval(a.s.u, a.s.v) {
                    a.s = f;
                }
            }
            dir = if a.kind == SKind::Turn {
                -dir
            } else {
                let r = self.dphi_dx(&a.s);
                if r > 0.0 {
                    1.0
                } else if r < 0.0 {
                    -1.0
                } else {
                    dir
                }
            };
            // Spans that make no progress in pixels (samples bunched at a
            // fold or a turn) hand over to the exact step after a while.
            let j_before = j;
            let b = if stall < 32 {
                self.span(&a, a_loc, dir, sigma, ys, p, &mut j, hits, st)
            } else {
                None
            };
            if let Some((b, loc)) = b {
                match b.kind {
                    SKind::Sil => return End::Fold(Box::new(b.s)),
                    SKind::Edge => return End::Boundary,
                    _ => {}
                }
                stall = if j > j_before { 0 } else { stall + 1 };
                a = b;
                a_loc = loc;
                continue;
            }
            stall = 0;
            // No span: the next pixel exactly, then sample again.
            let xp = self.xpix(j);
            let q = match self.try_newton(&a.s, sigma, ys, xp, st) {
                Some(q) => q,
                None => match self.continuation(&a.s, s, sigma, ys, xp, st) {
                    Ok(q) => q,
                    Err(e) => return e,
                },
            };
            st.pixel_solves += 1;
            self.put_sample(hits, j, &q);
            j += 1;
            a = Sample::new(SKind::Pixel, q, self.phi(&q));
            a_loc = None;
        }
        End::Done
    }

    /// Record a pixel with an explicit unit normal (zero: none, as at a
    /// pole).
    #[allow(clippy::too_many_arguments)]
    fn put(&self, hits: &mut [Option<Hit>], j: usize, z: f64, u: f64, v: f64, p: DVec3, n: DVec3) {
        let (n, pn) = if n == DVec3::ZERO {
            (DVec3::ZERO, DVec3::ZERO)
        } else {
            (n, n)
        };
        self.record(
            hits,
            j,
            Hit {
                z,
                u,
                v,
                jac: 0.0,
                p,
                n,
                pn,
            },
        );
    }

    fn put_sample(&self, hits: &mut [Option<Hit>], j: usize, q: &ScreenSample) {
        self.put(hits, j, q.z, q.u, q.v, q.p.p, normal(q));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_is_a_line_angle() {
        assert!((wrap(PI) - 0.0).abs() < 1e-15);
        assert!((wrap(-FRAC_PI_2) - FRAC_PI_2).abs() < 1e-15);
        assert!((wrap(0.75 * PI) + 0.25 * PI).abs() < 1e-15);
        // The same bits as with the library rounding, across the range.
        for i in -4000..=4000 {
            let x = i as f64 * 1e-3 * PI + 1e-7;
            for x in [x, 0.5 * PI, -0.5 * PI, 1.5 * PI, -1.5 * PI] {
                let w = x - PI * (x / PI).round();
                let w = if w <= -FRAC_PI_2 { w + PI } else { w };
                assert_eq!(wrap(x).to_bits(), w.to_bits(), "{x}");
            }
        }
    }
}
