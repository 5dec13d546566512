//! The exact horizon along each sector's centre direction by a line sweep
//! (Dozier, Bruno and Downey 1981; Timonen and Westerholm 2010).
//!
//! The grid is cut into digital lines of the direction r_i: for a direction
//! within 45° of the columns, line c holds the cells (c + round(m·j), j) for
//! every column j, with m the slope in rows per column (rows and columns
//! swap roles otherwise). Every cell lies on exactly one line per direction.
//! A line's profile is its cells at their distance w = (u, v)·r_i along the
//! direction, heights linear in between, so a cell's horizon is the highest
//! elevation of the cells ahead of it on its line. Walking the line from its
//! far end keeps the upper convex hull of the profile ahead as a stack: a new
//! cell pops the vertices under its tangent and the top is its horizon
//! point, O(1) amortised per cell. Elevations go through a fast arctangent
//! accurate to a few 1e-8 rad (the output is float32).
//!
//! With `max_distance`, the cells ahead are scanned up to that distance
//! along the line (no hull).

use super::{Frame, Options, Progress, Terrain, EMPTY};
use crate::cancel::Cancel;
use crate::error::Result;

/// atan(x) to about 1e-7 relative (Cephes `atanf` reduction and polynomial,
/// in f64).
#[inline]
pub fn fast_atan(x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    let (sgn, a) = if x < 0.0 { (-1.0, -x) } else { (1.0, x) };
    let (base, t) = if a > 2.414213562373095 {
        (FRAC_PI_2, -1.0 / a)
    } else if a > 0.414_213_562_373_095 {
        (FRAC_PI_4, (a - 1.0) / (a + 1.0))
    } else {
        (0.0, a)
    };
    let z = t * t;
    let p = (((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
        - 3.33329491539e-1)
        * z
        * t
        + t;
    sgn * (base + p)
}

/// One direction on a (possibly transposed) grid whose lines step along
/// columns: `m` rows per column (|m| ≤ 1), `fwd` whether "ahead" is towards
/// higher columns, `wc`, `wr` the distance along r per column and per row.
#[allow(clippy::too_many_arguments)]
fn lines(
    z: &[f64],
    rows: usize,
    cols: usize,
    m: f64,
    fwd: bool,
    wc: f64,
    wr: f64,
    c: f64,
    dmax: Option<f64>,
    out: &mut [f32],
    cancel: &Cancel,
) -> Result<()> {
    let shift: Vec<i64> = (0..cols).map(|j| (m * j as f64).round() as i64).collect();
    let (smin, smax) = (
        *shift.iter().min().unwrap_or(&0),
        *shift.iter().max().unwrap_or(&0),
    );
    let order: Vec<usize> = if fwd {
        (0..cols).rev().collect()
    } else {
        (0..cols).collect()
    };
    let mut stack: Vec<(f64, f64)> = Vec::with_capacity(64);
    let mut seen: Vec<(f64, f64)> = Vec::new();
    for (li, line) in (-smax..(rows as i64 - smin)).enumerate() {
        if li % 256 == 0 {
            cancel.check()?;
        }
        stack.clear();
        seen.clear();
        for &j in &order {
            let i = line + shift[j];
            if i < 0 || i >= rows as i64 {
                continue;
            }
            let q = i as usize * cols + j;
            let h = z[q];
            if !h.is_finite() {
                out[q] = f32::NAN;
                continue;
            }
            let w = j as f64 * wc + i as f64 * wr;
            let zz = if c == 0.0 { h } else { h - c * w * w };
            if let Some(d) = dmax {
                let mut best: Option<f64> = None;
                for &(qw, qz) in seen.iter().rev() {
                    if qw - w > d {
                        break;
                    }
                    let s = (qz - zz) / (qw - w);
                    if best.is_none_or(|b| s > b) {
                        best = Some(s);
                    }
                }
                out[q] = match best {
                    Some(s) => fast_atan(s + 2.0 * c * w) as f32,
                    None => EMPTY,
                };
                seen.push((w, zz));
                continue;
            }
            while stack.len() >= 2 {
                let (tw, tz) = stack[stack.len() - 1];
                let (sw, sz) = stack[stack.len() - 2];
                if (sz - zz) * (tw - w) >= (tz - zz) * (sw - w) {
                    stack.pop();
                } else {
                    break;
                }
            }
            out[q] = match stack.last() {
                Some(&(tw, tz)) => fast_atan((tz - zz) / (tw - w) + 2.0 * c * w) as f32,
                None => EMPTY,
            };
            stack.push((w, zz));
        }
    }
    Ok(())
}

pub fn sector(
    t: &Terrain,
    f: &Frame,
    o: &Options,
    plane: &mut [f32],
    cancel: &Cancel,
    progress: &Progress,
) -> Result<()> {
    let (rows, cols, du, dv) = t.grid.expect("validated: sweep needs a grid");
    let (gc, gr) = (f.r.0 / du, f.r.1 / dv);
    if gc.abs() >= gr.abs() {
        lines(
            &t.z,
            rows,
            cols,
            gr / gc,
            gc > 0.0,
            f.r.0 * du,
            f.r.1 * dv,
            o.curvature,
            o.max_distance,
            plane,
            cancel,
        )?;
    } else {
        // Transpose so that lines step along contiguous memory.
        let mut zt = vec![0.0; rows * cols];
        for i in 0..rows {
            for j in 0..cols {
                zt[j * rows + i] = t.z[i * cols + j];
            }
        }
        let mut tmp = vec![0.0f32; rows * cols];
        lines(
            &zt,
            cols,
            rows,
            gc / gr,
            gr > 0.0,
            f.r.1 * dv,
            f.r.0 * du,
            o.curvature,
            o.max_distance,
            &mut tmp,
            cancel,
        )?;
        for i in 0..rows {
            for j in 0..cols {
                plane[i * cols + j] = tmp[j * rows + i];
            }
        }
    }
    progress.add(rows * cols);
    Ok(())
}
