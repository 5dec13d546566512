//! Exact orientation predicate on f64 points (Shewchuk's adaptive filter with
//! an exact expansion fallback). Every comparison of elevations in `brute` and
//! `stewart` goes through [`orient`], so both see the same answers and their
//! horizons agree bit for bit.

/// Sign of the 2×2 determinant (a − c) × (b − c): positive if a, b, c turn
/// counter-clockwise, negative if clockwise, zero if exactly collinear.
#[inline]
pub fn orient(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> i32 {
    let (det, bound) = det_bound(a, b, c);
    if det.abs() > bound || bound == 0.0 {
        return (det > 0.0) as i32 - (det < 0.0) as i32;
    }
    orient_exact(a, b, c)
}

/// The rounded determinant of [`orient`] and the bound on its error.
/// Shewchuk's filter without branches on the operands' signs: when detleft
/// and detright differ in sign (or one is zero) there is no cancellation
/// and |det| = |detleft| + |detright| exceeds the bound, so one test covers
/// his three cases (the signs of the rounded differences and products are
/// exact). Both zero: det = 0 exactly (bound 0).
#[inline(always)]
fn det_bound(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> (f64, f64) {
    let detleft = (a.0 - c.0) * (b.1 - c.1);
    let detright = (a.1 - c.1) * (b.0 - c.0);
    // (3 + 16ε)ε with ε = 2^-53 (Shewchuk's ccwerrboundA).
    const ERR: f64 = (3.0 + 16.0 * f64::EPSILON / 2.0) * (f64::EPSILON / 2.0);
    (detleft - detright, ERR * (detleft.abs() + detright.abs()))
}

/// The sign of [`orient`] when the filter alone decides it (`Some(true)`:
/// positive, `Some(false)`: negative; `None`: ask [`orient`]). A caller
/// that only needs one side of zero branches once on the rounded
/// determinant instead of on a sign formed from it.
#[inline(always)]
pub fn orient_filtered(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> Option<bool> {
    let (det, bound) = det_bound(a, b, c);
    // det > bound ≥ 0 (or < −bound) is exactly orient's filter passing
    // with that sign; everything else (|det| ≤ bound, NaN) goes to orient.
    if det > bound {
        Some(true)
    } else if det < -bound {
        Some(false)
    } else {
        None
    }
}

/// A first filter for points inside one box (every coordinate of a, b and
/// c between the box's bounds): one error bound for all such triples, so a
/// test is the rounded determinant against a constant, without the bound
/// of [`orient_filtered`] computed per triple. Sound: the rounded
/// differences are at most the rounded extents (rounding is monotone), so
/// |detleft| and |detright| are at most P = fl(Δw·Δz) and Shewchuk's bound
/// fl(ERR·fl(|detleft| + |detright|)) at most fl(ERR·2P); a determinant
/// beyond that beats the per-triple bound too. Inside it, the per-triple
/// filter and then the exact sign decide, so every answer is
/// [`orient_filtered`]'s (a decided sign) or [`orient`]'s.
#[derive(Clone, Copy, Debug)]
pub struct BoxFilter {
    bound: f64,
}

impl BoxFilter {
    /// No box: every test goes to the per-triple filter.
    pub const NONE: BoxFilter = BoxFilter {
        bound: f64::INFINITY,
    };

    /// The filter for points with w in `w.0..=w.1` and Z in `z.0..=z.1`
    /// ([`BoxFilter::NONE`] unless all four are numbers).
    pub fn new(w: (f64, f64), z: (f64, f64)) -> BoxFilter {
        const ERR: f64 = (3.0 + 16.0 * f64::EPSILON / 2.0) * (f64::EPSILON / 2.0);
        let p = (w.1 - w.0) * (z.1 - z.0);
        let bound = ERR * (p + p);
        // (a NaN bound, from a NaN or infinite extent, would decide nothing
        // either, but the comparison below is kept to numbers)
        if bound.is_nan() || w.0 > w.1 || z.0 > z.1 {
            BoxFilter::NONE
        } else {
            BoxFilter { bound }
        }
    }

    /// [`orient_filtered`] for three points of the box.
    #[inline(always)]
    pub fn sign(self, a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> Option<bool> {
        // (the determinant of `det_bound`, whose per-triple bound this one
        // exceeds; that bound, unused, is not computed)
        let det = det_bound(a, b, c).0;
        if det > self.bound {
            Some(true)
        } else if det < -self.bound {
            Some(false)
        } else {
            orient_filtered_cold(a, b, c)
        }
    }

    /// [`BoxFilter::sign`] as one well-predicted branch (on whether the box
    /// bound decides) and the sign of the rounded determinant as a value,
    /// for callers that select on it without branching.
    #[inline(always)]
    pub fn sign_flat(self, a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> Option<bool> {
        let det = det_bound(a, b, c).0;
        // (a NaN determinant is not decided here, as in `sign`)
        if det.abs() > self.bound {
            Some(det > 0.0)
        } else {
            orient_filtered_cold(a, b, c)
        }
    }
}

/// [`orient_filtered`] out of line (the rare case of [`BoxFilter::sign`]).
#[cold]
#[inline(never)]
fn orient_filtered_cold(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> Option<bool> {
    orient_filtered(a, b, c)
}

#[inline]
fn sign(x: f64) -> i32 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let x = a + b;
    let bv = x - a;
    let av = x - bv;
    (x, (a - av) + (b - bv))
}

#[inline]
fn two_diff(a: f64, b: f64) -> (f64, f64) {
    let x = a - b;
    let bv = a - x;
    let av = x + bv;
    (x, (a - av) + (bv - b))
}

#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// Exact sign by summing the 16 exact partial products into a
/// non-overlapping expansion (Shewchuk's GROW-EXPANSION with zero
/// elimination); the sign is that of its largest component.
#[cold]
fn orient_exact(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> i32 {
    let x1 = two_diff(a.0, c.0);
    let y2 = two_diff(b.1, c.1);
    let y1 = two_diff(a.1, c.1);
    let x2 = two_diff(b.0, c.0);
    let mut terms = [0.0f64; 16];
    let mut t = 0;
    for (u, v, s) in [(x1, y2, 1.0), (y1, x2, -1.0)] {
        for p in [u.0, u.1] {
            for q in [v.0, v.1] {
                let (h, l) = two_prod(p, q);
                terms[t] = s * h;
                terms[t + 1] = s * l;
                t += 2;
            }
        }
    }
    let mut e = [0.0f64; 17];
    let mut len = 0usize;
    for &b in &terms {
        let mut q = b;
        let mut k = 0;
        for i in 0..len {
            let (s, r) = two_sum(q, e[i]);
            q = s;
            if r != 0.0 {
                e[k] = r;
                k += 1;
            }
        }
        if q != 0.0 {
            e[k] = q;
            k += 1;
        }
        len = k;
    }
    if len == 0 {
        0
    } else {
        sign(e[len - 1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Xorshift64 from `seed`.
    fn xorshift(mut s: u64) -> impl FnMut() -> u64 {
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        }
    }

    #[test]
    fn exact_on_integers_and_near_collinear() {
        // Integer coordinates: compare with i128 arithmetic.
        let mut next = xorshift(12345);
        let mut rnd = || (next() % 2001) as i64 - 1000;
        for _ in 0..20000 {
            let p: Vec<i64> = (0..6).map(|_| rnd()).collect();
            let d = (p[0] - p[4]) as i128 * (p[3] - p[5]) as i128
                - (p[1] - p[5]) as i128 * (p[2] - p[4]) as i128;
            let f = |i: usize| p[i] as f64;
            assert_eq!(
                orient((f(0), f(1)), (f(2), f(3)), (f(4), f(5))),
                d.signum() as i32
            );
        }
        // Nearly collinear points far from the origin (the filter fails, the
        // exact path decides): points on the line y = x + 1e-3 shifted by ulps.
        let a = (1e9, 1e9 + 1e-3);
        let b = (1e9 + 1.0, 1e9 + 1.0 + 1e-3);
        let c = (1e9 + 2.0, 1e9 + 2.0 + 1e-3);
        let expected = {
            // exact rational check via integer multiples of 2^-30
            let sc = |x: f64| (x * (1u64 << 30) as f64) as i128;
            let (ax, ay, bx, by, cx, cy) = (sc(a.0), sc(a.1), sc(b.0), sc(b.1), sc(c.0), sc(c.1));
            ((ax - cx) * (by - cy) - (ay - cy) * (bx - cx)).signum() as i32
        };
        assert_eq!(orient(a, b, c), expected);
        assert_eq!(orient((0.0, 0.0), (1.0, 1.0), (2.0, 2.0)), 0);
        assert_eq!(orient((0.1, 0.3), (0.2, 0.3), (0.7, 0.3)), 0);
        // The filter agrees with the exact expansion on nearly collinear
        // real triples of every sign pattern.
        let mut next = xorshift(99);
        let mut unit = || (next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        for _ in 0..20000 {
            let (x0, y0, dx, dy) = (unit() * 1e3, unit() * 1e3, unit(), unit());
            let (t1, t2) = (unit() * 7.0, unit() * 7.0);
            let e = unit() * 1e-12;
            let a = (x0, y0);
            let b = (x0 + t1 * dx, y0 + t1 * dy + e);
            let c = (x0 + t2 * dx, y0 + t2 * dy);
            for (p, q, r) in [(a, b, c), (b, c, a), (c, a, b), (b, a, c)] {
                assert_eq!(orient(p, q, r), orient_exact(p, q, r), "{p:?} {q:?} {r:?}");
            }
        }
    }

    #[test]
    fn box_filter_decides_only_the_exact_sign() {
        let mut next = xorshift(7);
        let mut unit = || (next() >> 11) as f64 / (1u64 << 53) as f64;
        let (mut by_box, mut total) = (0, 0);
        for case in 0..4000 {
            // a box, and triples inside it: random, nearly collinear (a
            // point moved off the line through two others by ulps) and
            // collinear on a grid line
            let (w0, z0) = (unit() * 2e3 - 1e3, unit() * 2e3 - 1e3);
            let (dw, dz) = (unit() * 1e3 * (case % 7) as f64, unit() * 50.0);
            let bx = BoxFilter::new((w0, w0 + dw), (z0, z0 + dz));
            let r: Vec<f64> = (0..7).map(|_| unit()).collect();
            let pt = |i: usize| (w0 + r[i] * dw, z0 + r[i + 1] * dz);
            let (a, b) = (pt(0), pt(2));
            let on = (a.0 + r[6] * (b.0 - a.0), a.1 + r[6] * (b.1 - a.1));
            let nudge = (on.0, f64::from_bits(on.1.to_bits() + (case % 5) as u64));
            let c = if case % 3 == 0 { pt(4) } else { nudge };
            let g = (w0.floor(), z0.floor());
            let grid = [g, (g.0 + 1.0, g.1), (g.0 + 2.0, g.1)];
            let clamp = |p: (f64, f64)| (p.0.clamp(w0, w0 + dw), p.1.clamp(z0, z0 + dz));
            for (p, q, r) in [(a, b, c), (c, a, b), (b, c, a), (a, c, b)]
                .into_iter()
                .map(|(p, q, r)| (clamp(p), clamp(q), clamp(r)))
                .chain([(grid[0], grid[1], grid[2])])
            {
                let inside =
                    |p: (f64, f64)| (w0..=w0 + dw).contains(&p.0) && (z0..=z0 + dz).contains(&p.1);
                let bx = if [p, q, r].into_iter().all(inside) {
                    bx
                } else {
                    BoxFilter::NONE
                };
                let want = orient(p, q, r);
                total += 1;
                match bx.sign(p, q, r) {
                    Some(pos) => {
                        assert_eq!(want, if pos { 1 } else { -1 }, "{p:?} {q:?} {r:?}");
                        by_box += (orient_filtered(p, q, r) == Some(pos)) as usize;
                    }
                    None => assert_eq!(orient_filtered(p, q, r), None),
                }
            }
        }
        // most triples are decided (by the box bound or the per-triple one)
        assert!(by_box * 2 > total, "{by_box} of {total}");
    }
}
