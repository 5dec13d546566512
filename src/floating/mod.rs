//! Function surfaces w = f(u, v) without patches (Gordon 2001): the modified
//! floating horizon (§4.1, A.1: a line drawing) and the floating column
//! (§4.2, A.2: shaded, every pixel column independent).
//!
//! The sampling geometry (§3, derived for the SPEC §1 camera) is in
//! [`sampling`]; the orthographic column sweep in [`column`]; the
//! perspective sweep, run in vertical planes through the eye so that every
//! section is a graph and the sweep stays exact, in [`radial`]; the batched
//! exact per-pixel solve in [`refine`]; the §5 artifact tests and
//! corrections in [`artifacts`]; the line drawing in [`horizon`].

pub mod artifacts;
pub mod column;
pub mod horizon;
pub mod radial;
pub mod refine;
pub mod sampling;

use crate::camera::{Camera, View};
use crate::cancel::Cancel;
use crate::error::{FcolError, Result};
use crate::image::{Buffers, Outputs};
use crate::shade::Shading;
use crate::surface::HeightField;
pub use artifacts::Corrections;
use column::{ColumnStats, Ctx, Pixel};
use rayon::prelude::*;

/// What is interpolated across a revealed span (§4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShadingMode {
    /// Intensity interpolation ("Gouraud", the seed's `iis`).
    Intensity,
    /// Normal interpolation ("Phong", the seed's `nis`), with specular.
    Normal,
}

/// Options of both renderers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloatingOptions {
    pub shading: ShadingMode,
    /// Solve each revealed pixel exactly on its ray (depth, normal, uv).
    pub refine: bool,
    /// Largest row gap between consecutive samples, in pixels (the sample
    /// step adapts to the projected step). None: 1 with `coverage`
    /// (whose sub-pixel silhouettes come from the cubic between samples),
    /// else 5 where pixels are solved exactly (`refine`; 8 local pixels
    /// in a perspective bin), each step there also held to a bend
    /// ([`FloatingOptions::sweep_step`]), and 3 without. With the exact
    /// solve, the cubic through two samples 3 to 5 pixels apart, with
    /// their exact slopes, seeds each pixel to about 1e-3 px, so that one
    /// evaluation per pixel mostly settles it.
    pub step: Option<f64>,
    /// Largest step along a sweep, in lateral pixel footprints. None: 4, or
    /// 2 with `coverage`.
    pub max_step: Option<f64>,
    /// Newton stops when its step is below `refine_tol` pixels.
    pub refine_tol: f64,
    pub refine_iters: usize,
    pub corrections: Corrections,
    /// Column supersampling factor for `rgb` and `intensity` (§6.4).
    pub antialias: usize,
    /// Sub-pixel coverage of `rgb` and `intensity` in the column direction
    /// (§6.4): a pixel crossed by a silhouette is blended with the
    /// background by the covered fraction of its row extent.
    pub coverage: bool,
    /// Floating horizon: number of sampling planes (lines).
    pub planes: usize,
    /// Worker threads (None: rayon's default pool).
    pub threads: Option<usize>,
    /// Stop a perspective sweep as soon as the surface's height bounds
    /// ([`crate::surface::HeightField::height_bound`], and
    /// [`crate::surface::HeightField::height_max_in`] along the plane where
    /// the source keeps local ones) show that no later
    /// point can rise into an uncovered elevation of the bin's rays (§4.2's
    /// early exit, beyond a full column). The picture is the same either
    /// way; only samples are saved.
    pub height_bound: bool,
    /// Step at once over a stretch of a column or plane that the surface's
    /// bounds over it ([`crate::surface::HeightField::height_range_in`])
    /// keep wholly below or above the picture (zoomed views: most of each
    /// line lies in front of the picture). The samples after such a
    /// stretch move, so pixels may differ within the exact solve's
    /// tolerance from a sweep without it.
    pub skip_outside: bool,
    /// Perspective: the widest azimuth bin, in pixels across at the most
    /// sensitive pixel (a pixel lies up to half of it off its bin's
    /// vertical plane). None: 1.25 with the exact solve, 1 without it or
    /// with `coverage` (see [`FloatingOptions::bin_width`]).
    pub bin_width: Option<f64>,
}

impl Default for FloatingOptions {
    fn default() -> Self {
        FloatingOptions {
            shading: ShadingMode::Normal,
            refine: true,
            step: None,
            max_step: None,
            refine_tol: 5e-4,
            refine_iters: 8,
            corrections: Corrections::default(),
            antialias: 1,
            coverage: false,
            planes: 80,
            threads: None,
            height_bound: true,
            skip_outside: true,
            bin_width: None,
        }
    }
}

impl FloatingOptions {
    /// The sample step in rows (see [`FloatingOptions::step`]).
    #[inline]
    pub fn step(&self) -> f64 {
        self.step.unwrap_or(if self.coverage { 1.0 } else { 3.0 })
    }

    /// The sample step in rows of a column's sweep (orthographic) or a
    /// bin's (`radial`: perspective, in local pixels), `exact` whether its
    /// pixels are solved on their rays: by default 5 there, 8 in a bin
    /// (each step also held to a bend, and crests between samples sampled:
    /// see `column::bend_limit`), else [`FloatingOptions::step`]. A bin's
    /// edge pixels and depth steps are searched on their own rays after
    /// the sweeps: its longer steps show neither in the edge views' counts
    /// nor against the exact hit (bench view, 480 × 477: 17 % fewer sweep
    /// samples than at 5, normal median 1.52e-5° → 1.58e-5°, depths the
    /// same); an orthographic column's edge views lose pixels to them.
    #[inline]
    pub fn sweep_step(&self, exact: bool, radial: bool) -> f64 {
        match self.long_steps(exact) {
            true if radial => 8.0,
            true => 5.0,
            false => self.step(),
        }
    }

    /// Whether a sweep whose pixels are solved on their rays (`exact`)
    /// takes the long default steps of [`Self::sweep_step`] (no `step`
    /// given, no coverage), held to a bend and, orthographic, longer still
    /// deep in the covered rows (`column::DEEP_MAX`).
    #[inline]
    pub fn long_steps(&self, exact: bool) -> bool {
        exact && self.step.is_none() && !self.coverage
    }

    /// The largest step in footprints (see [`FloatingOptions::max_step`]).
    #[inline]
    pub fn max_step(&self) -> f64 {
        self.max_step
            .unwrap_or(if self.coverage { 2.0 } else { 4.0 })
    }

    /// The perspective bins' width in pixels (see
    /// [`FloatingOptions::bin_width`]), `refine` being whether the pixels
    /// are solved on their rays: their solve, its side checks and the
    /// mask's edge search ([`radial`]) absorb a plane up to 0.625 px off
    /// (fewer, wider bins: about 20 % fewer sweep samples); the
    /// interpolated pixels without it, and coverage's sub-pixel
    /// silhouettes along the plane, keep half a pixel.
    #[inline]
    pub fn bin_width(&self, refine: bool) -> f64 {
        self.bin_width
            .unwrap_or(if refine && !self.coverage { 1.25 } else { 1.0 })
    }

    pub fn validate(&self) -> Result<()> {
        let pos = |name: &str, x: f64| -> Result<()> {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(FcolError::value(
                    name,
                    format!("must be a positive finite number, got {x}"),
                ))
            }
        };
        if let Some(x) = self.step {
            pos("step", x)?;
        }
        if let Some(x) = self.max_step {
            pos("max_step", x)?;
        }
        pos("refine_tol", self.refine_tol)?;
        if let Some(x) = self.bin_width {
            if !(x.is_finite() && x > 0.0 && x <= 4.0) {
                return Err(FcolError::value(
                    "bin_width",
                    format!("must be a number in (0, 4] (pixels), got {x}"),
                ));
            }
        }
        pos("threshold", self.corrections.threshold)?;
        if self.refine_iters == 0 || self.refine_iters > 100 {
            return Err(FcolError::value("refine_iters", "must be in 1..=100"));
        }
        if self.corrections.rate < 2 || self.corrections.rate > 256 {
            return Err(FcolError::value("rate", "must be in 2..=256"));
        }
        if self.antialias == 0 || self.antialias > 16 {
            return Err(FcolError::value("antialias", "must be in 1..=16"));
        }
        if self.planes < 2 || self.planes > 100_000 {
            return Err(FcolError::value("planes", "must be in 2..=100000"));
        }
        if let Some(t) = self.threads {
            if t == 0 || t > 1024 {
                return Err(FcolError::value("threads", "must be in 1..=1024"));
            }
        }
        Ok(())
    }
}

/// Run `f` on a pool of `threads` workers (or rayon's global pool).
pub(crate) fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> T + Send,
) -> Result<T> {
    match threads {
        None => Ok(f()),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map(|p| p.install(f))
            .map_err(|e| FcolError::value("threads", e.to_string())),
    }
}

/// Render w = f(u, v) by the floating column (§4.2, A.2).
#[allow(clippy::too_many_arguments)]
pub fn render_floating_column(
    field: &dyn HeightField,
    view: &View,
    width: usize,
    height: usize,
    outputs: &Outputs,
    shading: &Shading,
    opts: &FloatingOptions,
    cancel: &Cancel,
) -> Result<Buffers> {
    opts.validate()?;
    shading.validate()?;
    if outputs.lines {
        return Err(FcolError::value(
            "outputs",
            "the \"lines\" buffer belongs to method=\"floating_horizon\"",
        ));
    }
    let cam = Camera::new(view, width, height)?;
    let frame = sampling::Frame::new(&cam, field.domain());
    let wants = outputs.depth
        || outputs.normal
        || outputs.uv
        || outputs.side
        || (outputs.needs_shading() && opts.shading == ShadingMode::Normal);
    let aa = opts.antialias;
    let shade_aa = aa > 1 && outputs.needs_shading();
    let ctx = Ctx {
        cam: &cam,
        frame,
        field,
        shading,
        opts,
        refine: opts.refine && wants,
        fallback: wants,
        // (see the orthographic pass below)
        searched: !cam.perspective,
    };
    let cov = opts.coverage;
    // The plain renders (no supersampled shading, no coverage) write each
    // pixel once: the surface's as they are solved, the background's in
    // the pass over the image that looks for the searches on the mask's
    // edge (radial::edge_searches), not in a fill before.
    let deferred = !shade_aa && !cov;
    let mut buf = if deferred {
        Buffers::deferred(width, height, outputs)
    } else {
        Buffers::new(width, height, outputs, shading.background)
    };
    let geom = outputs.depth || outputs.normal || outputs.uv || outputs.side || outputs.mask;
    let mut total = ColumnStats::default();
    if cam.perspective && shade_aa {
        // §6.4 for perspective views: the radial sweep once per sub-column
        // offset (each pass holds what a plain render holds), its colours
        // averaged into one accumulator. The pass of sub-column m also
        // shifts its rays to sub-row π(m), a permutation of the k sub-rows
        // (an n-rooks pattern), so that the k samples cover both directions
        // at the cost of k passes.
        let q = rook_step(aa);
        let n = width * height;
        let mut acc = vec![[0.0f64; 4]; n];
        let bg = shade(&Pixel::default(), shading, false);
        for m in 0..aa {
            let off = (m as f64 + 0.5) / aa as f64 - 0.5;
            let roff = ((m * q) % aa) as f64 + 0.5;
            let roff = roff / aa as f64 - 0.5;
            let (px, st) = with_threads(opts.threads, || {
                radial::render_radial(&ctx, (roff, off), None, cancel)
            })??;
            total.add(&st);
            let mut seen = vec![false; n];
            for (k, p) in px.iter().flatten() {
                seen[*k] = true;
                let c = shade(p, shading, cov);
                let a = &mut acc[*k];
                for c2 in 0..3 {
                    a[c2] += c[c2] / aa as f64;
                }
                if c[3].is_finite() {
                    a[3] += c[3] / aa as f64;
                }
            }
            for (a, s) in acc.iter_mut().zip(&seen) {
                if !s {
                    for c2 in 0..3 {
                        a[c2] += bg[c2] / aa as f64;
                    }
                }
            }
        }
        let mut centre = Vec::new();
        if geom {
            let (px, st) = with_threads(opts.threads, || {
                radial::render_radial(&ctx, (0.0, 0.0), None, cancel)
            })??;
            total.add(&st);
            centre = px;
        }
        write_aa(&mut buf, &centre, &acc, shading);
    } else if cam.perspective && !cov {
        // Each bin writes its pixels straight into the buffers.
        let out = SharedOut::new(&mut buf, shading);
        let (_, st) = with_threads(opts.threads, || {
            radial::render_radial(&ctx, (0.0, 0.0), Some(&out), cancel)
        })??;
        total = st;
    } else if cam.perspective {
        let (px, st) = with_threads(opts.threads, || {
            radial::render_radial(&ctx, (0.0, 0.0), None, cancel)
        })??;
        total = st;
        write_list(&mut buf, &px, shading, cov);
    } else {
        // Every column writes its pixels straight into the row-major
        // buffers (each pixel belongs to one column); a worker's columns
        // reuse one scratch (pixels, sweep and solve buffers).
        // Without coverage: groups of columns whose sweeps share their
        // batched evaluations (column::render_columns_direct), their set
        // pixels marked for the searches at the mask's edge and the depth
        // steps. With supersampled shading the geometry is this same pass
        // (the searches included, so that it equals a plain render's), and
        // the colours come from the sub-columns after it.
        let n = width * height;
        let mut set = crate::scratch::ScratchArray::<bool>::zeroed(n);
        let mut covered = vec![0.0f32; if cov { n } else { 0 }];
        let geometry_pass = !shade_aa || geom;
        // (one pool for the columns, the searches and the sub-columns)
        let found;
        (total, found) = with_threads(opts.threads, || -> Result<_> {
            let mut total = ColumnStats::default();
            let mut found = Vec::new();
            if geometry_pass {
                // (+∞ where unset: see radial::edge_searches)
                let mut zs = crate::scratch::ScratchArray::<f64>::filled(n, f64::INFINITY);
                let out = SharedOut::new(&mut buf, shading);
                let out = if shade_aa { out.geometry_only() } else { out };
                let out = out.with_marks(&mut set, &mut zs, &mut covered);
                let group = if cov { 1 } else { column::GROUP };
                total = (0..width.div_ceil(group))
                    .into_par_iter()
                    .map(|g| {
                        cancel.check()?;
                        let js = g * group..((g + 1) * group).min(width);
                        Ok(with_scratch(js.len(), |scs| {
                            if group == 1 {
                                ortho_column(&ctx, js.start, &mut scs[0], &out)
                            } else {
                                ortho_group(&ctx, js, scs, &out)
                            }
                        }))
                    })
                    .try_reduce(ColumnStats::default, |mut a, b| {
                        a.add(&b);
                        Ok(a)
                    })?;
                // A crest's top or a domain edge between the column's
                // samples, and a crest in front that the plane's samples
                // step over: the pixels beside set ones searched on their
                // own rays (as in perspective, see radial::edge_searches).
                // (and the background, see `deferred`)
                let fill = deferred.then(|| SharedOut::new(&mut buf, shading));
                let moved = radial::edge_searches(
                    &ctx,
                    (0.0, 0.0),
                    &mut set,
                    &mut zs,
                    &mut found,
                    &mut total,
                    fill.as_ref(),
                );
                found.extend(moved);
            }
            if shade_aa {
                // §6.4: each column's sub-columns, their colours averaged
                // (a failed exact solve there keeps its interpolation: the
                // sub-columns are not searched).
                let sub = Ctx {
                    searched: false,
                    ..ctx
                };
                let out = SharedOut::new(&mut buf, shading).colour_only();
                let st = (0..width)
                    .into_par_iter()
                    .map(|j| {
                        cancel.check()?;
                        Ok(with_scratch(1, |scs| {
                            ortho_subcolumns(&sub, j, &mut scs[0], &out)
                        }))
                    })
                    .try_reduce(ColumnStats::default, |mut a, b| {
                        a.add(&b);
                        Ok(a)
                    })?;
                total.add(&st);
            }
            Ok((total, found))
        })??;
        let out = SharedOut::new(&mut buf, shading);
        let out = if shade_aa { out.geometry_only() } else { out };
        for (k, p) in &found {
            // With coverage, a pixel the column covers in part keeps that
            // fraction (§6.4), its colour blended with it.
            let f = if cov { covered[*k] as f64 } else { 1.0 };
            // SAFETY: the columns are done; this thread alone writes. A
            // found pixel is set.
            unsafe {
                if f > 0.0 && f < 1.0 {
                    let p = Pixel { cover: f, ..*p };
                    out.put_with(*k, &p, Some(shade(&p, shading, true)));
                } else {
                    out.put_set(*k, p);
                }
            }
        }
    }
    if deferred {
        // SAFETY: every pixel was written: those set by their solves (or
        // the searches after them), the others by the searches' pass (see
        // `deferred` above).
        unsafe { buf.set_filled() };
    }
    buf.samples = total.sweep_evals + total.refine_evals;
    buf.stat("sweep_samples", total.sweep_evals as f64);
    buf.stat("refine_evals", total.refine_evals as f64);
    buf.stat("refine_failures", total.refine_fail as f64);
    buf.stat("walls", total.walls as f64);
    buf.stat("problems", total.problems as f64);
    buf.stat("early_exits", total.early_exit as f64);
    buf.stat("holes_filled", total.holes_filled as f64);
    buf.stat("nearer_sheets", total.nearer as f64);
    Ok(buf)
}

/// Render orthographic column j (plain or with coverage) and write it into
/// `out`.
fn ortho_column(
    ctx: &Ctx<'_>,
    j: usize,
    sc: &mut column::ColumnScratch,
    out: &SharedOut<'_>,
) -> ColumnStats {
    let (h, w) = (ctx.cam.height, ctx.cam.width);
    let (shading, cov) = (ctx.shading, ctx.opts.coverage);
    // A plain render leaves its pixels unset after each column (below) and
    // reads only those it sets; coverage renders also read the `cover` of
    // unset pixels, so they start from cleared pixels (the buffer may come
    // from a plain render's column).
    let mut centre = std::mem::take(&mut sc.centre);
    if centre.len() != h || cov {
        centre.clear();
        centre.resize(h, Pixel::default());
    }
    // Plain renders: the exact solve writes its pixels straight into the
    // buffers.
    let direct = column::Direct { out, j, width: w };
    let direct = (!cov).then_some(&direct);
    // SAFETY: pixel (i, j) belongs to column j only.
    let st = unsafe { column::render_column_direct(ctx, j as f64, &mut centre, sc, direct) };
    for (i, p) in centre.iter_mut().enumerate() {
        if !cov {
            if p.set {
                // SAFETY: pixel (i, j) belongs to column j only.
                unsafe { out.put_set(i * w + j, p) };
                // The other pixels of a plain render are read only where
                // set (and written whole when set).
                p.set = false;
            }
            continue;
        }
        // A partly covered pixel (the others are written as without
        // coverage).
        let a = (p.cover > 0.0 && (p.cover < 1.0 || !p.set)).then(|| shade(p, shading, true));
        if p.set || a.is_some() {
            // SAFETY: pixel (i, j) belongs to column j only.
            unsafe { out.put_with(i * w + j, p, a) };
        }
        *p = Pixel::default();
    }
    sc.centre = centre;
    st
}

/// §6.4 supersampled shading of orthographic column j: its sub-columns'
/// colours averaged and written into `out` (the geometry comes from a
/// plain pass, see [`render_floating_column`]).
fn ortho_subcolumns(
    ctx: &Ctx<'_>,
    j: usize,
    sc: &mut column::ColumnScratch,
    out: &SharedOut<'_>,
) -> ColumnStats {
    let (h, w) = (ctx.cam.height, ctx.cam.width);
    let (shading, aa, cov) = (ctx.shading, ctx.opts.antialias, ctx.opts.coverage);
    let mut st = ColumnStats::default();
    // Shading accumulated over sub-columns: (r, g, b, I).
    let mut acc = std::mem::take(&mut sc.acc);
    acc.clear();
    acc.resize(h, [0.0; 4]);
    let mut sub = std::mem::take(&mut sc.sub);
    for m in 0..aa {
        let off = (m as f64 + 0.5) / aa as f64 - 0.5;
        sub.clear();
        sub.resize(h, Pixel::default());
        st.add(&column::render_column_with(
            ctx,
            j as f64 + off,
            &mut sub,
            sc,
        ));
        for (a, p) in acc.iter_mut().zip(&sub) {
            let c = shade(p, shading, cov);
            for k in 0..3 {
                a[k] += c[k] / aa as f64;
            }
            if c[3].is_finite() {
                a[3] += c[3] / aa as f64;
            }
        }
    }
    let unset = Pixel::default();
    for (i, a) in acc.iter().enumerate() {
        // SAFETY: pixel (i, j) belongs to column j only.
        unsafe { out.put_with(i * w + j, &unset, Some(*a)) };
    }
    sc.sub = sub;
    sc.acc = acc;
    st
}

thread_local! {
    /// Column buffers of this worker, kept from task to task (rayon calls a
    /// `map_init` initialiser once per split job, too often for buffers
    /// that grow to a column's needs).
    static SCRATCH: std::cell::RefCell<Vec<column::ColumnScratch>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// Run `f` on at least `n` column buffers of this worker.
fn with_scratch<T>(n: usize, f: impl FnOnce(&mut [column::ColumnScratch]) -> T) -> T {
    SCRATCH.with(|cell| match cell.try_borrow_mut() {
        Ok(mut scs) => {
            if scs.len() < n {
                scs.resize_with(n, Default::default);
            }
            f(&mut scs[..n])
        }
        // Re-entered (not expected): fresh buffers.
        Err(_) => {
            let mut scs: Vec<column::ColumnScratch> = Vec::new();
            scs.resize_with(n, Default::default);
            f(&mut scs)
        }
    })
}

/// Render the orthographic columns `js` of a plain render (no
/// supersampling, no coverage) together and write them into `out`.
fn ortho_group(
    ctx: &Ctx<'_>,
    js: std::ops::Range<usize>,
    scs: &mut [column::ColumnScratch],
    out: &SharedOut<'_>,
) -> ColumnStats {
    let w = ctx.cam.width;
    let scs = &mut scs[..js.len()];
    // SAFETY: pixel (i, j) belongs to column j only, and this call alone
    // renders the columns js.
    let st = unsafe { column::render_columns_direct(ctx, js.clone(), scs, Some((out, w))) };
    for (j, sc) in js.zip(scs.iter_mut()) {
        // (most columns put every pixel straight into the buffers)
        if !sc.centre_written {
            continue;
        }
        for (i, p) in sc.centre.iter_mut().enumerate() {
            if p.set {
                // SAFETY: pixel (i, j) belongs to column j only.
                unsafe { out.put_set(i * w + j, p) };
                // The other pixels are read only where set (and written
                // whole when set).
                p.set = false;
            }
        }
    }
    st
}

/// Colour (r, g, b) and intensity of a pixel; NaN intensity when the
/// surface is not seen. With `coverage`, blended with the background by the
/// pixel's covered fraction (intensity: times the fraction, the background
/// counting as 0, as the column supersampling's average does).
#[inline]
fn shade(p: &Pixel, shading: &Shading, coverage: bool) -> [f64; 4] {
    let b = shading.background;
    let bg = [b[0] as f64, b[1] as f64, b[2] as f64, f64::NAN];
    let f = if !coverage {
        if p.set {
            1.0
        } else {
            0.0
        }
    } else if p.set || p.cover > 0.0 {
        p.cover
    } else {
        0.0
    };
    if f <= 0.0 {
        return bg;
    }
    let c = shading.colour(p.inten, p.side);
    let mut out = [0.0; 4];
    for k in 0..3 {
        out[k] = f * c[k] as f64 + (1.0 - f) * bg[k];
    }
    out[3] = f * p.inten;
    out
}

/// Write the listed pixels (row-major index, pixel; each pixel listed at
/// most once); the others keep their background.
fn write_list(buf: &mut Buffers, lists: &[Vec<(usize, Pixel)>], shading: &Shading, cov: bool) {
    // In list order: a bin's pixels lie along one line of the screen, so
    // the writes stay local (no pass over the whole image).
    let h = buf.height.max(1);
    for mut b in split_rows(buf, h) {
        for (k, p) in lists.iter().flatten() {
            // With coverage, a partly covered pixel is blended (the others
            // are written as without coverage).
            let a = (cov && p.cover > 0.0 && (p.cover < 1.0 || !p.set))
                .then(|| shade(p, shading, true));
            write_pixel(&mut b, *k, p, a, shading);
        }
    }
}

/// The step q of the sub-row permutation m ↦ q·m mod k of the perspective
/// supersampling: coprime to k and near k/φ, so that consecutive sub-columns
/// take far-apart sub-rows.
fn rook_step(k: usize) -> usize {
    fn gcd(a: usize, b: usize) -> usize {
        if b == 0 {
            a
        } else {
            gcd(b, a % b)
        }
    }
    let target = k as f64 * 0.618_033_988_749_895;
    (1..=k.max(1))
        .filter(|&q| gcd(q, k) == 1)
        .min_by(|&a, &b| {
            let (da, db) = ((a as f64 - target).abs(), (b as f64 - target).abs());
            da.total_cmp(&db).then(a.cmp(&b))
        })
        .unwrap_or(1)
}

/// Write a supersampled render: colour and intensity from `acc` (every
/// pixel), the other buffers from the listed centre pixels.
fn write_aa(
    buf: &mut Buffers,
    centre: &[Vec<(usize, Pixel)>],
    acc: &[[f64; 4]],
    shading: &Shading,
) {
    let h = buf.height.max(1);
    let mut px = vec![Pixel::default(); acc.len()];
    for (k, p) in centre.iter().flatten() {
        px[*k] = *p;
    }
    for mut b in split_rows(buf, h) {
        for (k, a) in acc.iter().enumerate() {
            write_pixel(&mut b, k, &px[k], Some(*a), shading);
        }
    }
}

/// The buffers of a render as raw row-major views, written by many threads
/// at once, each pixel by one thread only (the perspective sweep's azimuth
/// bins partition the pixels, and a bin reveals each of its rays once).
pub(crate) struct SharedOut<'a> {
    n: usize,
    rgb: *mut u8,
    intensity: *mut f32,
    depth: *mut f32,
    normal: *mut f32,
    uv: *mut f32,
    side: *mut i8,
    mask: *mut bool,
    /// Set flags and depths (f64) of the set pixels, for the searches after
    /// the columns (null: not kept).
    set: *mut bool,
    zs: *mut f64,
    /// Covered fractions of the pixels written with [`Self::put_with`]
    /// (coverage renders; null: not kept).
    cover: *mut f32,
    shading: &'a Shading,
    _buf: std::marker::PhantomData<&'a mut Buffers>,
}

// SAFETY: the views are only written through `put`, whose callers write
// every pixel from one thread only.
unsafe impl Sync for SharedOut<'_> {}
unsafe impl Send for SharedOut<'_> {}

impl<'a> SharedOut<'a> {
    fn new(buf: &'a mut Buffers, shading: &'a Shading) -> Self {
        fn ptr<T>(v: &mut Option<Vec<T>>) -> *mut T {
            v.as_mut().map_or(std::ptr::null_mut(), |v| v.as_mut_ptr())
        }
        SharedOut {
            n: buf.width * buf.height,
            rgb: ptr(&mut buf.rgb),
            intensity: ptr(&mut buf.intensity),
            depth: ptr(&mut buf.depth),
            normal: ptr(&mut buf.normal),
            uv: ptr(&mut buf.uv),
            side: ptr(&mut buf.side),
            mask: ptr(&mut buf.mask),
            set: std::ptr::null_mut(),
            zs: std::ptr::null_mut(),
            cover: std::ptr::null_mut(),
            shading,
            _buf: std::marker::PhantomData,
        }
    }

    /// Write the geometry buffers only (depth, normal, uv, side, mask): the
    /// colours come from elsewhere (supersampled shading).
    fn geometry_only(mut self) -> Self {
        self.rgb = std::ptr::null_mut();
        self.intensity = std::ptr::null_mut();
        self
    }

    /// Write the colour buffers only (rgb, intensity).
    fn colour_only(mut self) -> Self {
        self.depth = std::ptr::null_mut();
        self.normal = std::ptr::null_mut();
        self.uv = std::ptr::null_mut();
        self.side = std::ptr::null_mut();
        self.mask = std::ptr::null_mut();
        self
    }

    /// Also mark each written pixel set, with its depth, in `set` and `zs`,
    /// and (if `cover` is not empty) the covered fraction of each pixel
    /// written with [`Self::put_with`] in `cover` (each as long as the
    /// image).
    fn with_marks(mut self, set: &'a mut [bool], zs: &'a mut [f64], cover: &'a mut [f32]) -> Self {
        assert!(
            set.len() == self.n && zs.len() == self.n,
            "marks of the image's size"
        );
        self.set = set.as_mut_ptr();
        self.zs = zs.as_mut_ptr();
        if !cover.is_empty() {
            assert!(
                cover.len() == self.n,
                "covered fractions of the image's size"
            );
            self.cover = cover.as_mut_ptr();
        }
        self
    }

    /// Write the background into the pixels of a row (from pixel `k0`)
    /// whose flag in `set` is false, in runs (the colour and NaN buffers;
    /// side and mask are allocated zeroed): the rest of a render into
    /// [`Buffers::deferred`] whose surface pixels are `set`.
    ///
    /// # Safety
    /// The row lies in the image; no other thread reads or writes its
    /// pixels meanwhile.
    pub(crate) unsafe fn fill_unset(&self, k0: usize, set: &[bool]) {
        assert!(k0 + set.len() <= self.n, "pixels out of range");
        /// Values [a, b) of `ptr` (if not null) set to x.
        ///
        /// # Safety
        /// `ptr` (if not null) holds b values, used by this thread only.
        unsafe fn fill<T: Copy>(ptr: *mut T, a: usize, b: usize, x: T) {
            if !ptr.is_null() {
                // SAFETY: see above.
                unsafe { std::slice::from_raw_parts_mut(ptr.add(a), b - a).fill(x) };
            }
        }
        let mut j = 0;
        while j < set.len() {
            j = run_end(set, j, true);
            if j == set.len() {
                break;
            }
            let run = run_end(set, j, false) - j;
            let (a, b) = (k0 + j, k0 + j + run);
            // SAFETY: b ≤ n, and the caller's guarantee.
            unsafe {
                if !self.rgb.is_null() {
                    let rgb = std::slice::from_raw_parts_mut(self.rgb.add(3 * a), 3 * (b - a));
                    crate::image::fill_rgb(rgb, self.shading.background);
                }
                fill(self.intensity, a, b, f32::NAN);
                fill(self.depth, a, b, f32::NAN);
                fill(self.normal, 3 * a, 3 * b, f32::NAN);
                fill(self.uv, 2 * a, 2 * b, f32::NAN);
            }
            j += run;
        }
    }

    /// Write a set pixel k without supersampling: what [`write_pixel`]
    /// does, straight through the raw views (the common orthographic case).
    ///
    /// # Safety
    /// No other thread reads or writes pixel k meanwhile.
    #[inline]
    pub(crate) unsafe fn put_set(&self, k: usize, p: &Pixel) {
        assert!(p.set, "put_set of an unset pixel");
        // SAFETY: the caller's guarantee.
        unsafe { self.put_hit(k, p.side, p.inten, p.depth, p.n, p.uv) }
    }

    /// [`Self::put_set`] of a set pixel given by its values (side,
    /// intensity, depth, normal, (u, v)), in one pass over the buffers.
    ///
    /// # Safety
    /// No other thread reads or writes pixel k meanwhile.
    #[inline(always)]
    pub(crate) unsafe fn put_hit(
        &self,
        k: usize,
        side: i8,
        inten: f64,
        depth: f64,
        n: glam::DVec3,
        uv: glam::DVec2,
    ) {
        assert!(k < self.n, "pixel index out of range");
        // SAFETY: k < n, every non-null view holds n pixels, and the caller
        // guarantees exclusive access to pixel k.
        unsafe {
            if !self.rgb.is_null() {
                let c = self.shading.colour(inten, side);
                std::ptr::copy_nonoverlapping(c.as_ptr(), self.rgb.add(3 * k), 3);
            }
            if !self.intensity.is_null() {
                *self.intensity.add(k) = inten as f32;
            }
            if !self.depth.is_null() {
                *self.depth.add(k) = depth as f32;
            }
            if !self.normal.is_null() {
                let v = self.normal.add(3 * k);
                *v = n.x as f32;
                *v.add(1) = n.y as f32;
                *v.add(2) = n.z as f32;
            }
            if !self.uv.is_null() {
                *self.uv.add(2 * k) = uv.x as f32;
                *self.uv.add(2 * k + 1) = uv.y as f32;
            }
            if !self.side.is_null() {
                *self.side.add(k) = side;
            }
            if !self.mask.is_null() {
                *self.mask.add(k) = true;
            }
            if !self.set.is_null() {
                *self.set.add(k) = true;
                *self.zs.add(k) = depth;
            }
        }
    }

    /// Write pixel k as [`write_pixel`] does, `acc` its supersampled colour
    /// and intensity (if any).
    ///
    /// # Safety
    /// No other thread reads or writes pixel k meanwhile.
    #[inline]
    pub(crate) unsafe fn put_with(&self, k: usize, p: &Pixel, acc: Option<[f64; 4]>) {
        assert!(k < self.n, "pixel index out of range");
        /// Pixel k of a buffer of `ch` values per pixel, as a slice.
        ///
        /// # Safety
        /// `ptr` (if not null) holds more than k pixels, pixel k used by
        /// this thread only.
        unsafe fn one<'b, T>(ptr: *mut T, k: usize, ch: usize) -> Option<&'b mut [T]> {
            // SAFETY: see above.
            (!ptr.is_null()).then(|| unsafe { std::slice::from_raw_parts_mut(ptr.add(ch * k), ch) })
        }
        // SAFETY: k < n, every buffer holds n pixels, and the caller
        // guarantees exclusive access to pixel k.
        let mut px = unsafe {
            RowsMut {
                rgb: one(self.rgb, k, 3),
                intensity: one(self.intensity, k, 1),
                depth: one(self.depth, k, 1),
                normal: one(self.normal, k, 3),
                uv: one(self.uv, k, 2),
                side: one(self.side, k, 1),
                mask: one(self.mask, k, 1),
            }
        };
        write_pixel(&mut px, 0, p, acc, self.shading);
        // SAFETY: as above (the marks hold n pixels).
        unsafe {
            if p.set && !self.set.is_null() {
                *self.set.add(k) = true;
                *self.zs.add(k) = p.depth;
            }
            if !self.cover.is_null() {
                *self.cover.add(k) = p.cover as f32;
            }
        }
    }
}

/// The end of the run of flags equal to `x` from index j (the first index
/// from j whose flag differs, or the length), eight flags at a time.
#[inline]
fn run_end(flags: &[bool], mut j: usize, x: bool) -> usize {
    let all = if x { 0x0101_0101_0101_0101u64 } else { 0 };
    while j + 8 <= flags.len() && radial::bytes8(flags, j) == all {
        j += 8;
    }
    while j < flags.len() && flags[j] == x {
        j += 1;
    }
    j
}

/// Rows of every buffer of a render (row-major slices).
#[derive(Default)]
struct RowsMut<'a> {
    rgb: Option<&'a mut [u8]>,
    intensity: Option<&'a mut [f32]>,
    depth: Option<&'a mut [f32]>,
    normal: Option<&'a mut [f32]>,
    uv: Option<&'a mut [f32]>,
    side: Option<&'a mut [i8]>,
    mask: Option<&'a mut [bool]>,
}

/// The buffers cut into blocks of `rows` rows (to write them in parallel).
fn split_rows(buf: &mut Buffers, rows: usize) -> Vec<RowsMut<'_>> {
    let (w, h) = (buf.width, buf.height);
    let n = h.div_ceil(rows.max(1));
    let mut out: Vec<RowsMut<'_>> = (0..n).map(|_| RowsMut::default()).collect();
    macro_rules! cut {
        ($f:ident, $ch:expr) => {
            if let Some(v) = buf.$f.as_mut() {
                for (o, c) in out.iter_mut().zip(v.chunks_mut(rows * w * $ch)) {
                    o.$f = Some(c);
                }
            }
        };
    }
    cut!(rgb, 3);
    cut!(intensity, 1);
    cut!(depth, 1);
    cut!(normal, 3);
    cut!(uv, 2);
    cut!(side, 1);
    cut!(mask, 1);
    out
}

/// Write pixel k (row-major index within the block); `acc` is the
/// supersampled colour and intensity when column supersampling is on.
#[inline(always)]
fn write_pixel(
    buf: &mut RowsMut<'_>,
    k: usize,
    p: &Pixel,
    acc: Option<[f64; 4]>,
    shading: &Shading,
) {
    if let Some(a) = acc {
        if let Some(rgb) = buf.rgb.as_mut() {
            for c in 0..3 {
                rgb[3 * k + c] = a[c].round().clamp(0.0, 255.0) as u8;
            }
        }
        if let Some(v) = buf.intensity.as_mut() {
            if a[3] != 0.0 || p.set {
                v[k] = a[3] as f32;
            }
        }
    }
    if !p.set {
        return;
    }
    if acc.is_none() {
        if let Some(rgb) = buf.rgb.as_mut() {
            rgb[3 * k..3 * k + 3].copy_from_slice(&shading.colour(p.inten, p.side));
        }
        if let Some(v) = buf.intensity.as_mut() {
            v[k] = p.inten as f32;
        }
    }
    if let Some(v) = buf.depth.as_mut() {
        v[k] = p.depth as f32;
    }
    if let Some(v) = buf.normal.as_mut() {
        v[3 * k] = p.n.x as f32;
        v[3 * k + 1] = p.n.y as f32;
        v[3 * k + 2] = p.n.z as f32;
    }
    if let Some(v) = buf.uv.as_mut() {
        v[2 * k] = p.uv.x as f32;
        v[2 * k + 1] = p.uv.y as f32;
    }
    if let Some(v) = buf.side.as_mut() {
        v[k] = p.side;
    }
    if let Some(v) = buf.mask.as_mut() {
        v[k] = true;
    }
}

pub use horizon::render_floating_horizon;

#[cfg(test)]
mod tests;
