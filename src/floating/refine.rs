//! Exact per-pixel solve, batched: every pixel revealed by a sweep carries a
//! seed on its own ray (the §4.2 interpolation) and a bracket; Newton steps
//! on h(λ) = w_ray(λ) − f(u_ray(λ), v_ray(λ)) run for all pixels of a column
//! (or radial bin) together, one batched evaluation per iteration, so that
//! sources amortise their per-call cost.

use super::column::{Ctx, Pixel};
use super::ShadingMode;
use crate::surface::{finite_zero, HeightSample};
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

/// Buffers of the batched Newton ([`newton`]), reused from call to call.
#[derive(Debug, Default)]
pub struct NewtonScratch {
    /// The jobs still running, in job order, and their λ.
    active: Vec<u32>,
    lam: Vec<f64>,
    /// The point (u, v, height) of each active job on its ray; grown only
    /// (the first `active.len()` are the round's).
    u: Vec<f64>,
    v: Vec<f64>,
    pz: Vec<f64>,
    hs: Vec<HeightSample>,
    failed: Vec<u32>,
}

impl NewtonScratch {
    /// The jobs that failed in the last [`newton`] (in the order they
    /// failed).
    pub(crate) fn failed(&self) -> &[u32] {
        &self.failed
    }
}

/// `buf` at least `n` long (grown only), its first `n` elements.
#[inline(always)]
fn at_least<T: Copy + Default>(buf: &mut Vec<T>, n: usize) -> &mut [T] {
    if buf.len() < n {
        buf.resize(n, T::default());
    }
    &mut buf[..n]
}

/// The batched Newton on pixel rays shared by every caller: job k's ray is
/// `ray(k)` = (origin, direction), its seed `seed(k)`, its bracket and
/// pixel footprint `bracket(k)` = (lo, hi, fp). Each round evaluates the
/// live jobs in one batch and steps λ ← λ − h/h' with h(λ) = w_ray(λ) −
/// f(u_ray(λ), v_ray(λ)); a job is done when its step is under `refine_tol`
/// footprints (`hit(k, λ, point, sample)`, the sample taken at the
/// previous iterate), and fails (listed in [`NewtonScratch::failed`]) when
/// it leaves the domain or its bracket, meets a non-finite value or a flat
/// h, or is still moving after `refine_iters` rounds. Returns the number of
/// evaluations.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn newton(
    ctx: &Ctx<'_>,
    n: usize,
    seed: impl Fn(usize) -> f64,
    ray: impl Fn(usize) -> (DVec3, DVec3),
    bracket: impl Fn(usize) -> (f64, f64, f64),
    sc: &mut NewtonScratch,
    mut hit: impl FnMut(usize, f64, DVec3, &HeightSample),
) -> u64 {
    let dom = ctx.frame.domain;
    let tol = ctx.opts.refine_tol;
    let NewtonScratch {
        lam,
        active,
        u,
        v,
        pz,
        hs,
        failed,
    } = sc;
    failed.clear();
    active.clear();
    active.extend(0..n as u32);
    lam.clear();
    lam.extend((0..n).map(&seed));
    let mut evals = 0u64;
    for _ in 0..ctx.opts.refine_iters {
        if active.is_empty() {
            break;
        }
        // The points in one pass over preallocated buffers; those outside
        // the domain (rare) fail, the others closed up after it.
        let mut m = active.len();
        let (u, v, pz) = (at_least(u, m), at_least(v, m), at_least(pz, m));
        let mut outside = false;
        let pts = u.iter_mut().zip(&mut *v).zip(&mut *pz);
        for ((&k, &l), ((u, v), z)) in active.iter().zip(lam.iter()).zip(pts) {
            let (o, dir) = ray(k as usize);
            let p = o + l * dir;
            outside |= !dom.contains(p.x, p.y);
            (*u, *v, *z) = (p.x, p.y, p.z);
        }
        if outside {
            // (those before the first point outside stay where they are)
            let first = (0..m).position(|i| !dom.contains(u[i], v[i]));
            let first = first.unwrap_or(m);
            let mut w = first;
            for i in first..m {
                if dom.contains(u[i], v[i]) {
                    (u[w], v[w], pz[w]) = (u[i], v[i], pz[i]);
                    (active[w], lam[w]) = (active[i], lam[i]);
                    w += 1;
                } else {
                    failed.push(active[i]);
                }
            }
            m = w;
        }
        let (u, v, pz) = (&u[..m], &v[..m], &pz[..m]);
        let hs = at_least(hs, m);
        ctx.field.eval_batch(u, v, hs);
        evals += m as u64;
        // The jobs still moving closed up at the front of `active` and
        // `lam` (in order).
        let mut kept = 0;
        for (i, (h, &pz)) in hs.iter().zip(pz).enumerate() {
            let k = active[i] as usize;
            if !h.is_finite() {
                failed.push(k as u32);
                continue;
            }
            let (o, dir) = ray(k);
            let (lo, hi, fp) = bracket(k);
            let g = pz - h.f;
            let gp = dir.z - (h.fu * dir.x + h.fv * dir.y);
            if !(gp != 0.0 && finite_zero(gp) == 0.0) {
                failed.push(k as u32);
                continue;
            }
            let dl = g / gp;
            let l = lam[i] - dl;
            if !(l >= lo && l <= hi) {
                failed.push(k as u32);
                continue;
            }
            if dl.abs() <= tol * fp {
                let q = o + l * dir;
                if !dom.contains(q.x, q.y) {
                    failed.push(k as u32);
                    continue;
                }
                hit(k, l, q, h);
            } else {
                (active[kept], lam[kept]) = (k as u32, l);
                kept += 1;
            }
        }
        active.truncate(kept);
        lam.truncate(kept);
    }
    failed.extend_from_slice(active);
    evals
}

/// Buffers of [`solve_with`], reused from call to call.
#[derive(Debug, Default)]
pub struct SolveScratch {
    newton: NewtonScratch,
    failed: Vec<usize>,
}

impl SolveScratch {
    /// The jobs (indices) that failed in the last [`solve_with`], in the
    /// order they failed.
    pub(crate) fn failed_jobs(&self) -> &[u32] {
        self.newton.failed()
    }
}

/// Solve `jobs` (the generic sweep's pixels), updating `out[job.slot]` for
/// each success; returns the slots that failed (left with their
/// interpolated values; a view of `sc`) and the number of evaluations.
pub fn solve_with<'s>(
    ctx: &Ctx<'_>,
    jobs: &[Job],
    out: &mut [Pixel],
    sc: &'s mut SolveScratch,
) -> (&'s [usize], u64) {
    let (eye, d) = (ctx.cam.eye, ctx.cam.d);
    let evals = newton(
        ctx,
        jobs.len(),
        |k| jobs[k].lam,
        |k| (jobs[k].o, jobs[k].dir),
        |k| (jobs[k].lo, jobs[k].hi, jobs[k].fp),
        &mut sc.newton,
        |k, l, q, h| {
            let j = &jobs[k];
            let depth = if ctx.cam.perspective {
                (q - eye).dot(d)
            } else {
                l
            };
            finish(ctx, &mut out[j.slot], j.dir, depth, DVec2::new(q.x, q.y), h);
        },
    );
    let failed = &mut sc.failed;
    failed.clear();
    failed.extend(sc.newton.failed().iter().map(|&k| jobs[k as usize].slot));
    failed.sort_unstable();
    (failed, evals)
}

/// Write an exact hit into a pixel (and its shading, in normal mode).
#[inline]
pub fn finish(ctx: &Ctx<'_>, px: &mut Pixel, dir: DVec3, depth: f64, uv: DVec2, h: &HeightSample) {
    px.depth = depth;
    px.uv = uv;
    (px.n, px.side, px.inten) = hit_shading(ctx, dir, h, px.side, px.inten);
}

/// The normal, seen side and intensity of an exact hit on ray `dir` with
/// the surface's sample `h` there; `side` and `inten` (the pixel's) kept
/// where the hit does not tell them (a ray in the tangent plane; shading
/// other than normal).
#[inline(always)]
pub(crate) fn hit_shading(
    ctx: &Ctx<'_>,
    dir: DVec3,
    h: &HeightSample,
    side: i8,
    inten: f64,
) -> (DVec3, i8, f64) {
    let n = h.normal();
    let c = -dir.dot(n);
    let side = match c != 0.0 {
        true if c > 0.0 => 1,
        true => -1,
        false => side,
    };
    let inten = if ctx.opts.shading == ShadingMode::Normal {
        ctx.shading.intensity_cos(n, -dir, c)
    } else {
        inten
    };
    (n, side, inten)
}

/// A revealed span of an orthographic column, kept for the pixels it
/// queues: the two samples' values to interpolate (should a pixel's solve
/// fail, or for the intensity in Gouraud mode) and the depth bracket.
#[derive(Debug, Clone, Copy)]
pub struct SpanSeed {
    pub topo: i8,
    pub lo: f64,
    pub hi: f64,
    pub n: [DVec3; 2],
    pub uv: [DVec2; 2],
    pub inten: [f64; 2],
}

impl SpanSeed {
    /// The interpolated pixel at weight `tau` towards the span's end, at
    /// depth `z` (§4.2).
    #[inline]
    pub(super) fn pixel(&self, tau: f64, z: f64) -> Pixel {
        Pixel {
            set: true,
            side: self.topo,
            depth: z,
            n: self.n[0].lerp(self.n[1], tau).normalize_or(self.n[0]),
            uv: self.uv[0].lerp(self.uv[1], tau),
            inten: self.inten[0] + tau * (self.inten[1] - self.inten[0]),
            cover: 1.0,
        }
    }
}

/// One pixel of an orthographic column to solve: its row, its span (an
/// index into the column's [`SpanSeed`]s), its weight in the span and its
/// seed depth. Its ray is the camera's: origin affine in the row,
/// direction d, λ the depth.
#[derive(Debug, Clone, Copy)]
pub struct SeedJob {
    pub slot: u32,
    pub span: u32,
    pub tau: f64,
    pub lam: f64,
}

/// Where a column's finished pixels go when they are written straight into
/// the render's buffers: pixel (i, `j`) at i·`width` + `j`.
pub(crate) struct Direct<'a, 'b> {
    pub(crate) out: &'a super::SharedOut<'b>,
    pub(crate) j: usize,
    pub(crate) width: usize,
}
