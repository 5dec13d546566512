//! Interval bounds of an expression over a box of (u, v): every value the
//! compiled evaluation can return there, other than NaN, lies in the bound.
//!
//! Natural interval extension over the extended reals (bounds may be ±∞),
//! each node of the DAG from its operands' bounds; an empty bound means the
//! node is NaN everywhere on the box (e.g. `sqrt` of a negative interval),
//! which propagates as NaN does. Each result is widened outwards by a few
//! ulps of its magnitude, so that the rounding of the point evaluation (and
//! the one-ulp accuracy of the batch kernels' sin, cos, exp and log) stays
//! inside: a bound is never too narrow, though it may be wide (the
//! dependency problem of interval arithmetic: `x - x` over [0, 1] gives
//! [−1, 1]). The renderers use it to stop a sweep when nothing further can
//! become visible.

use super::graph::{Bin, Graph, Id, Node, Un};
use std::f64::consts::{FRAC_PI_2, PI};

/// A closed interval [lo, hi] of the extended reals; empty when lo > hi.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iv {
    pub lo: f64,
    pub hi: f64,
}

const EMPTY: Iv = Iv {
    lo: f64::INFINITY,
    hi: f64::NEG_INFINITY,
};
const WHOLE: Iv = Iv {
    lo: f64::NEG_INFINITY,
    hi: f64::INFINITY,
};
/// Outward widening of every result, relative to its magnitude (16 ulps).
const REL: f64 = 1.0 / (1u64 << 48) as f64;

impl Iv {
    pub fn new(lo: f64, hi: f64) -> Iv {
        Iv { lo, hi }.fix()
    }
    fn point(x: f64) -> Iv {
        if x.is_nan() {
            EMPTY
        } else {
            Iv { lo: x, hi: x }
        }
    }
    pub fn is_empty(&self) -> bool {
        self.lo > self.hi || self.lo.is_nan() || self.hi.is_nan()
    }
    fn contains(&self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }
    /// A NaN end (0·∞, ∞ − ∞) becomes unbounded on its side; reversed ends
    /// (from a monotone map) are ordered.
    fn fix(self) -> Iv {
        let lo = if self.lo.is_nan() {
            f64::NEG_INFINITY
        } else {
            self.lo
        };
        let hi = if self.hi.is_nan() {
            f64::INFINITY
        } else {
            self.hi
        };
        Iv { lo, hi }
    }
    /// Widened outwards by `rel` of its magnitude plus `abs`.
    fn widen(self, rel: f64, abs: f64) -> Iv {
        if self.is_empty() {
            return EMPTY;
        }
        let m = rel * self.lo.abs().max(self.hi.abs());
        let m = if m.is_finite() { m + abs } else { abs };
        Iv {
            lo: self.lo - m,
            hi: self.hi + m,
        }
    }
    /// The image under a non-decreasing function.
    fn up(self, f: impl Fn(f64) -> f64) -> Iv {
        if self.is_empty() {
            return EMPTY;
        }
        Iv {
            lo: f(self.lo),
            hi: f(self.hi),
        }
        .fix()
    }
    /// The image under a non-increasing function.
    fn down(self, f: impl Fn(f64) -> f64) -> Iv {
        if self.is_empty() {
            return EMPTY;
        }
        Iv {
            lo: f(self.hi),
            hi: f(self.lo),
        }
        .fix()
    }
    fn union(self, o: Iv) -> Iv {
        Iv {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }
    /// Intersection with [a, b] (the part of a function's domain).
    fn clip(self, a: f64, b: f64) -> Iv {
        let r = Iv {
            lo: self.lo.max(a),
            hi: self.hi.min(b),
        };
        if r.is_empty() {
            EMPTY
        } else {
            r
        }
    }
    fn abs(self) -> Iv {
        if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            Iv {
                lo: -self.hi,
                hi: -self.lo,
            }
        } else {
            Iv {
                lo: 0.0,
                hi: (-self.lo).max(self.hi),
            }
        }
    }
    fn mul(self, o: Iv) -> Iv {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        if p.iter().any(|x| x.is_nan()) {
            // 0 · ∞: any value.
            return WHOLE;
        }
        Iv {
            lo: p.iter().copied().fold(f64::INFINITY, f64::min),
            hi: p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
    fn recip(self) -> Iv {
        if self.contains(0.0) {
            WHOLE
        } else {
            self.down(|x| 1.0 / x)
        }
    }
    /// x^n for an integer n (repeated multiplication, as the evaluation:
    /// x^0 is 1 even for NaN; otherwise empty stays empty).
    fn powi(self, n: i32) -> Iv {
        let m = n.unsigned_abs() as i32;
        let p = if m == 0 {
            Iv::point(1.0)
        } else if m % 2 == 1 {
            self.up(|x| x.powi(m))
        } else {
            self.abs().up(|x| x.powi(m))
        };
        if n < 0 {
            p.widen(REL, 0.0).recip()
        } else {
            p
        }
    }
    /// A 2π-periodic f with values in [−1, 1], maxima at `max_at` + 2kπ and
    /// minima at `min_at` + 2kπ (sin, cos).
    fn periodic(self, f: impl Fn(f64) -> f64, max_at: f64, min_at: f64) -> Iv {
        if !(self.lo.is_finite() && self.hi.is_finite()) || self.hi - self.lo >= 2.0 * PI {
            return Iv { lo: -1.0, hi: 1.0 };
        }
        let (fa, fb) = (f(self.lo), f(self.hi));
        let (mut lo, mut hi) = (fa.min(fb), fa.max(fb));
        // (an extremum missed by the rounding of c + 2kπ lies within an ulp
        // of an end, where f is within the widening of ±1)
        let has = |c: f64| c + 2.0 * PI * ((self.lo - c) / (2.0 * PI)).ceil() <= self.hi;
        if has(max_at) {
            hi = 1.0;
        }
        if has(min_at) {
            lo = -1.0;
        }
        // (the argument reduction's rounding grows with the argument)
        let big = self.lo.abs().max(self.hi.abs());
        Iv { lo, hi }.widen(REL, REL * (1.0 + big))
    }
}

fn un(op: Un, x: Iv) -> Iv {
    if x.is_empty() {
        return EMPTY;
    }
    let r = match op {
        Un::Neg => x.down(|t| -t),
        Un::Sin => return x.periodic(f64::sin, FRAC_PI_2, -FRAC_PI_2),
        Un::Cos => return x.periodic(f64::cos, 0.0, PI),
        Un::Tan => {
            // Monotone between poles at π/2 + kπ.
            if !(x.lo.is_finite() && x.hi.is_finite()) || x.hi - x.lo >= PI {
                return WHOLE;
            }
            let k = ((x.lo - FRAC_PI_2) / PI).ceil();
            if FRAC_PI_2 + k * PI <= x.hi + 1e-12 * (1.0 + x.hi.abs()) {
                return WHOLE;
            }
            x.up(f64::tan)
                .widen(REL, REL * (1.0 + x.lo.abs().max(x.hi.abs())))
        }
        Un::Asin => x.clip(-1.0, 1.0).up(f64::asin),
        Un::Acos => x.clip(-1.0, 1.0).down(f64::acos),
        Un::Atan => x.up(f64::atan),
        Un::Sinh => x.up(f64::sinh),
        Un::Cosh => {
            let a = x.abs();
            a.up(f64::cosh)
        }
        Un::Tanh => x.up(f64::tanh),
        Un::Exp => x.up(f64::exp),
        Un::Ln => x.clip(0.0, f64::INFINITY).up(f64::ln),
        Un::Log10 => x.clip(0.0, f64::INFINITY).up(f64::log10),
        Un::Sqrt => x.clip(0.0, f64::INFINITY).up(f64::sqrt),
        Un::Abs => x.abs(),
        Un::Floor => x.up(f64::floor),
        Un::Ceil => x.up(f64::ceil),
        Un::Sign => x.up(super::graph::scalar::sign),
    };
    r.widen(REL, 0.0)
}

fn bin(op: Bin, a: Iv, b: Iv) -> Iv {
    if a.is_empty() || b.is_empty() {
        return EMPTY;
    }
    let r = match op {
        Bin::Add => Iv {
            lo: a.lo + b.lo,
            hi: a.hi + b.hi,
        }
        .fix(),
        Bin::Sub => Iv {
            lo: a.lo - b.hi,
            hi: a.hi - b.lo,
        }
        .fix(),
        Bin::Mul => a.mul(b),
        Bin::Div => a.mul(b.recip()),
        Bin::Pow => {
            // a^b = exp(b ln a) for a > 0; otherwise (negative bases with
            // integral exponents, zero) no bound is attempted.
            if a.lo > 0.0 {
                let l = a.up(f64::ln).widen(REL, 0.0);
                l.mul(b).widen(REL, 0.0).up(f64::exp)
            } else {
                WHOLE
            }
        }
        Bin::Atan2 => Iv { lo: -PI, hi: PI },
        Bin::Min => Iv {
            lo: a.lo.min(b.lo),
            hi: a.hi.min(b.hi),
        },
        Bin::Max => Iv {
            lo: a.lo.max(b.lo),
            hi: a.hi.max(b.hi),
        },
        Bin::Hypot => {
            let (x, y) = (a.abs(), b.abs());
            Iv {
                lo: x.lo.hypot(y.lo),
                hi: x.hi.hypot(y.hi),
            }
        }
    };
    r.widen(REL, 0.0)
}

/// x^c for a constant non-integer c: NaN for x < 0.
fn powf(x: Iv, c: f64) -> Iv {
    if x.is_empty() {
        return EMPTY;
    }
    let x = x.clip(0.0, f64::INFINITY);
    if x.is_empty() {
        return EMPTY;
    }
    let r = if c >= 0.0 {
        x.up(|t| t.powf(c))
    } else {
        x.down(|t| t.powf(c))
    };
    r.widen(REL, 0.0)
}

/// Bounds of `root` (a node of `g`, parameters bound) for u in `u` and v in
/// `v`. Empty: NaN everywhere there.
pub fn bound(g: &Graph, root: Id, u: (f64, f64), v: (f64, f64)) -> Iv {
    let mut iv: Vec<Iv> = Vec::with_capacity(root as usize + 1);
    for n in &g.nodes[..=root as usize] {
        let at = |i: Id| iv[i as usize];
        let r = match *n {
            Node::Const(c) => Iv::point(c),
            Node::Input(0) => Iv::new(u.0, u.1),
            Node::Input(_) => Iv::new(v.0, v.1),
            // (bound before evaluation; unbound, anything)
            Node::Param(_) => WHOLE,
            Node::Un(op, a) => un(op, at(a)),
            // x·x is a square (no dependency problem).
            Node::Bin(Bin::Mul, a, b) if a == b => at(a).powi(2).widen(REL, 0.0),
            Node::Bin(op, a, b) => bin(op, at(a), at(b)),
            Node::PowI(a, k) => at(a)
                .powi(k)
                .widen(REL * (1.0 + k.unsigned_abs() as f64), 0.0),
            Node::PowF(a, c) => powf(at(a), c),
            // The condition's NaN does not propagate: either branch.
            Node::Select(_, _, x, y) => at(x).union(at(y)),
        };
        iv.push(r);
    }
    iv[root as usize]
}

#[cfg(test)]
mod tests {
    use crate::expr::Compiled;

    /// The bound of `src` (parameter `a` = 0.7, t = 0.3) over the box, and
    /// every value of the compiled value and gradient programs (batch and
    /// point paths) on a dense grid of it, its corners and edges included.
    fn check(src: &str, u: (f64, f64), v: (f64, f64)) -> (f64, f64) {
        let c = Compiled::new(&[src], &["a"], 1).unwrap();
        let values = [0.3, 0.7];
        let iv = c.value_bound(&values, 0, u, v);
        let n = 97;
        let (mut us, mut vs) = (Vec::new(), Vec::new());
        for i in 0..n {
            for j in 0..n {
                us.push(u.0 + (u.1 - u.0) * j as f64 / (n - 1) as f64);
                vs.push(v.0 + (v.1 - v.0) * i as f64 / (n - 1) as f64);
            }
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for order in [0u8, 1] {
            let p = c.program(&values, order);
            let k = p.n_outputs();
            let mut cols = vec![vec![0.0; us.len()]; k];
            let mut refs: Vec<&mut [f64]> = cols.iter_mut().map(|x| x.as_mut_slice()).collect();
            p.eval_into(&us, &vs, &mut refs);
            let mut pt = vec![0.0; k];
            for (m, (&x, &y)) in us.iter().zip(&vs).enumerate() {
                p.eval_point(x, y, &mut pt);
                for f in [cols[0][m], pt[0]] {
                    if f.is_nan() {
                        continue;
                    }
                    assert!(
                        iv.lo <= f && f <= iv.hi,
                        "{src} over {u:?}×{v:?}: f({x}, {y}) = {f} outside [{}, {}]",
                        iv.lo,
                        iv.hi
                    );
                    lo = lo.min(f);
                    hi = hi.max(f);
                }
            }
        }
        if lo <= hi {
            assert!(
                !iv.is_empty(),
                "{src}: empty bound of a function with values"
            );
        }
        (iv.lo, iv.hi)
    }

    #[test]
    fn bounds_hold_for_every_operation() {
        let exprs = [
            "3*sin(u*cos(v))",
            "cos(u) - sin(v)*a",
            "tan(u/4)",
            "tan(u)",
            "asin(u/3) + acos(v/3)",
            "asin(u)",
            "atan(u*v) + atan2(v, u)",
            "sinh(u) * cosh(v) - tanh(u - v)",
            "exp(-(u*u + v*v)) / (1 + u**2)",
            "log(u*u + v*v + 0.01) + log10(abs(u) + 1)",
            "log(u)",
            "sqrt(abs(u*v)) + sqrt(u)",
            "min(u, v) * max(u, -v) + hypot(u, v)",
            "floor(u) + ceil(v) * sign(u*v)",
            "u**3 - v**4 + u**-2 + (v + 5)**0.5 + abs(u)**1.7",
            "(u + 3)**v + 2**(u/2)",
            "1 / (u - v)",
            "u / (v*v + 1) - t*u",
            "(u + 1e6) - 1e6",
            "sin(1000*u) * exp(v)",
            "sin(u*u*u*100)",
        ];
        for e in exprs {
            for (u, v) in [
                ((-2.5, 2.5), (-2.5, 2.5)),
                ((0.2, 0.9), (-0.4, 0.3)),
                ((-1.0, -0.5), (1.5, 3.0)),
                ((1.0, 1.0), (0.0, 2.0)),
            ] {
                check(e, u, v);
            }
        }
    }

    #[test]
    fn bounds_are_tight_where_the_operands_are_independent() {
        let near = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + b.abs());
        let (lo, hi) = check("3*sin(u*cos(v))", (-5.0, 5.0), (-5.0, 5.0));
        assert!(near(lo, -3.0) && near(hi, 3.0), "{lo} {hi}");
        let (lo, hi) = check("u*u", (-1.0, 2.0), (0.0, 1.0));
        assert!(near(lo, 0.0) && near(hi, 4.0), "{lo} {hi}");
        let (lo, hi) = check("exp(u) + v", (0.0, 1.0), (-1.0, 1.0));
        assert!(near(lo, 0.0) && near(hi, 1f64.exp() + 1.0), "{lo} {hi}");
        let (lo, hi) = check("cos(u)", (0.5, 2.0), (0.0, 1.0));
        assert!(near(lo, 2f64.cos()) && near(hi, 0.5f64.cos()), "{lo} {hi}");
        // A parameter is a constant once bound.
        let (lo, hi) = check("a*u", (0.0, 1.0), (0.0, 1.0));
        assert!(near(lo, 0.0) && near(hi, 0.7), "{lo} {hi}");
    }

    #[test]
    fn nan_everywhere_is_an_empty_bound_and_poles_are_unbounded() {
        let c = Compiled::new(&["sqrt(-1 - u*u)"], &[], 0).unwrap();
        assert!(c.value_bound(&[0.0], 0, (-1.0, 1.0), (0.0, 1.0)).is_empty());
        let c = Compiled::new(&["1/u"], &[], 0).unwrap();
        let iv = c.value_bound(&[0.0], 0, (-1.0, 1.0), (0.0, 1.0));
        assert!(iv.lo == f64::NEG_INFINITY && iv.hi == f64::INFINITY);
        let c = Compiled::new(&["tan(u)"], &[], 0).unwrap();
        let iv = c.value_bound(&[0.0], 0, (1.0, 2.0), (0.0, 1.0));
        assert!(iv.lo == f64::NEG_INFINITY && iv.hi == f64::INFINITY);
    }
}
