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
    fn pixel(&self, tau: f64, z: f64) -> Pixel {
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

/// Buffers of [`solve_ortho`], reused from call to call.
#[derive(Debug, Default)]
pub struct OrthoScratch {
    lam: Vec<f64>,
    active: Vec<u32>,
    next: Vec<u32>,
    live: Vec<u32>,
    u: Vec<f64>,
    v: Vec<f64>,
    hs: Vec<HeightSample>,
}

/// [`solve`] for the pixels of orthographic column `col` seeded by their
/// spans: the same Newton steps (bit for bit), with the ray origins computed
/// from the rows and each pixel written once, when its solve ends (an
/// exact hit, or its span's interpolation should the solve fail): into
/// `out`, or with `direct`, straight into the render's buffers. Returns the
/// number of failures and of evaluations.
pub(crate) fn solve_ortho(
    ctx: &Ctx<'_>,
    col: f64,
    jobs: &[SeedJob],
    spans: &[SpanSeed],
    out: &mut [Pixel],
    direct: Option<&Direct<'_, '_>>,
    sc: &mut OrthoScratch,
) -> (u64, u64) {
    let put = |out: &mut [Pixel], slot: u32, px: Pixel| match direct {
        // SAFETY: the caller of `render_column_with` guarantees that no
        // other thread touches column `j`'s pixels.
        Some(dst) => unsafe { dst.out.put_set(slot as usize * dst.width + dst.j, &px) },
        None => out[slot as usize] = px,
    };
    let cam = ctx.cam;
    let dom = ctx.frame.domain;
    let d = cam.d;
    let normal = ctx.opts.shading == ShadingMode::Normal;
    let fp = ctx.frame.pixel;
    let tol = ctx.opts.refine_tol * fp;
    // The ray origin of row i: what `Camera::ray` gives, the column's part
    // hoisted.
    let (xs, _) = cam.pixel_to_screen(0.0, col);
    let base = cam.eye + (xs * cam.pixel) * cam.r;
    let origin = |slot: u32| {
        let (_, ys) = cam.pixel_to_screen(slot as f64, col);
        base + (ys * cam.pixel) * cam.up
    };
    let mut fails = 0u64;
    let mut fail = |j: &SeedJob, out: &mut [Pixel]| {
        let s = &spans[j.span as usize];
        let mut px = s.pixel(j.tau, j.lam);
        if normal {
            px.inten = ctx.shading.intensity(px.n, -d);
        }
        put(out, j.slot, px);
        fails += 1;
    };
    let OrthoScratch {
        lam,
        active,
        next,
        live,
        u,
        v,
        hs,
    } = sc;
    lam.clear();
    lam.extend(jobs.iter().map(|j| j.lam));
    active.clear();
    active.extend(0..jobs.len() as u32);
    let mut evals = 0u64;
    for _ in 0..ctx.opts.refine_iters {
        if active.is_empty() {
            break;
        }
        u.clear();
        v.clear();
        live.clear();
        for &k in active.iter() {
            let j = &jobs[k as usize];
            let p = origin(j.slot) + lam[k as usize] * d;
            if dom.contains(p.x, p.y) {
                u.push(p.x);
                v.push(p.y);
                live.push(k);
            } else {
                fail(j, out);
            }
        }
        // Grown only (no clearing per batch).
        if hs.len() < live.len() {
            hs.resize(live.len(), HeightSample::default());
        }
        let hs = &mut hs[..live.len()];
        ctx.field.eval_batch(u, v, hs);
        evals += live.len() as u64;
        next.clear();
        for (n, &k) in live.iter().enumerate() {
            let j = &jobs[k as usize];
            let s = &spans[j.span as usize];
            let h = hs[n];
            let o = origin(j.slot);
            let p = o + lam[k as usize] * d;
            if !h.is_finite() {
                fail(j, out);
                continue;
            }
            let g = p.z - h.f;
            let gp = d.z - (h.fu * d.x + h.fv * d.y);
            if gp == 0.0 || !gp.is_finite() {
                fail(j, out);
                continue;
            }
            let dl = g / gp;
            let l = lam[k as usize] - dl;
            if !(l >= s.lo && l <= s.hi) {
                fail(j, out);
                continue;
            }
            lam[k as usize] = l;
            if dl.abs() <= tol {
                let q = o + l * d;
                if !dom.contains(q.x, q.y) {
                    fail(j, out);
                    continue;
                }
                let nrm = h.normal();
                let c = -d.dot(nrm);
                let side = if c > 0.0 {
                    1
                } else if c < 0.0 {
                    -1
                } else {
                    s.topo
                };
                let inten = if normal {
                    ctx.shading.intensity(nrm, -d)
                } else {
                    s.inten[0] + j.tau * (s.inten[1] - s.inten[0])
                };
                let px = Pixel {
                    set: true,
                    side,
                    depth: l,
                    n: nrm,
                    uv: DVec2::new(q.x, q.y),
                    inten,
                    cover: 1.0,
                };
                put(out, j.slot, px);
            } else {
                next.push(k);
            }
        }
        std::mem::swap(active, next);
    }
    for &k in active.iter() {
        fail(&jobs[k as usize], out);
    }
    (fails, evals)
}
