//! Centre-line sampling (Max 1988; Cabral, Max and Springmeyer 1987): the
//! horizon of sector σ_i is sampled only along its centre line r_i. The line
//! from p is followed across the grid; at every crossing with a column line
//! u = j·du or a row line v = i·dv the terrain height is interpolated
//! linearly between the two samples of that grid line bordering the crossing
//! (a node when the crossing hits one), and the sample's elevation is
//! atan2(h − z_p − c·t², t) at distance t. The line stops at the grid's
//! border (no terrain beyond) and at `max_distance`. A crossing next to a
//! no-data sample is skipped. O(√n) samples per point and sector.
//!
//! [`near_vertex`] is Stewart §IV-E: the same sampling restricted to the
//! distance d / sin(2π/s) (d the larger grid spacing) within which a narrow
//! sector may hold no sample point, merged into a sector maximum.

use super::{Frame, Options, Progress, Terrain, EMPTY};
use crate::cancel::Cancel;
use crate::error::Result;

/// Largest elevation along the centre line from grid point (i0, j0) up to
/// distance `tmax` (None: none sampled).
#[allow(clippy::too_many_arguments)]
pub fn line_max(
    z: &[f64],
    rows: usize,
    cols: usize,
    du: f64,
    dv: f64,
    i0: usize,
    j0: usize,
    r: (f64, f64),
    c: f64,
    tmax: f64,
) -> Option<f64> {
    let zp = z[i0 * cols + j0];
    let gc = r.0 / du; // columns per unit distance
    let gr = r.1 / dv; // rows per unit distance
    let mut best: Option<f64> = None;
    let mut take = |h: f64, t: f64| {
        if h.is_finite() {
            let e = (h - zp - c * t * t).atan2(t);
            if best.is_none_or(|b| e > b) {
                best = Some(e);
            }
        }
    };
    // Crossings with column lines j, samples along them in rows i.
    let (across, along) = (Axis::new(gc, j0, cols), Axis::new(gr, i0, rows));
    crossings(across, along, tmax, |j, i| z[i * cols + j], &mut take);
    // Crossings with row lines i, samples along them in columns j.
    let (across, along) = (Axis::new(gr, i0, rows), Axis::new(gc, j0, cols));
    crossings(across, along, tmax, |i, j| z[i * cols + j], &mut take);
    best
}

/// One grid axis seen from the line's start: lines per unit distance
/// along it, the start index and the number of lines.
#[derive(Clone, Copy)]
struct Axis {
    g: f64,
    start: usize,
    n: usize,
}

impl Axis {
    fn new(g: f64, start: usize, n: usize) -> Axis {
        Axis { g, start, n }
    }
}

/// The crossings of the centre line with the grid lines across `across`
/// (every line it meets, in order, up to distance `tmax` and the grid's
/// border along `along`): `take(h, t)` with h interpolated linearly between
/// the two samples `at(line, k)`, `at(line, k + 1)` bordering the crossing.
fn crossings(
    across: Axis,
    along: Axis,
    tmax: f64,
    at: impl Fn(usize, usize) -> f64,
    take: &mut impl FnMut(f64, f64),
) {
    if across.g == 0.0 {
        return;
    }
    let step = if across.g > 0.0 { 1i64 } else { -1 };
    let m = along.g / across.g.abs();
    let last = (along.n - 1) as f64;
    let mut k = 1i64;
    loop {
        let line = across.start as i64 + k * step;
        if line < 0 || line as usize >= across.n {
            break;
        }
        let t = k as f64 / across.g.abs();
        if t > tmax {
            break;
        }
        let pos = along.start as f64 + k as f64 * m;
        if !(0.0..=last).contains(&pos) {
            break;
        }
        let p0 = pos.floor();
        let fr = pos - p0;
        let (line, p0) = (line as usize, p0 as usize);
        let h = if fr == 0.0 {
            at(line, p0)
        } else {
            at(line, p0) * (1.0 - fr) + at(line, p0 + 1) * fr
        };
        take(h, t);
        k += 1;
    }
}

fn grid(t: &Terrain) -> (usize, usize, f64, f64) {
    t.grid.expect("validated: cms needs a grid")
}

pub fn sector(
    t: &Terrain,
    f: &Frame,
    o: &Options,
    plane: &mut [f32],
    cancel: &Cancel,
    progress: &Progress,
) -> Result<()> {
    let (rows, cols, du, dv) = grid(t);
    let tmax = o.max_distance.unwrap_or(f64::INFINITY);
    for i in 0..rows {
        cancel.check()?;
        for j in 0..cols {
            let q = i * cols + j;
            plane[q] = if !t.has_data(q) {
                f32::NAN
            } else {
                match line_max(&t.z, rows, cols, du, dv, i, j, f.r, o.curvature, tmax) {
                    Some(e) => e as f32,
                    None => EMPTY,
                }
            };
        }
        progress.add(cols);
    }
    Ok(())
}

/// Stewart §IV-E: merge centre-line samples near the vertex into `plane`.
pub fn near_vertex(
    t: &Terrain,
    f: &Frame,
    o: &Options,
    plane: &mut [f32],
    cancel: &Cancel,
) -> Result<()> {
    let (rows, cols, du, dv) = grid(t);
    let width = 2.0 * std::f64::consts::PI / o.sectors as f64;
    let mut tmax = du.abs().max(dv.abs()) / width.sin().max(1e-300);
    if let Some(d) = o.max_distance {
        tmax = tmax.min(d);
    }
    for i in 0..rows {
        if i % 16 == 0 {
            cancel.check()?;
        }
        for j in 0..cols {
            let q = i * cols + j;
            if !t.has_data(q) {
                continue;
            }
            if let Some(e) = line_max(&t.z, rows, cols, du, dv, i, j, f.r, o.curvature, tmax) {
                let e = e as f32;
                if e > plane[q] {
                    plane[q] = e;
                }
            }
        }
    }
    Ok(())
}
