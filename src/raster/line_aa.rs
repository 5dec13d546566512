//! Anti-aliased line: the notes' anti-aliased Bresenham ("virtual pixels",
//! Wu's method) with exact integer arithmetic.

use crate::error::Result;

/// Pixels and coverage values of the anti-aliased line from `(r0, c0)` to
/// `(r1, c1)`, as `(rows, cols, values)`.
///
/// At each of the `n + 1` steps along the major axis (n = the larger of
/// |Δrow|, |Δcol|), the ideal line crosses the minor axis at `m + e` with an
/// integer `m` and a fraction `0 ≤ e < 1`. The notes split one unit of
/// intensity between the two pixels straddling that point (a virtual pixel
/// between them): `1 − e` to pixel `m` and `e` to pixel `m + 1`. The
/// fraction is kept as the exact rational `rem / n` (an integer Bresenham
/// remainder), so values are exact to rounding of one division, every step
/// carries intensity exactly 1 and the total is `n + 1`. Pixels with zero
/// weight (where the line passes exactly through a pixel centre) are not
/// returned.
pub fn line_aa(r0: i64, c0: i64, r1: i64, c1: i64) -> Result<(Vec<i64>, Vec<i64>, Vec<f64>)> {
    let len = super::line_length(r0, c0, r1, c1)?;
    let (dr, dc) = ((r1 - r0).abs(), (c1 - c0).abs());
    let sr = if r1 >= r0 { 1 } else { -1 };
    let sc = if c1 >= c0 { 1 } else { -1 };
    let steep = dr > dc;
    let (n, dmin, smaj, smin) = if steep {
        (dr, dc, sr, sc)
    } else {
        (dc, dr, sc, sr)
    };
    let (maj0, min0) = if steep { (r0, c0) } else { (c0, r0) };
    let mut rr = Vec::with_capacity(2 * len);
    let mut cc = Vec::with_capacity(2 * len);
    let mut vv = Vec::with_capacity(2 * len);
    let mut push = |maj: i64, min: i64, v: f64| {
        if steep {
            rr.push(maj);
            cc.push(min);
        } else {
            rr.push(min);
            cc.push(maj);
        }
        vv.push(v);
    };
    if n == 0 {
        push(maj0, min0, 1.0);
        return Ok((rr, cc, vv));
    }
    let nf = n as f64;
    // Minor offset at step k is dmin·k / n = q + rem / n.
    let (mut q, mut rem) = (0i64, 0i64);
    for k in 0..=n {
        let maj = maj0 + smaj * k;
        let m = min0 + smin * q;
        if rem == 0 {
            push(maj, m, 1.0);
        } else {
            let e = rem as f64 / nf;
            push(maj, m, 1.0 - e);
            push(maj, m + smin, e);
        }
        rem += dmin;
        if rem >= n {
            rem -= n;
            q += 1;
        }
    }
    Ok((rr, cc, vv))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_step_carries_unit_intensity() {
        for &(r1, c1) in &[(3, 10), (-10, 3), (7, -7), (0, -4), (9, 0)] {
            let (r, c, v) = line_aa(2, 1, r1, c1).unwrap();
            let n = (r1 - 2i64).abs().max((c1 - 1i64).abs());
            let total: f64 = v.iter().sum();
            assert!((total - (n + 1) as f64).abs() < 1e-12);
            assert!(v.iter().all(|&x| x > 0.0 && x <= 1.0));
            assert_eq!(r.len(), c.len());
            // The intensity-weighted centre of each step lies on the ideal line.
            let steep = (r1 - 2).abs() > (c1 - 1).abs();
            let mut acc = std::collections::BTreeMap::new();
            for i in 0..r.len() {
                let (maj, min) = if steep { (r[i], c[i]) } else { (c[i], r[i]) };
                let e = acc.entry(maj).or_insert((0.0, 0.0));
                e.0 += v[i];
                e.1 += v[i] * min as f64;
            }
            for (maj, (w, m)) in acc {
                let (maj0, min0, dmaj, dmin) = if steep {
                    (2.0, 1.0, (r1 - 2) as f64, (c1 - 1) as f64)
                } else {
                    (1.0, 2.0, (c1 - 1) as f64, (r1 - 2) as f64)
                };
                let exact = min0 + dmin * (maj as f64 - maj0) / dmaj;
                assert!((m / w - exact).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn point() {
        assert_eq!(line_aa(4, 4, 4, 4).unwrap(), (vec![4], vec![4], vec![1.0]));
    }
}
