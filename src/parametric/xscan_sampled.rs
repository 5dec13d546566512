//! The sampled X scan (Blinn 1978 §4).
//!
//! Instead of Newton at every pixel, each level-curve piece is sampled at
//! points spaced by equal steps of the angle ϑ of its cross-section curve
//! in the (x, depth) plane (§4.1: samples cluster where the curve bends),
//! and depth, parameters and the normal are interpolated linearly between
//! samples, the normal renormalised (Phong). Where the interpolated normal
//! would be off by more than `max_error` at the middle of a span, the span
//! is halved: more normal-angle samples where the error demands. Turn
//! points of ϑ (§4.3) are counted; a span that straddles one is always
//! checked by the error test.
//!
//! The samples are found on each scan line by stepping along the piece
//! (Blinn's "sideways iteration", §4.2) with the pixel Newton of §3.3,
//! rather than tracked between scan lines; the last pixels before the end
//! of a piece (a silhouette or the patch boundary) are solved exactly.

use super::screen::ScreenSample;
use super::xscan_exact::{End, Hit, XScan, XStats};
use crate::surface::ParamSample;
use glam::DVec3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// ϑ step in radians (2π / samples per turn).
    pub step: f64,
    /// Largest normal error accepted at a span's midpoint, radians.
    pub max_error: f64,
}

/// Unit normal P_u × P_v.
fn normal(s: &ScreenSample) -> DVec3 {
    s.p.pu.cross(s.p.pv).normalize_or_zero()
}

impl<'a> XScan<'a> {
    /// ϑ of the cross-section curve at s (direction of increasing x), with
    /// depth in pixels.
    fn theta(&self, q: &ScreenSample, s: f64) -> f64 {
        let (tu, tv) = (-s * q.yv, s * q.yu);
        let dx = q.xu * tu + q.xv * tv;
        let dz = (q.zu * tu + q.zv * tv) / self.sc.cam.pixel_size_at(q.z);
        dz.atan2(dx)
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
        let mut a = match self.try_newton(&start, sigma, ys, xp0, st) {
            Some(q) => q,
            None => match self.continuation(&start, s, sigma, ys, xp0, st) {
                Ok(q) => q,
                Err(e) => return e,
            },
        };
        st.samples += 1;
        self.put(hits, j0, &a, &normal(&a));
        let mut j = j0 + 1;
        let mut step_px: f64 = 4.0;
        let mut last_dir = 0.0;
        let x_last = self.xpix(self.width - 1);
        while j < self.width {
            if self.cancel.is_some_and(|c| c.is_cancelled()) {
                return End::Failed;
            }
            let ta = self.theta(&a, s);
            let na = normal(&a);
            // Find the next sample b within one ϑ step and the error bound.
            let mut accepted = None;
            let mut dx = step_px.clamp(1.0, 64.0);
            while dx >= 2.0 {
                let xb = (a.x + dx).min(x_last.max(a.x + 1.0));
                st.sample_solves += 1;
                if let Some(b) = self.try_newton(&a, sigma, ys, xb, st) {
                    let tb = self.theta(&b, s);
                    let dth = tb - ta;
                    if dth.abs() <= p.step {
                        // Error test at the middle of the span.
                        let xm = 0.5 * (a.x + b.x);
                        st.sample_solves += 1;
                        if let Some(m) = self.try_newton(&a, sigma, ys, xm, st) {
                            let t = (xm - a.x) / (b.x - a.x);
                            let nb = normal(&b);
                            let ni = (na * (1.0 - t) + nb * t).normalize_or_zero();
                            let err = ni.dot(normal(&m)).clamp(-1.0, 1.0).acos();
                            if err <= p.max_error {
                                accepted = Some((b, dth));
                                break;
                            }
                            st.refined += 1;
                        }
                    }
                }
                dx *= 0.5;
            }
            let Some((b, dth)) = accepted else {
                // Too curved for a span of two pixels, or the end of the
                // piece is near: the next pixel exactly, then sample again.
                let xp = self.xpix(j);
                let q = match self.try_newton(&a, sigma, ys, xp, st) {
                    Some(q) => q,
                    None => match self.continuation(&a, s, sigma, ys, xp, st) {
                        Ok(q) => q,
                        Err(e) => return e,
                    },
                };
                st.pixel_solves += 1;
                self.put(hits, j, &q, &normal(&q));
                j += 1;
                a = q;
                step_px = 2.0;
                continue;
            };
            st.samples += 1;
            if dth * last_dir < 0.0 {
                st.turns += 1;
            }
            if dth != 0.0 {
                last_dir = dth.signum();
            }
            // Interpolate the pixels in (a.x, b.x].
            let nb = normal(&b);
            while j < self.width && self.xpix(j) <= b.x {
                let t = (self.xpix(j) - a.x) / (b.x - a.x);
                let n = (na * (1.0 - t) + nb * t).normalize_or_zero();
                let lerp = |x: f64, y: f64| x + t * (y - x);
                let q = ScreenSample {
                    u: lerp(a.u, b.u),
                    v: lerp(a.v, b.v),
                    z: lerp(a.z, b.z),
                    p: ParamSample {
                        p: a.p.p.lerp(b.p.p, t),
                        ..Default::default()
                    },
                    ..a
                };
                self.put(hits, j, &q, &n);
                j += 1;
            }
            // Next step: aim at one ϑ step from the curvature just seen.
            let rate = dth.abs() / (b.x - a.x);
            step_px = if rate > 0.0 {
                0.9 * p.step / rate
            } else {
                64.0
            };
            a = b;
            if a.x >= x_last {
                return End::Done;
            }
        }
        End::Done
    }

    /// Record a pixel with an explicit unit normal.
    fn put(&self, hits: &mut [Option<Hit>], j: usize, q: &ScreenSample, n: &DVec3) {
        // Encode the normal as P_u × P_v of an orthonormal pair.
        let (e1, e2) = n.any_orthonormal_pair();
        let (e1, e2) = if e1.cross(e2).dot(*n) >= 0.0 {
            (e1, e2)
        } else {
            (e2, e1)
        };
        let p = ParamSample {
            p: q.p.p,
            pu: e1,
            pv: e2,
            ..Default::default()
        };
        self.record(
            hits,
            j,
            Hit {
                z: q.z,
                u: q.u,
                v: q.v,
                jac: 0.0,
                p,
            },
        );
    }
}
