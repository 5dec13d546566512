//! The floating column of Gordon 2001 §4.2 / A.2: every pixel column is its
//! own front-to-back sweep along the column's curve, keeping the rows already
//! covered (the seed's min and max; a short list of intervals once NaN holes
//! or the domain edge break the curve) and filling each newly revealed span of
//! rows from the two samples that bracket it.
//!
//! Values (depth, (u, v), normal, intensity) are stored at every sample,
//! visible or not, and interpolated across revealed spans (§4.2). With
//! `refine`, each revealed pixel is then solved exactly: a few Newton steps on
//! the pixel's ray h(λ) = w_ray(λ) − f(u_ray(λ), v_ray(λ)), seeded by the
//! interpolation, which is still "evaluate only where visible".

use super::artifacts;
pub(crate) use super::refine::Direct;
use super::sampling::{Ahead, Frame, Raw, Sample, Sampler};
use super::{FloatingOptions, ShadingMode};
use crate::camera::Camera;
use crate::shade::Shading;
use crate::surface::{finite_zero, HeightField};
use glam::{DVec2, DVec3};
use std::cell::RefCell;

/// The result for one pixel of a column.
#[derive(Debug, Clone, Copy, Default)]
pub struct Pixel {
    pub set: bool,
    pub side: i8,
    pub depth: f64,
    pub n: DVec3,
    pub uv: DVec2,
    pub inten: f64,
    /// Covered fraction of the pixel's row extent (with `coverage` only;
    /// an unset pixel with `cover` > 0 holds the side and intensity of the
    /// silhouette that reaches into it).
    pub cover: f64,
}

/// Counters of one column.
#[derive(Debug, Clone, Copy, Default)]
pub struct ColumnStats {
    pub sweep_evals: u64,
    pub refine_evals: u64,
    pub refine_fail: u64,
    pub folds: u64,
    pub walls: u64,
    pub problems: u64,
    pub early_exit: u64,
    pub holes_filled: u64,
    /// Pixels moved to a nearer sheet their ray meets first (the searches
    /// after the sweeps, see `radial::edge_searches`).
    pub nearer: u64,
}

impl ColumnStats {
    pub fn add(&mut self, o: &ColumnStats) {
        self.sweep_evals += o.sweep_evals;
        self.refine_evals += o.refine_evals;
        self.refine_fail += o.refine_fail;
        self.folds += o.folds;
        self.walls += o.walls;
        self.problems += o.problems;
        self.early_exit += o.early_exit;
        self.holes_filled += o.holes_filled;
        self.nearer += o.nearer;
    }
}

/// Everything a column needs, shared read-only by all columns.
pub struct Ctx<'a> {
    pub cam: &'a Camera,
    pub frame: Frame,
    pub field: &'a dyn HeightField,
    pub shading: &'a Shading,
    pub opts: &'a FloatingOptions,
    /// Exact per-pixel solve of every revealed pixel wanted (depth/normal/uv
    /// asked for, or normal shading), and asked for by the options.
    pub refine: bool,
    /// Exact solve of the pixels whose interpolation the error estimate
    /// does not trust (the default mode; implied by `refine`).
    pub fallback: bool,
    /// The pixels beside set ones are searched on their own rays after the
    /// sweeps (orthographic views, see `radial::edge_searches`): a pixel
    /// whose exact solve finds no crossing is left unset for them rather
    /// than interpolated.
    pub searched: bool,
}

/// Covered rows of a column: disjoint closed intervals, sorted.
#[derive(Debug, Default)]
pub(super) struct Coverage {
    iv: Vec<(f64, f64)>,
}

impl Coverage {
    /// Nothing covered (the buffer kept).
    pub(super) fn clear(&mut self) {
        self.iv.clear();
    }
    #[inline]
    pub(super) fn contains(&self, x: f64) -> bool {
        if let [(a, b)] = self.iv[..] {
            return x >= a && x <= b;
        }
        self.iv.iter().any(|&(a, b)| x >= a && x <= b)
    }
    #[inline]
    pub(super) fn add(&mut self, lo: f64, hi: f64) {
        // The common case: one interval, overlapping [lo, hi] (what the
        // general case does with it, inline).
        if let [(a, b)] = self.iv.as_mut_slice() {
            if !(*b < lo || *a > hi) {
                (*a, *b) = (a.min(lo), b.max(hi));
                return;
            }
        }
        self.add_general(lo, hi);
    }

    #[inline(never)]
    fn add_general(&mut self, lo: f64, hi: f64) {
        // In place (no allocation in the common case of one interval).
        let mut first: Option<usize> = None;
        let mut k = 0;
        while k < self.iv.len() {
            let (a, b) = self.iv[k];
            if b < lo || a > hi {
                k += 1;
                continue;
            }
            match first {
                None => {
                    self.iv[k] = (a.min(lo), b.max(hi));
                    first = Some(k);
                    k += 1;
                }
                Some(f) => {
                    let (fa, fb) = self.iv[f];
                    self.iv[f] = (fa.min(a), fb.max(b));
                    self.iv.remove(k);
                }
            }
        }
        if first.is_none() {
            let pos = self.iv.partition_point(|&(a, _)| a < lo);
            self.iv.insert(pos, (lo, hi));
        }
    }
    /// Distance of x inside its covered interval (0 when not covered).
    pub(super) fn depth(&self, x: f64) -> f64 {
        // (the common case, one interval, without the search)
        if let [(a, b)] = self.iv[..] {
            return if x >= a && x <= b {
                min_num(x - a, b - x)
            } else {
                0.0
            };
        }
        self.iv
            .iter()
            .find(|&&(a, b)| x >= a && x <= b)
            .map(|&(a, b)| min_num(x - a, b - x))
            .unwrap_or(0.0)
    }
    /// The covered interval holding x.
    pub(super) fn interval(&self, x: f64) -> Option<(f64, f64)> {
        if let [(a, b)] = self.iv[..] {
            return (x >= a && x <= b).then_some((a, b));
        }
        self.iv.iter().copied().find(|&(a, b)| x >= a && x <= b)
    }
    /// The lowest and highest covered values (None: nothing covered; NaN
    /// where that cannot be told).
    pub(super) fn extent(&self) -> Option<(f64, f64)> {
        let mut ext: Option<(f64, f64)> = None;
        for &(a, b) in &self.iv {
            if a.is_nan() || b.is_nan() {
                return Some((f64::NAN, f64::NAN));
            }
            ext = Some(ext.map_or((a, b), |(lo, hi)| (lo.min(a), hi.max(b))));
        }
        ext
    }
    pub(super) fn covers(&self, lo: f64, hi: f64) -> bool {
        if let [(a, b)] = self.iv[..] {
            return a <= lo && b >= hi;
        }
        self.iv.iter().any(|&(a, b)| a <= lo && b >= hi)
    }
    /// Covered length of [lo, hi].
    pub(super) fn overlap(&self, lo: f64, hi: f64) -> f64 {
        self.iv
            .iter()
            .map(|&(a, b)| (b.min(hi) - a.max(lo)).max(0.0))
            .sum()
    }
}

/// `a.min(b)` for a number `b` (not NaN): the same value, `a` where
/// smaller, else `b` (also for a NaN `a`), in one comparison, where
/// `f64::min` tests both for NaN. Both projections' sweeps.
#[inline(always)]
pub(super) fn min_num(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

/// 0 < x < ∞, in two float comparisons (x·0 is 0 for finite x, NaN for
/// ±∞ and NaN): the compiler's own test of finiteness is a dozen integer
/// operations.
#[inline(always)]
pub(super) fn positive_finite(x: f64) -> bool {
    x > 0.0 && x * 0.0 == 0.0
}

/// `a.max(b)` for a number `b` (not NaN), as [`min_num`].
#[inline(always)]
pub(super) fn max_num(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

const MAX_STEPS: usize = 4_000_000;

/// Fraction of the allowed row gap the sweep's step aims at.
pub(super) const AIM: f64 = 0.85;

/// Rows beyond the image's first and last (clamped to by the sweep;
/// perspective: units of a bin's `rho`, about pixels, beyond its rays)
/// within which a sample counts as on the picture for the skip over
/// stretches outside it ([`invisible_run`]).
pub(super) const SKIP_MARGIN: f64 = 4.0;

/// The shortest stretch [`invisible_run`] tries, in largest steps; after a
/// try that fails the sweep goes this far before the next.
pub(super) const SKIP_MIN: f64 = 8.0;

/// The longest length among `min_len`·2^k, capped at `max_len`, for which
/// `invisible(l)` holds (the stretch of that length ahead shows nothing:
/// it lies wholly above or below the picture); 0 if `min_len` fails. Both
/// projections' sweeps step over such a stretch at once.
pub(super) fn invisible_run(min_len: f64, max_len: f64, invisible: impl Fn(f64) -> bool) -> f64 {
    let mut best = 0.0;
    let mut l = min_len;
    loop {
        let l_try = l.min(max_len);
        if l_try <= best || !invisible(l_try) {
            return best;
        }
        best = l_try;
        l *= 2.0;
    }
}

/// The shortest step a sweep retries at parameter `x`: a few units of its
/// last place (shorter steps would round to none, and a jump (a wall)
/// would be retried in place without end). Both projections.
#[inline]
pub(super) fn retry_floor(x: f64) -> f64 {
    8.0 * f64::EPSILON * x.abs()
}

/// Bounds (lo, hi) of f over the (u, v) box of a stretch with ends p and q
/// (lo > hi: no finite value there); None where unknown or not a number.
pub(super) fn stretch_bound(
    field: &dyn crate::surface::HeightField,
    p: DVec2,
    q: DVec2,
) -> Option<(f64, f64)> {
    field
        .height_range_in(p.x.min(q.x), p.x.max(q.x), p.y.min(q.y), p.y.max(q.y))
        .filter(|(lo, hi)| !(lo.is_nan() || hi.is_nan()))
}

struct Sweep<'c, 'a> {
    ctx: &'c Ctx<'a>,
    sampler: Sampler<'a>,
    col: f64,
    cov: Coverage,
    /// The image's rows, as a float (the sweep's row bounds).
    h: f64,
    stats: ColumnStats,
    jobs: Vec<super::refine::Job>,
    /// Pixels queued by orthographic spans, and those spans.
    seeds: Vec<super::refine::SeedJob>,
    spans: Vec<super::refine::SpanSeed>,
    /// Batched look-ahead (vertical column planes only).
    ahead: Option<Box<Ahead>>,
    /// With `coverage`: the covered rows at floating-point precision,
    /// including the extrema between samples (§6.4).
    fine: Option<Coverage>,
    /// Where the look-ahead batches are evaluated.
    pool: &'c RefCell<Pool>,
    /// §5 problem detection asked for (off by default).
    detect: bool,
    /// Has the coverage grown since the last early-exit check?
    grew: bool,
    /// The sampler's domain bounds ([`Sampler::bounds`]) for its look-ahead.
    bounds: [f64; 4],
    /// Has a pixel been put in the column's own buffer ([`Self::pixel`])?
    /// (With `direct`, the others go straight to the render's buffers.)
    wrote: bool,
}

/// Buffers a worker reuses from column to column.
#[derive(Default)]
pub struct ColumnScratch {
    /// The column's pixels, and those of a sub-column and the accumulated
    /// shading of the sub-columns (antialiasing), for the caller.
    pub centre: Vec<Pixel>,
    pub sub: Vec<Pixel>,
    pub acc: Vec<[f64; 4]>,
    jobs: Vec<super::refine::Job>,
    seeds: Vec<super::refine::SeedJob>,
    spans: Vec<super::refine::SpanSeed>,
    ahead: Box<Ahead>,
    solve: super::refine::SolveScratch,
    /// The shared evaluations and solve buffers of a group of columns
    /// (kept by its first).
    pool: Pool,
    /// Whether the last column put a pixel in `centre` (where a render
    /// that writes its pixels directly finds the few it did not: with
    /// none, `centre` need not be read).
    pub centre_written: bool,
}

/// Render one (possibly fractional) column `col` into `out` (length H).
pub fn render_column(ctx: &Ctx<'_>, col: f64, out: &mut [Pixel]) -> ColumnStats {
    render_column_with(ctx, col, out, &mut ColumnScratch::default())
}

/// [`render_column`] with reused buffers.
pub fn render_column_with(
    ctx: &Ctx<'_>,
    col: f64,
    out: &mut [Pixel],
    sc: &mut ColumnScratch,
) -> ColumnStats {
    // SAFETY: nothing is written outside `out`.
    unsafe { render_column_direct(ctx, col, out, sc, None) }
}

/// [`render_column_with`], the pixels of the exact orthographic solve
/// written straight into the render's buffers with `direct` (without
/// coverage only; the others still go to `out`).
///
/// # Safety
/// With `direct`, no other thread reads or writes the pixels of column
/// `direct.j` meanwhile, and `col` is that column.
pub(crate) unsafe fn render_column_direct(
    ctx: &Ctx<'_>,
    col: f64,
    out: &mut [Pixel],
    sc: &mut ColumnScratch,
    direct: Option<&super::refine::Direct<'_, '_>>,
) -> ColumnStats {
    let pool = RefCell::new(std::mem::take(&mut sc.pool));
    let st = {
        // SAFETY: as for this function.
        let task = std::pin::pin!(unsafe { column_task(ctx, col, out, sc, direct, &pool) });
        let mut st = [None];
        run_together(ctx.field, &mut [task], &pool, &mut st);
        st[0].unwrap_or_default()
    };
    sc.pool = pool.into_inner();
    st
}

/// Columns rendered together (orthographic views without supersampling or
/// coverage): their sweeps' look-ahead batches are evaluated as one.
pub(crate) const GROUP: usize = 16;

/// Several orthographic columns `cols` (at most [`GROUP`]), each into its
/// scratch's `centre` and, with `direct`, straight into the render's
/// buffers: [`render_column_direct`] for each, their sweeps run in step so
/// that the look-ahead batches of all of them are one evaluation (a batch
/// of a few points costs nearly as much as one of many; the values are the
/// same point by point, so the output is too).
///
/// # Safety
/// With `direct`, no other thread reads or writes the pixels of the
/// columns `cols` meanwhile.
pub(crate) unsafe fn render_columns_direct(
    ctx: &Ctx<'_>,
    cols: std::ops::Range<usize>,
    scs: &mut [ColumnScratch],
    direct: Option<(&super::SharedOut<'_>, usize)>,
) -> ColumnStats {
    let pool = RefCell::new(std::mem::take(&mut scs[0].pool));
    let h = ctx.cam.height;
    let mut centres: Vec<Vec<Pixel>> = scs
        .iter_mut()
        .map(|sc| {
            let mut c = std::mem::take(&mut sc.centre);
            if c.len() != h {
                c.clear();
                c.resize(h, Pixel::default());
            }
            c
        })
        .collect();
    let directs: Vec<Direct<'_, '_>> = match direct {
        Some((out, width)) => cols.clone().map(|j| Direct { out, j, width }).collect(),
        None => Vec::new(),
    };
    let mut tasks: Vec<_> = cols
        .clone()
        .zip(centres.iter_mut().zip(scs.iter_mut()))
        .enumerate()
        .map(|(k, (j, (c, sc)))| {
            // SAFETY: as for this function; pixel (i, j) of column j only.
            Box::pin(unsafe { column_task(ctx, j as f64, c, sc, directs.get(k), &pool) })
        })
        .collect();
    let mut sts = vec![None; tasks.len()];
    run_together(ctx.field, &mut tasks, &pool, &mut sts);
    drop(tasks);
    let mut total = ColumnStats::default();
    for st in sts.iter().flatten() {
        total.add(st);
    }
    for (sc, c) in scs.iter_mut().zip(centres) {
        sc.centre = c;
    }
    scs[0].pool = pool.into_inner();
    total
}

/// Evaluations asked for by the sweeps of columns run together: the points
/// of the current round, and the values of the last one; and the buffers
/// of their exact solves (each runs whole within one poll).
#[derive(Debug, Default)]
pub(super) struct Pool {
    u: Vec<f64>,
    v: Vec<f64>,
    hs: Vec<crate::surface::HeightSample>,
    ortho: OrthoScratch,
}

/// A future that is pending once (a sweep waiting for its batch).
struct Yield(bool);

impl std::future::Future for Yield {
    type Output = ();
    fn poll(
        mut self: std::pin::Pin<&mut Self>,
        _: &mut std::task::Context<'_>,
    ) -> std::task::Poll<()> {
        if self.0 {
            std::task::Poll::Ready(())
        } else {
            self.0 = true;
            std::task::Poll::Pending
        }
    }
}

/// Run column tasks to the end: poll each, evaluate the points they ask
/// for in one batch, and again, until all are done; task k's result goes
/// to `done[k]` (which starts as `None`).
fn run_together<P>(
    field: &dyn HeightField,
    tasks: &mut [std::pin::Pin<P>],
    pool: &RefCell<Pool>,
    done: &mut [Option<ColumnStats>],
) where
    P: std::ops::DerefMut,
    P::Target: std::future::Future<Output = ColumnStats>,
{
    let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
    loop {
        for (task, d) in tasks.iter_mut().zip(done.iter_mut()) {
            if d.is_none() {
                if let std::task::Poll::Ready(st) =
                    std::future::Future::poll(task.as_mut(), &mut cx)
                {
                    *d = Some(st);
                }
            }
        }
        if done.iter().all(Option::is_some) {
            return;
        }
        let mut p = pool.borrow_mut();
        let Pool { u, v, hs, .. } = &mut *p;
        if hs.len() < u.len() {
            hs.resize(u.len(), Default::default());
        }
        field.eval_batch(u, v, &mut hs[..u.len()]);
        u.clear();
        v.clear();
    }
}

/// [`render_column_direct`] as a task that waits for its look-ahead
/// batches to be evaluated with those of other columns (`pool`).
///
/// # Safety
/// As for [`render_column_direct`].
async unsafe fn column_task(
    ctx: &Ctx<'_>,
    col: f64,
    out: &mut [Pixel],
    sc: &mut ColumnScratch,
    direct: Option<&super::refine::Direct<'_, '_>>,
    pool: &RefCell<Pool>,
) -> ColumnStats {
    let fr = ctx.frame;
    let xpix = fr.xpix(col);
    let line = fr.column(xpix);
    let sampler = Sampler {
        frame: &ctx.frame,
        field: ctx.field,
        line,
        evals: 0,
        folds: 0,
        lateral_tol: 0.02,
        d: ctx.cam.d,
        shading: ctx.shading,
        shade: ctx.opts.shading == ShadingMode::Intensity || ctx.opts.corrections.any_detection(),
    };
    let bounds = sampler.bounds();
    let mut sw = Sweep {
        ctx,
        sampler,
        col,
        cov: Coverage::default(),
        h: ctx.cam.height as f64,
        stats: ColumnStats::default(),
        jobs: {
            let mut j = std::mem::take(&mut sc.jobs);
            j.clear();
            j
        },
        seeds: {
            let mut j = std::mem::take(&mut sc.seeds);
            j.clear();
            j
        },
        spans: {
            let mut j = std::mem::take(&mut sc.spans);
            j.clear();
            j
        },
        ahead: (line.kappa == 0.0).then(|| {
            let mut a = std::mem::take(&mut sc.ahead);
            a.reset();
            a
        }),
        fine: ctx.opts.coverage.then(Coverage::default),
        pool,
        detect: ctx.opts.corrections.any_detection(),
        grew: false,
        bounds,
        wrote: false,
    };
    if !fr.persp {
        if let Some((t0, t1)) = fr.domain_t_range_at_s(line.s0) {
            sw.sweep(t0, 1.0, t1 - t0, out).await;
        }
    } else {
        let (tmin, tmax) = fr.domain_t_range();
        if tmax > 0.0 {
            sw.sweep(tmin.max(0.0), 1.0, tmax - tmin.max(0.0), out)
                .await;
        }
        // Rays whose horizontal direction points backwards (looking steeply
        // down or up): a second, independent sweep from the eye backwards.
        let hh = 0.5 * ctx.cam.height as f64;
        let back = fr.focal * fr.d_t - hh * fr.up_t.abs() < 0.0;
        if back && tmin < 0.0 {
            sw.cov = Coverage::default();
            sw.sweep(tmax.min(0.0), -1.0, tmax.min(0.0) - tmin, out)
                .await;
        }
    }
    if let Some(a) = sw.ahead.take() {
        sc.ahead = a;
    }
    if !sw.seeds.is_empty() {
        let (failed, evals) = solve_ortho(
            ctx,
            col,
            &sw.seeds,
            &sw.spans,
            out,
            direct,
            &mut pool.borrow_mut().ortho,
        );
        sw.stats.refine_evals += evals;
        sw.stats.refine_fail += failed;
    }
    if !sw.jobs.is_empty() {
        let (failed, evals) = super::refine::solve_with(ctx, &sw.jobs, out, &mut sc.solve);
        sw.stats.refine_evals += evals;
        sw.stats.refine_fail += failed.len() as u64;
        if ctx.searched {
            // As in `solve_ortho`: the ray marched over its bracket
            // (widened by eight pixels), else left for the searches.
            for &k in sc.solve.failed_jobs() {
                let j = &sw.jobs[k as usize];
                let slot = j.slot;
                let side = out[slot].side;
                let (lo, hi) = (j.lo - 8.0 * j.fp, j.hi + 8.0 * j.fp);
                let (hit, n) = super::radial::march_ray(ctx, j.o, j.dir, lo, hi, j.fp, side);
                sw.stats.refine_evals += n;
                match hit {
                    Some((l, h)) => {
                        let q = j.o + l * j.dir;
                        let depth = (q - ctx.cam.eye).dot(ctx.cam.d);
                        super::refine::finish(
                            ctx,
                            &mut out[slot],
                            j.dir,
                            depth,
                            DVec2::new(q.x, q.y),
                            &h,
                        );
                    }
                    None => out[slot].set = false,
                }
            }
        } else if ctx.opts.shading == ShadingMode::Normal {
            for &slot in failed {
                let (_, dir) = ctx.cam.ray(slot as f64, col);
                out[slot].inten = ctx.shading.intensity(out[slot].n, -dir);
            }
        }
    }
    if let Some(fine) = &sw.fine {
        // §6.4: each pixel's covered fraction of its row extent
        // [i − ½, i + ½]; an uncovered one keeps its silhouette's shading.
        for (i, p) in out.iter_mut().enumerate() {
            let x = i as f64;
            let f = fine.overlap(x - 0.5, x + 0.5).min(1.0);
            p.cover = if p.set || p.cover > 0.0 { f } else { 0.0 };
            if !p.set && p.cover > 0.0 && p.inten.is_nan() {
                let (_, dir) = ctx.cam.ray(x, col);
                p.inten = ctx.shading.intensity(p.n, -dir);
            }
        }
    }
    sw.stats.sweep_evals = sw.sampler.evals;
    sw.stats.folds = sw.sampler.folds;
    sc.jobs = std::mem::take(&mut sw.jobs);
    sc.seeds = std::mem::take(&mut sw.seeds);
    sc.spans = std::mem::take(&mut sw.spans);
    sc.centre_written = sw.wrote;
    sw.stats
}

/// Buffers of [`solve_ortho`], reused from column to column.
#[derive(Debug, Default)]
pub(super) struct OrthoScratch {
    /// Per job: its ray origin.
    orig: Vec<DVec3>,
    newton: super::refine::NewtonScratch,
}

/// The exact solve of the pixels of orthographic column `col` seeded by
/// their spans: [`super::refine::newton`] on the camera's rays, with the
/// ray origins computed once from the rows and each pixel written once,
/// when its solve ends (an exact hit, or its span's interpolation should
/// the solve fail): into `out`, or with `direct`, straight into the
/// render's buffers. Returns the number of failures and of evaluations.
#[inline(never)]
fn solve_ortho(
    ctx: &Ctx<'_>,
    col: f64,
    jobs: &[super::refine::SeedJob],
    spans: &[super::refine::SpanSeed],
    out: &mut [Pixel],
    direct: Option<&Direct<'_, '_>>,
    sc: &mut OrthoScratch,
) -> (u64, u64) {
    let cam = ctx.cam;
    let d = cam.d;
    let normal = ctx.opts.shading == ShadingMode::Normal;
    // The ray origin of row i: what `Camera::ray` gives, the column's part
    // hoisted.
    let (xs, _) = cam.pixel_to_screen(0.0, col);
    let base = cam.eye + (xs * cam.pixel) * cam.r;
    let OrthoScratch { orig, newton } = sc;
    orig.clear();
    orig.extend(jobs.iter().map(|j| {
        let (_, ys) = cam.pixel_to_screen(j.slot as f64, col);
        base + (ys * cam.pixel) * cam.up
    }));
    let fp = ctx.frame.pixel;
    let mut evals = super::refine::newton(
        ctx,
        jobs.len(),
        |k| jobs[k].lam,
        |k| (orig[k], d),
        |k| {
            let s = &spans[jobs[k].span as usize];
            (s.lo, s.hi, fp)
        },
        newton,
        |k, l, q, h| {
            let j = &jobs[k];
            put_exact(ctx, out, direct, j, &spans[j.span as usize], l, q, h);
        },
    );
    let failed = newton.failed();
    // A failed pixel's ray marched over its span's bracket (widened by
    // eight pixels) from the side the span reveals; with no crossing there,
    // it is left unset for the searches after the sweeps (`ctx.searched`)
    // or keeps its span's interpolation.
    for &k in failed {
        let j = &jobs[k as usize];
        let s = &spans[j.span as usize];
        let o = orig[k as usize];
        let (hit, n) =
            super::radial::march_ray(ctx, o, d, s.lo - 8.0 * fp, s.hi + 8.0 * fp, fp, s.topo);
        evals += n;
        if let Some((l, h)) = hit {
            put_exact(ctx, out, direct, j, s, l, o + l * d, &h);
        } else if ctx.searched {
            if direct.is_none() {
                out[j.slot as usize].set = false;
            }
        } else {
            let mut px = s.pixel(j.tau, j.lam);
            if normal {
                px.inten = ctx.shading.intensity(px.n, -d);
            }
            put_solved(out, direct, j.slot, &px);
        }
    }
    (failed.len() as u64, evals)
}

/// Write the exact hit of job `j` (span `s`) at distance `l` along its ray,
/// point `q`, surface sample `h` (see [`solve_ortho`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn put_exact(
    ctx: &Ctx<'_>,
    out: &mut [Pixel],
    direct: Option<&Direct<'_, '_>>,
    j: &super::refine::SeedJob,
    s: &super::refine::SpanSeed,
    l: f64,
    q: DVec3,
    h: &crate::surface::HeightSample,
) {
    let d = ctx.cam.d;
    let normal = ctx.opts.shading == ShadingMode::Normal;
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
        ctx.shading.intensity_cos(nrm, -d, c)
    } else {
        s.inten[0] + j.tau * (s.inten[1] - s.inten[0])
    };
    match direct {
        // SAFETY: the caller of `render_column_direct` guarantees
        // that no other thread touches column `j`'s pixels.
        Some(dst) => unsafe {
            let k = j.slot as usize * dst.width + dst.j;
            dst.out
                .put_hit(k, side, inten, l, nrm, DVec2::new(q.x, q.y));
        },
        None => {
            out[j.slot as usize] = Pixel {
                set: true,
                side,
                depth: l,
                n: nrm,
                uv: DVec2::new(q.x, q.y),
                inten,
                cover: 1.0,
            }
        }
    }
}

/// Write a finished pixel of row `slot` of an orthographic column: into
/// `out`, or with `direct`, straight into the render's buffers.
#[inline(always)]
fn put_solved(out: &mut [Pixel], direct: Option<&Direct<'_, '_>>, slot: u32, px: &Pixel) {
    match direct {
        // SAFETY: the caller of `render_column_direct` guarantees that no
        // other thread touches column `j`'s pixels.
        Some(dst) => unsafe { dst.out.put_set(slot as usize * dst.width + dst.j, px) },
        None => out[slot as usize] = *px,
    }
}

/// The critical points in (0, 1) of the cubic Hermite through (0, p0),
/// (1, p1) with slopes m0, m1 (finite), each given to `at` as (x, p(x)).
#[inline]
fn hermite_extrema(p0: f64, p1: f64, m0: f64, m1: f64, mut at: impl FnMut(f64, f64)) {
    let a = 2.0 * (p0 - p1) + m0 + m1;
    let b = 3.0 * (p1 - p0) - 2.0 * m0 - m1;
    let c = m0;
    let mut inside = |x: f64| {
        if x > 0.0 && x < 1.0 {
            at(x, ((a * x + b) * x + c) * x + p0);
        }
    };
    // p'(x) = 3a x² + 2b x + c.
    if a.abs() < 1e-300 {
        if b != 0.0 {
            inside(-c / (2.0 * b));
        }
    } else {
        let disc = b * b - 3.0 * a * c;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            inside((-b + sq) / (3.0 * a));
            inside((-b - sq) / (3.0 * a));
        }
    }
}

/// Range of the cubic Hermite through (0, p0), (1, p1) with slopes m0, m1
/// over [0, 1] (its extrema in (0, 1) included).
pub(crate) fn hermite_range(p0: f64, p1: f64, m0: f64, m1: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (p0.min(p1), p0.max(p1));
    if m0.is_finite() && m1.is_finite() {
        hermite_extrema(p0, p1, m0, m1, |_, p| {
            lo = lo.min(p);
            hi = hi.max(p);
        });
    }
    (lo, hi)
}

/// The cubic Hermite of a span a → b through the two samples' rows and
/// heights with their exact slopes along the sweep (§4.2's interpolation, to
/// fourth order instead of second), its coefficients set up once per span.
/// `None` where the cubic's rows are not monotone over the span (a
/// silhouette between the samples: Fritsch–Carlson's α² + β² ≤ 9 fails);
/// the caller then interpolates linearly and solves the pixels exactly.
#[derive(Debug, Clone, Copy)]
pub(super) struct SpanCubic {
    rho0: f64,
    t0: f64,
    dt: f64,
    dr: f64,
    m0: f64,
    ca: f64,
    cb: f64,
    /// 3·ca and 2·cb (the slope's coefficients, as `at` multiplies them).
    ca3: f64,
    cb2: f64,
    w0: f64,
    n0: f64,
    wa: f64,
    wb: f64,
}

impl SpanCubic {
    #[inline]
    pub(super) fn new(a: &Sample, b: &Sample) -> Option<SpanCubic> {
        let dt = b.t - a.t;
        let dr = b.rho - a.rho;
        let (m0, m1) = (a.drho_dt * dt, b.drho_dt * dt);
        // (finite_zero sums: 0 only where every term is finite)
        if dr == 0.0 || finite_zero(m0) + finite_zero(m1) != 0.0 {
            return None;
        }
        let (al, be) = (m0 / dr, m1 / dr);
        if al < 0.0 || be < 0.0 || al * al + be * be > 9.0 {
            return None;
        }
        let (w0, w1) = (a.wr, b.wr);
        let (n0, n1) = (a.dw_dt * dt, b.dw_dt * dt);
        if finite_zero(n0) + finite_zero(n1) != 0.0 {
            return None;
        }
        let ca = 2.0 * (a.rho - b.rho) + m0 + m1;
        let cb = 3.0 * dr - 2.0 * m0 - m1;
        Some(SpanCubic {
            rho0: a.rho,
            t0: a.t,
            dt,
            dr,
            m0,
            ca,
            cb,
            ca3: 3.0 * ca,
            cb2: 2.0 * cb,
            w0,
            n0,
            wa: 2.0 * (w0 - w1) + n0 + n1,
            wb: 3.0 * (w1 - w0) - 2.0 * n0 - n1,
        })
    }

    /// The point of the span at row `row`: (τ, t, w'); `None` where the
    /// solve for τ does not settle.
    #[inline(always)]
    pub(super) fn at(&self, row: f64) -> Option<(f64, f64, f64)> {
        let (ca, cb, m0, dr) = (self.ca, self.cb, self.m0, self.dr);
        let mut tau = ((row - self.rho0) / dr).clamp(0.0, 1.0);
        let mut res = f64::INFINITY;
        for _ in 0..4 {
            let p = ((ca * tau + cb) * tau + m0) * tau + self.rho0 - row;
            res = p.abs();
            // (far under the exact solve's tolerance, which this seeds;
            // 1e-7 took a third round for most rows)
            if res < 1e-5 {
                break;
            }
            let dp = (self.ca3 * tau + self.cb2) * tau + m0;
            if dp * dr <= 0.0 {
                return None;
            }
            tau = (tau - p / dp).clamp(0.0, 1.0);
        }
        if res > 1e-3 {
            let p = ((ca * tau + cb) * tau + m0) * tau + self.rho0 - row;
            if p.abs() > 1e-3 {
                return None;
            }
        }
        let w = ((self.wa * tau + self.wb) * tau + self.n0) * tau + self.w0;
        Some((tau, self.t0 + tau * self.dt, w))
    }
}

/// A value linear in a span's points, c_t·t + c_w·w′ (an orthographic
/// depth, a perspective bin's horizontal distance or height), as the cubic
/// Hermite in the row through the two samples, with its exact slopes
/// there (dv/dρ = (c_t + c_w·dw′/dt) / (dρ/dt)): one Horner line per row
/// where [`SpanCubic::at`] first solves its rows' cubic for τ. Only for a
/// span whose rows rise about evenly along it, each end's row slope within
/// [`ROW_GRAPH`] of the chord's: there the row cubic is a slightly worse
/// seed (bench view, 480 × 477: 2 % more evaluations in the exact solves)
/// but needs no inner solve and its unpredictable branches (about 8 % less
/// time in interleaved runs, both projections; orthographic instructions
/// −2 %, −4.7 % with the τ-cubic then not set up), while a slope far from
/// the chord's (the span nears a silhouette or a crest) makes dv/dρ large
/// and the graph a poor fit.
#[derive(Debug, Clone, Copy)]
pub(super) struct RowCubic<const N: usize> {
    rho0: f64,
    inv_dr: f64,
    k: [[f64; 4]; N],
}

/// Row slope at a span's ends over the chord's, within which [`RowCubic`]
/// is used: [1/√2, √2].
pub(super) const ROW_GRAPH: (f64, f64) =
    (std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::SQRT_2);

impl<const N: usize> RowCubic<N> {
    /// The cubics of the values c_t·t + c_w·w′ for each (c_t, c_w) of `c`.
    #[inline]
    pub(super) fn new(a: &Sample, b: &Sample, c: [(f64, f64); N]) -> Option<RowCubic<N>> {
        let dt = b.t - a.t;
        let dr = b.rho - a.rho;
        let inv_dr = 1.0 / dr;
        // (false for NaN: a flat or non-finite span is left to SpanCubic)
        let (al, be) = (a.drho_dt * dt * inv_dr, b.drho_dt * dt * inv_dr);
        let (lo, hi) = ROW_GRAPH;
        if !(al >= lo && al <= hi && be >= lo && be <= hi) {
            return None;
        }
        // dv/ds at each end (s = (ρ − ρ_a)/(ρ_b − ρ_a)): dv/dτ over ds/dτ,
        // dv/dt times dt/α (the two divisions shared by the N values).
        let (qa, qb) = (dt / al, dt / be);
        let mut k = [[0.0; 4]; N];
        let mut finite = 0.0;
        for (k, (ct, cw)) in k.iter_mut().zip(c) {
            let (va, vb) = (ct * a.t + cw * a.wr, ct * b.t + cw * b.wr);
            let ma = (ct + cw * a.dw_dt) * qa;
            let mb = (ct + cw * b.dw_dt) * qb;
            *k = [
                2.0 * (va - vb) + ma + mb,
                3.0 * (vb - va) - 2.0 * ma - mb,
                ma,
                va,
            ];
            finite += k.iter().map(|&x| finite_zero(x)).sum::<f64>();
        }
        (finite == 0.0).then_some(RowCubic {
            rho0: a.rho,
            inv_dr,
            k,
        })
    }

    /// The row's weight s in the span (linear in the row, for the
    /// interpolations that a weight serves) and the values at row `row`.
    #[inline(always)]
    pub(super) fn at(&self, row: f64) -> (f64, [f64; N]) {
        let s = (row - self.rho0) * self.inv_dr;
        (s, self.k.map(|k| ((k[0] * s + k[1]) * s + k[2]) * s + k[3]))
    }
}

impl<'c, 'a> Sweep<'c, 'a> {
    #[inline]
    fn clamp_row(&self, r: f64) -> f64 {
        r.clamp(-2.0, self.h + 1.0)
    }

    fn valid(&self, s: &Option<Sample>) -> bool {
        matches!(s, Some(x) if x.rho.is_finite())
    }

    fn sample(&mut self, t: f64, w_pred: f64) -> Option<Sample> {
        let s = self.sampler.sample(t, w_pred);
        match s {
            Some(x) if finite_zero(x.rho) + finite_zero(x.z) == 0.0 => Some(x),
            _ => None,
        }
    }

    /// The next sample of a sweep after τ, at τ + h, or at any τ' in
    /// [τ + h/2, τ + h_max] already evaluated ahead (a smaller step than
    /// wanted is always safe: the row gap is checked all the same). The
    /// sample is written into `out` (in place: samples are large); returns
    /// τ' and whether there is one (`out` is garbage otherwise), or `None`
    /// when the look-ahead has nothing that fits ([`Self::refill`]).
    #[allow(clippy::too_many_arguments)]
    fn next(
        &mut self,
        tt: impl Fn(f64) -> f64,
        tau: f64,
        h: f64,
        h_max: f64,
        limit: f64,
        snap: f64,
        pred: f64,
        out: &mut Sample,
    ) -> Option<(f64, bool)> {
        let Some(ahead) = self.ahead.as_mut() else {
            let mut tau_n = tau + h;
            if tau_n >= limit - snap {
                tau_n = limit;
            }
            return Some(match self.sample(tt(tau_n), pred) {
                Some(x) => {
                    *out = x;
                    (tau_n, true)
                }
                None => (tau_n, false),
            });
        };
        let hi = min_num(tau + h_max, limit);
        let r = ahead.take(tau + 0.5 * h, hi)?;
        Some(self.finish_raw(r, out))
    }

    /// [`Self::next`] where nothing buffered fits: a new look-ahead batch
    /// from τ at step h, evaluated with the other columns' batches, and
    /// its first sample.
    async fn refill(
        &mut self,
        tt: impl Fn(f64) -> f64,
        tau: f64,
        h: f64,
        limit: f64,
        snap: f64,
        out: &mut Sample,
    ) -> (f64, bool) {
        let ahead = self.ahead.as_deref_mut().expect("look-ahead sweep");
        let (start, n) = {
            let mut p = self.pool.borrow_mut();
            let p = &mut *p;
            let start = p.u.len();
            let b = &self.bounds;
            let n = ahead.plan_points(
                &self.sampler,
                tau,
                h,
                limit,
                snap,
                tt,
                b,
                &mut p.u,
                &mut p.v,
            );
            (start, n)
        };
        if n > 0 {
            Yield(false).await;
        }
        let first = {
            let p = self.pool.borrow();
            let hs = if n > 0 { &p.hs[start..start + n] } else { &[] };
            let ahead = self.ahead.as_deref_mut().expect("look-ahead sweep");
            ahead.fill_points(&mut self.sampler, hs)
        };
        self.finish_raw(first, out)
    }

    /// The sample of a look-ahead point (τ', raw values) into `out`;
    /// returns τ' and whether there is one.
    #[inline(always)]
    fn finish_raw(&mut self, r: (f64, Option<Raw>), out: &mut Sample) -> (f64, bool) {
        let ok = match r.1 {
            Some(x) => {
                self.sampler.finish_into(x.t, x.uv, x.h, false, out);
                finite_zero(out.rho) + finite_zero(out.z) == 0.0
            }
            None => false,
        };
        (r.0, ok)
    }

    /// Prediction of w' at parameter distance dtau (signed t step) from a.
    #[inline]
    fn predict(a: &Sample, dt: f64) -> f64 {
        let p = a.wr + a.dw_dt * dt;
        if finite_zero(a.dw_dt) + finite_zero(p) == 0.0 {
            p
        } else {
            a.wr
        }
    }

    fn z_guess(&self, t: f64) -> f64 {
        let fr = &self.ctx.frame;
        let w = self.ctx.cam.view.target.z - fr.origin.z;
        let z = t * fr.d_t + w * fr.d_w;
        let d = match self.ctx.cam.view.projection {
            crate::camera::Projection::Perspective { distance, .. } => distance,
            _ => 1.0,
        };
        z.max(1e-3 * d)
    }

    /// One sweep: t = t_start + sign·τ for τ in [0, len].
    async fn sweep(&mut self, t_start: f64, sign: f64, len: f64, out: &mut [Pixel]) {
        let opts = self.ctx.opts;
        let fr = self.ctx.frame;
        // An orthographic column whose pixels are solved exactly: longer
        // steps by default, each held to a bend and crests sampled (see
        // `bend_limit` and `crest`).
        let exact = self.ctx.refine && !fr.persp;
        let step_px = opts.sweep_step(exact, false);
        let tt = |tau: f64| t_start + sign * tau;
        let w0 = self.ctx.cam.view.target.z - fr.origin.z;
        let mut tau = 0.0;
        // The previous sample (`pa`, when `has_prev`) and the candidate
        // (`pb`): two slots whose references swap when a step is taken.
        let (mut s0, mut s1) = (Sample::default(), Sample::default());
        let (mut pa, mut pb) = (&mut s0, &mut s1);
        let mut has_prev = false;
        if let Some(a) = self.sample(tt(0.0), w0) {
            self.start_run(&a);
            *pa = a;
            has_prev = true;
        }
        let mut last_w = if has_prev { pa.wr } else { w0 };
        // End of the current valid stretch (found by bisection), if known.
        let mut barrier: Option<(f64, f64)> = None;
        let mut steps = 0usize;
        let min_frac = 1e-6;
        // Stretches outside the image stepped over at once (orthographic
        // columns): not before this τ again after a try that failed.
        let skips = !fr.persp && opts.skip_outside;
        // The step the last step's bend allows (∞: unknown), `bend_limit`.
        let mut bend = f64::INFINITY;
        let crests = exact && !self.detect;
        // (a sample deep in the covered rows may step farther, see `deep`)
        let long = opts.long_steps(exact);
        let mut no_skip_until = f64::NEG_INFINITY;
        while tau < len && steps < MAX_STEPS {
            steps += 1;
            let fp = if has_prev {
                fr.footprint(pa.z)
            } else {
                fr.footprint(self.z_guess(tt(tau)))
            };
            let cap = opts.max_step() * fp;
            let limit = match barrier {
                Some((b, _)) if has_prev => b,
                _ => len,
            };
            let mut skip = 0.0;
            let hf = self.h;
            // (on the picture, the common case: one test)
            let outside = has_prev && !(pa.rho >= -SKIP_MARGIN && pa.rho <= hf - 1.0 + SKIP_MARGIN);
            // (or in a hole, or outside the domain: no sample to step from)
            if (outside || !has_prev) && skips && tau >= no_skip_until {
                // (orthographic columns: their line in (u, v) is fixed)
                skip = invisible_run(SKIP_MIN * cap, limit - tau, |l| {
                    self.invisible(tt(tau), tt(tau + l))
                });
                if skip <= cap {
                    no_skip_until = tau + SKIP_MIN * cap;
                }
            }
            // The step aims a little under the row gap allowed (so that
            // few steps are retried), and any step up to the allowed gap
            // is taken from the look-ahead.
            let (mut h, mut h_max) = if skip > cap {
                (skip, skip)
            } else if !has_prev || outside {
                // Beyond the picture's rows the row rate sets no step (the
                // rows are clamped; a step into the picture shows as a gap
                // and is retried shorter): near a pole, where that rate
                // grows without bound, steps by it would approach the pole
                // without end.
                (cap, cap)
            } else if let Some(k) = self.deep(pa, step_px, long) {
                // Deep inside the covered rows nothing can show before the
                // curve climbs out: the largest step, or up to twice it
                // deeper still (checked below).
                (k * cap, k * cap)
            } else {
                let r = pa.drho_dt.abs();
                if positive_finite(r) {
                    let mut hm = step_px / r;
                    if exact {
                        hm = min_num(hm, bend);
                    }
                    (min_num(AIM * hm, cap), min_num(hm, cap))
                } else {
                    (cap, cap)
                }
            };
            let mut halvings = 0;
            loop {
                let pred = if has_prev {
                    Self::predict(pa, sign * h)
                } else {
                    last_w
                };
                let (tau_n, ok) = match self.next(tt, tau, h, h_max, limit, 1e-12 * fp, pred, pb) {
                    Some(r) => r,
                    None => self.refill(tt, tau, h, limit, 1e-12 * fp, pb).await,
                };
                let hh = tau_n - tau;
                match (has_prev, ok) {
                    (true, true) => {
                        let (a, b) = (&*pa, &*pb);
                        let gap = (self.clamp_row(b.rho) - self.clamp_row(a.rho)).abs();
                        let hidden = gap > step_px && self.hidden(a, b);
                        let ulps = retry_floor(tau.abs().max(tt(tau).abs()));
                        if gap > step_px
                            && !hidden
                            && halvings < 40
                            && hh > (min_frac * fp).max(2.0 * ulps)
                        {
                            // Retry at the step the gap suggests (rows vary
                            // about linearly over a small step).
                            h = (hh * (0.9 * step_px / gap).clamp(0.05, 0.5)).max(ulps);
                            h_max = h;
                            halvings += 1;
                            continue;
                        }
                        let wall = gap > step_px && !hidden;
                        if wall {
                            self.stats.walls += 1;
                        }
                        let from = if wall { None } else { self.correct(a, b, out) };
                        let from = match from {
                            None if crests && !wall && !rows_monotone(a, b) => {
                                self.crest(a, b, out)
                            }
                            f => f,
                        };
                        self.span(from.as_ref().unwrap_or(a), b, wall, out);
                        last_w = b.wr;
                        bend = bend_limit(a, b, 1.0, BEND);
                        // The candidate becomes the previous sample.
                        std::mem::swap(&mut pa, &mut pb);
                        tau = tau_n;
                        if let Some((bt, after)) = barrier {
                            if tau >= bt {
                                // End of the valid stretch: jump past it.
                                has_prev = false;
                                tau = after;
                                barrier = None;
                            }
                        }
                        break;
                    }
                    (true, false) => {
                        // The surface ends in (τ, τ_n): bisect for its edge.
                        let (lo, hi) = self.bisect(tt, tau, tau_n, true, pa, sign, fp);
                        barrier = Some((lo, hi));
                        if lo <= tau {
                            has_prev = false;
                            tau = hi;
                            barrier = None;
                        }
                        break;
                    }
                    (false, true) => {
                        let b = *pb;
                        let (lo, hi) = self.bisect(tt, tau, tau_n, false, &b, sign, fp);
                        let _ = lo;
                        let first = if hi < tau_n {
                            self.sample(tt(hi), Self::predict(&b, sign * (hi - tau_n)))
                        } else {
                            Some(b)
                        };
                        let first = first.unwrap_or(b);
                        let tau_f = if hi < tau_n && self.valid(&Some(first)) {
                            hi
                        } else {
                            tau_n
                        };
                        self.start_run(&first);
                        *pa = first;
                        has_prev = true;
                        last_w = first.wr;
                        tau = tau_f;
                        break;
                    }
                    (false, false) => {
                        tau = tau_n;
                        break;
                    }
                }
            }
            // Early exit once every row is covered (checked only when
            // the coverage grew).
            if std::mem::take(&mut self.grew) && self.cov.covers(-0.5, self.h - 0.5) {
                self.stats.early_exit += 1;
                return;
            }
        }
    }

    /// How far sample `a` lies inside the covered rows, as a multiple of
    /// the largest step it may take: None within 2·`step_px` rows of the
    /// coverage's edge, else 1, or with `longer` (the long default steps,
    /// [`super::FloatingOptions::long_steps`], see [`DEEP_MAX`]) the depth
    /// over that, up to [`DEEP_MAX`].
    #[inline]
    fn deep(&self, a: &Sample, step_px: f64, longer: bool) -> Option<f64> {
        let depth = self.cov.depth(self.clamp_row(a.rho));
        (depth > 2.0 * step_px).then(|| {
            if longer {
                min_num(depth / (2.0 * step_px), DEEP_MAX)
            } else {
                1.0
            }
        })
    }

    /// Is the column's curve between t = ta and tb wholly above or wholly
    /// below the image's rows ([`SKIP_MARGIN`] rows out)? By the surface's
    /// bounds over the stretch's (u, v) box: the camera's y = t·up_t +
    /// w'·up_w is bilinear in (t, w'), so its range there is taken at the
    /// corners of [ta, tb] × [w'_lo, w'_hi].
    #[inline(never)]
    fn invisible(&self, ta: f64, tb: f64) -> bool {
        let fr = &self.ctx.frame;
        let s0 = self.sampler.line.s0;
        let Some((lo, hi)) = stretch_bound(self.ctx.field, fr.uv(s0, ta), fr.uv(s0, tb)) else {
            return false;
        };
        if lo > hi {
            // No finite value there: nothing to see.
            return true;
        }
        let (wl, wh) = ((lo - fr.origin.z) * fr.up_w, (hi - fr.origin.z) * fr.up_w);
        let (ya, yb) = (ta * fr.up_t, tb * fr.up_t);
        let (y0, y1) = (ya.min(yb) + wl.min(wh), ya.max(yb) + wl.max(wh));
        // (rows grow downwards: the highest y is the smallest row)
        let (r0, r1) = (fr.row(y1, 1.0), fr.row(y0, 1.0));
        r1 < -SKIP_MARGIN || r0 > self.h - 1.0 + SKIP_MARGIN
    }

    /// Does the curve stay inside the covered rows between a and b? Both
    /// ends in one covered interval, and so the extremum of the cubic
    /// through their rows and slopes (§5.2), with a pixel of margin.
    fn hidden(&self, a: &Sample, b: &Sample) -> bool {
        let (ra, rb) = (self.clamp_row(a.rho), self.clamp_row(b.rho));
        let Some((lo, hi)) = self.cov.interval(ra) else {
            return false;
        };
        let (lo, hi) = (lo + 1.0, hi - 1.0);
        if !(ra >= lo && ra <= hi && rb >= lo && rb <= hi) {
            return false;
        }
        hermite_inside(
            a.rho,
            b.rho,
            a.drho_dt * (b.t - a.t),
            b.drho_dt * (b.t - a.t),
            lo,
            hi,
        )
    }

    /// Bisection on validity between τ_a and τ_b (one valid, one not).
    /// Returns (last valid τ, first invalid τ) when `valid_first`, else
    /// (last invalid τ, first valid τ).
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn bisect(
        &mut self,
        tt: impl Fn(f64) -> f64,
        ta: f64,
        tb: f64,
        valid_first: bool,
        known: &Sample,
        sign: f64,
        fp: f64,
    ) -> (f64, f64) {
        let (mut lo, mut hi) = (ta, tb);
        let tol = 1e-3 * fp;
        let mut it = 0;
        while hi - lo > tol && it < 60 {
            it += 1;
            let mid = 0.5 * (lo + hi);
            let kt = if valid_first { ta } else { tb };
            let pred = Self::predict(known, sign * (mid - kt));
            let ok = self.sample(tt(mid), pred).is_some();
            if ok == valid_first {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (lo, hi)
    }

    #[inline(never)]
    fn start_run(&mut self, a: &Sample) {
        let r = self.clamp_row(a.rho);
        if !self.cov.contains(r) {
            self.cov.add(r, r);
            self.grew = true;
            if let Some(f) = self.fine.as_mut() {
                f.add(r, r);
            }
        }
    }

    /// §5 problem detection and correction between consecutive samples a and
    /// b: extra samples are inserted (and their spans drawn); returns the
    /// sample the caller's last span (to b) starts from when it is not a.
    fn correct(&mut self, a: &Sample, b: &Sample, out: &mut [Pixel]) -> Option<Sample> {
        if !self.detect {
            return None;
        }
        let c = self.ctx.opts.corrections;
        let m = self.ctx.frame.plane_normal(self.ctx.cam, self.col);
        let problem = artifacts::detect(&c, a, b, m)?;
        self.stats.problems += 1;
        let inserted: Vec<f64> = if c.spline {
            artifacts::spline_top(problem, a, b, m)
                .into_iter()
                .collect()
        } else {
            let n = c.rate.max(2);
            (1..n)
                .map(|k| a.t + (b.t - a.t) * k as f64 / n as f64)
                .collect()
        };
        let mut prev = *a;
        for t in inserted {
            let pred = Self::predict(&prev, t - prev.t);
            if let Some(mid) = self.sample(t, pred) {
                self.span(&prev, &mid, false, out);
                prev = mid;
            }
        }
        Some(prev)
    }

    /// A crest between samples a and b: where the cubic through their rows
    /// and slopes (§5.2) reaches beyond both by a quarter row or more, into
    /// rows not yet covered, one more sample at the cubic's extremum, and
    /// the span from a to it drawn; returns it (the caller's span to b
    /// starts there). Without it the crest's top between the samples is
    /// left to the searches after the sweeps, and a farther sheet may take
    /// its rows first.
    #[inline(never)]
    fn crest(&mut self, a: &Sample, b: &Sample, out: &mut [Pixel]) -> Option<Sample> {
        let (x, elo, ehi) = crest_beyond(a, b, |r| self.clamp_row(r))?;
        if ehi - elo < 0.25 || self.cov.covers(elo, ehi) {
            return None;
        }
        let dt = b.t - a.t;
        let m = self.sample(a.t + x * dt, Self::predict(a, x * dt))?;
        self.span(a, &m, false, out);
        Some(m)
    }

    /// Fill the rows newly revealed between samples a and b.
    #[inline]
    fn span(&mut self, a: &Sample, b: &Sample, wall: bool, out: &mut [Pixel]) {
        let ra = self.clamp_row(a.rho);
        let rb = self.clamp_row(b.rho);
        let (lo, hi) = if ra <= rb { (ra, rb) } else { (rb, ra) };
        if self.fine.is_none() && self.cov.covers(lo, hi) {
            // Nothing newly revealed (the common case behind the front).
            return;
        }
        self.reveal(a, b, wall, lo, hi, out);
    }

    /// [`Self::span`] past its common case: rows lo..hi, maybe newly
    /// revealed.
    #[inline(never)]
    fn reveal(&mut self, a: &Sample, b: &Sample, wall: bool, lo: f64, hi: f64, out: &mut [Pixel]) {
        if self.fine.is_some() {
            self.edges(a, b, wall, lo, hi, out);
            if self.cov.covers(lo, hi) {
                return;
            }
        }
        let i0 = ceil_i(lo).max(0);
        let i1 = floor_i(hi).min(self.h as i64 - 1);
        if i0 <= i1 {
            let upward = b.rho < a.rho;
            let fr = &self.ctx.frame;
            let topo: i8 = if upward == fr.upper_if_upward { 1 } else { -1 };
            // Orthographic spans: the cubic through the two samples (set up
            // once per span); perspective ones and walls: linear weights.
            let cam = self.ctx.cam;
            let dd = cam.d.dot(cam.d);
            let solved = !fr.persp && !wall && self.ctx.refine && dd > 0.0;
            // (the depth over the rows where the span is well conditioned,
            // else on its cubic in τ, not set up then)
            let graph = if solved {
                RowCubic::new(a, b, [(fr.d_t, fr.d_w)])
            } else {
                None
            };
            let cubic = if fr.persp || wall || graph.is_some() {
                None
            } else {
                SpanCubic::new(a, b)
            };
            if solved && (graph.is_some() || cubic.is_some()) {
                // The common orthographic case, every pixel queued for its
                // exact solve and written once when it ends
                // ([`solve_ortho`]): its seed depth and its
                // weight in the span, the span's values kept once. With
                // coverage the interpolated pixel is also put in the column
                // at once, for the §6.4 edge pass of the spans to come.
                let fp = fr.pixel;
                let span = (a.z - b.z).abs();
                // (the samples' depths are numbers: one comparison orders them)
                let (z0, z1) = if a.z < b.z { (a.z, b.z) } else { (b.z, a.z) };
                let seed = super::refine::SpanSeed {
                    topo,
                    lo: z0 - 2.0 * fp - span,
                    hi: z1 + 2.0 * fp + span,
                    n: [a.n, b.n],
                    uv: [a.uv, b.uv],
                    inten: [a.inten, b.inten],
                };
                let k = self.spans.len() as u32;
                let mut queued = false;
                for i in i0..i1 + 1 {
                    let row = i as f64;
                    if self.cov.contains(row) {
                        continue;
                    }
                    let (tau, lam) = match &graph {
                        Some(g) => {
                            let (s, [lam]) = g.at(row);
                            (s, lam)
                        }
                        None => match cubic.as_ref().and_then(|c| c.at(row)) {
                            Some((tau, t, w)) => (tau, t * fr.d_t + w * fr.d_w),
                            None => {
                                out[i as usize] = self.pixel(a, b, &cubic, i as usize, topo, wall);
                                continue;
                            }
                        },
                    };
                    if self.fine.is_some() {
                        out[i as usize] = seed.pixel(tau, lam);
                    }
                    self.seeds.push(super::refine::SeedJob {
                        slot: i as u32,
                        span: k,
                        tau,
                        lam,
                    });
                    queued = true;
                }
                if queued {
                    self.spans.push(seed);
                }
            } else {
                for i in i0..i1 + 1 {
                    let x = i as f64;
                    if self.cov.contains(x) {
                        continue;
                    }
                    out[i as usize] = self.pixel(a, b, &cubic, i as usize, topo, wall);
                }
            }
        }
        self.cov.add(lo, hi);
        self.grew = true;
    }

    /// §6.4 sub-pixel coverage of the span from a to b (rows lo..hi): the
    /// span's rows at floating-point precision, extended to the extremum of
    /// the cubic through the two samples' rows and slopes (the silhouette
    /// between samples, at most half a pixel beyond them), are added to the
    /// fine coverage; pixels it reaches into without covering their centre
    /// receive, from the first (nearest) such span, its shading there.
    fn edges(&mut self, a: &Sample, b: &Sample, wall: bool, lo: f64, hi: f64, out: &mut [Pixel]) {
        let (mut elo, mut ehi) = (lo, hi);
        let fine = self.fine.as_ref().expect("coverage mode");
        if fine.covers(self.clamp_row(lo - 0.5), self.clamp_row(hi + 0.5)) {
            // Behind the front (the common case): nothing reaches out.
            return;
        }
        if !wall {
            let dt = b.t - a.t;
            let (hl, hh) = hermite_range(a.rho, b.rho, a.drho_dt * dt, b.drho_dt * dt);
            elo = self.clamp_row(hl.max(lo - 0.5));
            ehi = self.clamp_row(hh.min(hi + 0.5));
        }
        let fine = self.fine.as_mut().expect("coverage mode");
        if fine.covers(elo, ehi) {
            return;
        }
        fine.add(elo, ehi);
        let i0 = ((elo - 0.5).floor() + 1.0).max(0.0) as i64;
        let i1 = ((ehi + 0.5).ceil() - 1.0).min(self.h - 1.0) as i64;
        let fr = self.ctx.frame;
        let upward = b.rho < a.rho;
        let topo: i8 = if upward == fr.upper_if_upward { 1 } else { -1 };
        for i in i0..i1 + 1 {
            let x = i as f64;
            let q = &out[i as usize];
            // Skip pixels set or reached before, and those this span sets
            // itself (in [lo, hi], not yet covered: a sweep's first sample
            // covers its own row without setting it).
            if q.set || q.cover > 0.0 || (x >= lo && x <= hi && !self.cov.contains(x)) {
                continue;
            }
            out[i as usize] = self.edge_pixel(a, b, x, topo, wall);
        }
    }

    /// The shading of the span from a to b at its end nearest to row x,
    /// for a pixel whose centre it does not cover (no exact solve).
    fn edge_pixel(&self, a: &Sample, b: &Sample, x: f64, topo: i8, wall: bool) -> Pixel {
        let ctx = self.ctx;
        let tau = chord_tau(a, b, x);
        let wb = if ctx.frame.persp {
            let iz = (1.0 - tau) / a.z + tau / b.z;
            tau / b.z / iz
        } else {
            tau
        };
        // Shaded from its normal after the sweep (most of these pixels are
        // set by the next span), unless intensities are interpolated.
        edge_shading(ctx, a, b, wb, topo, wall, ctx.frame.eh)
    }

    #[inline]
    fn pixel(
        &mut self,
        a: &Sample,
        b: &Sample,
        cubic: &Option<SpanCubic>,
        i: usize,
        topo: i8,
        wall: bool,
    ) -> Pixel {
        self.wrote = true;
        let fr = &self.ctx.frame;
        let row = i as f64;
        // Orthographic spans: the point on the cubic through the two
        // samples (fourth order); elsewhere, or where the cubic's rows are
        // not monotone (a silhouette between the samples), linear weights
        // and an exact solve.
        let herm = cubic.as_ref().and_then(|c| c.at(row));
        // A wall (§5.1, a jump between the samples): the pixel's ray meets
        // it at the wall's place, midway between them along the sweep, not
        // where the two sides' values would interpolate to (beside a pole
        // of tan(u), heights of ±10¹⁶: a depth and (u, v) far outside).
        let at_wall = if wall { self.wall_hit(a, b, row) } else { None };
        let (z, wb) = match (herm, at_wall) {
            (Some((tau, t, w)), _) => (t * fr.d_t + w * fr.d_w, tau),
            (None, Some((z, _))) => (z, 0.5),
            (None, None) => {
                let tau = chord_tau(a, b, row);
                // Perspective-correct weights (1/z is linear on the screen).
                if fr.persp {
                    let iz = (1.0 - tau) / a.z + tau / b.z;
                    (1.0 / iz, tau / b.z / iz)
                } else {
                    (a.z + tau * (b.z - a.z), tau)
                }
            }
        };
        let uv = at_wall.map_or_else(|| a.uv.lerp(b.uv, wb), |(_, uv)| uv);
        let n = a.n.lerp(b.n, wb).normalize_or(a.n);
        let inten = a.inten + wb * (b.inten - a.inten);
        let mut px = Pixel {
            set: true,
            side: topo,
            depth: z,
            n,
            uv,
            inten,
            cover: 1.0,
        };
        let exact = !wall && (self.ctx.refine || (self.ctx.fallback && herm.is_none()));
        let mut queued = false;
        let dir = if fr.persp || exact {
            let (o, dir) = self.ctx.cam.ray(row, self.col);
            if exact {
                queued = self.queue(a, b, i, o, dir, z);
            }
            dir
        } else {
            self.ctx.cam.d
        };
        if wall && self.ctx.opts.corrections.walls {
            // §5.1: a wall is not sampled; shade it as the vertical face it
            // is (normal horizontal, along the column's plane towards the
            // viewer) rather than smearing the two sides' values.
            let fr = &self.ctx.frame;
            let e = DVec3::new(fr.eh.x, fr.eh.y, 0.0);
            let wn = if b.wr > a.wr { -e } else { e };
            let toward = -dir;
            px.inten = self.ctx.shading.intensity(wn, toward);
            px.n = n;
            return px;
        }
        // A queued pixel is shaded by its exact solve (or, should that
        // fail, from its interpolated normal afterwards).
        if self.ctx.opts.shading == ShadingMode::Normal && !queued {
            px.inten = self.ctx.shading.intensity(px.n, -dir);
        }
        px
    }
}

impl Sweep<'_, '_> {
    /// Where the ray of row `row` meets the vertical wall between samples
    /// a and b, placed midway between them along the sweep: its depth and
    /// (u, v). None where the rays are vertical (no wall shows) or not in
    /// an orthographic view.
    fn wall_hit(&self, a: &Sample, b: &Sample, row: f64) -> Option<(f64, DVec2)> {
        let (fr, cam) = (&self.ctx.frame, self.ctx.cam);
        if fr.persp {
            return None;
        }
        let d = DVec2::new(cam.d.x, cam.d.y);
        let dd = d.length_squared();
        if dd < 1e-12 {
            return None;
        }
        let p = fr.uv(self.sampler.line.s0, 0.5 * (a.t + b.t));
        let (o, _) = cam.ray(row, self.col);
        let o = DVec2::new(o.x, o.y);
        let lam = (p - o).dot(d) / dd;
        lam.is_finite().then(|| (lam, o + lam * d))
    }

    /// Queue pixel `i` (ray o + λ·dir, interpolated depth z) for the
    /// batched exact solve, bracketed by the span a–b; false when the ray
    /// does not look into the scene.
    fn queue(&mut self, a: &Sample, b: &Sample, i: usize, o: DVec3, dir: DVec3, z: f64) -> bool {
        let fr = &self.ctx.frame;
        let dd = dir.dot(self.ctx.cam.d);
        if dd <= 0.0 {
            return false;
        }
        let to_lam = |z: f64| if fr.persp { z / dd } else { z };
        let fp = fr.footprint(z);
        let span = (to_lam(a.z) - to_lam(b.z)).abs();
        self.jobs.push(super::refine::Job {
            slot: i,
            o,
            dir,
            lam: to_lam(z),
            lo: to_lam(a.z).min(to_lam(b.z)) - 2.0 * fp - span,
            hi: to_lam(a.z).max(to_lam(b.z)) + 2.0 * fp + span,
            fp,
        });
        true
    }
}

/// ⌈x⌉ of a row (finite, far below 2⁵³ in size) without a call to `ceil`.
#[inline]
fn ceil_i(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) < x {
        t + 1
    } else {
        t
    }
}

/// ⌊x⌋ of a row (finite, far below 2⁵³ in size) without a call to `floor`.
#[inline]
fn floor_i(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x {
        t - 1
    } else {
        t
    }
}

/// Where row (or elevation) `x` lies between samples `a` and `b` along
/// their chord: 0 at a, 1 at b, clamped; ½ when both have the same one.
#[inline]
pub(super) fn chord_tau(a: &Sample, b: &Sample, x: f64) -> f64 {
    let dr = b.rho - a.rho;
    if dr != 0.0 {
        ((x - a.rho) / dr).clamp(0.0, 1.0)
    } else {
        0.5
    }
}

/// An edge pixel (partly covered, not solved exactly) shaded from the span
/// a–b at weight `wb` towards b: a wall's horizontal normal (along ±`eh`, the
/// sweep plane's horizontal direction), the interpolated normal, or the
/// interpolated intensity. Shared by the column and radial sweeps.
pub(super) fn edge_shading(
    ctx: &Ctx<'_>,
    a: &Sample,
    b: &Sample,
    wb: f64,
    topo: i8,
    wall: bool,
    eh: DVec2,
) -> Pixel {
    let (n, inten) = if wall && ctx.opts.corrections.walls {
        let e = DVec3::new(eh.x, eh.y, 0.0);
        (if b.wr > a.wr { -e } else { e }, f64::NAN)
    } else if ctx.opts.shading == ShadingMode::Normal {
        (a.n.lerp(b.n, wb).normalize_or(a.n), f64::NAN)
    } else {
        (DVec3::ZERO, a.inten + wb * (b.inten - a.inten))
    };
    Pixel {
        set: false,
        side: topo,
        n,
        inten,
        cover: 1.0,
        ..Pixel::default()
    }
}

/// Does the cubic Hermite through (0, p0), (1, p1) with slopes m0, m1 stay
/// within [lo, hi]? (Its extrema in (0, 1) checked.)
pub(crate) fn hermite_inside(p0: f64, p1: f64, m0: f64, m1: f64, lo: f64, hi: f64) -> bool {
    if finite_zero(m0) + finite_zero(m1) != 0.0 {
        return false;
    }
    let a = 2.0 * (p0 - p1) + m0 + m1;
    let b = 3.0 * (p1 - p0) - 2.0 * m0 - m1;
    let c = m0;
    let p = |x: f64| ((a * x + b) * x + c) * x + p0;
    let ok = |x: f64| !(x > 0.0 && x < 1.0) || (p(x) >= lo && p(x) <= hi);
    if a.abs() < 1e-300 {
        return b == 0.0 || ok(-c / (2.0 * b));
    }
    let disc = b * b - 3.0 * a * c;
    if disc < 0.0 {
        return true;
    }
    let sq = disc.sqrt();
    ok((-b + sq) / (3.0 * a)) && ok((-b - sq) / (3.0 * a))
}

/// Largest row deviation from the chord allowed over a step of an exactly
/// solved orthographic column, in rows (see [`bend_limit`]).
pub(super) const BEND: f64 = 0.05;

/// The same for a perspective sweep, in local pixels: there the pixels
/// beside the mask's edge and beside depth steps are searched on their own
/// rays after the sweeps, and a looser bend shows in none of the edge
/// views' counts, nor in the depths and normals against the exact hit
/// (bench view, 480 × 477: 14 % fewer sweep samples than at 0.05, 1 %
/// more evaluations in the solves); the orthographic columns' edge views
/// lose pixels to it (a DEM seen low: 2 farther than the first hit at
/// 160 × 120 become 10 at 0.1).
pub(super) const BEND_RADIAL: f64 = 0.2;

/// Longest step of an orthographic column's sample deep inside the covered
/// rows, in its largest steps (`max_step` footprints), where its pixels
/// are solved exactly at the default step (the long-step regime of
/// [`super::FloatingOptions::sweep_step`]) and without coverage (whose
/// sub-pixel silhouettes come from the spans themselves; a plain render
/// with coverage's steps has its geometry): a sample 2k·`step` rows
/// inside steps k of them, up to this (the curve must climb that far to
/// show). On the bench view, 480 × 477: 8 % fewer sweep samples than
/// one largest step everywhere there, no change against the exact hit, and
/// on the edge views 5 fewer pixels on a farther sheet. (A limit of 4
/// takes more samples, not fewer: the steps that rise out of the coverage
/// are retried shorter. Perspective bins, whose rays are searched after
/// the sweeps, lose pixels on their edge views to it.)
pub(super) const DEEP_MAX: f64 = 2.0;

/// The longest step (in t) after the step from sample a to b over which
/// the row curve, bending as it did over that step (|ρ''| = |Δρ'/Δt| in
/// rows per t², times `scale`, local pixels per row), stays within `bend`
/// rows of its chord ([`BEND`], [`BEND_RADIAL`]): the deviation of a
/// parabola from its chord over a step h is |ρ''| h² / 8. With it the row
/// gap between samples can be 5 pixels where the curve is nearly straight
/// (the cubic between them still seeds each pixel's solve to well under
/// the solve's tolerance) while fine ripples and folds keep short steps,
/// so that features between samples are not stepped over. ∞ where the
/// curve did not bend or its bend is not finite. (One division and a
/// square root from the sample to the limit: the next step waits on it.)
#[inline(always)]
pub(super) fn bend_limit(a: &Sample, b: &Sample, scale: f64, bend: f64) -> f64 {
    let h2 = 8.0 * bend * (b.t - a.t).abs() / ((b.drho_dt - a.drho_dt).abs() * scale);
    // (NaN and a negative zero fail: no limit)
    if h2 >= 0.0 {
        h2.sqrt()
    } else {
        f64::INFINITY
    }
}

/// The cubic Hermite through (0, p0), (1, p1) with slopes m0, m1 stays
/// within [min(p0, p1), max(p0, p1)] by the Fritsch–Carlson condition (a
/// sufficient one: most spans pass it, and the callers test it in line
/// before they look for an extremum).
#[inline(always)]
pub(crate) fn hermite_monotone(p0: f64, p1: f64, m0: f64, m1: f64) -> bool {
    let dr = p1 - p0;
    m0 * dr >= 0.0 && m1 * dr >= 0.0 && m0 * m0 + m1 * m1 <= 9.0 * dr * dr
}

/// [`hermite_monotone`] for the rows of the cubic between samples a and b
/// (no crest between them).
#[inline(always)]
pub(super) fn rows_monotone(a: &Sample, b: &Sample) -> bool {
    let dt = b.t - a.t;
    hermite_monotone(a.rho, b.rho, a.drho_dt * dt, b.drho_dt * dt)
}

/// The crest of the cubic through samples a and b (rows and slopes) that
/// reaches beyond both ends, rows mapped by `clamp`: (x, lo, hi), its
/// place x in (0, 1) along the step and the rows [lo, hi] it reaches
/// beyond the nearer end (shared by the orthographic and the perspective
/// sweeps' `crest`).
#[inline]
pub(super) fn crest_beyond(
    a: &Sample,
    b: &Sample,
    clamp: impl Fn(f64) -> f64,
) -> Option<(f64, f64, f64)> {
    let dt = b.t - a.t;
    let (x, r) = hermite_overshoot(a.rho, b.rho, a.drho_dt * dt, b.drho_dt * dt)?;
    let (ra, rb, r) = (clamp(a.rho), clamp(b.rho), clamp(r));
    let (lo, hi) = if ra <= rb { (ra, rb) } else { (rb, ra) };
    Some(if r < lo { (x, r, lo) } else { (x, hi, r) })
}

/// The extremum in (0, 1) of the cubic Hermite through (0, p0), (1, p1)
/// with slopes m0, m1 that reaches farthest beyond [min(p0, p1), max(p0,
/// p1)], as (x, p(x)); `None` where the cubic stays within (most spans:
/// the Fritsch–Carlson condition tells those at once).
pub(crate) fn hermite_overshoot(p0: f64, p1: f64, m0: f64, m1: f64) -> Option<(f64, f64)> {
    if hermite_monotone(p0, p1, m0, m1) {
        return None;
    }
    if finite_zero(m0) + finite_zero(m1) != 0.0 {
        return None;
    }
    let (lo, hi) = if p0 <= p1 { (p0, p1) } else { (p1, p0) };
    let beyond = |v: f64| (lo - v).max(v - hi);
    let mut best: Option<(f64, f64)> = None;
    hermite_extrema(p0, p1, m0, m1, |x, v| {
        if beyond(v) > 0.0 && best.is_none_or(|(_, w)| beyond(v) > beyond(w)) {
            best = Some((x, v));
        }
    });
    best
}

#[cfg(test)]
mod row_tests {
    use super::{ceil_i, floor_i};

    /// A crest's overshoot is found where the cubic leaves its ends' rows,
    /// at the cubic's extremum, and never for a monotone span.
    #[test]
    fn hermite_overshoot_finds_the_crest() {
        use super::hermite_overshoot;
        // Monotone (slopes along the span, small): nothing.
        assert!(hermite_overshoot(0.0, 3.0, 2.0, 4.0).is_none());
        // A crest: from row 0 up past row 3 and back (slopes 6, -3).
        let (x, r) = hermite_overshoot(0.0, 3.0, 6.0, -3.0).expect("crest");
        let p = |x: f64| {
            (2.0 * (0.0 - 3.0) + 6.0 - 3.0) * x * x * x + (9.0 - 12.0 + 3.0) * x * x + 6.0 * x
        };
        assert!((p(x) - r).abs() < 1e-12 && r > 3.0);
        for k in 1..100 {
            assert!(p(k as f64 / 100.0) <= r + 1e-12);
        }
        // Downwards (rows decreasing past the lower end).
        let (_, r) = hermite_overshoot(3.0, 0.0, -2.0, 6.0).expect("dip");
        assert!(r < 0.0);
        // Non-finite slopes: none.
        assert!(hermite_overshoot(0.0, 1.0, f64::NAN, 1.0).is_none());
    }

    /// The integer ceil and floor agree with `f64::ceil` and `f64::floor`
    /// over the clamped row range, integers and their neighbours included.
    #[test]
    fn integer_ceil_and_floor_match() {
        let mut xs = vec![
            -2.0, -1.5, -0.5, -0.0, 0.0, 1e-300, -1e-300, 0.5, 477.0, 478.0,
        ];
        for k in -3..500 {
            let x = k as f64;
            xs.extend([x, x + 1e-12, x - 1e-12, x + 0.25, x - 0.75]);
        }
        for x in xs {
            assert_eq!(ceil_i(x), x.ceil() as i64, "ceil {x}");
            assert_eq!(floor_i(x), x.floor() as i64, "floor {x}");
        }
    }
}
