//! Surfaces defined by expressions: w = f(u, v) and (X, Y, Z)(u, v), with
//! exact derivatives from the expression engine ([`crate::expr`]).

use crate::error::{FcolError, Result};
use crate::expr::{Compiled, Program, ValueBound};
use crate::surface::{Domain, HeightField, HeightSample, ParamSample, ParametricSurface};
use glam::DVec3;
use std::sync::Arc;

/// Parameter values in the order of [`Compiled::params`] (`t` first), from
/// `(name, value)` pairs. Unknown names are errors naming them; missing
/// names (other than `t`, default 0) too.
pub fn param_values(c: &Compiled, t: f64, given: &[(String, f64)]) -> Result<Vec<f64>> {
    let names = c.params();
    let mut values = vec![f64::NAN; names.len()];
    values[0] = t;
    for (name, x) in given {
        let Some(i) = names.iter().position(|n| n == name) else {
            return Err(FcolError::value(
                "params",
                format!(
                    "unknown parameter {name:?} (the parameters are {:?})",
                    &names[1..]
                ),
            ));
        };
        if !x.is_finite() {
            return Err(FcolError::value(
                "params",
                format!("{name:?} must be finite, got {x}"),
            ));
        }
        values[i] = *x;
    }
    if !t.is_finite() {
        return Err(FcolError::value("t", format!("must be finite, got {t}")));
    }
    let missing: Vec<&String> = names
        .iter()
        .zip(&values)
        .filter(|(_, x)| x.is_nan())
        .map(|(n, _)| n)
        .collect();
    if !missing.is_empty() {
        return Err(FcolError::value(
            "params",
            format!("missing value for parameter(s) {missing:?}"),
        ));
    }
    Ok(values)
}

/// Batches up to this size are evaluated point by point (faster than a
/// chunk pass for so few points; identical results).
const SMALL: usize = 2;

/// `values` with some parameters (or `t`) changed; unknown names and
/// non-finite values are errors naming them.
fn changed_values(c: &Compiled, values: &[f64], changes: &[(String, f64)]) -> Result<Vec<f64>> {
    let mut values = values.to_vec();
    for (name, x) in changes {
        let Some(i) = c.params().iter().position(|n| n == name) else {
            return Err(FcolError::value(
                "params",
                format!(
                    "unknown parameter {name:?} (the parameters are t and {:?})",
                    &c.params()[1..]
                ),
            ));
        };
        if !x.is_finite() {
            return Err(FcolError::value(
                name.as_str(),
                format!("must be finite, got {x}"),
            ));
        }
        values[i] = *x;
    }
    Ok(values)
}

/// Compiled expression(s) and the parameter values bound to them, `t`
/// first (rebinding never re-parses).
#[derive(Clone)]
struct Bound {
    compiled: Arc<Compiled>,
    values: Vec<f64>,
}

impl Bound {
    /// Compile `exprs` to derivative order `order`; every parameter must
    /// appear in them (else the error `unused(name)`).
    fn new(
        exprs: &[&str],
        params: &[(String, f64)],
        t: f64,
        order: u8,
        unused: impl Fn(&str) -> String,
    ) -> Result<Self> {
        let names: Vec<&str> = params.iter().map(|(n, _)| n.as_str()).collect();
        let c = Compiled::new(exprs, &names, order)?;
        for n in &names {
            if !c.uses(n) {
                return Err(FcolError::value("params", unused(n)));
            }
        }
        let values = param_values(&c, t, params)?;
        Ok(Bound {
            compiled: Arc::new(c),
            values,
        })
    }

    /// The same expression(s) with some values changed.
    fn changed(&self, changes: &[(String, f64)]) -> Result<Self> {
        Ok(Bound {
            compiled: self.compiled.clone(),
            values: changed_values(&self.compiled, &self.values, changes)?,
        })
    }

    /// (name, value) of every parameter, `t` first.
    fn params(&self) -> Vec<(String, f64)> {
        self.compiled
            .params()
            .iter()
            .cloned()
            .zip(self.values.iter().copied())
            .collect()
    }

    /// The program of derivative order `order` at these values.
    fn program(&self, order: u8) -> Arc<Program> {
        Arc::new(self.compiled.program(&self.values, order))
    }
}

/// Evaluate a tiny batch (at most [`SMALL`] points) point by point with
/// `eval`; false (nothing done) for a larger one.
fn small_batch<T>(u: &[f64], v: &[f64], out: &mut [T], eval: impl Fn(f64, f64) -> T) -> bool {
    if u.len() > SMALL {
        return false;
    }
    for ((o, &u), &v) in out.iter_mut().zip(u).zip(v) {
        *o = eval(u, v);
    }
    true
}

/// w = f(u, v) from an expression: a program for (f, f_u, f_v) and one for f
/// alone, bound to parameter values (rebinding never re-parses).
#[derive(Clone)]
pub struct ExprHeight {
    bound: Bound,
    domain: Domain,
    grad: Arc<Program>,
    value: Arc<Program>,
    /// Interval bounds of f over the domain (None: unbounded).
    range: Option<(f64, f64)>,
    /// f's value DAG, for bounds over parts of the domain.
    bounder: Arc<ValueBound>,
}

impl ExprHeight {
    /// Compile `expr` with parameters `params` (name, value) and time `t`.
    pub fn new(expr: &str, params: &[(String, f64)], t: f64, domain: Domain) -> Result<Self> {
        let bound = Bound::new(&[expr], params, t, 1, |n| {
            format!("parameter {n:?} does not appear in the expression {expr:?}")
        })?;
        Ok(Self::bind(bound, domain))
    }

    fn bind(bound: Bound, domain: Domain) -> Self {
        let bounder = Arc::new(bound.compiled.value_bounder(&bound.values, 0));
        let d = domain;
        // (None where f is NaN everywhere, as where a bound is infinite)
        let range = box_range(&bounder, d, (d.u0, d.u1), (d.v0, d.v1)).filter(|(lo, hi)| lo <= hi);
        ExprHeight {
            grad: bound.program(1),
            value: bound.program(0),
            range,
            bounder,
            bound,
            domain,
        }
    }

    /// The same compiled expression with some parameter values (or `t`)
    /// changed.
    pub fn with_values(&self, changes: &[(String, f64)]) -> Result<Self> {
        Ok(Self::bind(self.bound.changed(changes)?, self.domain))
    }

    pub fn compiled(&self) -> &Arc<Compiled> {
        &self.bound.compiled
    }
    /// (name, value) of every parameter, `t` first.
    pub fn params(&self) -> Vec<(String, f64)> {
        self.bound.params()
    }
    pub fn expr(&self) -> &str {
        &self.bound.compiled.sources()[0]
    }
    /// The (f, f_u, f_v) program.
    pub fn program(&self) -> &Program {
        &self.grad
    }
}

/// Interval bounds of the value over the box `u` × `v` of `domain`,
/// widened by 1e-9 of the domain's size (for evaluations a rounding
/// outside): (+∞, −∞) where f is NaN everywhere there, None where a bound
/// is infinite.
fn box_range(b: &ValueBound, d: Domain, u: (f64, f64), v: (f64, f64)) -> Option<(f64, f64)> {
    let (pu, pv) = (1e-9 * (d.u1 - d.u0), 1e-9 * (d.v1 - d.v0));
    let iv = b.over((u.0 - pu, u.1 + pu), (v.0 - pv, v.1 + pv));
    if iv.is_empty() {
        return Some((f64::INFINITY, f64::NEG_INFINITY));
    }
    (iv.lo.is_finite() && iv.hi.is_finite()).then_some((iv.lo, iv.hi))
}

impl HeightField for ExprHeight {
    fn domain(&self) -> Domain {
        self.domain
    }
    fn height_bound(&self) -> Option<(f64, f64)> {
        self.range
    }
    fn height_range_in(&self, u0: f64, u1: f64, v0: f64, v1: f64) -> Option<(f64, f64)> {
        box_range(&self.bounder, self.domain, (u0, u1), (v0, v1))
    }
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [HeightSample]) {
        // Tiny batches take the one-point path (same results, bit for bit).
        if small_batch(u, v, out, |u, v| self.eval(u, v)) {
            return;
        }
        self.grad.eval_chunks(u, v, |start, cols| {
            let (f, fu, fv) = (cols[0], cols[1], cols[2]);
            let vals = f.iter().zip(fu).zip(fv);
            for (o, ((&f, &fu), &fv)) in out[start..start + f.len()].iter_mut().zip(vals) {
                *o = HeightSample { f, fu, fv };
            }
        });
    }
    #[inline]
    fn eval(&self, u: f64, v: f64) -> HeightSample {
        let mut r = [0.0; 3];
        self.grad.eval_point(u, v, &mut r);
        HeightSample {
            f: r[0],
            fu: r[1],
            fv: r[2],
        }
    }
    fn eval_value_batch(&self, u: &[f64], v: &[f64], out: &mut [f64]) {
        self.value.eval_into(u, v, &mut [out]);
    }
    #[inline]
    fn eval_value(&self, u: f64, v: f64) -> f64 {
        let mut r = [0.0];
        self.value.eval_point(u, v, &mut r);
        r[0]
    }
}

/// (X, Y, Z)(u, v) from three expressions sharing one parameter table, with
/// exact first and second derivatives.
#[derive(Clone)]
pub struct ExprParametric {
    bound: Bound,
    domain: Domain,
    second: Arc<Program>,
    first: Arc<Program>,
    point: Arc<Program>,
}

impl ExprParametric {
    pub fn new(exprs: [&str; 3], params: &[(String, f64)], t: f64, domain: Domain) -> Result<Self> {
        let bound = Bound::new(&exprs, params, t, 2, |n| {
            format!("parameter {n:?} appears in none of x, y, z")
        })?;
        Ok(Self::bind(bound, domain))
    }

    fn bind(bound: Bound, domain: Domain) -> Self {
        ExprParametric {
            second: bound.program(2),
            first: bound.program(1),
            point: bound.program(0),
            bound,
            domain,
        }
    }

    pub fn with_values(&self, changes: &[(String, f64)]) -> Result<Self> {
        Ok(Self::bind(self.bound.changed(changes)?, self.domain))
    }

    pub fn params(&self) -> Vec<(String, f64)> {
        self.bound.params()
    }
    pub fn exprs(&self) -> &[String] {
        self.bound.compiled.sources()
    }
}

#[inline]
fn v3(c: &[&[f64]], k: usize, i: usize) -> DVec3 {
    DVec3::new(c[k][i], c[k + 1][i], c[k + 2][i])
}

// Program output order: for X, Y, Z in turn: value, d/du, d/dv, d²/du²,
// d²/dudv, d²/dv² (order 2), so component e of derivative q is at e*per + q.
fn gather(c: &[&[f64]], per: usize, q: usize, i: usize) -> DVec3 {
    DVec3::new(c[q][i], c[per + q][i], c[2 * per + q][i])
}

impl ParametricSurface for ExprParametric {
    fn domain(&self) -> Domain {
        self.domain
    }
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [ParamSample]) {
        if small_batch(u, v, out, |u, v| self.eval(u, v)) {
            return;
        }
        self.second.eval_chunks(u, v, |start, c| {
            for (i, o) in out[start..start + c[0].len()].iter_mut().enumerate() {
                *o = ParamSample {
                    p: gather(c, 6, 0, i),
                    pu: gather(c, 6, 1, i),
                    pv: gather(c, 6, 2, i),
                    puu: gather(c, 6, 3, i),
                    puv: gather(c, 6, 4, i),
                    pvv: gather(c, 6, 5, i),
                };
            }
        });
    }
    fn eval(&self, u: f64, v: f64) -> ParamSample {
        let mut r = [0.0; 18];
        self.second.eval_point(u, v, &mut r);
        let g = |q: usize| DVec3::new(r[q], r[6 + q], r[12 + q]);
        ParamSample {
            p: g(0),
            pu: g(1),
            pv: g(2),
            puu: g(3),
            puv: g(4),
            pvv: g(5),
        }
    }
    fn eval_first_batch(&self, u: &[f64], v: &[f64], out: &mut [ParamSample]) {
        if small_batch(u, v, out, |u, v| self.eval_first(u, v)) {
            return;
        }
        self.first.eval_chunks(u, v, |start, c| {
            for (i, o) in out[start..start + c[0].len()].iter_mut().enumerate() {
                o.p = gather(c, 3, 0, i);
                o.pu = gather(c, 3, 1, i);
                o.pv = gather(c, 3, 2, i);
            }
        });
    }
    fn eval_first(&self, u: f64, v: f64) -> ParamSample {
        let mut r = [0.0; 9];
        self.first.eval_point(u, v, &mut r);
        let g = |q: usize| DVec3::new(r[q], r[3 + q], r[6 + q]);
        ParamSample {
            p: g(0),
            pu: g(1),
            pv: g(2),
            ..Default::default()
        }
    }
    fn eval_point_batch(&self, u: &[f64], v: &[f64], out: &mut [DVec3]) {
        self.point.eval_chunks(u, v, |start, c| {
            for (i, o) in out[start..start + c[0].len()].iter_mut().enumerate() {
                *o = v3(c, 0, i);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bounds over parts of the domain that the sweeps step over
    /// stretches by: every finite value sampled in a box lies inside its
    /// bound, and small boxes get bounds near the values' own range (far
    /// tighter than the domain's).
    #[test]
    fn local_bounds_hold_and_tighten() {
        let d = Domain::new(-5.0, 5.0, -5.0, 5.0).unwrap();
        let mut rnd = crate::test_rng::uniform(11);
        for src in [
            "3*sin(u*cos(v))",
            "exp(-(u*u + v*v)) + 0.1*u",
            "log(u*u + v*v)",
            "sqrt(u) + v",
        ] {
            let h = ExprHeight::new(src, &[], 0.0, d).unwrap();
            for size in [10.0, 1.0, 0.01] {
                for _ in 0..50 {
                    let (u0, v0) = (-5.0 + (10.0 - size) * rnd(), -5.0 + (10.0 - size) * rnd());
                    let (u1, v1) = (u0 + size * rnd(), v0 + size * rnd());
                    let Some((lo, hi)) = h.height_range_in(u0, u1, v0, v1) else {
                        continue;
                    };
                    for _ in 0..40 {
                        let f = h.eval(u0 + (u1 - u0) * rnd(), v0 + (v1 - v0) * rnd()).f;
                        if f.is_finite() {
                            assert!(lo <= f && f <= hi, "{src}: {f} outside [{lo}, {hi}]");
                        }
                    }
                    if size == 0.01 && src.starts_with('3') {
                        // (|∇f| ≤ 15 here: a box 0.01 wide spans at most 0.3)
                        assert!(hi - lo < 0.5, "{src}: [{lo}, {hi}] over a box of {size}");
                    }
                }
            }
        }
    }

    #[test]
    fn batch_and_point_paths_agree_bit_for_bit() {
        let d = Domain::new(-2.0, 2.0, -2.0, 2.0).unwrap();
        let h = ExprHeight::new("3*sin(u*cos(v)) + exp(-u*v)", &[], 0.0, d).unwrap();
        let p =
            ExprParametric::new(["u*cos(v)", "u*sin(v)", "log(1 + u*u)*v"], &[], 0.0, d).unwrap();
        for n in [1usize, 2, 3, 7, 300] {
            let u: Vec<f64> = (0..n).map(|i| -1.9 + 0.0123 * i as f64).collect();
            let v: Vec<f64> = (0..n).map(|i| 1.7 - 0.0101 * i as f64).collect();
            let mut hs = vec![HeightSample::default(); n];
            h.eval_batch(&u, &v, &mut hs);
            let mut ps = vec![ParamSample::default(); n];
            p.eval_batch(&u, &v, &mut ps);
            let mut vals = vec![0.0; n];
            h.eval_value_batch(&u, &v, &mut vals);
            for i in 0..n {
                assert_eq!(hs[i], h.eval(u[i], v[i]));
                assert_eq!(vals[i].to_bits(), hs[i].f.to_bits());
                assert_eq!(ps[i], p.eval(u[i], v[i]));
                assert_eq!(p.eval_first(u[i], v[i]).pu, ps[i].pu);
            }
        }
    }
}
