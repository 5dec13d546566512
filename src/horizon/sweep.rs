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
//! accurate to a few 1e-8 rad (the output is float32), taken in a separate
//! pass over the slopes (rounded to float32 meanwhile: at most 3e-8 rad).
//!
//! The lines are walked a block of neighbours at a time, one step for the
//! whole block before the next: the block's cells at one step are adjacent
//! rows of a column (or adjacent cells of a row), so every cache line of the
//! grid is loaded once instead of once per line.
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

/// [`fast_atan`] without branches (selects only), so that a loop over a
/// slice of slopes vectorises; same reduction and polynomial.
#[inline]
pub fn atan_select(x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    let a = x.abs();
    let big = a > 2.414213562373095;
    let mid = a > 0.414_213_562_373_095;
    let num = if big {
        -1.0
    } else if mid {
        a - 1.0
    } else {
        a
    };
    let den = if big {
        a
    } else if mid {
        a + 1.0
    } else {
        1.0
    };
    let base = if big {
        FRAC_PI_2
    } else if mid {
        FRAC_PI_4
    } else {
        0.0
    };
    let t = num / den;
    let z = t * t;
    let p = (((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
        - 3.33329491539e-1)
        * z
        * t
        + t;
    (base + p).copysign(x)
}

/// Replace slopes by their elevation angles (−∞ gives −π/2, NaN stays).
fn slopes_to_angles(out: &mut [f32]) {
    for v in out.iter_mut() {
        *v = atan_select(*v as f64) as f32;
    }
}

/// Lines walked together (one cache line of output per step and line).
const BLOCK: i64 = 64;

/// One direction without a distance limit. The lines step along columns
/// (`along_cols`, one cell per column, |m| ≤ 1 rows per column) or along
/// rows; `fwd` says whether "ahead" is towards higher steps; `wstep`,
/// `wperp` are the distances along r per step and per perpendicular index.
#[allow(clippy::too_many_arguments)]
fn lines_blocked(
    z: &[f64],
    rows: usize,
    cols: usize,
    along_cols: bool,
    m: f64,
    fwd: bool,
    wstep: f64,
    wperp: f64,
    c: f64,
    out: &mut [f32],
    cancel: &Cancel,
) -> Result<()> {
    let (nsteps, nperp) = if along_cols {
        (cols, rows as i64)
    } else {
        (rows, cols as i64)
    };
    let shift: Vec<i64> = (0..nsteps).map(|u| (m * u as f64).round() as i64).collect();
    let smin = *shift.iter().min().unwrap_or(&0);
    let smax = *shift.iter().max().unwrap_or(&0);
    let (sv, su) = if along_cols { (cols, 1) } else { (1, cols) };
    // The hull stacks of the block's lines, flat: line b's stack lives in
    // hw/hz[b·cap .. b·cap + len[b]] (a line has at most `nsteps` cells).
    let cap = nsteps;
    let mut hw = vec![0.0f64; cap * BLOCK as usize];
    let mut hz = vec![0.0f64; cap * BLOCK as usize];
    let mut len = [0usize; BLOCK as usize];
    let mut l0 = -smax;
    while l0 < nperp - smin {
        cancel.check()?;
        let l1 = (l0 + BLOCK).min(nperp - smin);
        len.fill(0);
        for step in 0..nsteps {
            let u = if fwd { nsteps - 1 - step } else { step };
            let sh = shift[u];
            // line l holds perpendicular index v = l + sh, 0 ≤ v < nperp
            let (la, lb) = (l0.max(-sh), l1.min(nperp - sh));
            if la >= lb {
                continue;
            }
            let wu = u as f64 * wstep;
            let base = u * su;
            assert!(la >= l0 && lb <= l0 + BLOCK && la + sh >= 0 && lb + sh <= nperp);
            assert!(base + (nperp as usize - 1) * sv < out.len().min(z.len()));
            for l in la..lb {
                let b = (l - l0) as usize;
                let v = (l + sh) as usize;
                let q = base + v * sv;
                // SAFETY: 0 ≤ v < nperp and u < nsteps (asserted above), so q
                // is a cell of the grid; b < BLOCK; a line has at most one
                // cell per step, so its stack never exceeds cap = nsteps.
                unsafe {
                    let h = *z.get_unchecked(q);
                    if !h.is_finite() {
                        *out.get_unchecked_mut(q) = f32::NAN;
                        continue;
                    }
                    let w = wu + v as f64 * wperp;
                    let zz = if c == 0.0 { h } else { h - c * w * w };
                    let sw_ = hw.as_mut_ptr().add(b * cap);
                    let sz_ = hz.as_mut_ptr().add(b * cap);
                    let mut k = *len.get_unchecked(b);
                    while k >= 2 {
                        let (tw, tz) = (*sw_.add(k - 1), *sz_.add(k - 1));
                        let (sw, sz) = (*sw_.add(k - 2), *sz_.add(k - 2));
                        if (sz - zz) * (tw - w) >= (tz - zz) * (sw - w) {
                            k -= 1;
                        } else {
                            break;
                        }
                    }
                    // The slope for now (rounded to f32: ≤ 3e-8 rad once
                    // turned into an angle); the angles are taken in one
                    // vector pass.
                    *out.get_unchecked_mut(q) = if k > 0 {
                        ((*sz_.add(k - 1) - zz) / (*sw_.add(k - 1) - w) + 2.0 * c * w) as f32
                    } else {
                        f32::NEG_INFINITY
                    };
                    *sw_.add(k) = w;
                    *sz_.add(k) = zz;
                    *len.get_unchecked_mut(b) = k + 1;
                }
            }
        }
        l0 = l1;
    }
    slopes_to_angles(out);
    Ok(())
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
    if o.max_distance.is_none() {
        let (wc, wr) = (f.r.0 * du, f.r.1 * dv);
        if gc.abs() >= gr.abs() {
            lines_blocked(
                &t.z,
                rows,
                cols,
                true,
                gr / gc,
                gc > 0.0,
                wc,
                wr,
                o.curvature,
                plane,
                cancel,
            )?;
        } else {
            lines_blocked(
                &t.z,
                rows,
                cols,
                false,
                gc / gr,
                gr > 0.0,
                wr,
                wc,
                o.curvature,
                plane,
                cancel,
            )?;
        }
        progress.add(rows * cols);
        return Ok(());
    }
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
