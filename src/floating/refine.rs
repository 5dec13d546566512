//! Exact per-pixel solve, batched: every pixel revealed by a sweep carries a
//! seed on its own ray (the §4.2 interpolation) and a bracket; Newton steps
//! on h(λ) = w_ray(λ) − f(u_ray(λ), v_ray(λ)) run for all pixels of a column
//! (or radial bin) together, one batched evaluation per iteration, so that
//! sources amortise their per-call cost.

use super::column::{Ctx, Pixel};
use super::ShadingMode;
use crate::surface::HeightSample;
use glam::{DVec2, DVec3};

/// One pixel to solve.
#[derive(Debug, Clone, Copy)]
pub struct Job {
    /// Index of the pixel in the caller's output.
    pub slot: usize,
    pub o: DVec3,
    pub dir: DVec3,
    pub lam: f64,
    pub lo: f64,
    pub hi: f64,
    /// World size of a pixel at the seed.
    pub fp: f64,
}

/// Buffers of [`solve_with`], reused from call to call.
#[derive(Debug, Default)]
pub struct SolveScratch {
    lam: Vec<f64>,
    active: Vec<usize>,
    next: Vec<usize>,
    live: Vec<usize>,
    failed: Vec<usize>,
    u: Vec<f64>,
    v: Vec<f64>,
    hs: Vec<HeightSample>,
}

/// Solve `jobs`, updating `out[job.slot]` for each success; returns the
/// slots that failed (left with their interpolated values) and the number
/// of evaluations made.
pub fn solve(ctx: &Ctx<'_>, jobs: &[Job], out: &mut [Pixel]) -> (Vec<usize>, u64) {
    let mut sc = SolveScratch::default();
    let (_, evals) = solve_with(ctx, jobs, out, &mut sc);
    (sc.failed, evals)
}

/// [`solve`] with reused buffers: the failed slots are returned as a view
/// of `sc`.
pub fn solve_with<'s>(
    ctx: &Ctx<'_>,
    jobs: &[Job],
    out: &mut [Pixel],
    sc: &'s mut SolveScratch,
) -> (&'s [usize], u64) {
    let dom = ctx.frame.domain;
    let d = ctx.cam.d;
    let SolveScratch {
        lam,
        active,
        next,
        live,
        failed,
        u,
        v,
        hs,
    } = sc;
    lam.clear();
    lam.extend(jobs.iter().map(|j| j.lam));
    active.clear();
    active.extend(0..jobs.len());
    failed.clear();
    next.clear();
    let mut evals = 0u64;
    for _ in 0..ctx.opts.refine_iters {
        if active.is_empty() {
            break;
        }
        u.clear();
        v.clear();
        live.clear();
        for &k in active.iter() {
            let p = jobs[k].o + lam[k] * jobs[k].dir;
            if dom.contains(p.x, p.y) {
                u.push(p.x);
                v.push(p.y);
                live.push(k);
            } else {
                failed.push(jobs[k].slot);
            }
        }
        hs.clear();
        hs.resize(live.len(), HeightSample::default());
        ctx.field.eval_batch(u, v, hs);
        evals += live.len() as u64;
        next.clear();
        for (n, &k) in live.iter().enumerate() {
            let j = &jobs[k];
            let h = hs[n];
            let p = j.o + lam[k] * j.dir;
            if !h.is_finite() {
                failed.push(j.slot);
                continue;
            }
            let g = p.z - h.f;
            let gp = j.dir.z - (h.fu * j.dir.x + h.fv * j.dir.y);
            if gp == 0.0 || !gp.is_finite() {
                failed.push(j.slot);
                continue;
            }
            let dl = g / gp;
            let l = lam[k] - dl;
            if !(l >= j.lo && l <= j.hi) {
                failed.push(j.slot);
                continue;
            }
            lam[k] = l;
            if dl.abs() <= ctx.opts.refine_tol * j.fp {
                let q = j.o + l * j.dir;
                if !dom.contains(q.x, q.y) {
                    failed.push(j.slot);
                    continue;
                }
                let depth = if ctx.cam.perspective {
                    (q - ctx.cam.eye).dot(d)
                } else {
                    l
                };
                finish(
                    ctx,
                    &mut out[j.slot],
                    j.dir,
                    depth,
                    DVec2::new(q.x, q.y),
                    &h,
                );
            } else {
                next.push(k);
            }
        }
        std::mem::swap(active, next);
    }
    failed.extend(active.iter().map(|&k| jobs[k].slot));
    failed.sort_unstable();
    (failed, evals)
}

/// Write an exact hit into a pixel (and its shading, in normal mode).
pub fn finish(ctx: &Ctx<'_>, px: &mut Pixel, dir: DVec3, depth: f64, uv: DVec2, h: &HeightSample) {
    px.depth = depth;
    px.uv = uv;
    px.n = h.normal();
    let c = -dir.dot(px.n);
    if c != 0.0 {
        px.side = if c > 0.0 { 1 } else { -1 };
    }
    if ctx.opts.shading == ShadingMode::Normal {
        px.inten = ctx.shading.intensity(px.n, -dir);
    }
}
