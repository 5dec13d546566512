//! The surface in screen space: x_pix(u, v), y_pix(u, v) and depth(u, v).
//!
//! Blinn 1978 §2 assumes the perspective transform was applied to the
//! defining functions beforehand, so that an orthographic scan of X and Y is
//! appropriate. Here it is applied to the functions: with camera coordinates
//! c = ((P−E)·r, (P−E)·up, (P−E)·d) the screen functions are
//! orthographic  x = c_x / p,        y = c_y / p,
//! perspective   x = F c_x / c_z,    y = F c_y / c_z,
//! and their first and second partial derivatives follow by the chain rule
//! from P, P_u, P_v, P_uu, P_uv, P_vv (quotient rule for perspective).

use crate::camera::Camera;
use crate::surface::{Domain, ParamSample, ParametricSurface};
use glam::DVec3;
use std::sync::atomic::{AtomicU64, Ordering};

/// Screen functions and their derivatives at one (u, v).
#[derive(Debug, Clone, Copy, Default)]
pub struct ScreenSample {
    pub u: f64,
    pub v: f64,
    /// Screen position in pixels from the image centre (x right, y up).
    pub x: f64,
    pub y: f64,
    /// Camera depth (SPEC §1).
    pub z: f64,
    pub xu: f64,
    pub xv: f64,
    pub yu: f64,
    pub yv: f64,
    pub zu: f64,
    pub zv: f64,
    pub xuu: f64,
    pub xuv: f64,
    pub xvv: f64,
    pub yuu: f64,
    pub yuv: f64,
    pub yvv: f64,
    /// The world sample it came from.
    pub p: ParamSample,
}

impl ScreenSample {
    /// Screen Jacobian determinant J = x_u y_v − x_v y_u. Its zeros are the
    /// silhouette (Blinn's Zn = 0): there the level curve y = const has an
    /// extremum of x. Along the level-curve tangent t = (−y_v, y_u),
    /// dx/ds = −J.
    #[inline]
    pub fn jac(&self) -> f64 {
        self.xu * self.yv - self.xv * self.yu
    }
    /// ∇J = (J_u, J_v) from the second derivatives.
    #[inline]
    pub fn jac_grad(&self) -> (f64, f64) {
        let ju = self.xuu * self.yv + self.xu * self.yuv - self.xuv * self.yu - self.xv * self.yuu;
        let jv = self.xuv * self.yv + self.xu * self.yvv - self.xvv * self.yu - self.xv * self.yuv;
        (ju, jv)
    }
}

/// Quotient q = a / b with first and second derivatives.
#[inline]
fn quotient(a: [f64; 6], b: [f64; 6]) -> [f64; 6] {
    // [f, f_u, f_v, f_uu, f_uv, f_vv]
    let ib = 1.0 / b[0];
    let q = a[0] * ib;
    let qu = (a[1] - q * b[1]) * ib;
    let qv = (a[2] - q * b[2]) * ib;
    // q b = a  ⇒  q_ij b + q_i b_j + q_j b_i + q b_ij = a_ij
    let quu = (a[3] - 2.0 * qu * b[1] - q * b[3]) * ib;
    let quv = (a[4] - qu * b[2] - qv * b[1] - q * b[4]) * ib;
    let qvv = (a[5] - 2.0 * qv * b[2] - q * b[5]) * ib;
    [q, qu, qv, quu, quv, qvv]
}

#[inline]
fn comp(s: &ParamSample, eye: DVec3, axis: DVec3) -> [f64; 6] {
    [
        (s.p - eye).dot(axis),
        s.pu.dot(axis),
        s.pv.dot(axis),
        s.puu.dot(axis),
        s.puv.dot(axis),
        s.pvv.dot(axis),
    ]
}

/// A parametric surface seen through a camera.
pub struct Screen<'a> {
    pub surf: &'a (dyn ParametricSurface + Sync),
    pub cam: &'a Camera,
    pub dom: Domain,
    evals: AtomicU64,
}

impl<'a> Screen<'a> {
    pub fn new(surf: &'a (dyn ParametricSurface + Sync), cam: &'a Camera) -> Self {
        Screen {
            surf,
            cam,
            dom: surf.domain(),
            evals: AtomicU64::new(0),
        }
    }

    /// Function evaluations made so far.
    pub fn evals(&self) -> u64 {
        self.evals.load(Ordering::Relaxed)
    }

    /// Convert a world sample; `None` where the surface is not finite or
    /// (perspective) the point lies at or behind the near bound.
    pub fn from_sample(&self, u: f64, v: f64, p: ParamSample) -> Option<ScreenSample> {
        if !(p.is_finite() && p.puu.is_finite() && p.puv.is_finite() && p.pvv.is_finite()) {
            return None;
        }
        let cam = self.cam;
        let cx = comp(&p, cam.eye, cam.r);
        let cy = comp(&p, cam.eye, cam.up);
        let cz = comp(&p, cam.eye, cam.d);
        let (x, y) = if cam.perspective {
            if cz[0] <= cam.near {
                return None;
            }
            let f = cam.focal;
            let mut x = quotient(cx, cz);
            let mut y = quotient(cy, cz);
            x.iter_mut().for_each(|t| *t *= f);
            y.iter_mut().for_each(|t| *t *= f);
            (x, y)
        } else {
            let s = 1.0 / cam.pixel;
            (cx.map(|t| t * s), cy.map(|t| t * s))
        };
        let out = ScreenSample {
            u,
            v,
            x: x[0],
            y: y[0],
            z: cz[0],
            xu: x[1],
            xv: x[2],
            yu: y[1],
            yv: y[2],
            zu: cz[1],
            zv: cz[2],
            xuu: x[3],
            xuv: x[4],
            xvv: x[5],
            yuu: y[3],
            yuv: y[4],
            yvv: y[5],
            p,
        };
        let ok = out.x.is_finite()
            && out.y.is_finite()
            && out.xu.is_finite()
            && out.xv.is_finite()
            && out.yu.is_finite()
            && out.yv.is_finite()
            && out.xuu.is_finite()
            && out.xuv.is_finite()
            && out.xvv.is_finite()
            && out.yuu.is_finite()
            && out.yuv.is_finite()
            && out.yvv.is_finite();
        ok.then_some(out)
    }

    /// [`from_sample`](Self::from_sample) to first order: P, P_u, P_v
    /// only; the second derivatives of the result are NaN (any use shows).
    pub fn from_sample_first(&self, u: f64, v: f64, p: ParamSample) -> Option<ScreenSample> {
        if !p.is_finite() {
            return None;
        }
        let cam = self.cam;
        let c3 = |axis: DVec3| [(p.p - cam.eye).dot(axis), p.pu.dot(axis), p.pv.dot(axis)];
        let (cx, cy, cz) = (c3(cam.r), c3(cam.up), c3(cam.d));
        let (x, y) = if cam.perspective {
            if cz[0] <= cam.near {
                return None;
            }
            // q = F a / c: q_i = F (a_i − (a/c) c_i) / c, rounded as in
            // `quotient` so that both orders agree bit for bit.
            let f = cam.focal;
            let ic = 1.0 / cz[0];
            let q = |a: [f64; 3]| {
                let r = a[0] * ic;
                [
                    f * r,
                    f * ((a[1] - r * cz[1]) * ic),
                    f * ((a[2] - r * cz[2]) * ic),
                ]
            };
            (q(cx), q(cy))
        } else {
            let k = 1.0 / cam.pixel;
            (cx.map(|t| t * k), cy.map(|t| t * k))
        };
        let nan = f64::NAN;
        let out = ScreenSample {
            u,
            v,
            x: x[0],
            y: y[0],
            z: cz[0],
            xu: x[1],
            xv: x[2],
            yu: y[1],
            yv: y[2],
            zu: cz[1],
            zv: cz[2],
            xuu: nan,
            xuv: nan,
            xvv: nan,
            yuu: nan,
            yuv: nan,
            yvv: nan,
            p,
        };
        let ok = out.x.is_finite()
            && out.y.is_finite()
            && out.xu.is_finite()
            && out.xv.is_finite()
            && out.yu.is_finite()
            && out.yv.is_finite();
        ok.then_some(out)
    }

    /// Evaluate at one point to first order (counted): the second
    /// derivatives of the result are NaN.
    #[inline]
    pub fn eval_first(&self, u: f64, v: f64) -> Option<ScreenSample> {
        self.evals.fetch_add(1, Ordering::Relaxed);
        let p = self.surf.eval_first(u, v);
        self.from_sample_first(u, v, p)
    }

    /// [`eval_first`](Self::eval_first) at many points in one batch.
    pub fn eval_first_batch(&self, u: &[f64], v: &[f64]) -> Vec<Option<ScreenSample>> {
        self.batch(
            u,
            v,
            |u, v, out| self.surf.eval_first_batch(u, v, out),
            Self::from_sample_first,
        )
    }

    /// Evaluate at one point (counted).
    #[inline]
    pub fn eval(&self, u: f64, v: f64) -> Option<ScreenSample> {
        self.evals.fetch_add(1, Ordering::Relaxed);
        let p = self.surf.eval(u, v);
        self.from_sample(u, v, p)
    }

    /// Evaluate at many points in one batch (counted).
    pub fn eval_batch(&self, u: &[f64], v: &[f64]) -> Vec<Option<ScreenSample>> {
        self.batch(
            u,
            v,
            |u, v, out| self.surf.eval_batch(u, v, out),
            Self::from_sample,
        )
    }

    /// One counted batch: `fill` evaluates the surface, `finish` takes each
    /// point to the screen.
    fn batch(
        &self,
        u: &[f64],
        v: &[f64],
        fill: impl FnOnce(&[f64], &[f64], &mut [ParamSample]),
        finish: impl Fn(&Self, f64, f64, ParamSample) -> Option<ScreenSample>,
    ) -> Vec<Option<ScreenSample>> {
        self.evals.fetch_add(u.len() as u64, Ordering::Relaxed);
        let mut out = vec![ParamSample::default(); u.len()];
        fill(u, v, &mut out);
        out.into_iter()
            .zip(u.iter().zip(v))
            .map(|(p, (&u, &v))| finish(self, u, v, p))
            .collect()
    }

    /// Newton iterations of many points in lockstep: each round evaluates
    /// every unfinished point in one batch (one call per round for a
    /// Python-callable surface), then `step(round, sample, u, v, state)`
    /// gives the point's next (u, v, state), or `None` when it is done or
    /// has failed. Points whose evaluation fails are dropped.
    pub fn lockstep<T: Copy>(
        &self,
        mut active: Vec<(f64, f64, T)>,
        rounds: u32,
        first_order: bool,
        mut step: impl FnMut(u32, &ScreenSample, f64, f64, T) -> Option<(f64, f64, T)>,
    ) {
        let (mut bu, mut bv) = (Vec::new(), Vec::new());
        for round in 0..rounds {
            if active.is_empty() {
                break;
            }
            bu.clear();
            bv.clear();
            bu.extend(active.iter().map(|a| a.0));
            bv.extend(active.iter().map(|a| a.1));
            let ss = if first_order {
                self.eval_first_batch(&bu, &bv)
            } else {
                self.eval_batch(&bu, &bv)
            };
            let mut next = Vec::with_capacity(active.len());
            for (&(u, v, t), s) in active.iter().zip(ss) {
                if let Some(n) = s.and_then(|s| step(round, &s, u, v, t)) {
                    next.push(n);
                }
            }
            active = next;
        }
    }

    /// Unit direction from a world point towards the viewer.
    #[inline]
    pub fn to_eye(&self, p: DVec3) -> DVec3 {
        if self.cam.perspective {
            (self.cam.eye - p).normalize()
        } else {
            -self.cam.d
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Projection, View};
    use crate::parametric::shapes;

    /// Finite differences of the screen functions agree with the chain rule.
    #[test]
    fn derivatives_match_finite_differences() {
        let surf = shapes::torus(2.0, 0.7);
        for proj in [
            Projection::Orthographic { view_height: 7.0 },
            Projection::Perspective {
                distance: 9.0,
                fov: 40.0,
            },
        ] {
            let view = View {
                elevation: 35.0,
                azimuth: 20.0,
                projection: proj,
                target: DVec3::new(0.1, -0.2, 0.0),
            };
            let cam = Camera::new(&view, 300, 200).unwrap();
            let sc = Screen::new(&surf, &cam);
            let (u, v) = (0.7, 2.1);
            let h = 1e-5;
            let s = sc.eval(u, v).unwrap();
            let su = sc.eval(u + h, v).unwrap();
            let sm = sc.eval(u - h, v).unwrap();
            let tv = sc.eval(u, v + h).unwrap();
            let tm = sc.eval(u, v - h).unwrap();
            let rel = |a: f64, b: f64| (a - b).abs() / (1.0 + b.abs());
            assert!(rel((su.x - sm.x) / (2.0 * h), s.xu) < 1e-6);
            assert!(rel((tv.y - tm.y) / (2.0 * h), s.yv) < 1e-6);
            assert!(rel((su.z - sm.z) / (2.0 * h), s.zu) < 1e-6);
            assert!(rel((su.xu - sm.xu) / (2.0 * h), s.xuu) < 1e-5);
            assert!(rel((tv.yu - tm.yu) / (2.0 * h), s.yuv) < 1e-5);
            assert!(rel((tv.yv - tm.yv) / (2.0 * h), s.yvv) < 1e-5);
            let (ju, jv) = s.jac_grad();
            assert!(rel((su.jac() - sm.jac()) / (2.0 * h), ju) < 1e-5);
            assert!(rel((tv.jac() - tm.jac()) / (2.0 * h), jv) < 1e-5);
            // The first-order evaluation agrees to first order.
            let f = sc.eval_first(u, v).unwrap();
            for (a, b) in [
                (f.x, s.x),
                (f.y, s.y),
                (f.z, s.z),
                (f.xu, s.xu),
                (f.xv, s.xv),
            ] {
                assert!(rel(a, b) < 1e-12, "{a} {b}");
            }
            for (a, b) in [(f.yu, s.yu), (f.yv, s.yv), (f.zu, s.zu), (f.zv, s.zv)] {
                assert!(rel(a, b) < 1e-12, "{a} {b}");
            }
            // Bit for bit: the sampled scan completes first-order pixel
            // solves to second order and relies on the two agreeing.
            for (a, b) in [
                (f.x, s.x),
                (f.y, s.y),
                (f.z, s.z),
                (f.xu, s.xu),
                (f.xv, s.xv),
                (f.yu, s.yu),
                (f.yv, s.yv),
                (f.zu, s.zu),
                (f.zv, s.zv),
            ] {
                assert_eq!(a.to_bits(), b.to_bits());
            }
            assert!(f.p.pu == s.p.pu && f.p.pv == s.p.pv && f.p.p == s.p.p);
            assert!(f.xuu.is_nan() && f.yvv.is_nan());
            // Screen position agrees with the camera's projection.
            let q = cam.to_screen(s.p.p);
            assert!((q.x - s.x).abs() < 1e-9 && (q.y - s.y).abs() < 1e-9);
        }
    }
}
