//! Integer midpoint (Bresenham) line, all eight octants.

use crate::error::Result;

/// Pixels of the line from `(r0, c0)` to `(r1, c1)`, both ends included, as
/// `(rows, cols)`.
///
/// The notes' midpoint method: step one pixel along the major axis (the one
/// with the larger extent; the column axis when both are equal) and keep the
/// decision variable `d = 2·Δminor·k − Δmajor·(2m − 1)` (twice the signed
/// distance of the midpoint between the two candidate pixels, scaled by
/// Δmajor), stepping along the minor axis too when `d ≥ 0`.
///
/// Tie rule: when the ideal line passes exactly through that midpoint
/// (`d = 0`) the step is diagonal. Steps run from `(r0, c0)` towards
/// `(r1, c1)`, so at ties `line(a, b)` need not be `line(b, a)` reversed.
/// This is the rule of scikit-image's `draw.line`, which the result equals
/// pixel for pixel.
pub fn line(r0: i64, c0: i64, r1: i64, c1: i64) -> Result<(Vec<i64>, Vec<i64>)> {
    let n = super::line_length(r0, c0, r1, c1)?;
    let (dr, dc) = ((r1 - r0).abs(), (c1 - c0).abs());
    let sr = if r1 > r0 { 1 } else { -1 };
    let sc = if c1 > c0 { 1 } else { -1 };
    let mut rr = Vec::with_capacity(n);
    let mut cc = Vec::with_capacity(n);
    // (major, minor) = (column, row) unless the line is steep.
    let steep = dr > dc;
    let (dmaj, dmin, smaj, smin) = if steep {
        (dr, dc, sr, sc)
    } else {
        (dc, dr, sc, sr)
    };
    let (mut maj, mut min) = if steep { (r0, c0) } else { (c0, r0) };
    let mut d = 2 * dmin - dmaj;
    for _ in 0..dmaj {
        if steep {
            rr.push(maj);
            cc.push(min);
        } else {
            rr.push(min);
            cc.push(maj);
        }
        if d >= 0 {
            min += smin;
            d -= 2 * dmaj;
        }
        maj += smaj;
        d += 2 * dmin;
    }
    rr.push(r1);
    cc.push(c1);
    Ok((rr, cc))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(r0: i64, c0: i64, r1: i64, c1: i64) -> Vec<(i64, i64)> {
        let (r, c) = line(r0, c0, r1, c1).unwrap();
        r.into_iter().zip(c).collect()
    }

    #[test]
    fn octants_are_connected_and_hit_both_ends() {
        for &(r1, c1) in &[
            (3, 7),
            (7, 3),
            (-3, 7),
            (-7, 3),
            (3, -7),
            (7, -3),
            (-3, -7),
            (-7, -3),
            (0, 5),
            (5, 0),
            (0, -5),
            (-5, 0),
            (4, 4),
            (-4, 4),
        ] {
            let p = pts(0, 0, r1, c1);
            assert_eq!(p[0], (0, 0));
            assert_eq!(*p.last().unwrap(), (r1, c1));
            assert_eq!(p.len() as i64, r1.abs().max(c1.abs()) + 1);
            for w in p.windows(2) {
                let (a, b) = (w[0], w[1]);
                assert!((a.0 - b.0).abs() <= 1 && (a.1 - b.1).abs() <= 1);
            }
        }
    }

    #[test]
    fn single_point_and_budget() {
        assert_eq!(pts(5, -2, 5, -2), vec![(5, -2)]);
        let e = line(0, 0, 0, 1_000_000_000_000).unwrap_err();
        assert!(e.to_string().contains("budget"));
        assert!(line(i64::MIN, 0, i64::MAX, 0).is_err());
    }

    #[test]
    fn midpoint_distance_is_at_most_half_a_pixel() {
        // Every pixel lies within half a pixel of the ideal line, measured
        // along the minor axis.
        let (r1, c1) = (13i64, 37i64);
        for (r, c) in pts(0, 0, r1, c1) {
            let exact = r1 as f64 * c as f64 / c1 as f64;
            assert!((r as f64 - exact).abs() <= 0.5 + 1e-12);
        }
    }
}
