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
//! The lines are walked a block of neighbours at a time, a few steps of one
//! line before the same steps of the next (16 when the lines run along the
//! rows, so those steps are adjacent cells of a row; 4 when they run along
//! the columns, where the block's cells at one step are adjacent cells of a
//! row): every cache line of the grid is loaded once instead of once per
//! line. The distances along the direction are tabulated per step, and the
//! top of each line's hull stack stays in registers while the line is walked.
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
/// The same operations in the same order whatever the vector width, so the
/// result does not depend on the CPU.
fn slopes_to_angles(out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX (checked just above).
        unsafe { slopes_to_angles_avx(out) };
        return;
    }
    slopes_to_angles_plain(out);
}

#[inline(always)]
fn slopes_to_angles_plain(out: &mut [f32]) {
    for v in out.iter_mut() {
        *v = atan_select(*v as f64) as f32;
    }
}

/// [`slopes_to_angles_plain`] compiled for 4-wide f64 vectors (no FMA: the
/// values are bit-identical to the plain pass).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn slopes_to_angles_avx(out: &mut [f32]) {
    slopes_to_angles_plain(out);
}

/// Lines walked together (one cache line of output per step and line).
const BLOCK: i64 = 64;

/// Steps walked on one line before the next line of the block when the
/// block's cells at one step are a column (lines along the rows): a line's
/// next `CHUNK` cells are then adjacent in memory and every cache line of
/// the grid is used up before it can be evicted; the stacks stay the same.
const CHUNK: usize = 16;

/// The same when the block's cells at one step are a run of a row (lines
/// along the columns): a few steps per line amortise the per-line set-up
/// while the rows touched stay few.
const CHUNK_ROWS: usize = 4;

/// A step of the lines of one direction (in walking order).
#[derive(Clone, Copy)]
struct Step {
    /// Cell index of line 0 at this step (line l: q0 + l·sv).
    q0: i64,
    /// Perpendicular index of line 0 (line l: sh + l).
    sh: i64,
    /// Distance along r of line 0 (line l: w + l·wperp).
    w: f64,
}

/// Walk line `l` over `steps`, with its hull stack of `k` vertices at
/// `sw`, `sz` (distances and heights); returns the new stack length. `CURV`:
/// whether c ≠ 0 (then `wl` = l·wperp is added to the distances). The top
/// vertex is kept in registers: the stack in memory is only read below it,
/// so no load waits on the store of the cell just before.
///
/// # Safety
/// `z` and `out` hold the grid, whose cell at perpendicular index v of a step
/// is `q0 + (v − sh)·sv` for 0 ≤ v < nperp; `sw` and `sz` have room for `k`
/// plus one value per step.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn walk<const CURV: bool>(
    z: &[f64],
    out: &mut [f32],
    steps: &[Step],
    l: i64,
    nperp: i64,
    sv: usize,
    c: f64,
    wl: f64,
    sw: *mut f64,
    sz: *mut f64,
    mut k: usize,
) -> usize {
    let off = l * sv as i64;
    let (mut tw, mut tz) = if k > 0 {
        (*sw.add(k - 1), *sz.add(k - 1))
    } else {
        (0.0, 0.0)
    };
    for s in steps {
        // the line's cell at this step is on the grid when 0 ≤ l + sh < nperp
        if ((l + s.sh) as u64) >= nperp as u64 {
            continue;
        }
        let q = (s.q0 + off) as usize;
        let h = *z.get_unchecked(q);
        if !h.is_finite() {
            // ±inf or NaN: no data
            *out.get_unchecked_mut(q) = f32::NAN;
            continue;
        }
        let (w, zz) = if CURV {
            let w = s.w + wl;
            (w, h - c * w * w) // Z = z − c·w²
        } else {
            (s.w, h)
        };
        // pop the top t while it is on or under the segment from the new
        // point to the vertex p below it
        while k >= 2 {
            let (pw, pz) = (*sw.add(k - 2), *sz.add(k - 2));
            if (pz - zz) * (tw - w) >= (tz - zz) * (pw - w) {
                k -= 1;
                (tw, tz) = (pw, pz);
            } else {
                break;
            }
        }
        // The slope for now (rounded to f32: ≤ 3e-8 rad once turned into an
        // angle); the angles are taken in one vector pass.
        *out.get_unchecked_mut(q) = if k > 0 {
            let slope = (tz - zz) / (tw - w);
            (if CURV { slope + 2.0 * c * w } else { slope }) as f32
        } else {
            f32::NEG_INFINITY
        };
        *sw.add(k) = w;
        *sz.add(k) = zz;
        k += 1;
        (tw, tz) = (w, zz);
    }
    k
}

/// One direction without a distance limit. The lines step along columns
/// (`along_cols`, one cell per column, |m| ≤ 1 rows per column) or along
/// rows; `fwd` says whether "ahead" is towards higher steps; `wstep`,
/// `wperp` are the distances along r per step and per perpendicular index.
///
/// Line l holds, at step u, the cell at perpendicular index v = l + sh(u),
/// so its distance along r is w = (u·wstep + sh(u)·wperp) + l·wperp: the
/// first term is the same for every line of a direction and is tabulated
/// once; the line's constant l·wperp is left out without curvature (the
/// slopes only see differences of w along one line).
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
    // The steps in walking order (the far end first), with their shift and
    // tabulated distance.
    let order: Vec<usize> = if fwd {
        (0..nsteps).rev().collect()
    } else {
        (0..nsteps).collect()
    };
    let shift: Vec<i64> = order
        .iter()
        .map(|&u| (m * u as f64).round() as i64)
        .collect();
    let wtab: Vec<f64> = order
        .iter()
        .zip(&shift)
        .map(|(&u, &sh)| u as f64 * wstep + sh as f64 * wperp)
        .collect();
    let smin = *shift.iter().min().unwrap_or(&0);
    let smax = *shift.iter().max().unwrap_or(&0);
    let (sv, su) = if along_cols { (cols, 1) } else { (1, cols) };
    // per step: the cell index of line 0 (i64: it may lie off the grid), the
    // shift and the distance
    let steps: Vec<Step> = order
        .iter()
        .zip(&shift)
        .zip(&wtab)
        .map(|((&u, &sh), &w)| Step {
            q0: (u * su) as i64 + sh * sv as i64,
            sh,
            w,
        })
        .collect();
    let chunk = if along_cols { CHUNK } else { CHUNK_ROWS };
    assert!(z.len() >= rows * cols && out.len() >= rows * cols);
    // The hull stacks of the block's lines, flat: line b's distances are
    // st[2b·cap ..][.. len[b]] and its heights st[(2b + 1)·cap ..][.. len[b]]
    // (a line has at most `nsteps` cells; the spare values stagger the
    // stacks over the cache sets).
    let cap = nsteps + 3;
    let mut st = vec![0.0f64; 2 * cap * BLOCK as usize];
    let mut len = [0usize; BLOCK as usize];
    let mut l0 = -smax;
    while l0 < nperp - smin {
        cancel.check()?;
        let l1 = (l0 + BLOCK).min(nperp - smin);
        len.fill(0);
        let mut s0 = 0;
        while s0 < nsteps {
            let s1 = (s0 + chunk).min(nsteps);
            // lines of the block that have a cell at some step of the chunk
            let (cmin, cmax) = shift[s0..s1]
                .iter()
                .fold((i64::MAX, i64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            let (la, lb) = (l0.max(-cmax), l1.min(nperp - cmin));
            for l in la..lb {
                let b = (l - l0) as usize;
                let (sw, sz) = st[2 * b * cap..(2 * b + 2) * cap].split_at_mut(cap);
                let (sw, sz) = (sw.as_mut_ptr(), sz.as_mut_ptr());
                // SAFETY: b < BLOCK since l0 ≤ la ≤ l < lb ≤ l1 ≤ l0 + BLOCK;
                // the chunk is a range of `steps`; see `walk` for the cells.
                unsafe {
                    let k = len.get_unchecked_mut(b);
                    *k = if c == 0.0 {
                        walk::<false>(z, out, &steps[s0..s1], l, nperp, sv, 0.0, 0.0, sw, sz, *k)
                    } else {
                        let wl = l as f64 * wperp;
                        walk::<true>(z, out, &steps[s0..s1], l, nperp, sv, c, wl, sw, sz, *k)
                    };
                }
            }
            s0 = s1;
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
