//! The O(n²) definition (Stewart §II-A), word by word: for each point p,
//! consider each other point q, determine which sector(s) of p contain q
//! (two when q lies on a shared border), and keep in each the elevation of q
//! if it beats the best so far. Membership uses the a⊥/b⊥ keys of the
//! module docs; comparisons are exact ([`super::better`]).

use super::{better, elevation, project, Frame, Options, Progress, Proj, Terrain, EMPTY};
use crate::cancel::Cancel;
use crate::error::Result;
use rayon::prelude::*;
use std::f64::consts::PI;

/// All requested sectors at once; `out` is plane-major (k planes of n).
pub fn all(
    t: &Terrain,
    o: &Options,
    out: &mut [f32],
    cancel: &Cancel,
    progress: &Progress,
) -> Result<()> {
    let s = o.sectors;
    let list = o.sector_list();
    let k = list.len();
    let n = t.len();
    // plane index of each sector (usize::MAX: not requested)
    let mut plane_of = vec![usize::MAX; s];
    for (pi, &i) in list.iter().enumerate() {
        plane_of[i] = pi;
    }
    let frames: Vec<Frame> = (0..s).map(|i| Frame::new(i, s)).collect();
    // keys and projections, point-major: pre[q * k + plane]
    #[derive(Clone, Copy)]
    struct Pre {
        a: f64,
        b: f64,
        p: Proj,
    }
    let mut pre = Vec::with_capacity(n * k);
    for q in 0..n {
        for &i in &list {
            let f = &frames[i];
            pre.push(Pre {
                a: f.key_a(t.kx[q], t.ky[q]),
                b: f.key_b(t.kx[q], t.ky[q]),
                p: project(f, t.x[q], t.y[q], t.z[q], o.curvature),
            });
        }
    }
    let valid: Vec<usize> = (0..n).filter(|&q| t.has_data(q)).collect();
    let d2max = o.max_distance.map(|d| d * d);
    let mut res = vec![0.0f32; n * k];
    res.par_chunks_mut(k)
        .enumerate()
        .try_for_each(|(p, row)| -> Result<()> {
            if p % 64 == 0 {
                cancel.check()?;
            }
            if !t.has_data(p) {
                row.fill(f32::NAN);
                return Ok(());
            }
            let mut best: Vec<Option<usize>> = vec![None; k];
            for &q in &valid {
                if q == p {
                    continue;
                }
                let (dx, dy) = (t.x[q] - t.x[p], t.y[q] - t.y[p]);
                if let Some(d2) = d2max {
                    if dx * dx + dy * dy > d2 {
                        continue;
                    }
                }
                // Which sector holds q: the azimuth gives it up to rounding
                // and shared borders, the exact key test decides.
                let az = dy.atan2(dx).rem_euclid(2.0 * PI);
                let i0 = ((az * s as f64 / (2.0 * PI)) as usize).min(s - 1);
                for i in [i0 + s - 1, i0, i0 + 1] {
                    let i = i % s;
                    let pi = plane_of[i];
                    if pi == usize::MAX {
                        continue;
                    }
                    let (kq, kp) = (pre[q * k + pi], pre[p * k + pi]);
                    if !(kq.a <= kp.a && kq.b >= kp.b) || (kq.a == kp.a && kq.b == kp.b) {
                        continue;
                    }
                    match best[pi] {
                        None => best[pi] = Some(q),
                        Some(c) => {
                            if better(kp.p, pre[c * k + pi].p, kq.p) {
                                best[pi] = Some(q)
                            }
                        }
                    }
                }
            }
            for pi in 0..k {
                row[pi] = match best[pi] {
                    None => EMPTY,
                    Some(q) => elevation(pre[p * k + pi].p, pre[q * k + pi].p, o.curvature),
                };
            }
            progress.add(k);
            Ok(())
        })?;
    for p in 0..n {
        for pi in 0..k {
            out[pi * n + p] = res[p * k + pi];
        }
    }
    Ok(())
}
