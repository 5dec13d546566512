//! What a renderer needs of a surface. Sources (expressions, height grids,
//! Python callables) implement these traits; renderers never know which.
//! Non-finite values mark holes.

use crate::error::{FcolError, Result};
use glam::DVec3;

/// A rectangle [u0, u1] × [v0, v1] of parameter space (u0 < u1, v0 < v1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Domain {
    pub u0: f64,
    pub u1: f64,
    pub v0: f64,
    pub v1: f64,
}

impl Domain {
    pub fn new(u0: f64, u1: f64, v0: f64, v1: f64) -> Result<Domain> {
        if !(u0.is_finite() && u1.is_finite() && v0.is_finite() && v1.is_finite()) {
            return Err(FcolError::value("domain", "bounds must be finite"));
        }
        if u0 >= u1 || v0 >= v1 {
            return Err(FcolError::value(
                "domain",
                format!("expected ((u0, u1), (v0, v1)) with u0 < u1 and v0 < v1, got (({u0}, {u1}), ({v0}, {v1}))"),
            ));
        }
        Ok(Domain { u0, u1, v0, v1 })
    }
    #[inline]
    pub fn contains(&self, u: f64, v: f64) -> bool {
        u >= self.u0 && u <= self.u1 && v >= self.v0 && v <= self.v1
    }
}

/// x − x: 0 for finite x, NaN for ±∞ and NaN (x is finite exactly when
/// this is 0: a test without class checks, and sums of it test several).
#[inline(always)]
#[allow(clippy::eq_op)]
pub(crate) fn finite_zero(x: f64) -> f64 {
    x - x
}

/// f and its first partial derivatives at a point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HeightSample {
    pub f: f64,
    pub fu: f64,
    pub fv: f64,
}

impl HeightSample {
    #[inline]
    pub fn is_finite(&self) -> bool {
        // One comparison for the three (cheaper than three class tests).
        finite_zero(self.f) + finite_zero(self.fu) + finite_zero(self.fv) == 0.0
    }
    /// Unit upper-side normal (−f_u, −f_v, 1)/‖·‖ (SPEC §2).
    #[inline]
    pub fn normal(&self) -> DVec3 {
        DVec3::new(-self.fu, -self.fv, 1.0).normalize()
    }
}

/// A function surface w = f(u, v) over its domain.
pub trait HeightField: Sync {
    fn domain(&self) -> Domain;

    /// Evaluate f, f_u, f_v at many points (the batch form lets callable
    /// sources make one call per batch). `out.len() == u.len() == v.len()`;
    /// every element of `out` is written (NaN where f is undefined).
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [HeightSample]);

    /// Evaluate at one point.
    fn eval(&self, u: f64, v: f64) -> HeightSample {
        let mut out = [HeightSample::default()];
        self.eval_batch(&[u], &[v], &mut out);
        out[0]
    }

    /// True when single-point evaluation is cheap (compiled expressions,
    /// grids); false for sources that cross into Python per call.
    fn cheap_point_eval(&self) -> bool {
        true
    }

    /// Evaluate f alone at many points (sources override this when the
    /// value is cheaper than the value with its gradient).
    fn eval_value_batch(&self, u: &[f64], v: &[f64], out: &mut [f64]) {
        let mut tmp = vec![HeightSample::default(); u.len()];
        self.eval_batch(u, v, &mut tmp);
        for (o, s) in out.iter_mut().zip(&tmp) {
            *o = s.f;
        }
    }

    /// Bounds (lo, hi) of every finite value of f over the domain (None:
    /// unknown). A bound may be loose but is never too narrow: the
    /// renderers stop a sweep where it shows that nothing further can be
    /// seen.
    fn height_bound(&self) -> Option<(f64, f64)> {
        None
    }

    /// An upper bound of every finite value of f over the part of the
    /// domain in [u0, u1] × [v0, v1] (−∞: none there), where the source
    /// keeps local bounds cheaply (grids); None: only the global bound of
    /// [`Self::height_bound`].
    fn height_max_in(&self, _u0: f64, _u1: f64, _v0: f64, _v1: f64) -> Option<f64> {
        None
    }

    /// Bounds (lo, hi) of every finite value of f over the part of the
    /// domain in [u0, u1] × [v0, v1] (lo > hi: no finite value there;
    /// None: unknown): by default the global bound of
    /// [`Self::height_bound`] with the local maximum of
    /// [`Self::height_max_in`]; expressions bound the box itself.
    fn height_range_in(&self, u0: f64, u1: f64, v0: f64, v1: f64) -> Option<(f64, f64)> {
        let (lo, hi) = self.height_bound()?;
        let hi = self.height_max_in(u0, u1, v0, v1).map_or(hi, |m| m.min(hi));
        Some((lo, hi))
    }

    /// Evaluate f alone at one point.
    fn eval_value(&self, u: f64, v: f64) -> f64 {
        let mut out = [0.0];
        self.eval_value_batch(&[u], &[v], &mut out);
        out[0]
    }
}

/// A parametric surface point with first and second derivatives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ParamSample {
    pub p: DVec3,
    pub pu: DVec3,
    pub pv: DVec3,
    pub puu: DVec3,
    pub puv: DVec3,
    pub pvv: DVec3,
}

impl ParamSample {
    pub fn is_finite(&self) -> bool {
        self.p.is_finite() && self.pu.is_finite() && self.pv.is_finite()
    }
}

/// A parametric surface (X, Y, Z)(u, v) over its domain.
pub trait ParametricSurface: Sync {
    fn domain(&self) -> Domain;
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [ParamSample]);
    fn eval(&self, u: f64, v: f64) -> ParamSample {
        let mut out = [ParamSample::default()];
        self.eval_batch(&[u], &[v], &mut out);
        out[0]
    }
    fn cheap_point_eval(&self) -> bool {
        true
    }

    /// Evaluate P, P_u, P_v only; the second derivatives of `out` are left
    /// unspecified (sources override this when it is cheaper than
    /// [`eval_batch`](Self::eval_batch)).
    fn eval_first_batch(&self, u: &[f64], v: &[f64], out: &mut [ParamSample]) {
        self.eval_batch(u, v, out)
    }

    /// Evaluate P, P_u, P_v at one point (second derivatives unspecified).
    fn eval_first(&self, u: f64, v: f64) -> ParamSample {
        let mut out = [ParamSample::default()];
        self.eval_first_batch(&[u], &[v], &mut out);
        out[0]
    }

    /// Evaluate the point P alone at many points.
    fn eval_point_batch(&self, u: &[f64], v: &[f64], out: &mut [DVec3]) {
        let mut tmp = vec![ParamSample::default(); u.len()];
        self.eval_first_batch(u, v, &mut tmp);
        for (o, s) in out.iter_mut().zip(&tmp) {
            *o = s.p;
        }
    }
}

/// A height field from Rust closures (for tests and Rust users):
/// `f(u, v) -> [f, f_u, f_v]`.
pub struct FnHeight<F: Fn(f64, f64) -> [f64; 3] + Sync> {
    pub domain: Domain,
    pub f: F,
}

impl<F: Fn(f64, f64) -> [f64; 3] + Sync> HeightField for FnHeight<F> {
    fn domain(&self) -> Domain {
        self.domain
    }
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [HeightSample]) {
        for ((o, &u), &v) in out.iter_mut().zip(u).zip(v) {
            let [f, fu, fv] = (self.f)(u, v);
            *o = HeightSample { f, fu, fv };
        }
    }
}

/// A parametric surface from a Rust closure (for tests and Rust users).
pub struct FnParametric<F: Fn(f64, f64) -> ParamSample + Sync> {
    pub domain: Domain,
    pub f: F,
}

impl<F: Fn(f64, f64) -> ParamSample + Sync> ParametricSurface for FnParametric<F> {
    fn domain(&self) -> Domain {
        self.domain
    }
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [ParamSample]) {
        for ((o, &u), &v) in out.iter_mut().zip(u).zip(v) {
            *o = (self.f)(u, v);
        }
    }
}
