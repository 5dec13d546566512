//! Branch-free sin/cos, exp and log for the batch kernels, written so that
//! a loop over a slice vectorises (no calls, selects instead of branches).
//! Reduction and polynomials follow fdlibm (Sun Microsystems, 1993):
//! Cody-Waite reduction by π/2 with a three-part constant, the minimax
//! kernels `__kernel_sin`/`__kernel_cos`, `e_exp.c` and `e_log.c`. Each
//! `*_fast` kernel is valid where its `*_ok` predicate holds; an argument
//! outside that range (huge, non-finite, subnormal results) is recomputed by the standard library in a fix-up pass, so results are
//! within about 1 ulp everywhere and NaN/inf behave as in libm.

// The constants are fdlibm's, digit for digit.
#![allow(clippy::excessive_precision)]

const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52: round to nearest

// π/2 in three 33-bit parts (fdlibm e_rem_pio2.c): k·part is exact for
// |k| < 2^20.
const PIO2_1: f64 = 1.570_796_326_734_125_614_17e+00;
const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11;
const PIO2_3: f64 = 2.022_266_248_711_166_455_80e-21;
const INV_PIO2: f64 = std::f64::consts::FRAC_2_PI;

const S1: f64 = -1.666_666_666_666_663_243_48e-01;
const S2: f64 = 8.333_333_333_322_489_461_24e-03;
const S3: f64 = -1.984_126_982_985_794_931_34e-04;
const S4: f64 = 2.755_731_370_707_006_767_89e-06;
const S5: f64 = -2.505_076_025_340_686_341_95e-08;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;

const C1: f64 = 4.166_666_666_666_660_190_37e-02;
const C2: f64 = -1.388_888_888_887_410_957_49e-03;
const C3: f64 = 2.480_158_728_947_672_941_78e-05;
const C4: f64 = -2.755_731_435_139_066_330_35e-07;
const C5: f64 = 2.087_572_321_298_174_827_90e-09;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// Arguments with |x| below this take the fast sin/cos path.
pub const SINCOS_MAX: f64 = 1.0e5;

/// sin and cos of x for |x| < [`SINCOS_MAX`] (garbage otherwise).
#[inline(always)]
pub fn sin_cos_fast(x: f64) -> (f64, f64) {
    let kk = x * INV_PIO2 + MAGIC;
    let q = kk.to_bits() as i64; // low bits: the quadrant
    let k = kk - MAGIC;
    let r = ((x - k * PIO2_1) - k * PIO2_2) - k * PIO2_3;
    let z = r * r;
    // __kernel_sin and __kernel_cos without the tail term, their
    // polynomials in Estrin's form (shorter dependency chains for the
    // one-point path).
    let z2 = z * z;
    let z4 = z2 * z2;
    let ps = (S2 + z * S3) + z2 * ((S4 + z * S5) + z2 * S6);
    let sr = r + (r * z) * (S1 + z * ps);
    let pc = z * ((C1 + z * C2) + z2 * (C3 + z * C4) + z4 * (C5 + z * C6));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let cr = w + (((1.0 - w) - hz) + z * pc);
    let swap = q & 1 != 0;
    let s0 = if swap { cr } else { sr };
    let c0 = if swap { sr } else { cr };
    let s = if q & 2 != 0 { -s0 } else { s0 };
    let c = if (q + 1) & 2 != 0 { -c0 } else { c0 };
    (s, c)
}

#[inline(always)]
pub fn sin_cos_ok(x: f64) -> bool {
    x.abs() < SINCOS_MAX
}

/// sin and cos at one point, with the fall-back.
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if sin_cos_ok(x) {
        sin_cos_fast(x)
    } else {
        x.sin_cos()
    }
}

const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-01;
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
const INV_LN2: f64 = std::f64::consts::LOG2_E;
const P1: f64 = 1.666_666_666_666_660_190_37e-01;
const P2: f64 = -2.777_777_777_701_559_338_42e-03;
const P3: f64 = 6.613_756_321_437_934_361_17e-05;
const P4: f64 = -1.653_390_220_546_525_153_90e-06;
const P5: f64 = 4.138_136_797_057_238_460_39e-08;

/// exp(x) for |x| < 708 (the result and 2^k stay normal).
#[inline(always)]
pub fn exp_fast(x: f64) -> f64 {
    let kk = x * INV_LN2 + MAGIC;
    let k = kk - MAGIC;
    let ki = (kk.to_bits() as i64).wrapping_sub(MAGIC.to_bits() as i64); // k as an integer
    let hi = x - k * LN2_HI;
    let lo = k * LN2_LO;
    let r = hi - lo;
    let t = r * r;
    let c = r - t * (P1 + t * (P2 + t * (P3 + t * (P4 + t * P5))));
    let y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
    let scale = f64::from_bits(((ki + 1023) as u64) << 52);
    y * scale
}

#[inline(always)]
pub fn exp_ok(x: f64) -> bool {
    x.abs() < 708.0
}

#[inline(always)]
pub fn exp(x: f64) -> f64 {
    if exp_ok(x) {
        exp_fast(x)
    } else {
        x.exp()
    }
}

const LG1: f64 = 6.666_666_666_666_735_130e-01;
const LG2: f64 = 3.999_999_999_940_941_908e-01;
const LG3: f64 = 2.857_142_874_366_239_149e-01;
const LG4: f64 = 2.222_219_843_214_978_396e-01;
const LG5: f64 = 1.818_357_216_161_805_012e-01;
const LG6: f64 = 1.531_383_769_920_937_332e-01;
const LG7: f64 = 1.479_819_860_511_658_591e-01;
const SQRT2: f64 = std::f64::consts::SQRT_2;

/// ln(x) for positive normal finite x.
#[inline(always)]
pub fn ln_fast(x: f64) -> f64 {
    let bits = x.to_bits();
    let e0 = ((bits >> 52) as i64) - 1023;
    // Mantissa in [1, 2).
    let m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    // Bring it to [√2/2, √2).
    let big = m > SQRT2;
    let m = if big { 0.5 * m } else { m };
    let e = (e0 + big as i64) as f64;
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG2 + w * (LG4 + w * LG6));
    let t2 = z * (LG1 + w * (LG3 + w * (LG5 + w * LG7)));
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    e * LN2_HI - ((hfsq - (s * (hfsq + r) + e * LN2_LO)) - f)
}

#[inline(always)]
pub fn ln_ok(x: f64) -> bool {
    (f64::MIN_POSITIVE..f64::INFINITY).contains(&x)
}

#[inline(always)]
pub fn ln(x: f64) -> f64 {
    if ln_ok(x) {
        ln_fast(x)
    } else {
        x.ln()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(a: f64, b: f64) -> f64 {
        if a == b {
            return 0.0;
        }
        (a - b).abs() / (f64::EPSILON * b.abs().max(f64::MIN_POSITIVE))
    }

    #[test]
    fn accuracy_against_libm() {
        let mut x = 0.123_456_789_f64;
        let (mut ws, mut wc, mut we, mut wl) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for i in 0..200_000 {
            // Pseudo-random arguments over many scales.
            x = (x * 9301.0 + 49297.0) % 233280.0;
            let t = x / 233280.0;
            let a = (t - 0.5) * [1.0, 10.0, 100.0, 1e4, 9e4][i % 5];
            let (s, c) = sin_cos(a);
            // Absolute error relative to 1 (sin near its zeros).
            ws = ws.max((s - a.sin()).abs() / f64::EPSILON);
            wc = wc.max((c - a.cos()).abs() / f64::EPSILON);
            let b = (t - 0.5) * 1400.0;
            we = we.max(ulps(exp(b), b.exp()));
            let l = t * [1e-300, 1.0, 1e10, 1e300][i % 4];
            if l > 0.0 {
                wl = wl.max((ln(l) - l.ln()).abs() / (f64::EPSILON * l.ln().abs().max(1.0)));
            }
        }
        assert!(ws <= 1.0 && wc <= 1.0, "sin {ws} cos {wc}");
        assert!(we <= 2.0, "exp {we} ulp");
        assert!(wl <= 1.0, "log {wl}");
        assert!(sin_cos(f64::NAN).0.is_nan() && sin_cos(f64::INFINITY).1.is_nan());
        assert_eq!(exp(-1000.0), 0.0);
        assert_eq!(exp(1000.0), f64::INFINITY);
        assert!(ln(-1.0).is_nan() && ln(0.0) == f64::NEG_INFINITY);
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(ln(1.0), 0.0);
    }
}
