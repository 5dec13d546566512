//! Batch and single-point kernels of every tape operation. Batch kernels
//! are straight loops over slices (one operation per loop) so the compiler
//! can vectorise them; the single-point forms share the same scalar code,
//! so both paths give identical results.

use super::fastmath as fm;
use super::graph::{eval_bin, eval_un, scalar, Bin, Un};

#[inline(always)]
pub fn un1(op: Un, x: f64) -> f64 {
    match op {
        Un::Sin => fm::sin_cos(x).0,
        Un::Cos => fm::sin_cos(x).1,
        Un::Exp => fm::exp(x),
        Un::Ln => fm::ln(x),
        _ => eval_un(op, x),
    }
}

#[inline]
pub fn bin1(op: Bin, a: f64, b: f64) -> f64 {
    eval_bin(op, a, b)
}

#[inline]
pub fn powf1(a: f64, k: f64) -> f64 {
    a.powf(k)
}

macro_rules! map1 {
    ($a:expr, $d:expr, |$x:ident| $body:expr) => {
        for (d, &$x) in $d.iter_mut().zip($a) {
            *d = $body;
        }
    };
}

/// Whether some x of `a` fails `ok` (one vectorised scan, so that a batch
/// with every argument in range skips the scalar fix-up loop).
#[inline(always)]
fn any_fails(a: &[f64], ok: impl Fn(f64) -> bool) -> bool {
    a.iter().fold(false, |bad, &x| bad | !ok(x))
}

/// Vectorisable pass with the fast kernel, then a scalar fix-up of the
/// (rare) arguments outside its range.
macro_rules! fast1 {
    ($a:expr, $d:expr, $fast:expr, $ok:expr, $slow:expr) => {{
        map1!($a, $d, |x| $fast(x));
        if any_fails($a, $ok) {
            for (d, &x) in $d.iter_mut().zip($a) {
                if !$ok(x) {
                    *d = $slow(x);
                }
            }
        }
    }};
}

#[inline(always)]
pub fn un(op: Un, a: &[f64], d: &mut [f64]) {
    match op {
        Un::Neg => map1!(a, d, |x| -x),
        Un::Sin => fast1!(a, d, |x| fm::sin_cos_fast(x).0, fm::sin_cos_ok, f64::sin),
        Un::Cos => fast1!(a, d, |x| fm::sin_cos_fast(x).1, fm::sin_cos_ok, f64::cos),
        Un::Exp => fast1!(a, d, fm::exp_fast, fm::exp_ok, f64::exp),
        Un::Ln => fast1!(a, d, fm::ln_fast, fm::ln_ok, f64::ln),
        Un::Sqrt => map1!(a, d, |x| x.sqrt()),
        Un::Abs => map1!(a, d, |x| x.abs()),
        Un::Floor => map1!(a, d, |x| x.floor()),
        Un::Ceil => map1!(a, d, |x| x.ceil()),
        Un::Sign => map1!(a, d, |x| scalar::sign(x)),
        _ => map1!(a, d, |x| eval_un(op, x)),
    }
}

#[inline(always)]
pub fn sin_cos(a: &[f64], s: &mut [f64], c: &mut [f64]) {
    for ((s, c), &x) in s.iter_mut().zip(c.iter_mut()).zip(a) {
        (*s, *c) = fm::sin_cos_fast(x);
    }
    if !any_fails(a, fm::sin_cos_ok) {
        return;
    }
    for ((s, c), &x) in s.iter_mut().zip(c.iter_mut()).zip(a) {
        if !fm::sin_cos_ok(x) {
            (*s, *c) = x.sin_cos();
        }
    }
}

#[inline(always)]
pub fn bin(op: Bin, a: &[f64], b: &[f64], d: &mut [f64]) {
    macro_rules! map2 {
        (|$x:ident, $y:ident| $body:expr) => {
            for ((d, &$x), &$y) in d.iter_mut().zip(a).zip(b) {
                *d = $body;
            }
        };
    }
    match op {
        Bin::Add => map2!(|x, y| x + y),
        Bin::Sub => map2!(|x, y| x - y),
        Bin::Mul => map2!(|x, y| x * y),
        Bin::Div => map2!(|x, y| x / y),
        Bin::Min => map2!(|x, y| scalar::min(x, y)),
        Bin::Max => map2!(|x, y| scalar::max(x, y)),
        _ => map2!(|x, y| eval_bin(op, x, y)),
    }
}

#[inline(always)]
pub fn powi(a: &[f64], n: i32, d: &mut [f64]) {
    match n {
        2 => map1!(a, d, |x| x * x),
        3 => map1!(a, d, |x| x * x * x),
        -1 => map1!(a, d, |x| 1.0 / x),
        _ => map1!(a, d, |x| scalar::powi(x, n)),
    }
}

#[inline(always)]
pub fn powf(a: &[f64], k: f64, d: &mut [f64]) {
    map1!(a, d, |x| powf1(x, k));
}
