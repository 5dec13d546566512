//! Perspective floating column on vertical planes through the eye.
//!
//! A pixel column of a perspective camera is a plane through the eye that is
//! vertical only for α = 0 or the centre column (§3.3). Its section with a
//! height field is then not a graph over the sampling parameter: where the
//! plane is tangent to the surface (1 − κ f_s = 0 in [`super::sampling`]) the
//! section folds, and sheets the t-sweep does not follow are missed. The seed
//! sidesteps this by sampling the plane's trace on w = 0 (eq. 9), which puts
//! samples off the column by up to x_pix·w·sin α / z pixels.
//!
//! Here every sweep runs in a vertical plane through the eye, whose screen
//! image is a line through the vanishing point of the verticals (the
//! "columns" of a perspective view converge there). A vertical plane cuts a
//! height field in a graph w(ρ) over the horizontal distance ρ from the eye,
//! and along every ray in the plane ρ increases, so the §4.2 sweep (front to
//! back, covered elevations instead of rows: the pseudo-angle tan(θ/2) of
//! θ = atan2(w − E_w, ρ), monotone in θ and free of transcendental calls) is
//! exact. Pixels are grouped by the azimuth φ of their ray into bins narrow
//! enough that a pixel lies within half a pixel of its bin's plane (0.625 px
//! with `refine`, see [`super::FloatingOptions::bin_width`]); each pixel takes its
//! span from its bin's sweep (by its own θ) and, with `refine`, is solved on
//! its own ray; unrevealed pixels on the mask's edge are searched on their
//! own rays from their neighbours' hits ([`edge_searches`]). A bin is the
//! wedge of the screen between two lines through that vanishing point, one
//! run of pixels per row: each task takes
//! a few neighbouring bins, generates their rays row by row from those runs
//! and sweeps them (no binning of the whole image, no scatter of its pixels),
//! a few bins side by side so that their samples are evaluated in one batch.
//! A bin's elevation scale comes from its wedge ([`Runs::wedge`]), so that
//! without coverage a bin is swept before its rays exist: its rays are then
//! generated only up to the highest elevation the sweep covered (those above
//! see no surface: often most of the image) and the sweep's spans replayed
//! on them ([`two_pass_bins`]).

use super::artifacts;
use super::column::{max_num, min_num, positive_finite, SKIP_MARGIN, SKIP_MIN};
use super::column::{ColumnStats, Ctx, Pixel};
use super::sampling::{Ahead, Raw, Sample, Scratch};
use super::ShadingMode;
use super::SharedOut;
use crate::cancel::Cancel;
use crate::error::Result;
use crate::scratch::ScratchArray;
use crate::surface::HeightSample;
use glam::{DVec2, DVec3};
use rayon::prelude::*;

/// A bin's pixels, counters and the pixels it dropped (see
/// [`RadialSweep::missed`]).
type BinResult = (Vec<(usize, Pixel)>, ColumnStats, Vec<(u32, f64)>);

/// The pixels where the surface is seen, as lists of (row-major index,
/// pixel): one list per azimuth bin and one of the filled holes.
pub type PixelLists = Vec<Vec<(usize, Pixel)>>;

/// One pixel's ray in the radial frame: pixel index, pseudo-elevation
/// tan(θ/2) (see [`elevation`]) and unit direction (bit for bit
/// [`crate::camera::Camera::ray`]'s).
#[derive(Debug, Clone, Copy)]
struct Ray {
    k: u32,
    theta: f64,
    dir: DVec3,
}

/// Render a perspective view: the pixels where the surface is seen (each
/// once, in lists of (row-major index, pixel)) and the counters. Pixel (i, j) is
/// sampled on the ray through (row i + `off`.0, column j + `off`.1): (0, 0)
/// is the pixel centre, offsets in (−½, ½) are the sub-pixel positions of
/// the §6.4 supersampling.
///
/// With `direct`, each bin writes its pixels into those buffers as it
/// finishes (and the lists come back empty); without coverage only.
pub(crate) fn render_radial(
    ctx: &Ctx<'_>,
    off: (f64, f64),
    direct: Option<&SharedOut<'_>>,
    cancel: &Cancel,
) -> Result<(PixelLists, ColumnStats)> {
    render_radial_with(ctx, off, direct, cancel, true)
}

/// [`render_radial`]; without `two_pass`, every bin's rays generated before
/// its sweep (as with coverage).
fn render_radial_with(
    ctx: &Ctx<'_>,
    off: (f64, f64),
    direct: Option<&SharedOut<'_>>,
    cancel: &Cancel,
    two_pass: bool,
) -> Result<(PixelLists, ColumnStats)> {
    let cam = ctx.cam;
    let (w, h) = (cam.width, cam.height);
    let nb = bin_count(cam, ctx.opts.bin_width(ctx.refine));
    let bins = Bins::new(nb);
    // Each bin generates its own rays, row by row (see [`Runs`]): no
    // binning of the whole image, no scatter into bins. Its rays' order is
    // settled by their sort by θ (ties by pixel index), whatever the order
    // they come in.
    let n = w * h;
    let runs = Runs::new(cam, &bins, off);
    let cands = runs.candidates();
    // Which pixels are set and their depths, compactly (for the hole
    // filling): written by the bins (each its own pixels) when they write
    // their pixels directly, else gathered from their lists. An unset
    // pixel's depth is +∞ (the searches' scan reads depths alone, see
    // [`edge_searches`]).
    let mut set = ScratchArray::<bool>::zeroed(n);
    let mut depth = ScratchArray::<f64>::filled(n, f64::INFINITY);
    let direct = direct.filter(|_| !ctx.opts.coverage);
    let marks = Marks {
        n: w * h,
        set: set.as_mut_ptr(),
        depth: depth.as_mut_ptr(),
    };
    let groups = runs.groups(&cands);
    // Without coverage, each bin is swept before its rays are generated,
    // and only the rays up to the highest elevation the sweep covered are
    // (those above it see no surface).
    let two_pass = two_pass && !ctx.opts.coverage && !runs.exact_only;
    // The sweeps of each worker thread, kept from group to group (rayon's
    // per-task `map_init` would start each task afresh, regrowing every
    // buffer; its other buffers are kept from render to render, see
    // [`THREAD_BUFS`]); a slot found busy (a task nested in another on the
    // same thread) is replaced by fresh sweeps. The buffers' contents never
    // reach the output.
    let pool: Vec<std::sync::Mutex<Option<Lockstep<'_, '_>>>> = (0..rayon::current_num_threads()
        .max(1))
        .map(|_| std::sync::Mutex::new(None))
        .collect();
    let results: Vec<Result<Vec<BinResult>>> = groups
        .par_iter()
        .map(|&(g0, g1)| {
            let slot = rayon::current_thread_index().and_then(|t| pool.get(t));
            let mut guard = slot.and_then(|m| m.try_lock().ok());
            let mut fresh = None;
            let ls = match guard.as_deref_mut() {
                Some(held) => held.get_or_insert_with(Lockstep::default),
                None => fresh.insert(Lockstep::default()),
            };
            THREAD_BUFS.with(|kept| {
                let mut held = kept.try_borrow_mut().ok();
                let mut fresh = None;
                let tb = match held.as_deref_mut() {
                    Some(tb) => tb,
                    None => fresh.insert(ThreadBufs::default()),
                };
                (|| -> Result<Vec<BinResult>> {
                    cancel.check()?;
                    if two_pass {
                        // A few bins at a time (two lockstep batches of sweeps,
                        // see [`sweep_together`]): a small working set, the rays
                        // of several bins generated row by row together.
                        let mut res = Vec::with_capacity(g1 - g0);
                        for s0 in (g0..g1).step_by(TWO_PASS_BINS) {
                            let s1 = (s0 + TWO_PASS_BINS).min(g1);
                            two_pass_bins(
                                ctx, &runs, s0, s1, off, direct, &marks, ls, tb, cancel, &mut res,
                            )?;
                        }
                        return Ok(res);
                    }
                    runs.group_rays(g0, g1, None, &mut tb.gs);
                    let mut res = Vec::new();
                    let mut todo = std::mem::take(&mut tb.todo);
                    todo.clear();
                    todo.extend((g0..g1).filter(|&b| !tb.gs.lists[b - g0].is_empty()));
                    // A few bins at a time, swept side by side: their samples
                    // are evaluated together, in batches large enough to
                    // amortise a batch's cost (the samples are the same as
                    // one bin at a time, bit for bit).
                    for chunk in todo.chunks(LOCKSTEP) {
                        cancel.check()?;
                        while ls.sweeps.len() < chunk.len() {
                            ls.sweeps
                                .push((RadialSweep::new(ctx, 0.0, &[]), RunState::default()));
                        }
                        let sweeps = &mut ls.sweeps[..chunk.len()];
                        for (&b, (sw, _)) in chunk.iter().zip(sweeps.iter_mut()) {
                            let rays = std::mem::take(&mut tb.gs.lists[b - g0]);
                            let phi = bins.centre(b);
                            // The sweep's previous rays become the list's buffer.
                            tb.gs.lists[b - g0] = sw.reset(phi, rays);
                            sw.off = off;
                            let wedge = if runs.exact_only {
                                None
                            } else {
                                runs.wedge(phi)
                            };
                            let (th0, th1) = wedge
                                .unwrap_or((sw.rays[0].theta, sw.rays[sw.rays.len() - 1].theta));
                            (sw.ppr, sw.rate) = bin_ppr(cam, phi, th0, th1);
                            sw.srange = (th0, th1);
                            if ctx.opts.coverage {
                                sw.start_coverage();
                            }
                        }
                        sweep_together(ctx, sweeps, &mut tb.eval);
                        for (sw, _) in sweeps.iter_mut() {
                            sw.solve(direct.map(|o| (o, &marks)));
                            sw.finish_coverage();
                            res.push(bin_result(sw, direct, &marks));
                        }
                    }
                    tb.todo = todo;
                    Ok(res)
                })()
            })
        })
        .collect();
    let results = results.into_iter().collect::<Result<Vec<_>>>()?;
    let mut stats = ColumnStats::default();
    let mut all = Vec::with_capacity(results.len() + 1);
    let mut missed = Vec::new();
    for (px, st, miss) in results.into_iter().flatten() {
        stats.add(&st);
        missed.extend_from_slice(&miss);
        if direct.is_none() {
            for &(k, p) in &px {
                set[k] = p.set;
                depth[k] = if p.set { p.depth } else { f64::INFINITY };
            }
            all.push(px);
        }
    }
    let mut holes = Vec::new();
    behind_missed(
        ctx, off, &missed, &mut set, &mut depth, &mut holes, &mut stats,
    );
    fill_holes(ctx, off, &mut set, &mut depth, &mut holes, &mut stats);
    // (with `direct`, the search's scan of the image also writes the
    // background of the pixels left unset, see [`Buffers::deferred`])
    let moved = edge_searches(
        ctx, off, &mut set, &mut depth, &mut holes, &mut stats, direct,
    );
    if !moved.is_empty() && direct.is_none() {
        // (each pixel listed once: its first entry gives way)
        let mut gone = ScratchArray::<bool>::zeroed(n);
        for &(k, _) in &moved {
            gone[k] = true;
        }
        for list in all.iter_mut().chain(std::iter::once(&mut holes)) {
            list.retain(|(k, _)| !gone[*k]);
        }
    }
    holes.extend(moved);
    if let Some(out) = direct {
        for (k, p) in &holes {
            // SAFETY: the bins are done; this thread alone writes. A filled
            // hole is set.
            unsafe { out.put_set(*k, p) };
        }
    } else {
        all.push(holes);
    }
    if ctx.opts.coverage {
        // A partly covered pixel that the hole filling set keeps only its
        // set entry.
        for list in &mut all {
            list.retain(|(k, p)| p.set || !set[*k]);
        }
    }
    Ok((all, stats))
}

/// The number of azimuth bins of a perspective view: bins at most `width`
/// pixels wide laterally at the most sensitive pixel.
fn bin_count(cam: &crate::camera::Camera, width: f64) -> usize {
    use std::f64::consts::PI;
    let (w, h) = (cam.width, cam.height);
    let e = cam.eye;
    // The bin width: |∂(screen)/∂φ| (pixels per radian of azimuth) is
    // largest far from the vanishing point of the verticals, on the border.
    let delta: f64 = 1e-6;
    let (sd, cd) = delta.sin_cos();
    let probe = |i: usize, j: usize| -> f64 {
        let (_, dir) = cam.ray(i as f64, j as f64);
        if (dir.x * dir.x + dir.y * dir.y).sqrt() > 1e-9 {
            let d2 = DVec3::new(cd * dir.x - sd * dir.y, sd * dir.x + cd * dir.y, dir.z);
            let p1 = cam.to_screen(e + dir);
            let p2 = cam.to_screen(e + d2);
            let ds = ((p2.x - p1.x).powi(2) + (p2.y - p1.y).powi(2)).sqrt() / delta;
            if ds.is_finite() {
                return ds;
            }
        }
        1.0
    };
    // The border, then every 8th pixel of every 8th row (in parallel: the
    // maximum does not depend on the order).
    let sens = (0..w)
        .into_par_iter()
        .map(|j| probe(0, j).max(probe(h - 1, j)))
        .chain(
            (0..h)
                .into_par_iter()
                .map(|i| probe(i, 0).max(probe(i, w - 1))),
        )
        .reduce(|| 1.0, f64::max);
    let grid = (0..h.div_ceil(8))
        .into_par_iter()
        .map(|r| {
            (0..w)
                .step_by(8)
                .map(|j| probe(8 * r, j))
                .fold(1.0, f64::max)
        })
        .reduce(|| 1.0, f64::max);
    let sens = sens.max(grid);
    // Bins of width ≤ `width` px laterally at the most sensitive pixel.
    // (a field of view of a millionth of a degree wants some 10¹² bins;
    // beyond 10¹³ a bin edge's azimuth nears f64's resolution of π)
    (2.0 * PI * sens / width).ceil().clamp(1.0, 1e13) as usize
}

/// Bins [g0, g1) of [`render_radial`] without coverage, their results onto
/// `res`: each bin is swept first (its spans logged, see
/// [`RadialSweep::record`]), then the bins' rays are generated up to the
/// highest elevation each bin's sweep covered (the rays above it see no
/// surface), and each bin's spans are replayed on its rays, revealing them
/// as a sweep run with all its rays would have, and its pixels solved.
#[allow(clippy::too_many_arguments)]
fn two_pass_bins<'c, 'a>(
    ctx: &'c Ctx<'a>,
    runs: &Runs<'_>,
    g0: usize,
    g1: usize,
    off: (f64, f64),
    direct: Option<&SharedOut<'_>>,
    marks: &Marks,
    ls: &mut Lockstep<'c, 'a>,
    tb: &mut ThreadBufs,
    cancel: &Cancel,
    res: &mut Vec<BinResult>,
) -> Result<()> {
    let cam = ctx.cam;
    let mut todo = std::mem::take(&mut tb.todo);
    todo.clear();
    while ls.sweeps.len() < g1 - g0 {
        ls.sweeps
            .push((RadialSweep::new(ctx, 0.0, &[]), RunState::default()));
    }
    // The bins whose plane meets the image, each its sweep, in order.
    for b in g0..g1 {
        let phi = runs.bins.centre(b);
        let Some((th0, th1)) = runs.wedge(phi) else {
            continue;
        };
        let sw = &mut ls.sweeps[todo.len()].0;
        let mut buf = std::mem::take(&mut sw.rays);
        buf.clear();
        sw.reset(phi, buf);
        sw.off = off;
        (sw.ppr, sw.rate) = bin_ppr(cam, phi, th0, th1);
        sw.srange = (th0, th1);
        sw.record = true;
        todo.push(b);
    }
    let live = &mut ls.sweeps[..todo.len()];
    for chunk in live.chunks_mut(LOCKSTEP) {
        cancel.check()?;
        sweep_together(ctx, chunk, &mut tb.eval);
    }
    // Each bin's generation rows: those whose rays may lie below the
    // highest covered elevation.
    let mut rows = std::mem::take(&mut tb.rows);
    rows.clear();
    rows.resize(g1 - g0, None);
    for (&b, (sw, _)) in todo.iter().zip(live.iter()) {
        rows[b - g0] = sw
            .covered()
            .and_then(|cov| runs.rows_within(sw.eh, cov, sw.srange));
    }
    runs.group_rays(g0, g1, Some(&rows), &mut tb.gs);
    tb.rows = rows;
    for (&b, (sw, _)) in todo.iter().zip(live.iter_mut()) {
        let rays = std::mem::take(&mut tb.gs.lists[b - g0]);
        sw.swap_pixel_buffers(&mut tb.pixels);
        tb.gs.lists[b - g0] = sw.replay(rays);
        sw.solve(direct.map(|o| (o, marks)));
        res.push(bin_result(sw, direct, marks));
        sw.swap_pixel_buffers(&mut tb.pixels);
    }
    tb.todo = todo;
    Ok(())
}

/// A solved bin's result: with `direct`, its pixels written into the
/// buffers and `marks` (the list comes back empty), else its pixel list.
fn bin_result(
    sw: &mut RadialSweep<'_, '_>,
    direct: Option<&SharedOut<'_>>,
    marks: &Marks,
) -> BinResult {
    let stats = std::mem::take(&mut sw.stats);
    let missed = std::mem::take(&mut sw.missed);
    let Some(out) = direct else {
        return (std::mem::take(&mut sw.out), stats, missed);
    };
    // (those unset are written, see [`RadialSweep::solve`])
    for (k, p) in sw.out.iter().filter(|(_, p)| p.set) {
        // SAFETY: the bins partition the pixels and a bin lists each of its
        // pixels once, so no other thread touches pixel k.
        unsafe {
            out.put_set(*k, p);
            marks.put(*k, p.set, p.depth);
        }
    }
    (Vec::new(), stats, missed)
}

/// An exact hit (depth, (u, v), the surface's sample `h` on ray `dir`) of
/// pixel k written straight into the render's buffers `to` and `marks`;
/// its entry `px` in a bin's list takes the hit's side and is left unset
/// (written).
///
/// # Safety
/// No other thread reads or writes pixel k meanwhile.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn put_direct(
    ctx: &Ctx<'_>,
    to: &SharedOut<'_>,
    marks: &Marks,
    k: usize,
    px: &mut Pixel,
    dir: DVec3,
    depth: f64,
    uv: DVec2,
    h: &HeightSample,
) {
    let (n, side, inten) = super::refine::hit_shading(ctx, dir, h, px.side, px.inten);
    // SAFETY: the caller's guarantee.
    unsafe {
        to.put_hit(k, side, inten, depth, n, uv);
        marks.put(k, true, depth);
    }
    px.side = side;
    px.set = false;
}

/// The 4-neighbours of pixel k of a w × h image (up, down, left, right;
/// None beyond its border).
#[inline]
fn neighbours4(k: usize, w: usize, h: usize) -> [Option<usize>; 4] {
    let (i, j) = (k / w, k % w);
    [
        (i > 0).then(|| k - w),
        (i + 1 < h).then(|| k + w),
        (j > 0).then(|| k - 1),
        (j + 1 < w).then(|| k + 1),
    ]
}

/// The pixels a bin dropped (see [`RadialSweep::missed`]): their ray passes
/// by the near sheet the bin's plane met, and may meet a farther one, as
/// its set neighbours do. Each is solved on its own ray by Newton from the
/// hits of those neighbours beyond where its ray was searched (nearest
/// first), and set at the first that settles within 16 pixels of the
/// neighbour's; otherwise it stays unset.
fn behind_missed(
    ctx: &Ctx<'_>,
    off: (f64, f64),
    missed: &[(u32, f64)],
    set: &mut [bool],
    depth: &mut [f64],
    px: &mut Vec<(usize, Pixel)>,
    stats: &mut ColumnStats,
) {
    let cam = ctx.cam;
    let (w, h) = (cam.width, cam.height);
    let mut sc = super::refine::NewtonScratch::default();
    for &(k, searched) in missed {
        let k = k as usize;
        let (i, j) = (k / w, k % w);
        let (_, dir) = cam.ray(i as f64 + off.0, j as f64 + off.1);
        let dd = dir.dot(cam.d);
        if dd.is_nan() || dd <= 0.0 {
            continue;
        }
        let mut lams = [f64::NAN; 4];
        for (m, n) in neighbours4(k, w, h).into_iter().enumerate() {
            // (beyond where the pixel's ray was searched)
            if let Some(n) =
                n.filter(|&n| set[n] && depth[n].is_finite() && depth[n] / dd > searched)
            {
                lams[m] = depth[n] / dd;
            }
        }
        lams.sort_by(f64::total_cmp);
        let mut found = None;
        for &lam in lams.iter().filter(|l| l.is_finite()) {
            let fp = lam.max(cam.near) / cam.focal;
            stats.refine_evals += super::refine::newton(
                ctx,
                1,
                |_| lam,
                |_| (cam.eye, dir),
                |_| (lam - 16.0 * fp, lam + 16.0 * fp, fp),
                &mut sc,
                |_, l, q, hs| found = Some((l, q, *hs)),
            );
            if found.is_some() {
                break;
            }
        }
        let Some((_, q, hs)) = found else {
            continue;
        };
        let p = hit_pixel(ctx, dir, q, &hs);
        set[k] = true;
        depth[k] = p.depth;
        px.push((k, p));
        stats.holes_filled += 1;
    }
}

/// The pixel of an exact hit q on ray `dir` (upper side), finished and
/// shaded as the bins' solved pixels are.
fn hit_pixel(ctx: &Ctx<'_>, dir: DVec3, q: DVec3, hs: &HeightSample) -> Pixel {
    let cam = ctx.cam;
    let mut p = Pixel {
        set: true,
        side: 1,
        depth: (q - cam.eye).dot(cam.d),
        n: hs.normal(),
        uv: DVec2::new(q.x, q.y),
        inten: 0.0,
        cover: 1.0,
    };
    let z = p.depth;
    super::refine::finish(ctx, &mut p, dir, z, DVec2::new(q.x, q.y), hs);
    if ctx.opts.shading == ShadingMode::Intensity {
        p.inten = ctx.shading.intensity(p.n, -dir);
    }
    p
}

/// Raw views of the set flags and depths of [`render_radial`]'s pixels,
/// written by the bins (each pixel by one bin only).
struct Marks {
    n: usize,
    set: *mut bool,
    depth: *mut f64,
}

// SAFETY: written only through `put`, each pixel from one thread only.
unsafe impl Sync for Marks {}
unsafe impl Send for Marks {}

impl Marks {
    /// # Safety
    /// No other thread reads or writes pixel k meanwhile.
    #[inline]
    unsafe fn put(&self, k: usize, set: bool, depth: f64) {
        assert!(k < self.n, "pixel index out of range");
        // SAFETY: k < n (the length of both arrays), access exclusive.
        unsafe {
            *self.set.add(k) = set;
            *self.depth.add(k) = depth;
        }
    }
}

/// Screen pixels per unit of the pseudo-elevation s = tan(θ/2) (see
/// [`elevation`]) along the plane of azimuth φ, over the elevations
/// [s0, s1] of a bin's rays (probed, with a 10 % margin), so that the
/// sweep's row gaps measure pixels on the screen; and the local rate (see
/// [`PxRate`]).
fn bin_ppr(cam: &crate::camera::Camera, phi: f64, th0: f64, th1: f64) -> (f64, PxRate) {
    let (sp, cp) = phi.sin_cos();
    let at = |s: f64| cam.to_screen(cam.eye + direction(DVec2::new(cp, sp), s));
    let delta = 1e-6;
    let mut m: f64 = 0.0;
    let mut rate = [f64::NAN; PxRate::NODES];
    for (k, r) in rate.iter_mut().enumerate() {
        let th = th0 + (th1 - th0) * k as f64 / (PxRate::NODES - 1) as f64;
        let (p1, p2) = (at(th - 0.5 * delta), at(th + 0.5 * delta));
        let ds = (p2.x - p1.x).hypot(p2.y - p1.y) / delta;
        if ds.is_finite() {
            m = m.max(ds);
            *r = ds;
        }
    }
    if m > 0.0 && th1 > th0 && rate.iter().all(|r| r.is_finite()) {
        // The nodes as fractions of the largest rate: with the same 10 %
        // margin, pixels per unit of `rho` at each node.
        rate.iter_mut().for_each(|r| *r /= m);
        let ppr = 1.1 * m;
        let inv = (PxRate::NODES - 1) as f64 / ((th1 - th0) * ppr);
        (
            ppr,
            PxRate {
                r0: th0 * ppr,
                inv,
                rate,
            },
        )
    } else if m > 0.0 {
        (1.1 * m, PxRate::default())
    } else {
        (1.5 * cam.focal, PxRate::default())
    }
}

/// Screen pixels per unit of a bin's `rho` (elevation times
/// [`bin_ppr`]) as a function of `rho`: the rate of the
/// screen along the bin's plane falls away from the top of the image (by
/// 20 % or more at the bottom of a view looking down), and the sweep's step
/// control measures its gaps in pixels. Linear between the probed nodes,
/// constant beyond them; at most 1 (`rho` measures pixels at the largest
/// rate).
#[derive(Debug, Clone, Copy)]
struct PxRate {
    /// `rho` at the first node, nodes per unit of `rho`.
    r0: f64,
    inv: f64,
    rate: [f64; PxRate::NODES],
}

impl Default for PxRate {
    fn default() -> Self {
        PxRate {
            r0: 0.0,
            inv: 0.0,
            rate: [1.0; PxRate::NODES],
        }
    }
}

impl PxRate {
    const NODES: usize = 5;

    /// Pixels per unit of `rho` at `rho` = r.
    #[inline]
    fn at(&self, r: f64) -> f64 {
        // (comparisons that send NaN to the first node; a cast of a value
        // in [0, NODES − 2])
        let x = (r - self.r0) * self.inv;
        let x = if x > 0.0 { x } else { 0.0 };
        let top = (Self::NODES - 1) as f64;
        let x = if x < top { x } else { top };
        let k = x.min(top - 1.0) as u32 as usize;
        let f = x - k as f64;
        self.rate[k] + f * (self.rate[k + 1] - self.rate[k])
    }
}

/// A pixel lies up to half a bin off its bin's plane; on steep surfaces
/// that plane can pass through a notch (next to a crest) that the pixel's
/// own ray does not. Unrevealed pixels between two revealed neighbours
/// (above and below, or left and right, next to it or, across a gap of two
/// pixels — up to eight along the image's border — further on) at similar
/// depths are searched on their own ray, between the neighbours' hits.
fn fill_holes(
    ctx: &Ctx<'_>,
    off: (f64, f64),
    set: &mut [bool],
    depth: &mut [f64],
    px: &mut Vec<(usize, Pixel)>,
    stats: &mut ColumnStats,
) {
    let cam = ctx.cam;
    let (w, h) = (cam.width, cam.height);
    let mut sw = RadialSweep::new(ctx, 0.0, &[]);
    let lam_of = |set: &[bool], depth: &[f64], k: usize, dir: DVec3| -> Option<f64> {
        let dd = dir.dot(cam.d);
        (set[k] && dd > 0.0 && depth[k].is_finite()).then(|| depth[k] / dd)
    };
    for i in 0..h {
        let mut j = 0;
        while j < w {
            // Eight pixels at a time, those that cannot be holes are
            // skipped: a hole is unset with its upper or left neighbour set
            // (the patterns below), and filling one changes nothing before it.
            while j >= 1 && j + 8 <= w {
                let here = bytes8(set, i * w + j);
                let left = bytes8(set, i * w + j - 1);
                let up = if i > 0 {
                    bytes8(set, (i - 1) * w + j)
                } else {
                    0
                };
                if (!here & 0x0101_0101_0101_0101) & (up | left) != 0 {
                    break;
                }
                j += 8;
            }
            if j >= w {
                break;
            }
            if set[i * w + j] {
                j += 1;
                continue;
            }
            // Pixel (i, j), then on to the next.
            let jj = j;
            j += 1;
            let j = jj;
            let vertical = i > 0 && i + 1 < h && set[(i - 1) * w + j] && set[(i + 1) * w + j];
            let lateral = j > 0 && j + 1 < w && set[i * w + j - 1] && set[i * w + j + 1];
            // The first pixel of a gap (its partners are searched next,
            // between it and the far neighbour): of two pixels, or on the
            // image's border, where a pixel has one lateral (or vertical)
            // neighbour, of up to eight.
            let far = |k: usize, step: usize, n: usize, border: bool| -> Option<usize> {
                let limit = if border { 8 } else { 2 };
                (2..=limit)
                    .map(|m| k + m * step)
                    .take_while(|&q| q < n)
                    .find(|&q| set[q])
            };
            let vertical_far =
                (i > 0 && i + 2 < h && set[(i - 1) * w + j] && !set[(i + 1) * w + j])
                    .then(|| far(i * w + j, w, w * h, j == 0 || j + 1 == w))
                    .flatten()
                    .map(|q| ((i - 1) * w + j, q));
            let lateral_far = (j > 0 && j + 2 < w && set[i * w + j - 1] && !set[i * w + j + 1])
                .then(|| far(i * w + j, 1, (i + 1) * w, i == 0 || i + 1 == h))
                .flatten()
                .map(|q| (i * w + j - 1, q));
            if !(vertical || lateral) && vertical_far.is_none() && lateral_far.is_none() {
                continue;
            }
            let (_, dir) = cam.ray(i as f64 + off.0, j as f64 + off.1);
            let pairs = [
                vertical.then(|| ((i - 1) * w + j, (i + 1) * w + j)),
                lateral.then(|| (i * w + j - 1, i * w + j + 1)),
                vertical_far,
                lateral_far,
            ];
            for (a, b) in pairs.into_iter().flatten() {
                let (Some(l1), Some(l2)) = (lam_of(set, depth, a, dir), lam_of(set, depth, b, dir))
                else {
                    continue;
                };
                let fp = l1.min(l2).max(cam.near) / cam.focal;
                if (l1 - l2).abs() > 64.0 * fp {
                    continue;
                }
                let (lo, hi) = (l1.min(l2) - 8.0 * fp, l1.max(l2) + 8.0 * fp);
                let hit = sw
                    .march(cam.eye, dir, lo, hi, fp, 1)
                    .or_else(|| sw.march(cam.eye, dir, lo, hi, fp, -1));
                if let Some((l, hs)) = hit {
                    let p = hit_pixel(ctx, dir, cam.eye + l * dir, &hs);
                    set[i * w + j] = true;
                    depth[i * w + j] = p.depth;
                    px.push((i * w + j, p));
                    stats.holes_filled += 1;
                    break;
                }
            }
        }
    }
    stats.refine_evals += sw.stats.refine_evals;
}

/// A pixel to search on its own ray (see [`solve_from_seeds`]): its index,
/// its ray (origin, direction), seeds along it (nearest first, NaN for
/// none) and the distance its crossing must lie before.
type SeedSearch = (usize, (DVec3, DVec3), [f64; 4], f64);

/// The world size of a pixel at distance l along a ray: l / F in
/// perspective (from the near distance on), the pixel's size in an
/// orthographic view; as max(l, near)·scale + fixed, branch-free.
#[derive(Debug, Clone, Copy)]
struct Footprint {
    near: f64,
    scale: f64,
    fixed: f64,
}

impl Footprint {
    fn of(cam: &crate::camera::Camera) -> Self {
        if cam.perspective {
            Footprint {
                near: cam.near,
                scale: 1.0 / cam.focal,
                fixed: 0.0,
            }
        } else {
            Footprint {
                near: f64::NEG_INFINITY,
                scale: 0.0,
                fixed: cam.pixel,
            }
        }
    }

    /// (NaN for a non-finite l in an orthographic view.)
    #[inline(always)]
    fn at(&self, l: f64) -> f64 {
        l.max(self.near) * self.scale + self.fixed
    }
}

/// The searches of [`edge_searches`]: each pixel's ray
/// solved by Newton from its seeds in turn (bracket ± 8 footprints, and
/// short of its limit); a converged root is a true crossing of the ray. One
/// on the under side is replaced by the ray's entry up to 16 footprints
/// before it, if any. Batched by seed, in fixed chunks solved in parallel
/// (the same for any thread count); the pixels found and the evaluations.
fn solve_from_seeds(ctx: &Ctx<'_>, cands: &[SeedSearch]) -> Vec<(Vec<(usize, Pixel)>, u64)> {
    let cam = ctx.cam;
    const CHUNK: usize = 256;
    cands
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut sw = RadialSweep::new(ctx, 0.0, &[]);
            let mut sc = super::refine::NewtonScratch::default();
            let mut out = Vec::new();
            let mut evals = 0;
            let fpt = Footprint::of(cam);
            let fp = |l: f64| fpt.at(l);
            // The chunk's pixels by their m-th seed, batched: those whose
            // seed m − 1 did not settle.
            let mut todo: Vec<u32> = (0..chunk.len() as u32).collect();
            let mut hits: Vec<Option<(f64, HeightSample)>> = vec![None; chunk.len()];
            for m in 0..4 {
                todo.retain(|&c| chunk[c as usize].2[m].is_finite());
                if todo.is_empty() {
                    break;
                }
                let seed = |q: usize| chunk[todo[q] as usize].2[m];
                evals += super::refine::newton(
                    ctx,
                    todo.len(),
                    seed,
                    |q| chunk[todo[q] as usize].1,
                    |q| {
                        let (l, limit) = (seed(q), chunk[todo[q] as usize].3);
                        (l - 8.0 * fp(l), (l + 8.0 * fp(l)).min(limit), fp(l))
                    },
                    &mut sc,
                    |q, l, _, hs| hits[todo[q] as usize] = Some((l, *hs)),
                );
                todo.retain(|&c| hits[c as usize].is_none());
            }
            // An unset pixel on the image's border (no neighbour beyond it
            // to seed a farther sheet) that no seed settled: its ray
            // marched on from its nearest seed, in steps of two footprints,
            // from above or from below (entering the domain under the
            // surface, through its edge), to the domain's end or where it
            // rises above the height bound.
            let top = ctx.field.height_bound().map(|(_, hi)| hi);
            for c in 0..chunk.len() {
                let (k, (o, dir), seeds, limit) = chunk[c];
                let (i, j) = (k / cam.width, k % cam.width);
                let border = i == 0 || j == 0 || i + 1 == cam.height || j + 1 == cam.width;
                if hits[c].is_some() || limit != f64::INFINITY || !border || !seeds[0].is_finite() {
                    continue;
                }
                let l0 = seeds[0];
                let hi = match top {
                    Some(top) if dir.z > 0.0 => (top - o.z) / dir.z,
                    _ => f64::INFINITY,
                };
                if hi > l0 {
                    let (lo, f) = (l0 - 8.0 * fp(l0), 4.0 * fp(l0));
                    hits[c] = sw
                        .march(o, dir, lo, hi, f, 1)
                        .or_else(|| sw.march(o, dir, lo, hi, f, -1));
                }
            }
            for (c, hit) in hits.into_iter().enumerate() {
                let Some((mut l, mut hs)) = hit else {
                    continue;
                };
                let (k, (o, dir), _, _) = chunk[c];
                if hs.normal().dot(dir) > 0.0 {
                    // The under side: the entry before it, if any.
                    let f = fp(l);
                    if let Some(x) = sw.march(o, dir, l - 16.0 * f, l - 1e-3 * f, f, 1) {
                        (l, hs) = x;
                    }
                }
                out.push((k, hit_pixel(ctx, dir, o + l * dir, &hs)));
            }
            (out, evals + sw.stats.refine_evals)
        })
        .collect()
}

/// The pixels of row i that [`edge_searches`]' first round may search
/// (appended to `ks`): on the image's border, every pixel (the search
/// itself tells); inside, an unset pixel with a set 4-neighbour, or a set
/// one with a 4-neighbour nearer by more than four footprints. The flags
/// are computed branch-free over the row (in `flags`) from the depths
/// alone, an unset pixel's being +∞ (the callers' arrays hold +∞ wherever
/// `set` is false).
#[allow(clippy::too_many_arguments)]
fn scan_row(
    set: &[bool],
    depth: &[f64],
    i: usize,
    w: usize,
    h: usize,
    fp: Footprint,
    flags: &mut Vec<u8>,
    ks: &mut Vec<usize>,
) {
    let row = i * w;
    if i == 0 || i + 1 == h || w < 3 {
        ks.extend(row..row + w);
        return;
    }
    ks.push(row);
    let n = w - 2;
    let (c0, c1) = (row + 1, row + 1 + n);
    let (sc, sl, sr) = (&set[c0..c1], &set[c0 - 1..c1 - 1], &set[c0 + 1..c1 + 1]);
    let (su, sd) = (&set[c0 - w..c1 - w], &set[c0 + w..c1 + w]);
    let (dc, dl, dr) = (
        &depth[c0..c1],
        &depth[c0 - 1..c1 - 1],
        &depth[c0 + 1..c1 + 1],
    );
    let (du, dd) = (&depth[c0 - w..c1 - w], &depth[c0 + w..c1 + w]);
    flags.clear();
    flags.resize(n, 0);
    let nb = RowNeighbours {
        set: [sc, sl, sr, su, sd],
        depth: [dc, dl, dr, du, dd],
    };
    nb.flags(fp, flags);
    // Eight flags at a time: most rows want few pixels.
    let mut m = 0;
    while m < n {
        if m + 8 <= n {
            let b: &[u8; 8] = flags[m..m + 8].try_into().expect("eight flags");
            if u64::from_le_bytes(*b) == 0 {
                m += 8;
                continue;
            }
        }
        let end = (m + 8).min(n);
        ks.extend((m..end).filter(|&q| flags[q] != 0).map(|q| c0 + q));
        m = end;
    }
    ks.push(row + w - 1);
}

/// A row's set flags and depths (centre, left, right, up, down) for
/// [`scan_row`].
struct RowNeighbours<'a> {
    set: [&'a [bool]; 5],
    depth: [&'a [f64]; 5],
}

impl RowNeighbours<'_> {
    /// The flags of [`scan_row`] into `out` (as long as the rows).
    fn flags(&self, fp: Footprint, out: &mut [u8]) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2 (checked above).
                unsafe { self.flags_avx2(fp, out) };
                return;
            }
        }
        self.flags_impl(fp, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn flags_avx2(&self, fp: Footprint, out: &mut [u8]) {
        self.flags_impl(fp, out)
    }

    #[inline(always)]
    fn flags_impl(&self, fp: Footprint, out: &mut [u8]) {
        let n = out.len();
        let [sc, sl, sr, su, sd] = self.set.map(|x| &x[..n]);
        let [dc, dl, dr, du, dd] = self.depth.map(|x| &x[..n]);
        // Pixels m..m + K (K = 8, or the row's last few), straight-line
        // code over arrays that the compiler vectorises: the nearest set
        // neighbour's depth (an unset pixel's is +∞, so that the depths
        // alone tell; set pixels' depths are finite, so none is NaN and a
        // plain compare-select stands for f64::min, whose NaN rule would
        // keep the loop scalar) against the pixel's own less four
        // footprints.
        #[inline(always)]
        fn block<const K: usize>(d: [&[f64]; 5], m: usize, fp: Footprint) -> [u8; K] {
            let dv = d.map(|x| -> [f64; K] { x[m..m + K].try_into().expect("K depths") });
            let min = |a: f64, b: f64| if a < b { a } else { b };
            let mut o = [0u8; K];
            for (q, o) in o.iter_mut().enumerate() {
                let near = min(min(dv[1][q], dv[2][q]), min(dv[3][q], dv[4][q]));
                // (+∞ less a finite footprint for an unset pixel: +∞)
                let dk = dv[0][q];
                let lim = dk - 4.0 * fp.at(min(dk, 1e300));
                *o = (near < lim) as u8;
            }
            o
        }
        let d = [dc, dl, dr, du, dd];
        // Eight pixels at a time; where none of them or their neighbours is
        // set (the background), their depths are not read.
        let mut m = 0;
        while m + 8 <= n {
            let any = bytes8(sc, m) | bytes8(sl, m) | bytes8(sr, m) | bytes8(su, m) | bytes8(sd, m);
            let o: [u8; 8] = if any == 0 {
                [0; 8]
            } else {
                block::<8>(d, m, fp)
            };
            out[m..m + 8].copy_from_slice(&o);
            m += 8;
        }
        while m < n {
            out[m] = block::<1>(d, m, fp)[0];
            m += 1;
        }
    }
}

/// [`RadialSweep::march`] for a caller without a sweep: the first crossing
/// of the ray o + λ·dir over [lo, hi] from the `side` side, and the
/// evaluations it took.
pub(super) fn march_ray(
    ctx: &Ctx<'_>,
    o: DVec3,
    dir: DVec3,
    lo: f64,
    hi: f64,
    fp: f64,
    side: i8,
) -> (Option<(f64, HeightSample)>, u64) {
    let mut sw = RadialSweep::new(ctx, 0.0, &[]);
    let hit = sw.march(o, dir, lo, hi, fp, side);
    (hit, sw.stats.refine_evals)
}

/// Rounds of [`edge_searches`] on the mask's edge: it grows by up to this
/// many pixels.
const GROW_ROUNDS: usize = 2;

/// The searches on the pixels' own rays after the bins (perspective), where
/// a pixel up to half a bin off its bin's plane may see what the plane does
/// not, and after the columns (orthographic), where a crest's top or the
/// domain's edge between a column's samples, or a crest in front that they
/// step over, is missed the same way:
/// - unset pixels next to set ones, on the mask's edge (a silhouette in the
///   plane, a crest or the domain's edge where it runs nearly along the
///   plane, can lie a pixel or two from the pixel's own): solved from their
///   set 4-neighbours' hits, in [`GROW_ROUNDS`] rounds, each over the
///   neighbours of the pixels the last one set;
/// - set pixels beside a nearer set 4-neighbour (a depth step of more than
///   four footprints: a crest in front that the plane passes over can still
///   cross the pixel's ray): searched from the nearer neighbours' hits,
///   short of their own, and moved to a crossing found there; in the later
///   rounds, those beside the pixels the last one moved (a step two pixels
///   wide).
///
/// A converged root is a true crossing of the ray, and its first, as the
/// neighbour's whose sheet it is lies a pixel away ([`solve_from_seeds`]).
/// The first round's two kinds are found in one pass over the image and
/// solved together. `depth` holds +∞ wherever `set` is false (and the
/// pixels' depths where true). Returns the moved pixels (their depths
/// updated); the pixels set are added to `px`. With `fill`, that pass also writes the
/// background of the pixels not set there ([`SharedOut::fill_unset`]; the
/// pixels the searches set are written over it afterwards).
pub(super) fn edge_searches(
    ctx: &Ctx<'_>,
    off: (f64, f64),
    set: &mut [bool],
    depth: &mut [f64],
    px: &mut Vec<(usize, Pixel)>,
    stats: &mut ColumnStats,
    fill: Option<&SharedOut<'_>>,
) -> Vec<(usize, Pixel)> {
    let cam = ctx.cam;
    let (w, h) = (cam.width, cam.height);
    let fpt = Footprint::of(cam);
    let fp = |l: f64| fpt.at(l);
    // Pixel k's search, if it is one: unset with a set neighbour, or set
    // with a nearer one. (a depth is read only where its pixel is set)
    let search = |set: &[bool], depth: &[f64], k: usize| -> Option<SeedSearch> {
        let (i, j) = (k / w, k % w);
        let nb = neighbours4(k, w, h);
        let (is_set, lim) = if set[k] {
            (true, depth[k] - 4.0 * fp(depth[k]))
        } else {
            (false, f64::INFINITY)
        };
        let mut zs = [f64::NAN; 4];
        let mut any = false;
        for (m, n) in nb.into_iter().enumerate() {
            if let Some(n) = n.filter(|&n| set[n] && depth[n] < lim) {
                zs[m] = depth[n];
                any = true;
            }
        }
        if !any {
            return None;
        }
        let (o, dir) = cam.ray(i as f64 + off.0, j as f64 + off.1);
        let dd = dir.dot(cam.d);
        if dd.is_nan() || dd <= 0.0 {
            return None;
        }
        zs.sort_by(f64::total_cmp);
        // Depth z lies at (z − z0) / (dir·d) along the ray (z0 = 0 from the
        // eye; an orthographic ray starts on the eye's plane).
        let z0 = (o - cam.eye).dot(cam.d);
        // One seed per sheet: the nearest of those within 16 footprints of
        // each other.
        let mut seeds = [f64::NAN; 4];
        let mut c = 0;
        for &z in zs.iter().filter(|z| z.is_finite()) {
            let l = (z - z0) / dd;
            if c == 0 || l - seeds[c - 1] > 16.0 * fp(l) {
                seeds[c] = l;
                c += 1;
            }
        }
        let limit = if is_set {
            let l = (depth[k] - z0) / dd;
            l - 2.0 * fp(l)
        } else {
            f64::INFINITY
        };
        Some((k, (o, dir), seeds, limit))
    };
    let mut moved = Vec::new();
    let mut moved_from = 0;
    let mut tried: Vec<usize> = Vec::new();
    let mut grown: Vec<usize> = Vec::new();
    for round in 0..GROW_ROUNDS {
        let cands: Vec<SeedSearch> = if round == 0 {
            // The whole image, a band of rows per task, each row's flags
            // computed branch-free ([`scan_row`]); the search itself is
            // rarely wanted. (The bands' results in row order: the same
            // for any thread count.)
            let (set, depth) = (&*set, &*depth);
            const BAND: usize = 16;
            let bands: Vec<Vec<SeedSearch>> = (0..h.div_ceil(BAND))
                .into_par_iter()
                .map(|b| {
                    let mut ks = Vec::new();
                    let mut flags = Vec::new();
                    for i in b * BAND..((b + 1) * BAND).min(h) {
                        scan_row(set, depth, i, w, h, fpt, &mut flags, &mut ks);
                        if let Some(out) = fill {
                            // SAFETY: the bands are disjoint rows, and
                            // nothing else writes the buffers meanwhile.
                            unsafe { out.fill_unset(i * w, &set[i * w..(i + 1) * w]) };
                        }
                    }
                    ks.into_iter()
                        .filter_map(|k| search(set, depth, k))
                        .collect()
                })
                .collect();
            bands.into_iter().flatten().collect()
        } else {
            // Around the pixels the last round set or moved.
            let mut ks: Vec<usize> = grown
                .iter()
                .chain(moved[moved_from..].iter().map(|(k, _)| k))
                .flat_map(|&k| neighbours4(k, w, h))
                .flatten()
                .collect();
            ks.sort_unstable();
            ks.dedup();
            ks.into_iter()
                .filter(|&k| set[k] || tried.binary_search(&k).is_err())
                .filter_map(|k| search(set, depth, k))
                .collect()
        };
        if cands.is_empty() {
            break;
        }
        let found = solve_from_seeds(ctx, &cands);
        tried.extend(cands.iter().filter(|c| c.3 == f64::INFINITY).map(|c| c.0));
        tried.sort_unstable();
        grown.clear();
        moved_from = moved.len();
        for (list, evals) in found {
            stats.refine_evals += evals;
            for (k, p) in list {
                depth[k] = p.depth;
                if set[k] {
                    stats.nearer += 1;
                    moved.push((k, p));
                } else {
                    set[k] = true;
                    stats.holes_filled += 1;
                    px.push((k, p));
                    grown.push(k);
                }
            }
        }
        if grown.is_empty() && moved.len() == moved_from {
            break;
        }
    }
    // (a pixel moved twice keeps its last, nearer hit)
    moved.reverse();
    moved.sort_by_key(|(k, _)| *k);
    moved.dedup_by_key(|(k, _)| *k);
    moved
}

/// The rays of one bin, generated by the bin itself, row by row.
///
/// A pixel (row y, column x on the screen, centred) lies in bin b when its
/// ray's horizontal direction is counter-clockwise of bin edge b and not of
/// edge b + 1 ([`Bins::of`]'s tests). Unnormalised, that ray is
/// v = F·d + x·r + y·up, and the test against an edge e is the sign of
/// L_e = e × v_h = P0 + y·P1 + x·Q: linear in the column, so that on each
/// row a bin's pixels are one run (§3.3: the screen image of a vertical
/// plane through the eye is a line through the vanishing point of the
/// verticals, and a bin is the wedge between two such lines). The run's
/// ends come from the two edges' linear equations; a pixel whose L is
/// within rounding of zero (|L| ≤ 10⁻⁹ of the size of v's terms, about 10⁶
/// times the rounding of the camera's own computation) is decided by
/// [`Bins::of`] on its ray, bit for bit [`crate::camera::Camera::ray`].
struct Runs<'b> {
    bins: &'b Bins,
    w: usize,
    h: usize,
    off: (f64, f64),
    fd: DVec3,
    r: DVec3,
    up: DVec3,
    focal: f64,
    /// Pixel centre x of column j is j + `c0` (up to rounding).
    c0: f64,
    tol: f64,
    /// Few bins (see [`Bins::of`]): every pixel by its ray.
    exact_only: bool,
    /// Whether the vanishing point of the verticals is near the image
    /// (every bin may reach it).
    vp_near: bool,
    /// That vanishing point (screen x, y), if finite.
    vp: Option<DVec2>,
}

/// Columns [lo, hi) of a row: [0, hi), [lo, w), or empty (lo ≥ hi).
type Half = (usize, usize);

impl<'b> Runs<'b> {
    fn new(cam: &crate::camera::Camera, bins: &'b Bins, off: (f64, f64)) -> Self {
        let (w, h) = (cam.width, cam.height);
        let half_w = 0.5 * w as f64;
        let half_h = 0.5 * h as f64;
        let (fd, r, up) = (cam.focal * cam.d, cam.r, cam.up);
        let size = fd.x.abs()
            + fd.y.abs()
            + (half_w + 2.0) * (r.x.abs() + r.y.abs())
            + (half_h + 2.0) * (up.x.abs() + up.y.abs());
        // The vanishing point of the verticals: where F·d + x·r + y·up is
        // vertical (its horizontal part zero), at infinity when no finite x,
        // y solve it (d horizontal).
        let det = r.x * up.y - r.y * up.x;
        let vp = if det.abs() > 1e-12 {
            let x = (-fd.x * up.y + fd.y * up.x) / det;
            let y = (-r.x * fd.y + r.y * fd.x) / det;
            (x.is_finite() && y.is_finite()).then_some(DVec2::new(x, y))
        } else {
            None
        };
        let vp_near = vp.is_some_and(|v| !(v.x.abs() > half_w + 4.0 || v.y.abs() > half_h + 4.0));
        Runs {
            bins,
            w,
            h,
            off,
            fd,
            r,
            up,
            focal: cam.focal,
            c0: off.1 + 0.5 - half_w,
            tol: 1e-9 * size,
            exact_only: bins.n < 8 || !size.is_finite(),
            vp_near,
            vp,
        }
    }

    /// The pseudo-elevations (see [`elevation`]) that the vertical plane of
    /// azimuth φ reaches on the image, widened by two pixels on every side
    /// (the pixels of a bin, at most a few pixels wide, lie within them):
    /// its screen line L = 0 (see [`Runs`]) clipped to that rectangle, on the
    /// side where the plane's rays point along φ, and the vanishing point of
    /// the verticals (θ = ±π/2) when it lies inside. None: the plane misses
    /// the image.
    fn wedge(&self, phi: f64) -> Option<(f64, f64)> {
        let (fd, r, up) = (self.fd, self.r, self.up);
        let (sp, cp) = phi.sin_cos();
        let c = DVec2::new(cp, sp);
        let a = c.x * fd.y - c.y * fd.x;
        let q = c.x * r.y - c.y * r.x;
        let p = c.x * up.y - c.y * up.x;
        let (x0, x1) = (self.c0 - 2.0, self.c0 + self.w as f64 + 1.0);
        let (y0, y1) = (self.y(self.h - 1) - 2.0, self.y(0) + 2.0);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut take = |x: f64, y: f64| {
            let v = fd + x * r + y * up;
            if c.x * v.x + c.y * v.y > 0.0 {
                let s = elevation(v.z, (v.x * v.x + v.y * v.y).sqrt());
                lo = lo.min(s);
                hi = hi.max(s);
            }
        };
        if p != 0.0 {
            for x in [x0, x1] {
                let y = -(a + q * x) / p;
                if y >= y0 && y <= y1 {
                    take(x, y);
                }
            }
        }
        if q != 0.0 {
            for y in [y0, y1] {
                let x = -(a + p * y) / q;
                if x >= x0 && x <= x1 {
                    take(x, y);
                }
            }
        }
        if let Some(v) = self.vp {
            if v.x >= x0 && v.x <= x1 && v.y >= y0 && v.y <= y1 {
                let vz = fd.z + v.x * r.z + v.y * up.z;
                let s = if vz >= 0.0 { 1.0 } else { -1.0 };
                lo = lo.min(s);
                hi = hi.max(s);
            }
        }
        if !(a.is_finite() && p.is_finite() && q.is_finite()) || (p == 0.0 && q == 0.0) {
            return Some((-1.0, 1.0));
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// The rows (indices in [`Self::group_rays`]' order) on which the bin
    /// of azimuth (cos φ, sin φ) = `c` and wedge `srange` (see
    /// [`Self::wedge`]) may have pixels with pseudo-elevation in
    /// [`bottom`, `top`] = `within` (None: no such pixel). Along the bin's
    /// screen line the elevation is monotone, and its pixels lie within
    /// half a bin (about half a pixel) of that line: the rows where the line reaches
    /// `bottom` and `top`, three rows further for safety, bound them.
    fn rows_within(
        &self,
        c: DVec2,
        within: (f64, f64),
        srange: (f64, f64),
    ) -> Option<(usize, usize)> {
        let h = self.h;
        let all = Some((0, h - 1));
        let (bottom, top) = within;
        if top.is_nan() || bottom.is_nan() {
            return all;
        }
        if top < srange.0 || bottom > srange.1 {
            return None;
        }
        let up = self.up.z >= 0.0;
        // Index (fractional) of the row through the line's point at `s`.
        // (Screen y = F·(d·up)/(d·d_cam) = F²·(d·up)/(d·F d_cam); NaN
        // behind the eye.)
        let at = |s: f64| -> f64 {
            let d = direction(c, s);
            let fz = d.dot(self.fd);
            if fz.is_nan() || fz <= 0.0 {
                return f64::NAN;
            }
            let y = self.focal * self.focal * d.dot(self.up) / fz;
            let i = 0.5 * h as f64 - 0.5 - self.off.0 - y;
            if up {
                (h - 1) as f64 - i
            } else {
                i
            }
        };
        let (r_lo, r_hi) = (at(srange.0), at(srange.1));
        if !(r_lo.is_finite() && r_hi.is_finite()) || r_hi == r_lo {
            return all;
        }
        // The rows at the two bounds (an end of the wedge where the bound
        // lies beyond it, or cannot be told).
        let row = |s: f64, end: f64| {
            if s <= srange.0 || s >= srange.1 {
                return end;
            }
            let r = at(s);
            if r.is_finite() {
                r
            } else {
                end
            }
        };
        let last = (h - 1) as f64;
        // Row indices grow with the elevation (r_hi > r_lo) or fall.
        let (r_a, r_b) = if r_hi > r_lo {
            (row(bottom, 0.0), row(top, last))
        } else {
            (row(top, 0.0), row(bottom, last))
        };
        let start = (r_a.floor() - 3.0).clamp(0.0, last);
        let end = (r_b.ceil() + 3.0).clamp(0.0, last);
        Some((start as usize, end as usize))
    }

    /// The screen y of row i (as [`crate::camera::Camera::pixel_to_screen`]).
    #[inline]
    fn y(&self, i: usize) -> f64 {
        0.5 * self.h as f64 - 0.5 - (i as f64 + self.off.0)
    }

    /// The ray of pixel (i, j), bit for bit [`crate::camera::Camera::ray`]'s
    /// direction, given y·up for its row, and its pseudo-elevation (see
    /// [`elevation`]).
    #[inline(always)]
    fn ray(&self, yu: DVec3, j: usize) -> (DVec3, f64) {
        // The operations of `Camera::pixel_to_screen` and `Camera::ray` (F·d
        // + x·r + y·up, normalised by the reciprocal of its length), in the
        // same order, with the products that do not depend on the column
        // hoisted.
        let (fd, r) = (self.fd, self.r);
        let x = j as f64 + self.off.1 + 0.5 - 0.5 * self.w as f64;
        let v = DVec3::new(
            fd.x + x * r.x + yu.x,
            fd.y + x * r.y + yu.y,
            fd.z + x * r.z + yu.z,
        );
        let rl = 1.0 / (v.x * v.x + v.y * v.y + v.z * v.z).sqrt();
        let d = DVec3::new(v.x * rl, v.y * rl, v.z * rl);
        let hl = (d.x * d.x + d.y * d.y).sqrt();
        (d, elevation(d.z, hl))
    }

    /// The columns of row screen-y `y` where L_e > t for edge e; None where
    /// that cannot be told (non-finite terms).
    #[inline]
    fn above(&self, e: DVec2, y: f64, t: f64) -> Option<Half> {
        let (fd, r, up) = (self.fd, self.r, self.up);
        let w = self.w;
        let a = (e.x * fd.y - e.y * fd.x) + y * (e.x * up.y - e.y * up.x) - t;
        let q = e.x * r.y - e.y * r.x;
        if !(a.is_finite() && q.is_finite()) {
            return None;
        }
        if q == 0.0 {
            return Some(if a > 0.0 { (0, w) } else { (w, 0) });
        }
        // a + q·(j + c0) > 0 ⟺ j beyond z.
        let z = (-a / q - self.c0).clamp(-1.0, w as f64 + 1.0);
        Some(if q > 0.0 {
            (((z.floor() + 1.0).max(0.0) as usize).min(w), w)
        } else {
            (0, (z.ceil().max(0.0) as usize).min(w))
        })
    }

    /// The columns not in `s` (a [`Half`]).
    #[inline]
    fn not(&self, s: Half) -> Half {
        let w = self.w;
        let (lo, hi) = s;
        if lo >= hi {
            (0, w)
        } else if lo == 0 && hi == w {
            (w, 0)
        } else if lo == 0 {
            (hi, w)
        } else {
            (0, lo)
        }
    }

    /// The bins whose rays may include pixels, ascending: all when the
    /// vanishing point of the verticals is near the image; else the arc of
    /// bins from the image's border pixels (the azimuths of a convex region
    /// seen from a point outside it span less than π, the extremes on its
    /// border), widened by two bins for rounding.
    fn candidates(&self) -> Vec<usize> {
        let n = self.bins.n;
        if self.vp_near || self.exact_only || n < 16 {
            return (0..n).collect();
        }
        let (w, h) = (self.w, self.h);
        let bin = |i: usize, j: usize| {
            let (d, _) = self.ray(self.y(i) * self.up, j);
            self.bins.of(d.x, d.y)
        };
        // The border pixels' bins (in parallel: marks do not depend on the order).
        let border: Vec<[usize; 2]> = (0..w)
            .into_par_iter()
            .map(|j| [bin(0, j), bin(h - 1, j)])
            .chain((0..h).into_par_iter().map(|i| [bin(i, 0), bin(i, w - 1)]))
            .collect();
        // (sorted, not marked in an array of all the bins: a narrow field of
        // view far from the vertical has some 10⁸ of them)
        let mut marked: Vec<usize> = border.into_iter().flatten().collect();
        marked.sort_unstable();
        marked.dedup();
        // The largest circular gap between marked bins lies outside.
        let (mut gap, mut after) = (0, 0);
        for (k, &b) in marked.iter().enumerate() {
            let next = marked[(k + 1) % marked.len()];
            let g = (next + n - b) % n;
            let g = if g == 0 { n } else { g };
            if g > gap {
                gap = g;
                after = next;
            }
        }
        if gap <= 8 {
            return (0..n).collect();
        }
        // Bins from `after` − 2 to `after` + (n − gap) + 2, circularly.
        let span = n - gap + 5;
        let mut out: Vec<usize> = (0..span).map(|k| (after + n + k - 2) % n).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The candidate bins in groups [g0, g1) of consecutive bins, each
    /// narrower than a quarter turn (so that the pixels between its two
    /// outer edges are one run per row) and of at most [`GROUP`] bins.
    fn groups(&self, cands: &[usize]) -> Vec<(usize, usize)> {
        let g = GROUP.min(self.bins.n / 4).max(1);
        let mut out = Vec::new();
        let mut k = 0;
        while k < cands.len() {
            let g0 = cands[k];
            let mut g1 = g0 + 1;
            k += 1;
            while k < cands.len() && cands[k] == g1 && g1 - g0 < g {
                g1 += 1;
                k += 1;
            }
            out.push((g0, g1));
        }
        out
    }

    /// The rays of bins g0..g1 (pixel index, elevation, direction) into
    /// `gs.lists[b − g0]`, row by row, the rows in the order in which the
    /// elevation grows along a bin's line when the screen's up is upwards
    /// (bottom to top; else top to bottom), the columns of a row ascending,
    /// so that the bin's sort by θ has little to do. Each row's pixels
    /// between the group's outer edges (one run, see [`Runs`]) take their
    /// bins from [`Bins::near`], walked along the row, as a whole-image
    /// binning would give them.
    ///
    /// With `rows`, bin b's pixels only on rows whose index in that order
    /// lies in `rows[b − g0]` (none: no pixels), those of the others on
    /// such rows possibly too.
    #[inline(never)]
    fn group_rays(
        &self,
        g0: usize,
        g1: usize,
        rows: Option<&[Option<(usize, usize)>]>,
        gs: &mut GroupScratch,
    ) {
        let (w, h) = (self.w, self.h);
        let nl = g1 - g0;
        gs.lists.resize_with(nl.max(gs.lists.len()), Vec::new);
        for l in &mut gs.lists[..nl] {
            l.clear();
        }
        gs.dx.resize(w, 0.0);
        gs.dy.resize(w, 0.0);
        gs.dz.resize(w, 0.0);
        gs.th.resize(w, 0.0);
        gs.edges.clear();
        gs.edges.extend((g0..=g1).map(|b| self.bins.edge(b)));
        // A group as wide as a quarter turn or more: every pixel tested.
        let whole = self.exact_only || 4 * nl >= self.bins.n;
        let tol = self.tol;
        let up = self.up.z >= 0.0;
        // The bins [g0 + b0, g0 + b1] that take pixels on the row (with
        // `rows`), recomputed where one's rows start or end.
        let (mut b0, mut b1, mut next) = (0, nl - 1, if rows.is_some() { 0 } else { h });
        for r in 0..h {
            if r >= next {
                let rows = rows.expect("rows given");
                (b0, b1, next) = (usize::MAX, 0, h);
                for (k, iv) in rows.iter().enumerate().take(nl) {
                    let Some((ra, rb)) = *iv else { continue };
                    if r >= ra && r <= rb {
                        b0 = b0.min(k);
                        b1 = b1.max(k);
                        next = next.min(rb + 1);
                    } else if r < ra {
                        next = next.min(ra);
                    }
                }
            }
            if b0 > b1 {
                continue;
            }
            let (e0, e1) = (self.bins.edge(g0 + b0), self.bins.edge(g0 + b1 + 1));
            let i = if up { h - 1 - r } else { r };
            let y = self.y(i);
            // Possibly in the group: L_g0 > −tol and not L_g1 > tol.
            let (lo, hi) = if whole {
                (0, w)
            } else {
                match (self.above(e0, y, -tol), self.above(e1, y, tol)) {
                    (Some(m0), Some(m1)) => {
                        let n1 = self.not(m1);
                        (m0.0.max(n1.0), m0.1.min(n1.1))
                    }
                    _ => (0, w),
                }
            };
            if lo >= hi {
                continue;
            }
            let yu = y * self.up;
            let (dxs, dys, dzs, ths) = (
                &mut gs.dx[lo..hi],
                &mut gs.dy[lo..hi],
                &mut gs.dz[lo..hi],
                &mut gs.th[lo..hi],
            );
            // In plain arrays, so that the loop vectorises.
            for (m, (((dx, dy), dz), th)) in dxs
                .iter_mut()
                .zip(dys.iter_mut())
                .zip(dzs.iter_mut())
                .zip(ths.iter_mut())
                .enumerate()
            {
                let (d, t) = self.ray(yu, lo + m);
                (*dx, *dy, *dz, *th) = (d.x, d.y, d.z, t);
            }
            let base = i * w;
            // The walk starts at the bin of the run's first column: the
            // lower of the run's bins when the columns go counter-clockwise
            // (L_e grows with the column), else the upper.
            let mut lb = if e0.x * self.r.y - e0.y * self.r.x > 0.0 {
                b0
            } else {
                b1
            };
            let edges = &gs.edges[..=nl];
            for (m, (((&dx, &dy), &dz), &theta)) in dxs
                .iter()
                .zip(dys.iter())
                .zip(dzs.iter())
                .zip(ths.iter())
                .enumerate()
            {
                // The ray's bin by [`Bins::near`]'s edge tests, walked
                // among the group's edges: the one bin whose lower edge
                // the ray lies counter-clockwise of and whose upper edge
                // not. Beyond the group's outer edges (or where the tests
                // cannot tell), [`Bins::near`] decides.
                let ccw = |e: DVec2| e.x * dy - e.y * dx >= 0.0;
                let mut inside = true;
                if !ccw(edges[lb]) {
                    loop {
                        if lb == 0 {
                            inside = false;
                            break;
                        }
                        lb -= 1;
                        if ccw(edges[lb]) {
                            break;
                        }
                    }
                } else {
                    while ccw(edges[lb + 1]) {
                        if lb + 1 == nl {
                            inside = false;
                            break;
                        }
                        lb += 1;
                    }
                }
                if !inside {
                    match self.bins.near(g0 + lb, dx, dy).checked_sub(g0) {
                        Some(l) if l < nl => lb = l,
                        _ => continue,
                    }
                }
                gs.lists[lb].push(Ray {
                    k: (base + lo + m) as u32,
                    theta,
                    dir: DVec3::new(dx, dy, dz),
                });
            }
        }
    }
}

/// Stretches of a sweep with their own height bound (see
/// [`RadialSweep::local_bounds`]).
const SEGMENTS: usize = 64;

/// Bins per group of [`Runs::group_rays`] (one task: its rays, then its
/// sweeps).
const GROUP: usize = 32;

/// Buffers of [`Runs::group_rays`], kept between groups.
#[derive(Default)]
struct GroupScratch {
    lists: Vec<Vec<Ray>>,
    dx: Vec<f64>,
    dy: Vec<f64>,
    dz: Vec<f64>,
    th: Vec<f64>,
    /// The group's bin edges g0..=g1.
    edges: Vec<DVec2>,
}

/// Bins swept side by side (see [`sweep_together`]).
const LOCKSTEP: usize = 16;

/// Bins of one round of [`two_pass_bins`] (their sweeps, then their rays).
const TWO_PASS_BINS: usize = 16;

/// A worker thread's sweeps in a render, each with the state of its run.
#[derive(Default)]
struct Lockstep<'c, 'a> {
    sweeps: Vec<(RadialSweep<'c, 'a>, RunState)>,
}

/// A worker thread's other buffers: its group's rays, the batched
/// evaluation's and a bin's pixel buffers. Kept from render to render
/// ([`THREAD_BUFS`]): a new render neither regrows them nor touches fresh
/// memory.
#[derive(Default)]
struct ThreadBufs {
    gs: GroupScratch,
    todo: Vec<usize>,
    /// Each bin's generation rows (see [`Runs::rows_within`]).
    rows: Vec<Option<(usize, usize)>>,
    eval: EvalScratch,
    pixels: PixelBuffers,
}

thread_local! {
    /// The [`ThreadBufs`] of this thread, held by one group task at a time
    /// (a task nested in another on the same thread takes fresh ones). Their
    /// contents never reach the output.
    static THREAD_BUFS: std::cell::RefCell<ThreadBufs> = Default::default();
}

/// A bin's buffers from its rays' replay to its result (see
/// [`two_pass_bins`]), which the bins of a worker thread take in turn: one
/// set grown, not one per sweep.
#[derive(Default)]
struct PixelBuffers {
    rows: Vec<f64>,
    done: Vec<bool>,
    out: Vec<(usize, Pixel)>,
    jobs: Vec<BinJob>,
    walls: Vec<BinJob>,
    solver: super::refine::NewtonScratch,
    failed: Vec<u32>,
    checks: SideChecks,
}

/// Buffers of [`sweep_together`].
#[derive(Default)]
struct EvalScratch {
    sc: Scratch,
    batch: Vec<Option<Raw>>,
    need: Vec<usize>,
    next: Vec<usize>,
}

/// Run the sweeps side by side: each goes on as far as its samples
/// evaluated so far take it (see [`RadialSweep::drive`]), then the samples
/// that all of them ask for next are evaluated in one batch. A sweep's
/// samples, and all it does with them, are those of a sweep run alone.
#[inline(never)]
fn sweep_together(
    ctx: &Ctx<'_>,
    sweeps: &mut [(RadialSweep<'_, '_>, RunState)],
    es: &mut EvalScratch,
) {
    let e = ctx.cam.eye;
    let d = ctx.frame.domain;
    let EvalScratch {
        sc,
        batch,
        need,
        next,
    } = es;
    need.clear();
    for (m, (sw, st)) in sweeps.iter_mut().enumerate() {
        if sw.begin(st) {
            need.push(m);
        }
    }
    while !need.is_empty() {
        sc.clear();
        for &m in need.iter() {
            let sw = &sweeps[m].0;
            for &rho in &sw.ahead.ts {
                let uv = DVec2::new(e.x, e.y) + rho * sw.eh;
                sc.u.push(uv.x.clamp(d.u0, d.u1));
                sc.v.push(uv.y.clamp(d.v0, d.v1));
            }
        }
        sc.hs.resize(sc.u.len(), HeightSample::default());
        ctx.field.eval_batch(&sc.u, &sc.v, &mut sc.hs);
        next.clear();
        let mut at = 0;
        for &m in need.iter() {
            let (sw, st) = &mut sweeps[m];
            let n = sw.ahead.ts.len();
            batch.clear();
            for (k, &rho) in sw.ahead.ts.iter().enumerate() {
                let hs = sc.hs[at + k];
                batch.push(hs.is_finite().then_some(Raw {
                    t: rho,
                    s: 0.0,
                    uv: DVec2::new(sc.u[at + k], sc.v[at + k]),
                    h: hs,
                }));
            }
            at += n;
            sw.stats.sweep_evals += n as u64;
            if sw.deliver(st, batch) {
                next.push(m);
            }
        }
        std::mem::swap(need, next);
    }
}

/// Where a bin's sweep stands between two batches of samples (see
/// [`RadialSweep::drive`]).
#[derive(Default)]
struct RunState {
    /// The previous sample and the candidate, in two slots that swap roles
    /// as the sweep moves on (no copy of a sample per step): the previous
    /// one in `slots[p]`.
    slots: [Option<Sample>; 2],
    p: usize,
    rho: f64,
    r1: f64,
    scale: f64,
    steps: usize,
    hstep: f64,
    h_max: f64,
    halvings: u32,
    /// Local pixels per unit of `rho` at the previous sample (see
    /// [`PxRate`]), set when that sample is taken.
    rate: f64,
    /// Elevation range of the bin's rays (units of `rho`).
    th_lo: f64,
    th_hi: f64,
    /// The highest elevation (units of `rho`) any point beyond the sweep's
    /// position can reach, by the surface's height bound, when it is the
    /// same for every position (the eye above the bound: the far end's);
    /// else +∞ (see [`RadialSweep::bound_top`]).
    top: f64,
    /// Height of the bound above the eye when it is at or above the eye
    /// (the highest elevation then falls along the sweep); else NaN.
    zb: f64,
    /// Waiting for the sample at the start of the sweep.
    first: bool,
    /// Stretches outside the rays stepped over at once
    /// ([`RadialSweep::try_skip`]), not before this ρ again after a
    /// try that failed.
    skips: bool,
    no_skip_until: f64,
    /// The current step is such a stretch: its candidate lies in it, so
    /// its gap to the previous sample is no reason to retry.
    skipping: bool,
    /// The step the last step's bend allows (∞: unknown), see
    /// [`super::column::bend_limit`].
    bend: f64,
}

/// Sort a bin's rays by θ, ties by pixel index (keys are unique, so the
/// order is too). A bin's pixels come row by row (see
/// [`Runs::group_rays`]), a run of one or a few per row, along a line of the
/// screen on which θ is monotone: nearly sorted or nearly reversed, each ray a few places from its own, so that
/// an insertion sort after an optional reversal takes a few moves per ray.
fn sort_rays(rays: &mut [Ray]) {
    // The order of `total_cmp` then the pixel index; two numbers that
    // differ compare as numbers under both (one comparison in the common
    // case).
    let before = |x: &Ray, y: &Ray| {
        if x.theta < y.theta {
            true
        } else if x.theta > y.theta {
            false
        } else {
            x.theta.total_cmp(&y.theta).then(x.k.cmp(&y.k)).is_lt()
        }
    };
    let n = rays.len();
    if n < 2 {
        return;
    }
    if before(&rays[n - 1], &rays[0]) {
        rays.reverse();
    }
    let mut moves = 0usize;
    for i in 1..n {
        if !before(&rays[i], &rays[i - 1]) {
            // In place already (the common case).
            continue;
        }
        let x = rays[i];
        let mut j = i;
        while j > 0 && before(&x, &rays[j - 1]) {
            rays[j] = rays[j - 1];
            j -= 1;
        }
        rays[j] = x;
        moves += i - j;
        if moves > 16 * n + 64 {
            // Far from sorted after all.
            rays.sort_unstable_by(|x, y| x.theta.total_cmp(&y.theta).then(x.k.cmp(&y.k)));
            return;
        }
    }
}

/// Eight set flags from index a, one byte each (1: set).
#[inline]
pub(super) fn bytes8(set: &[bool], a: usize) -> u64 {
    let b: &[bool; 8] = set[a..a + 8].try_into().expect("eight flags");
    u64::from_le_bytes(b.map(u8::from))
}

/// The sweep's elevation coordinate of the direction (h, z) (horizontal
/// distance h ≥ 0, height z): tan(θ/2) = z / (h + √(h² + z²)) for the
/// elevation θ = atan2(z, h). Monotone in θ over (−π, π) (so it orders rays
/// and samples as θ does) and without a transcendental call;
/// dtan(θ/2)/dθ = (1 + tan²(θ/2)) / 2 lies in [½, 1] for |θ| ≤ π/2.
#[inline]
pub(crate) fn elevation(z: f64, h: f64) -> f64 {
    let r = (h * h + z * z).sqrt();
    if r > 0.0 {
        z / (h + r)
    } else {
        0.0
    }
}

/// A bound's elevation (units of `rho`) raised by far more than the
/// rounding of the samples' own elevations (about 1e-16 of their size), so
/// that a sample at the bound's height never lies above it.
#[inline]
fn bound_margin(x: f64) -> f64 {
    x + 1e-9 * (1.0 + x.abs())
}

/// The unit direction of azimuth (cos φ, sin φ) and pseudo-elevation
/// s = tan(θ/2) (see [`elevation`]).
#[inline]
fn direction(cs: DVec2, s: f64) -> DVec3 {
    let q = 1.0 / (1.0 + s * s);
    let (c, sn) = ((1.0 - s * s) * q, 2.0 * s * q);
    DVec3::new(c * cs.x, c * cs.y, sn)
}

/// Azimuth bins: bin b holds the horizontal directions of azimuth φ in
/// [−π + 2πb/n, −π + 2π(b+1)/n). The bin of a direction is estimated by a
/// cheap arctangent and settled exactly by the signs of its cross products
/// with the bin's two bounding directions (no atan2 per pixel).
pub(crate) struct Bins {
    n: usize,
    /// Bounding directions (cos, sin) of the n + 1 bin edges, tabulated
    /// up to [`Bins::TABLE`] bins (a narrow field of view far from the
    /// vertical wants bins by the hundred million, of which its rays meet
    /// a few hundred: their edges are computed where they are asked for).
    edge: Vec<DVec2>,
}

impl Bins {
    /// Most bins whose edges are tabulated.
    const TABLE: usize = 1 << 20;

    pub(crate) fn new(n: usize) -> Self {
        let edge = if n <= Self::TABLE {
            (0..=n).map(|b| Self::edge_of(n, b)).collect()
        } else {
            Vec::new()
        };
        Bins { n, edge }
    }

    #[inline]
    fn edge_of(n: usize, b: usize) -> DVec2 {
        use std::f64::consts::PI;
        let (s, c) = (-PI + 2.0 * PI * b as f64 / n as f64).sin_cos();
        DVec2::new(c, s)
    }

    /// The bounding direction of edge b (0 ≤ b ≤ n).
    #[inline]
    pub(crate) fn edge(&self, b: usize) -> DVec2 {
        match self.edge.get(b) {
            Some(&e) => e,
            None => Self::edge_of(self.n, b),
        }
    }

    /// The azimuth φ of bin b's centre line (the plane its sweep runs in).
    #[inline]
    pub(crate) fn centre(&self, b: usize) -> f64 {
        use std::f64::consts::PI;
        -PI + (b as f64 + 0.5) * 2.0 * PI / self.n as f64
    }

    #[inline]
    pub(crate) fn of(&self, x: f64, y: f64) -> usize {
        use std::f64::consts::PI;
        let n = self.n;
        if n < 8 || !(x.is_finite() && y.is_finite()) {
            // Bins as wide as a quadrant: the exact arctangent.
            let f = (fast_atan2(y, x) + PI) / (2.0 * PI);
            return ((f * n as f64) as usize).min(n - 1);
        }
        // (the cheap estimate is within 1e-5 rad: a few bins up to a
        // million; beyond, the exact one, within a bin up to some 10¹⁴)
        let phi = if n <= Self::TABLE {
            approx_atan2(y, x)
        } else {
            fast_atan2(y, x)
        };
        let f = (phi + PI) / (2.0 * PI);
        let mut b = ((f * n as f64).max(0.0) as usize).min(n - 1);
        // (x, y) lies counter-clockwise of edge e when e × (x, y) ≥ 0.
        let ccw = |e: DVec2| e.x * y - e.y * x >= 0.0;
        while b > 0 && !ccw(self.edge(b)) {
            b -= 1;
        }
        while b + 1 < n && ccw(self.edge(b + 1)) {
            b += 1;
        }
        b
    }
}

impl Bins {
    /// [`Bins::of`], walked to from bin `b0` (a neighbouring pixel's): the
    /// same bin, as the edge tests single it out, in a few comparisons.
    #[inline]
    pub(crate) fn near(&self, b0: usize, x: f64, y: f64) -> usize {
        let n = self.n;
        if b0 >= n || n < 8 || !(x.is_finite() && y.is_finite()) {
            return self.of(x, y);
        }
        let ccw = |e: DVec2| e.x * y - e.y * x >= 0.0;
        // Walked one way only (a step up leaves the direction
        // counter-clockwise of the new bin's lower edge, a step down
        // clockwise of its upper edge), each edge tested once, up to four
        // bins. Edges 0 and n are the same direction (φ = ±π): a walk
        // across it starts afresh.
        if ccw(self.edge(b0)) {
            for b in b0..(b0 + 4).min(n) {
                if !ccw(self.edge(b + 1)) {
                    // Between edges b and b + 1 (each within π of the other).
                    return b;
                }
            }
        } else {
            for b in (b0.saturating_sub(3)..b0).rev() {
                if ccw(self.edge(b)) {
                    return b;
                }
            }
        }
        self.of(x, y)
    }
}

/// atan2 to about 1e-5 rad (an odd polynomial on the octant), the estimate
/// that [`Bins::of`] settles.
#[inline]
fn approx_atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ax < ay { (ax, ay) } else { (ay, ax) };
    if hi == 0.0 {
        return 0.0;
    }
    let a = lo / hi;
    let s = a * a;
    let mut r = (((-0.046_496_474_9 * s + 0.159_314_22) * s - 0.327_622_764) * s) * a + a;
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// atan2(y, x) to about 1e-15 rad: Cephes' `atan` (range reduction to |z| ≤ tan(π/8) and a
/// rational approximation), several times cheaper than libm's `atan2`. The
/// sweep compares elevations of samples and rays computed by this one
/// function, so only its monotonicity matters for visibility.
#[inline]
pub(crate) fn fast_atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    if !(y.is_finite() && x.is_finite()) || x == 0.0 || (y == 0.0 && x < 0.0) {
        return y.atan2(x);
    }
    if x < 0.0 {
        // atan2 in the left half-plane, by symmetry.
        let r = fast_atan2(y, -x);
        return if y > 0.0 { PI - r } else { -PI - r };
    }
    let q = y / x;
    let a = q.abs();
    const T3P8: f64 = 2.414_213_562_373_095; // tan(3π/8)
    let (base, z) = if a > T3P8 {
        (FRAC_PI_2, -1.0 / a)
    } else if a > 0.66 {
        (FRAC_PI_4, (a - 1.0) / (a + 1.0))
    } else {
        (0.0, a)
    };
    let zz = z * z;
    let p = (((-8.750_608_600_031_904e-1 * zz - 1.615_753_718_733_365e1) * zz
        - 7.500_855_792_314_705e1)
        * zz
        - 1.228_866_684_490_136_1e2)
        * zz
        - 6.485_021_904_942_025e1;
    let qd = ((((zz + 2.485_846_490_142_306_4e1) * zz + 1.650_270_098_316_988_6e2) * zz
        + 4.328_810_604_912_903e2)
        * zz
        + 4.853_903_996_359_137e2)
        * zz
        + 1.945_506_571_482_614e2;
    let r = base + (z + z * zz * p / qd);
    if q < 0.0 {
        -r
    } else {
        r
    }
}

/// What the pixels of one span share: the samples' points, the nearer and
/// farther of their distances from the eye and the difference, the side
/// revealed, and the span's cubics (none for walls): its horizontal
/// distance and height over the elevations where the span is well
/// conditioned ([`super::column::RowCubic`]), else its cubic in τ.
struct SpanConst {
    pa: DVec3,
    pb: DVec3,
    near: f64,
    far: f64,
    span: f64,
    topo: i8,
    graph: Option<super::column::RowCubic<2>>,
    cubic: Option<super::column::SpanCubic>,
}

impl SpanConst {
    #[inline(always)]
    fn new(ctx: &Ctx<'_>, a: &Sample, b: &Sample, wall: bool) -> SpanConst {
        let e = ctx.cam.eye;
        let (pa, pb) = (a.world(&ctx.frame), b.world(&ctx.frame));
        let (la, lb) = ((pa - e).length(), (pb - e).length());
        let graph = if wall {
            None
        } else {
            super::column::RowCubic::new(a, b, [(1.0, 0.0), (0.0, 1.0)])
        };
        SpanConst {
            pa,
            pb,
            near: la.min(lb),
            far: la.max(lb),
            span: (la - lb).abs(),
            // Upwards (θ increasing) reveals the upper side, in world terms.
            topo: if b.rho > a.rho { 1 } else { -1 },
            graph,
            cubic: if wall || graph.is_some() {
                None
            } else {
                super::column::SpanCubic::new(a, b)
            },
        }
    }
}

/// Buffers of [`RadialSweep::solve`]'s side checks, kept from bin to bin:
/// the jobs (index, hit distance) whose hit lies on the side their span did
/// not reveal, and those on the under side; for the latter the points where
/// their rays enter the domain (job, hit, entry distance, height there) and
/// the surface at them.
#[derive(Default)]
struct SideChecks {
    suspect: Vec<(u32, f64)>,
    entry: Vec<(u32, f64)>,
    starts: Vec<(u32, f64, f64, f64)>,
    u: Vec<f64>,
    v: Vec<f64>,
    hs: Vec<HeightSample>,
}

impl SideChecks {
    /// Drop the entry points below the surface's lower bound over their
    /// (u, v) box (they enter from below, as the under side is seen: no
    /// evaluation needed to tell). A bin's rays share their azimuth, so
    /// that they enter the domain within a bin's width of each other and
    /// one bound over that small box decides most of them. (A bound is
    /// rigorous; a point within 10⁻⁹ of it relative is kept for its
    /// evaluation.)
    fn below_bound(&mut self, field: &dyn crate::surface::HeightField) {
        if self.starts.is_empty() {
            return;
        }
        let range = |x: &[f64]| {
            x.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                })
        };
        let ((u0, u1), (v0, v1)) = (range(&self.u), range(&self.v));
        let Some((lo, _)) = field.height_range_in(u0, u1, v0, v1) else {
            return;
        };
        let lo = lo - 1e-9 * lo.abs();
        if !lo.is_finite() {
            return;
        }
        let mut w = 0;
        for i in 0..self.starts.len() {
            if self.starts[i].3 >= lo {
                self.starts[w] = self.starts[i];
                self.u[w] = self.u[i];
                self.v[w] = self.v[i];
                w += 1;
            }
        }
        self.starts.truncate(w);
        self.u.truncate(w);
        self.v.truncate(w);
    }
}

/// One pixel of a bin to solve on its ray from the eye (see
/// [`RadialSweep::solve`]).
#[derive(Debug, Clone, Copy)]
struct BinJob {
    dir: DVec3,
    /// Seed and bracket of the distance along the ray.
    lam: f64,
    lo: f64,
    hi: f64,
    /// World size of a pixel at the seed.
    fp: f64,
    /// Index of the pixel in the sweep's output.
    slot: u32,
    /// Seen side (for the march fallback).
    side: i8,
}

struct RadialSweep<'c, 'a> {
    ctx: &'c Ctx<'a>,
    eh: DVec2,
    /// The bin's rays, sorted by θ.
    rays: Vec<Ray>,
    /// Their elevations θ·`ppr` in the units of the samples' `rho` (set by
    /// [`Self::begin`]).
    rows: Vec<f64>,
    done: Vec<bool>,
    /// Covered θ intervals.
    cov: super::column::Coverage,
    out: Vec<(usize, Pixel)>,
    stats: ColumnStats,
    jobs: Vec<BinJob>,
    /// The wall pixels (§5.1), each placed where its own ray meets the
    /// wall ([`Self::solve_walls`]): `lo`..`hi` the two samples' horizontal
    /// distances along the ray (`lam` their midpoint, where the pixel was
    /// put first).
    walls: Vec<BinJob>,
    /// Buffers of the batched solve.
    solver: super::refine::NewtonScratch,
    /// The jobs whose Newton failed (indices), for the march.
    failed: Vec<u32>,
    checks: SideChecks,
    /// Screen pixels per radian of θ along the bin's plane (see [`bin_ppr`]).
    ppr: f64,
    /// Local pixels per unit of `rho` (see [`PxRate`]).
    rate: PxRate,
    /// Pseudo-elevations of the bin's wedge (see [`Runs::wedge`]): its rays
    /// lie within them.
    srange: (f64, f64),
    ahead: Ahead,
    /// Where the last span's rays started (in `rays`).
    cursor: usize,
    /// Row and column offsets of the rays (see [`render_radial`]).
    off: (f64, f64),
    /// With `coverage`: the covered elevations (in the units of `rho`) at
    /// floating-point precision, including the extrema between samples.
    fine: Option<super::column::Coverage>,
    /// With `coverage`: each ray's pixel extent [i − ½, i + ½] in rows, as
    /// elevations (units of `rho`), and the largest half extent of the bin.
    ext: Vec<(f64, f64)>,
    half: f64,
    /// With `coverage`: the silhouette shading of rays that a span reaches
    /// into without covering their centre.
    edge: Vec<Option<Pixel>>,
    /// Sweep without rays, logging what changes the coverage (see
    /// [`two_pass_bins`]): the spans (ends in `log`) and the single points
    /// (after a hole), to be replayed on the rays by [`Self::replay`].
    record: bool,
    log: Vec<Sample>,
    events: Vec<Event>,
    points: Vec<f64>,
    /// With a source's local height bounds (see
    /// [`crate::surface::HeightField::height_max_in`]): for each of
    /// [`SEGMENTS`] equal stretches of the sweep, the highest elevation
    /// (units of `rho`) any point from it to the sweep's end can reach; and
    /// the stretches per unit of ρ from the sweep's start `seg_r0`.
    seg: Vec<f64>,
    seg_r0: f64,
    seg_inv: f64,
    /// Without coverage: the pixels (indices) whose solve found no hit on
    /// their ray near the span that revealed them (their ray passes by the
    /// sheet the bin's plane met), dropped from `out`.
    /// With each, how far along its ray it was searched.
    missed: Vec<(u32, f64)>,
}

/// A change of a sweep's coverage (see [`RadialSweep::record`]).
#[derive(Debug, Clone, Copy)]
enum Event {
    /// The span between two logged samples, and whether it is a wall.
    Span(u32, u32, bool),
    /// A single elevation (a sample after a hole).
    Point(f64),
}

impl<'c, 'a> RadialSweep<'c, 'a> {
    fn new(ctx: &'c Ctx<'a>, phi: f64, rays: &[Ray]) -> Self {
        RadialSweep {
            ctx,
            eh: DVec2::new(phi.cos(), phi.sin()),
            rays: rays.to_vec(),
            rows: Vec::new(),
            done: vec![false; rays.len()],
            cov: Default::default(),
            out: Vec::with_capacity(rays.len()),
            stats: ColumnStats::default(),
            jobs: Vec::with_capacity(if ctx.fallback { rays.len() } else { 0 }),
            walls: Vec::new(),
            solver: Default::default(),
            failed: Vec::new(),
            checks: SideChecks::default(),
            ppr: 1.5 * ctx.cam.focal,
            rate: PxRate::default(),
            srange: (-1.0, 1.0),
            ahead: Ahead::with_max(super::sampling::AHEAD_MAX_RADIAL),
            cursor: 0,
            off: (0.0, 0.0),
            fine: None,
            ext: Vec::new(),
            half: 0.0,
            edge: Vec::new(),
            record: false,
            log: Vec::new(),
            events: Vec::new(),
            points: Vec::new(),
            missed: Vec::new(),
            seg: Vec::new(),
            seg_r0: 0.0,
            seg_inv: 0.0,
        }
    }

    /// Ready the sweep for the bin of azimuth φ whose rays are `rays` (row
    /// by row), as [`Self::new`] would make it, keeping its
    /// buffers (one sweep serves many bins in turn).
    /// Returns the previous rays' buffer (cleared).
    fn reset(&mut self, phi: f64, rays: Vec<Ray>) -> Vec<Ray> {
        self.eh = DVec2::new(phi.cos(), phi.sin());
        let mut old = std::mem::replace(&mut self.rays, rays);
        old.clear();
        sort_rays(&mut self.rays);
        self.done.clear();
        self.done.resize(self.rays.len(), false);
        self.cov.clear();
        self.out.clear();
        self.stats = ColumnStats::default();
        self.jobs.clear();
        self.walls.clear();
        self.ppr = 1.5 * self.ctx.cam.focal;
        self.rate = PxRate::default();
        self.srange = (-1.0, 1.0);
        // (A new sweep's look-ahead, its buffers kept.)
        self.ahead.reset();
        self.cursor = 0;
        self.off = (0.0, 0.0);
        self.fine = None;
        self.ext.clear();
        self.half = 0.0;
        self.edge.clear();
        self.record = false;
        self.log.clear();
        self.events.clear();
        self.missed.clear();
        old
    }

    /// Trade the sweep's buffers of [`PixelBuffers`] for `bufs` (their
    /// contents go along).
    fn swap_pixel_buffers(&mut self, bufs: &mut PixelBuffers) {
        std::mem::swap(&mut self.rows, &mut bufs.rows);
        std::mem::swap(&mut self.done, &mut bufs.done);
        std::mem::swap(&mut self.out, &mut bufs.out);
        std::mem::swap(&mut self.jobs, &mut bufs.jobs);
        std::mem::swap(&mut self.walls, &mut bufs.walls);
        std::mem::swap(&mut self.solver, &mut bufs.solver);
        std::mem::swap(&mut self.failed, &mut bufs.failed);
        std::mem::swap(&mut self.checks, &mut bufs.checks);
    }

    /// The lowest and highest covered pseudo-elevations (None: nothing
    /// covered).
    fn covered(&self) -> Option<(f64, f64)> {
        self.cov.extent().map(|(b, t)| (b / self.ppr, t / self.ppr))
    }

    /// After a recorded sweep: its coverage rebuilt on the bin's rays
    /// `rays` (row by row) from the logged changes, revealing the rays as
    /// the sweep would have with them (the same spans in the same order).
    /// Returns the previous rays' buffer (cleared).
    fn replay(&mut self, rays: Vec<Ray>) -> Vec<Ray> {
        let mut old = std::mem::replace(&mut self.rays, rays);
        old.clear();
        sort_rays(&mut self.rays);
        self.done.clear();
        self.done.resize(self.rays.len(), false);
        let ppr = self.ppr;
        self.rows.clear();
        self.rows.extend(self.rays.iter().map(|r| r.theta * ppr));
        self.cursor = 0;
        self.record = false;
        // Emptied (they may hold another bin's pixels, see
        // [`PixelBuffers`]; the recorded sweep revealed none), with room
        // for every ray: where too small, a fresh buffer (nothing to copy).
        let n = self.rays.len();
        self.out.clear();
        self.jobs.clear();
        self.walls.clear();
        if self.out.capacity() < n {
            self.out = Vec::with_capacity(n);
        }
        if self.jobs.capacity() < n {
            self.jobs = Vec::with_capacity(n);
        }
        // The coverage is the union of the spans and points so far, and a
        // span reveals every ray it holds that is not done and not covered
        // before: a ray is covered exactly when it is done or on an earlier
        // single point (kept in `points`, few).
        self.points.clear();
        let log = std::mem::take(&mut self.log);
        let events = std::mem::take(&mut self.events);
        for ev in &events {
            match *ev {
                Event::Span(a, b, wall) => {
                    let (a, b) = (&log[a as usize], &log[b as usize]);
                    let (lo, hi) = if a.rho <= b.rho {
                        (a.rho, b.rho)
                    } else {
                        (b.rho, a.rho)
                    };
                    self.reveal(a, b, wall, lo, hi, true);
                }
                Event::Point(x) => self.points.push(x),
            }
        }
        self.log = log;
        self.events = events;
        old
    }

    /// The index in `log` of sample `s`, logged unless it is the last one.
    fn logged(&mut self, s: &Sample) -> u32 {
        if let Some(l) = self.log.last() {
            if l.t.to_bits() == s.t.to_bits()
                && l.rho.to_bits() == s.rho.to_bits()
                && l.wr.to_bits() == s.wr.to_bits()
            {
                return (self.log.len() - 1) as u32;
            }
        }
        self.log.push(*s);
        (self.log.len() - 1) as u32
    }

    /// Cover the single elevation x (a sample after a hole).
    fn point(&mut self, x: f64) {
        if self.record && !self.cov.contains(x) {
            self.events.push(Event::Point(x));
        }
        self.cov.add(x, x);
    }

    /// §6.4 coverage for the bin: each ray's row extent [i − ½, i + ½]
    /// along its vertical plane (the screen line through the vanishing
    /// point of the verticals), as elevations: θ ± ½ / |∂row/∂θ|.
    fn start_coverage(&mut self) {
        let cam = self.ctx.cam;
        let w = cam.width;
        let ppr = self.ppr;
        let delta = 1e-6;
        self.ext = self
            .rays
            .iter()
            .map(|ray| {
                let (i, j) = ((ray.k as usize / w) as f64, (ray.k as usize % w) as f64);
                let (_, d) = cam.ray(i + self.off.0, j + self.off.1);
                let hl = (d.x * d.x + d.y * d.y).sqrt();
                let th = ray.theta;
                let az = DVec2::new(d.x, d.y) / hl.max(1e-300);
                let row = |s: f64| cam.to_screen(cam.eye + direction(az, s)).y;
                let rate = ((row(th + delta) - row(th - delta)) / (2.0 * delta)).abs();
                let half = if rate.is_finite() && rate > 0.0 && hl > 1e-12 {
                    0.5 * ppr / rate
                } else {
                    0.5
                };
                (th * ppr - half, th * ppr + half)
            })
            .collect();
        let ppr = self.ppr;
        self.half = self
            .rays
            .iter()
            .zip(&self.ext)
            .map(|(r, &(lo, hi))| (r.theta * ppr - lo).max(hi - r.theta * ppr))
            .fold(0.0, f64::max);
        self.edge = vec![None; self.rays.len()];
        self.fine = Some(Default::default());
    }

    /// Each ray's covered fraction of its extent; the rays not set whose
    /// extent a span reached into join the output, unset, with that span's
    /// shading.
    fn finish_coverage(&mut self) {
        let Some(fine) = self.fine.take() else {
            return;
        };
        let cov_of = |k: usize| {
            let (lo, hi) = self.ext[k];
            if hi > lo {
                (fine.overlap(lo, hi) / (hi - lo)).min(1.0)
            } else if fine.contains(lo) {
                1.0
            } else {
                0.0
            }
        };
        // `out` holds the set rays in the order they were revealed; each
        // one's place there, by its index in the bin.
        let mut index: Vec<(u32, usize)> = self
            .rays
            .iter()
            .enumerate()
            .map(|(k, r)| (r.k, k))
            .collect();
        index.sort_unstable();
        let mut slot = vec![usize::MAX; self.rays.len()];
        for (n, (k, _)) in self.out.iter().enumerate() {
            let at = index.partition_point(|&(kk, _)| kk < *k as u32);
            slot[index[at].1] = n;
        }
        for (n, &s) in slot.iter().enumerate() {
            let f = cov_of(n);
            if s != usize::MAX {
                self.out[s].1.cover = f;
            } else if let Some(mut p) = self.edge[n] {
                if f > 0.0 {
                    p.cover = f;
                    if p.inten.is_nan() {
                        let dir = self.ray_dir(n);
                        p.inten = self.ctx.shading.intensity(p.n, -dir);
                    }
                    self.out.push((self.rays[n].k as usize, p));
                }
            }
        }
    }

    /// §6.4 sub-pixel coverage of the span from a to b (elevations lo..hi),
    /// as [`super::column`] does for rows: the span extended to the
    /// extremum of the cubic through the two samples (at most half a pixel
    /// beyond them) joins the fine coverage; rays whose extent it reaches
    /// into without covering their centre keep, from the first (nearest)
    /// such span, its shading there.
    fn edges(&mut self, a: &Sample, b: &Sample, wall: bool, lo: f64, hi: f64) {
        let fine = self.fine.as_ref().expect("coverage mode");
        if fine.covers(lo - 0.5, hi + 0.5) {
            // Behind the front (the common case): nothing reaches out.
            return;
        }
        let (mut elo, mut ehi) = (lo, hi);
        if !wall {
            let dt = b.t - a.t;
            let (hl, hh) =
                super::column::hermite_range(a.rho, b.rho, a.drho_dt * dt, b.drho_dt * dt);
            elo = hl.max(lo - 0.5);
            ehi = hh.min(hi + 0.5);
        }
        let fine = self.fine.as_mut().expect("coverage mode");
        if fine.covers(elo, ehi) {
            return;
        }
        fine.add(elo, ehi);
        let ppr = self.ppr;
        let m = self.half;
        let k0 = self.rays.partition_point(|r| r.theta * ppr < elo - m);
        let topo: i8 = if b.rho > a.rho { 1 } else { -1 };
        for k in k0..self.rays.len() {
            let th = self.rays[k].theta * ppr;
            if th > ehi + m {
                break;
            }
            let (xl, xh) = self.ext[k];
            if xh < elo || xl > ehi {
                continue;
            }
            // Skip rays set or reached before, and those this span sets
            // itself.
            if self.done[k]
                || self.edge[k].is_some()
                || (th >= lo && th <= hi && !self.cov.contains(th))
            {
                continue;
            }
            self.edge[k] = Some(self.edge_pixel(a, b, th, topo, wall));
        }
    }

    /// Direction of ray `k` of this sweep (its pixel centre shifted by the
    /// pass's sub-pixel offset).
    #[inline]
    fn ray_dir(&self, k: usize) -> DVec3 {
        self.rays[k].dir
    }

    /// The shading of the span from a to b at its end nearest to elevation
    /// `th`, for a ray whose centre it does not cover (no exact solve).
    fn edge_pixel(&self, a: &Sample, b: &Sample, th: f64, topo: i8, wall: bool) -> Pixel {
        let ctx = self.ctx;
        let tau = super::column::chord_tau(a, b, th);
        super::column::edge_shading(ctx, a, b, tau, topo, wall, self.eh)
    }

    fn hidden(&self, a: &Sample, b: &Sample) -> bool {
        let Some((lo, hi)) = self.cov.interval(a.rho) else {
            return false;
        };
        let (lo, hi) = (lo + 1.0, hi - 1.0);
        if !(a.rho >= lo && a.rho <= hi && b.rho >= lo && b.rho <= hi) {
            return false;
        }
        let dt = b.t - a.t;
        super::column::hermite_inside(a.rho, b.rho, a.drho_dt * dt, b.drho_dt * dt, lo, hi)
    }

    /// The surface sample at horizontal distance ρ (None: hole).
    fn sample(&mut self, rho: f64) -> Option<Sample> {
        let ctx = self.ctx;
        let e = ctx.cam.eye;
        let uv = DVec2::new(e.x, e.y) + rho * self.eh;
        let d = ctx.frame.domain;
        let uv = DVec2::new(uv.x.clamp(d.u0, d.u1), uv.y.clamp(d.v0, d.v1));
        self.stats.sweep_evals += 1;
        let hs = ctx.field.eval(uv.x, uv.y);
        if !hs.is_finite() {
            return None;
        }
        Some(self.finish(rho, uv, hs))
    }

    #[inline(always)]
    fn finish(&self, rho: f64, uv: DVec2, hs: HeightSample) -> Sample {
        let ctx = self.ctx;
        let e = ctx.cam.eye;
        let wr = hs.f - e.z;
        let theta = elevation(wr, rho);
        let f_rho = hs.fu * self.eh.x + hs.fv * self.eh.y;
        // dθ/dρ = (ρ f_ρ − w') / (ρ² + w'²), and ds/dθ = (1 + s²)/2 for
        // the pseudo-elevation s = tan(θ/2).
        let dth =
            0.5 * (1.0 + theta * theta) * (rho * f_rho - wr) / (rho * rho + wr * wr).max(1e-300);
        let p = DVec3::new(uv.x, uv.y, hs.f);
        let n = hs.normal();
        let shade =
            ctx.opts.shading == ShadingMode::Intensity || ctx.opts.corrections.any_detection();
        let (ldotn, inten, lxn) = if shade {
            let to_eye = (e - p).normalize_or(-ctx.cam.d);
            (
                to_eye.dot(n),
                ctx.shading.intensity(n, to_eye),
                to_eye.cross(n),
            )
        } else {
            (0.0, 0.0, DVec3::ZERO)
        };
        Sample {
            t: rho,
            wr,
            uv,
            n,
            rho: self.ppr * theta,
            z: (p - e).dot(ctx.cam.d),
            drho_dt: self.ppr * dth,
            dw_dt: f_rho,
            inten,
            ldotn,
            lxn,
            fold: false,
        }
    }

    /// Start the bin's sweep (its rays set by [`Self::reset`]): true when
    /// it asks for its first sample, at ρ = `self.ahead.ts`; false when
    /// there is nothing to sweep.
    fn begin(&mut self, st: &mut RunState) -> bool {
        let ctx = self.ctx;
        let e = ctx.cam.eye;
        if self.rays.is_empty() && !self.record {
            return false;
        }
        let ppr = self.ppr;
        self.rows.clear();
        self.rows.extend(self.rays.iter().map(|r| r.theta * ppr));
        (st.th_lo, st.th_hi) = (self.srange.0 * ppr, self.srange.1 * ppr);
        // Domain clip of the half-line E_h + ρ·e_h, ρ ≥ 0.
        let d = ctx.frame.domain;
        let (mut r0, mut r1) = (0.0f64, f64::INFINITY);
        for (oc, dc, a, b) in [(e.x, self.eh.x, d.u0, d.u1), (e.y, self.eh.y, d.v0, d.v1)] {
            if dc.abs() < 1e-15 {
                if oc < a || oc > b {
                    return false;
                }
            } else {
                let (p, q) = ((a - oc) / dc, (b - oc) / dc);
                r0 = r0.max(p.min(q));
                r1 = r1.min(p.max(q));
            }
        }
        if r0 >= r1 || r0.is_nan() || r1.is_nan() {
            return false;
        }
        st.scale = (d.u1 - d.u0).abs().max((d.v1 - d.v0).abs());
        let r0 = r0.max(1e-9 * st.scale);
        // The height bound's highest elevation beyond ρ: atan2(w_max − E_w,
        // ρ) falls with ρ when w_max ≥ E_w (taken at each position) and
        // rises towards the far end r1 otherwise (one value).
        (st.top, st.zb) = (f64::INFINITY, f64::NAN);
        self.seg.clear();
        if ctx.opts.height_bound && self.fine.is_none() {
            // The highest elevation over the whole sweep, by the local
            // bounds and by the global one (at its start or at its end).
            let mut highest = f64::INFINITY;
            self.local_bounds(r0, r1);
            if let Some(&first) = self.seg.first() {
                highest = first;
            }
            if let Some((_, wmax)) = ctx.field.height_bound() {
                let wr = wmax - e.z;
                highest = highest.min(if wr >= 0.0 {
                    st.zb = wr;
                    bound_margin(ppr * elevation(wr, r0))
                } else {
                    st.top = bound_margin(ppr * elevation(wr, r1));
                    st.top
                });
            }
            if highest < st.th_lo {
                // Every point of the plane lies below the bin's rays.
                self.stats.early_exit += 1;
                return false;
            }
        }
        st.slots = [None, None];
        st.p = 0;
        st.rho = r0;
        st.r1 = r1;
        st.steps = 0;
        st.bend = f64::INFINITY;
        st.first = true;
        st.skips = ctx.opts.skip_outside;
        st.no_skip_until = f64::NEG_INFINITY;
        self.ahead.ts.clear();
        self.ahead.ts.push(r0);
        true
    }

    /// Take the samples asked for (at `self.ahead.ts`) and sweep on (see
    /// [`Self::drive`]).
    fn deliver(&mut self, st: &mut RunState, batch: &mut Vec<Option<Raw>>) -> bool {
        if st.first {
            st.first = false;
            st.slots[0] = batch[0].map(|x| self.finish(x.t, x.uv, x.h));
            if let Some(a) = &st.slots[0] {
                self.point(a.rho);
                st.rate = self.rate.at(a.rho);
            }
            return self.drive(st, None);
        }
        let (t, r) = self.ahead.fill(batch);
        st.slots[1 - st.p] = r.map(|x| self.finish(x.t, x.uv, x.h));
        self.drive(st, Some(t))
    }

    /// The next step of the sweep from ρ = `st.rho` (false: the sweep is
    /// over): its step bounds from the previous sample.
    #[inline(always)]
    fn step_start(&mut self, st: &mut RunState) -> bool {
        let ctx = self.ctx;
        let opts = ctx.opts;
        if !(st.rho < st.r1 && st.steps < 4_000_000) {
            return false;
        }
        st.steps += 1;
        let scale = st.scale;
        st.skipping = false;
        let (h_max0, hstep) = match &st.slots[st.p] {
            Some(a) => {
                let outside = !(a.rho >= st.th_lo - SKIP_MARGIN && a.rho <= st.th_hi + SKIP_MARGIN);
                // (beyond the rays' elevations, at most a footprint of the
                // rays there: a sample's own distance grows without bound
                // beside a pole, and steps by it would overshoot the pole
                // again and again)
                let fp = if outside {
                    self.fp_at(a).min(self.band_fp(st))
                } else {
                    self.fp_at(a)
                };
                let cap = opts.max_step() * max_num(fp, 1e-12 * scale);
                // (the elevation rate in local pixels)
                let r = a.drho_dt.abs() * st.rate;
                let step = self.step();
                let deep = self.cov.depth(a.rho) > 2.0 * step;
                if outside && self.try_skip(st, cap) {
                    (st.hstep, st.hstep)
                } else if outside {
                    // Beyond the rays' elevations the elevation rate sets
                    // no step (the gaps there are clamped, see
                    // [`Self::drive`]): near a pole, where that rate grows
                    // without bound, steps by it would approach the pole
                    // without end (as in the orthographic sweep).
                    (cap, cap)
                } else if !deep && positive_finite(r) {
                    let mut hm = step / r;
                    if ctx.refine {
                        hm = min_num(hm, st.bend);
                    }
                    (min_num(hm, cap), min_num(super::column::AIM * hm, cap))
                } else {
                    (cap, cap)
                }
            }
            None => {
                // (a hole or the domain's edge: no sample to step from)
                let cap = opts.max_step() * (st.rho.max(1e-9 * scale)) / ctx.cam.focal;
                if self.try_skip(st, cap) {
                    (st.hstep, st.hstep)
                } else {
                    (cap, cap)
                }
            }
        };
        st.h_max = h_max0;
        st.hstep = hstep;
        st.halvings = 0;
        true
    }

    /// Step over the stretch ahead of ρ = `st.rho` that shows nothing
    /// ([`super::column::invisible_run`] with [`Self::invisible`]), when the
    /// sweep may: true (and `st.skipping`, the step's length in
    /// `st.hstep`) if it is longer than `cap`; after a try that fails, none
    /// before ρ + [`SKIP_MIN`]·`cap`.
    fn try_skip(&self, st: &mut RunState, cap: f64) -> bool {
        if !st.skips || st.rho < st.no_skip_until {
            return false;
        }
        let skip = super::column::invisible_run(SKIP_MIN * cap, st.r1 - st.rho, |l| {
            self.invisible(st, st.rho, st.rho + l)
        });
        st.skipping = skip > cap;
        if st.skipping {
            st.hstep = skip;
        } else {
            st.no_skip_until = st.rho + SKIP_MIN * cap;
        }
        st.skipping
    }

    /// Is the plane's curve over ρ ∈ [ra, rb] wholly below or wholly above
    /// the bin's rays ([`SKIP_MARGIN`] units of `rho` out)? By the
    /// surface's bounds over the stretch's (u, v) box (its ends clamped to
    /// the domain, as the samples are): the elevation of height w' at
    /// distance ρ rises with w' and falls with ρ above the eye (rises
    /// below it), so its extremes lie at the box's corners.
    fn invisible(&self, st: &RunState, ra: f64, rb: f64) -> bool {
        let ctx = self.ctx;
        let e = ctx.cam.eye;
        let d = ctx.frame.domain;
        let at = |r: f64| {
            let p = DVec2::new(e.x, e.y) + r * self.eh;
            DVec2::new(p.x.clamp(d.u0, d.u1), p.y.clamp(d.v0, d.v1))
        };
        let Some((lo, hi)) = super::column::stretch_bound(ctx.field, at(ra), at(rb)) else {
            return false;
        };
        if lo > hi {
            // No finite value there: nothing to see.
            return true;
        }
        let (wl, wh) = (lo - e.z, hi - e.z);
        let top = bound_margin(self.ppr * elevation(wh, ra).max(elevation(wh, rb)));
        let bottom = -bound_margin(-self.ppr * elevation(wl, ra).min(elevation(wl, rb)));
        top < st.th_lo - SKIP_MARGIN || bottom > st.th_hi + SKIP_MARGIN
    }

    /// The highest elevation (units of `rho`) that a span after the
    /// sweep's position `st.rho` can reach: the height bound's (see
    /// [`RunState::top`]), or the current sample's if higher; +∞ without a
    /// bound.
    #[inline]
    fn bound_top(&self, st: &RunState) -> f64 {
        let mut top = st.top;
        if !st.zb.is_nan() {
            top = bound_margin(self.ppr * elevation(st.zb, st.rho));
        }
        if !self.seg.is_empty() {
            let x = (st.rho - self.seg_r0) * self.seg_inv;
            let k = if x > 0.0 { x as usize } else { 0 };
            top = top.min(self.seg[k.min(self.seg.len() - 1)]);
        }
        match &st.slots[st.p] {
            Some(a) if a.rho > top => a.rho,
            _ => top,
        }
    }

    /// [`Self::seg`] for the sweep over ρ ∈ [r0, r1], where the source keeps
    /// local height bounds (else left empty): each stretch's highest point
    /// lies in the bounding box of its ends' (u, v) (clamped to the domain,
    /// as the samples are), and its highest elevation at its near end when
    /// that point is at or above the eye, else at its far end.
    fn local_bounds(&mut self, r0: f64, r1: f64) {
        let ctx = self.ctx;
        let e = ctx.cam.eye;
        let d = ctx.frame.domain;
        let eh = self.eh;
        let at = |r: f64| {
            let p = DVec2::new(e.x, e.y) + r * eh;
            DVec2::new(p.x.clamp(d.u0, d.u1), p.y.clamp(d.v0, d.v1))
        };
        let len = (r1 - r0) / SEGMENTS as f64;
        let pad = 1e-9 * (d.u1 - d.u0).abs().max((d.v1 - d.v0).abs());
        let mut seg = std::mem::take(&mut self.seg);
        seg.clear();
        for k in 0..SEGMENTS {
            let a = r0 + k as f64 * len;
            let b = if k + 1 == SEGMENTS { r1 } else { a + len };
            let (pa, pb) = (at(a), at(b));
            let Some(zm) = ctx.field.height_max_in(
                pa.x.min(pb.x) - pad,
                pa.x.max(pb.x) + pad,
                pa.y.min(pb.y) - pad,
                pa.y.max(pb.y) + pad,
            ) else {
                seg.clear();
                self.seg = seg;
                return;
            };
            let wr = zm - e.z;
            seg.push(if zm == f64::NEG_INFINITY {
                f64::NEG_INFINITY
            } else {
                bound_margin(self.ppr * elevation(wr, if wr >= 0.0 { a } else { b }))
            });
        }
        for k in (0..SEGMENTS - 1).rev() {
            seg[k] = seg[k].max(seg[k + 1]);
        }
        self.seg = seg;
        self.seg_r0 = r0;
        self.seg_inv = 1.0 / len;
    }

    /// The footprint of the bin's rays at horizontal distance `st.rho`:
    /// that distance over the cosine of their steepest elevation, over the
    /// focal length.
    fn band_fp(&self, st: &RunState) -> f64 {
        let s = (st.th_lo.abs().max(st.th_hi.abs()) / self.ppr).min(1.0);
        // (s = tan(θ/2): 1/cos θ = (1 + s²)/(1 − s²))
        let sec = (1.0 + s * s) / (1.0 - s * s).max(1e-12);
        st.rho * sec / self.ctx.cam.focal
    }

    /// World size of a pixel at sample `s`.
    #[inline]
    fn fp_at(&self, s: &Sample) -> f64 {
        let e = self.ctx.cam.eye;
        ((s.uv.x - e.x).powi(2) + (s.uv.y - e.y).powi(2) + s.wr * s.wr).sqrt() / self.ctx.cam.focal
    }

    /// The §4.2 sweep of the bin, front to back, from where it stands:
    /// `got` is the sweep parameter of the candidate just delivered into
    /// `st.slots` (None: at the start of a step). Goes on while the
    /// samples evaluated ahead last; returns true when it needs a new
    /// batch (its parameters planned into `self.ahead.ts`), false when the
    /// sweep is over.
    fn drive(&mut self, st: &mut RunState, mut got: Option<f64>) -> bool {
        if got.is_none() && !self.step_start(st) {
            return false;
        }
        loop {
            // The candidate after ρ: at ρ + h, or at any ρ' in [ρ + h/2,
            // ρ + h_max] already evaluated ahead (see [`Ahead`]).
            let rn = match got.take() {
                Some(t) => t,
                None => {
                    let (lo, hi) = (st.rho + 0.5 * st.hstep, (st.rho + st.h_max).min(st.r1));
                    match self.ahead.take(lo, hi) {
                        Some((t, r)) => {
                            // Written in place: a sample is large.
                            st.slots[1 - st.p] = r.map(|x| self.finish(x.t, x.uv, x.h));
                            t
                        }
                        None => {
                            let mut rhos = std::mem::take(&mut self.ahead.ts);
                            rhos.clear();
                            rhos.extend_from_slice(self.ahead.plan(st.rho, st.hstep, st.r1, 0.0));
                            self.ahead.ts = rhos;
                            return true;
                        }
                    }
                }
            };
            let rho = st.rho;
            let (prev, cand) = (&st.slots[st.p], &st.slots[1 - st.p]);
            // By reference: a sample is large, and most steps move none.
            match (prev, cand) {
                (Some(a), Some(b)) => {
                    // The gap in local pixels (the larger rate of its ends).
                    let rb = self.rate.at(b.rho);
                    // (elevations clamped to 2 units beyond the rays': a
                    // stretch wholly above or below them shows no gap)
                    let clamp = |r: f64| min_num(max_num(r, st.th_lo - 2.0), st.th_hi + 2.0);
                    let gap = (clamp(b.rho) - clamp(a.rho)).abs() * max_num(st.rate, rb);
                    let step = self.step();
                    let hidden = gap > step && (st.skipping || self.hidden(a, b));
                    let ulps = super::column::retry_floor(rho);
                    if gap > step
                        && !hidden
                        && st.halvings < 40
                        && (rn - rho) > (1e-9 * self.fp_at(a)).max(2.0 * ulps)
                    {
                        st.hstep = ((rn - rho) * (0.9 * step / gap).clamp(0.05, 0.5)).max(ulps);
                        st.h_max = st.hstep;
                        st.halvings += 1;
                        continue;
                    }
                    let wall = gap > step && !hidden;
                    if wall {
                        self.stats.walls += 1;
                    }
                    let rate = max_num(st.rate, rb);
                    let from = if wall { None } else { self.correct(a, b) };
                    let from = match from {
                        None if !wall && self.crests() && !super::column::rows_monotone(a, b) => {
                            self.crest(a, b, rate, clamp)
                        }
                        f => f,
                    };
                    match from {
                        Some(from) => self.span(&from, b, wall),
                        None => self.span(a, b, wall),
                    }
                    // (in local pixels)
                    st.bend = super::column::bend_limit(a, b, rate, super::column::BEND_RADIAL);
                    // (b is the next step's previous sample)
                    st.rate = rb;
                }
                (None, Some(b)) => {
                    self.point(b.rho);
                    st.rate = self.rate.at(b.rho);
                }
                (_, None) => {}
            }
            st.p = 1 - st.p;
            st.rho = rn;
            // Early exit (§4.2): every ray of the bin is covered (with
            // coverage, every ray's whole extent).
            let fine_done = match &self.fine {
                Some(f) => f.covers(st.th_lo - self.half, st.th_hi + self.half),
                None => true,
            };
            if self.cov.covers(st.th_lo, st.th_hi) && fine_done {
                self.stats.early_exit += 1;
                return false;
            }
            // Or nothing beyond can rise into an uncovered elevation of the
            // rays: every later span lies below the larger of the bound
            // and the current sample (its first end).
            let top = self.bound_top(st);
            if top < st.th_hi && self.cov.covers(st.th_lo, top) {
                self.stats.early_exit += 1;
                return false;
            }
            if !self.step_start(st) {
                return false;
            }
        }
    }

    /// The batched exact solve of the bin's pixels (Newton on the pixel's
    /// ray, [`super::refine::newton`], all from the eye), with a march
    /// along the ray for those Newton could not settle (the pixel's ray is
    /// up to half a bin off the bin's plane, so its seed can be poor at
    /// grazing).
    ///
    /// With `direct` (the render's buffers and marks), an exact hit is
    /// written there at once, its entry in `out` left unset (the others are
    /// written by [`bin_result`]).
    #[inline(never)]
    fn solve(&mut self, direct: Option<(&SharedOut<'_>, &Marks)>) {
        self.solve_walls(direct);
        if self.jobs.is_empty() {
            return;
        }
        let ctx = self.ctx;
        let (e, d) = (ctx.cam.eye, ctx.cam.d);
        let jobs = &self.jobs;
        let out = &mut self.out;
        // Hits on the side the span did not reveal: the ray may cross the
        // surface before (a grazing crest beside the bin's plane, which
        // Newton stepped over to the crest's far side).
        let mut ck = std::mem::take(&mut self.checks);
        ck.suspect.clear();
        ck.entry.clear();
        let under = ctx.field.height_bound().is_none_or(|(lo, _)| e.z > lo);
        let evals = super::refine::newton(
            ctx,
            jobs.len(),
            |k| jobs[k].lam,
            |k| (e, jobs[k].dir),
            |k| (jobs[k].lo, jobs[k].hi, jobs[k].fp),
            &mut self.solver,
            |k, lam, q, h| {
                let j = &jobs[k];
                let depth = (q - e).dot(d);
                let (pk, px) = &mut out[j.slot as usize];
                let uv = DVec2::new(q.x, q.y);
                match direct {
                    // SAFETY: as in [`bin_result`]: pixel pk is this bin's.
                    Some((to, marks)) => unsafe {
                        put_direct(ctx, to, marks, *pk, px, j.dir, depth, uv, h)
                    },
                    None => super::refine::finish(ctx, px, j.dir, depth, uv, h),
                }
                if px.side != j.side {
                    ck.suspect.push((k as u32, lam));
                } else if px.side < 0 && under {
                    ck.entry.push((k as u32, lam));
                }
            },
        );
        self.stats.refine_evals += evals;
        // An under-side hit whose ray enters the domain above the surface
        // has crossed it on the way (seen through the domain's edge, the
        // under side is entered from below): the entry points evaluated in
        // one batch, the ray marched from there where it is above.
        if !ck.entry.is_empty() {
            let dom = ctx.frame.domain;
            ck.starts.clear();
            ck.u.clear();
            ck.v.clear();
            for &(k, lam) in &ck.entry {
                let j = &self.jobs[k as usize];
                let range = super::sampling::domain_range(
                    &dom,
                    DVec2::new(e.x, e.y),
                    DVec2::new(j.dir.x, j.dir.y),
                );
                let Some((l_in, _)) = range else { continue };
                let l_in = l_in.max(0.0) + 1e-6 * j.fp;
                let p = e + l_in * j.dir;
                if l_in < lam - j.fp && dom.contains(p.x, p.y) {
                    ck.starts.push((k, lam, l_in, p.z));
                    ck.u.push(p.x);
                    ck.v.push(p.y);
                }
            }
            ck.below_bound(ctx.field);
            // (grown only: a height field's batch writes every element)
            if ck.hs.len() < ck.u.len() {
                ck.hs.resize(ck.u.len(), HeightSample::default());
            }
            let hs = &mut ck.hs[..ck.u.len()];
            if !hs.is_empty() {
                ctx.field.eval_batch(&ck.u, &ck.v, hs);
                self.stats.refine_evals += hs.len() as u64;
            }
            for (&(k, lam, l_in, z), h) in ck.starts.iter().zip(hs.iter()) {
                if h.is_finite() && z > h.f {
                    let j = self.jobs[k as usize];
                    if let Some((l, hs)) = self.march(e, j.dir, l_in, lam - 1e-3 * j.fp, j.fp, 1) {
                        self.put_hit(&j, l, &hs, direct);
                    }
                }
            }
        }
        for &(k, lam) in &ck.suspect {
            let j = self.jobs[k as usize];
            // The first crossing from the seen side before the hit, if any
            // (up to just before it: a crest's sliver can be thinner than
            // the march's step).
            if let Some((l, hs)) =
                self.march(e, j.dir, j.lo - 8.0 * j.fp, lam - 1e-3 * j.fp, j.fp, j.side)
            {
                self.put_hit(&j, l, &hs, direct);
            }
        }
        self.checks = ck;
        let mut failed = std::mem::take(&mut self.failed);
        failed.clear();
        failed.extend_from_slice(self.solver.failed());
        failed.sort_unstable();
        for &k in &failed {
            let j = self.jobs[k as usize];
            match self.march(e, j.dir, j.lo - 8.0 * j.fp, j.hi + 8.0 * j.fp, j.fp, j.side) {
                Some((lam, hs)) => self.put_hit(&j, lam, &hs, direct),
                None => {
                    // No hit near the span that revealed the pixel: its ray
                    // passes by the sheet the bin's plane met (up to half a
                    // pixel beside it). Dropped, to be solved behind (see
                    // [`behind_missed`]); with coverage it stays listed,
                    // unset, for its covered fraction.
                    self.stats.refine_fail += 1;
                    let (k, p) = &mut self.out[j.slot as usize];
                    if ctx.opts.coverage && ctx.opts.shading == ShadingMode::Normal {
                        p.inten = ctx.shading.intensity(p.n, -j.dir);
                    }
                    p.set = false;
                    self.missed.push((*k as u32, j.hi + 8.0 * j.fp));
                }
            }
        }
        self.failed = failed;
        if !ctx.opts.coverage && !self.missed.is_empty() {
            self.out.retain(|(_, p)| p.set);
        }
    }

    /// The wall pixels (§5.1): the pixel's own ray marched from before the
    /// nearer of the wall's two samples to beyond the farther (each at its
    /// horizontal distance along the ray, widened by eight footprints: the
    /// ray lies up to a bin's half width beside the plane, where the wall
    /// may stand nearer or farther). A crossing where the surface meets the
    /// ray (a steep sheet, as beside a pole of tan u) is an exact hit; one
    /// where it jumps past it (a step) places the pixel on the wall there,
    /// its wall shading kept; with none, the pixel stays where the ray
    /// passes the wall's place in the plane.
    fn solve_walls(&mut self, direct: Option<(&SharedOut<'_>, &Marks)>) {
        if self.walls.is_empty() {
            return;
        }
        let e = self.ctx.cam.eye;
        let d = self.ctx.cam.d;
        let walls = std::mem::take(&mut self.walls);
        for j in &walls {
            // (from either side: which side of a jump the ray meets first
            // is not the span's: beside a pole the far sample lies far
            // below the near one, yet the ray meets the rising sheet from
            // above)
            let hit = self.march(e, j.dir, j.lo - 8.0 * j.fp, j.hi + 8.0 * j.fp, j.fp, 0);
            let Some((l, hs)) = hit else { continue };
            let q = e + l * j.dir;
            if (q.z - hs.f).abs() <= j.fp {
                self.put_hit(j, l, &hs, direct);
            } else {
                let px = &mut self.out[j.slot as usize].1;
                px.depth = (q - e).dot(d);
                px.uv = DVec2::new(q.x, q.y);
            }
        }
        self.walls = walls;
    }

    /// The exact hit at distance `l` along job `j`'s ray into its pixel
    /// (with `direct`, see [`Self::solve`]).
    fn put_hit(
        &mut self,
        j: &BinJob,
        l: f64,
        hs: &HeightSample,
        direct: Option<(&SharedOut<'_>, &Marks)>,
    ) {
        let ctx = self.ctx;
        let e = ctx.cam.eye;
        let q = e + l * j.dir;
        let (pk, px) = &mut self.out[j.slot as usize];
        let (depth, uv) = ((q - e).dot(ctx.cam.d), DVec2::new(q.x, q.y));
        match direct {
            // SAFETY: as in [`bin_result`]: pixel pk is this bin's.
            Some((to, marks)) => unsafe {
                put_direct(ctx, to, marks, *pk, px, j.dir, depth, uv, hs)
            },
            None => super::refine::finish(ctx, px, j.dir, depth, uv, hs),
        }
    }

    /// The sample step in local pixels ([`FloatingOptions::sweep_step`]).
    #[inline]
    fn step(&self) -> f64 {
        self.ctx.opts.sweep_step(self.ctx.refine, true)
    }

    /// Crests between samples get a sample at their top (exactly solved
    /// pixels, no §5 detection: see [`Self::crest`]).
    #[inline]
    fn crests(&self) -> bool {
        self.ctx.refine && !self.ctx.opts.corrections.any_detection()
    }

    /// A crest between samples a and b (as the orthographic column's,
    /// `column::Sweep::crest`): where the cubic through their elevations
    /// and slopes reaches beyond both by a quarter of a local pixel or
    /// more (`rate` local pixels per unit of elevation; elevations by
    /// `clamp` to near the bin's rays), into elevations not yet covered,
    /// one more sample at the cubic's extremum and the span from a to it
    /// drawn; returns it (the span to b starts there).
    #[inline(never)]
    fn crest(
        &mut self,
        a: &Sample,
        b: &Sample,
        rate: f64,
        clamp: impl Fn(f64) -> f64,
    ) -> Option<Sample> {
        let (x, elo, ehi) = super::column::crest_beyond(a, b, clamp)?;
        let over = (ehi - elo) * rate;
        if over.is_nan() || over < 0.25 || self.cov.covers(elo, ehi) {
            return None;
        }
        let m = self.sample(a.t + x * (b.t - a.t))?;
        self.span(a, &m, false);
        Some(m)
    }

    /// §5 corrections between samples a and b: the spans up to the last
    /// inserted sample, which the span to b then starts from (None: no
    /// problem detected, the span starts from a).
    fn correct(&mut self, a: &Sample, b: &Sample) -> Option<Sample> {
        let c = self.ctx.opts.corrections;
        if !c.any_detection() {
            return None;
        }
        let m = DVec3::new(-self.eh.y, self.eh.x, 0.0);
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
            if let Some(mid) = self.sample(t) {
                self.span(&prev, &mid, false);
                prev = mid;
            }
        }
        Some(prev)
    }

    fn span(&mut self, a: &Sample, b: &Sample, wall: bool) {
        let (lo, hi) = if a.rho <= b.rho {
            (a.rho, b.rho)
        } else {
            (b.rho, a.rho)
        };
        if self.fine.is_some() {
            self.edges(a, b, wall, lo, hi);
        }
        if self.cov.covers(lo, hi) {
            // Nothing newly revealed (the common case behind the front).
            return;
        }
        if self.record {
            let (ia, ib) = (self.logged(a), self.logged(b));
            self.events.push(Event::Span(ia, ib, wall));
        } else {
            self.reveal(a, b, wall, lo, hi, false);
        }
        self.cov.add(lo, hi);
    }

    /// The rays of span a–b (elevations lo..hi) not revealed before: not
    /// done and not covered (by the coverage, or with `replay` by a single
    /// point of [`Self::replay`]).
    #[inline(always)]
    fn reveal(&mut self, a: &Sample, b: &Sample, wall: bool, lo: f64, hi: f64, replay: bool) {
        // Rays of the bin with θ in [lo, hi] (sorted by θ).
        // The first ray with θ ≥ lo, walked to from the previous span's
        // (consecutive spans share an end).
        let rows = &self.rows;
        let mut k = self.cursor.min(rows.len());
        while k > 0 && rows[k - 1] >= lo {
            k -= 1;
        }
        while k < rows.len() && rows[k] < lo {
            k += 1;
        }
        self.cursor = k;
        // Set up on the span's first revealed ray (many spans reveal none).
        let mut sp = None;
        while k < self.rows.len() && self.rows[k] <= hi {
            let th = self.rows[k];
            // (a plain loop over the points, most often none: the slice
            // search's set-up cost more)
            #[allow(clippy::manual_contains)]
            let covered = if replay {
                self.points.iter().any(|&x| x == th)
            } else {
                self.cov.contains(th)
            };
            if !self.done[k] && !covered {
                self.done[k] = true;
                let ray = self.rays[k];
                let dir = self.ray_dir(k);
                // (set up in line: a closure here was left out of line)
                if sp.is_none() {
                    sp = Some(SpanConst::new(self.ctx, a, b, wall));
                }
                let Some(sp) = &sp else { unreachable!() };
                let px = self.pixel(a, b, sp, dir, th, wall);
                self.out.push((ray.k as usize, px));
            }
            k += 1;
        }
    }

    #[inline(always)]
    fn pixel(
        &mut self,
        a: &Sample,
        b: &Sample,
        sp: &SpanConst,
        dir: DVec3,
        th: f64,
        wall: bool,
    ) -> Pixel {
        let ctx = self.ctx;
        let cam = ctx.cam;
        let e = cam.eye;
        let (pa, pb) = (sp.pa, sp.pb);
        // The point of the bin's plane at elevation θ: on the cubic through
        // the two samples (horizontal distance and height with their exact
        // slopes), or, where that cubic folds over (a silhouette between the
        // samples), on the chord with an exact solve to follow.
        let herm = match &sp.graph {
            Some(g) => {
                let (s, [r, w]) = g.at(th);
                Some((s, r, w))
            }
            None => sp.cubic.as_ref().and_then(|c| c.at(th)),
        };
        let (tau, p) = match herm {
            Some((tau, r, w)) => {
                let h = DVec2::new(e.x, e.y) + r * self.eh;
                (tau, DVec3::new(h.x, h.y, w + e.z))
            }
            None => {
                let tau = super::column::chord_tau(a, b, th);
                (tau, pa.lerp(pb, tau))
            }
        };
        // The pixel's ray is up to half a bin off the bin's plane: it
        // meets the surface where it meets the tangent plane at p (to second
        // order in that offset), unless it grazes that plane (|cos| ≤ 0.15).
        // The plane's normal m need not be unit for that: its
        // normalisation stays off the seed's dependency chain.
        let m = a.n.lerp(b.n, tau);
        let dn = dir.dot(m);
        // The seed: where the ray meets that plane, for a p on the cubic
        // (trusted); else p's projection on the ray.
        let tangent = herm.and_then(|_| {
            let l = (p - e).dot(m) / dn;
            (dn * dn > 0.15 * 0.15 * m.length_squared() && positive_finite(l)).then_some(l)
        });
        let trusted = tangent.is_some();
        let lam0 = tangent.unwrap_or_else(|| (p - e).dot(dir).max(0.0));
        let topo = sp.topo;
        let mut px = Pixel {
            set: true,
            side: topo,
            inten: a.inten + tau * (b.inten - a.inten),
            cover: 1.0,
            ..Pixel::default()
        };
        let queued = !wall && (ctx.refine || (ctx.fallback && !trusted));
        // A queued pixel takes its place and normal from its solve (one
        // whose solve fails is dropped, see [`Self::solve`]): interpolated
        // only where they may be kept (with coverage, or not queued).
        if !queued || ctx.opts.coverage {
            let q0 = e + lam0 * dir;
            px.depth = (q0 - e).dot(cam.d);
            px.n = m.normalize_or(a.n);
            px.uv = DVec2::new(q0.x, q0.y);
        }
        if queued {
            // Solved after the sweep, batched with the bin's other pixels.
            let fp = max_num(lam0, cam.near) / cam.focal;
            self.jobs.push(BinJob {
                dir,
                lam: lam0,
                lo: min_num(sp.near, lam0) - 4.0 * fp - sp.span,
                hi: max_num(sp.far, lam0) + 4.0 * fp + sp.span,
                fp,
                slot: self.out.len() as u32,
                side: topo,
            });
        }
        if wall {
            self.place_on_wall(&mut px, sp, dir, topo);
        }
        if wall && ctx.opts.corrections.walls {
            let hz = DVec3::new(self.eh.x, self.eh.y, 0.0);
            let wn = if b.wr > a.wr { -hz } else { hz };
            px.inten = ctx.shading.intensity(wn, -dir);
            return px;
        }
        // A queued pixel is shaded by its exact solve (or, should that
        // fail, from its interpolated normal afterwards).
        if ctx.opts.shading == ShadingMode::Normal && !queued {
            px.inten = ctx.shading.intensity(px.n, -dir);
        }
        px
    }

    /// A wall pixel `px` of span `sp` (ray `dir`) placed where its ray
    /// passes the wall's place in the plane, midway between the two
    /// samples' horizontal distances (not between their points: beside a
    /// pole of tan u, heights of ±10¹⁶, whose chord passes behind the eye),
    /// and queued for [`Self::solve_walls`]. Unchanged where the ray is
    /// (nearly) vertical: it runs along the wall and shows no face of it.
    fn place_on_wall(&mut self, px: &mut Pixel, sp: &SpanConst, dir: DVec3, topo: i8) {
        let cam = self.ctx.cam;
        let e = DVec2::new(cam.eye.x, cam.eye.y);
        let dh = DVec2::new(dir.x, dir.y).length();
        let ha = (DVec2::new(sp.pa.x, sp.pa.y) - e).length();
        let hb = (DVec2::new(sp.pb.x, sp.pb.y) - e).length();
        let (la, lb) = (ha / dh, hb / dh);
        if !(dh > 1e-9 && la.is_finite() && lb.is_finite()) {
            return;
        }
        let lam = 0.5 * (la + lb);
        let q = cam.eye + lam * dir;
        px.depth = (q - cam.eye).dot(cam.d);
        px.uv = DVec2::new(q.x, q.y);
        self.walls.push(BinJob {
            dir,
            lam,
            lo: la.min(lb),
            hi: la.max(lb),
            fp: lam.max(cam.near) / cam.focal,
            slot: self.out.len() as u32,
            side: topo,
        });
    }

    /// Fallback of the batched Newton ([`Self::solve`]): march the pixel's ray over [lo, hi]
    /// in half-footprint steps and solve the first crossing ([`Self::crossing`]).
    /// The march starts where the ray is on the seen side (`side`) of the
    /// surface, stepping back if needed; `side` 0: on whichever side the
    /// ray is where the march starts (the first crossing either way).
    fn march(
        &mut self,
        e: DVec3,
        dir: DVec3,
        lo: f64,
        hi: f64,
        fp: f64,
        side: i8,
    ) -> Option<(f64, HeightSample)> {
        let ctx = self.ctx;
        let dom = ctx.frame.domain;
        let h = |s: &mut Self, l: f64| -> Option<f64> {
            let p = e + l * dir;
            if !dom.contains(p.x, p.y) {
                return None;
            }
            s.stats.refine_evals += 1;
            let hs = ctx.field.eval(p.x, p.y);
            hs.is_finite().then_some(p.z - hs.f)
        };
        let mut outside = side as f64;
        // The part of the ray over the domain (a ray that grazes a corner
        // of it spends only a few footprints there).
        let (l_in, l_out) =
            super::sampling::domain_range(&dom, DVec2::new(e.x, e.y), DVec2::new(dir.x, dir.y))?;
        // Forward along a perspective ray only (an orthographic one is a
        // whole line, its origin on the eye's plane).
        let l_in = if ctx.cam.perspective {
            l_in.max(0.0)
        } else {
            l_in
        };
        // Just inside the edges (rounding).
        let pad = 1e-9 * fp;
        let (l_in, l_out) = (l_in + pad, l_out - pad);
        let hi = hi.min(l_out);
        let mut la = lo.max(l_in);
        if !matches!(
            la.partial_cmp(&hi),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        ) {
            return None;
        }
        let mut ga = h(self, la);
        for _ in 0..3 {
            match ga {
                Some(g) if outside == 0.0 && g != 0.0 => {
                    outside = g.signum();
                    break;
                }
                Some(g) if g * outside > 0.0 => break,
                _ => {
                    if la <= l_in {
                        break;
                    }
                    la = (la - 16.0 * fp).max(l_in);
                    ga = h(self, la);
                }
            }
        }
        let mut ga = ga.filter(|g| g * outside > 0.0)?;
        let step = 0.5 * fp;
        let mut n = 0;
        // The steps evaluated a few at a time, in one batch (the same values
        // as one by one); those past the first crossing are wasted.
        const AHEAD: usize = 8;
        let (mut ls, mut us, mut vs, mut zs) =
            ([0.0; AHEAD], [0.0; AHEAD], [0.0; AHEAD], [0.0; AHEAD]);
        let mut hs = [HeightSample::default(); AHEAD];
        let mut inside = [false; AHEAD];
        while la < hi && n < 10_000 {
            // The next steps from la: (the last step ends at hi: a crossing
            // just before the domain's edge is not stepped over)
            let mut m = 0;
            let mut l = la;
            while m < AHEAD && l < hi {
                l = (l + step).min(hi);
                ls[m] = l;
                m += 1;
            }
            let mut k = 0;
            for i in 0..m {
                let p = e + ls[i] * dir;
                (inside[i], zs[i]) = (dom.contains(p.x, p.y), p.z);
                if inside[i] {
                    (us[k], vs[k]) = (p.x, p.y);
                    k += 1;
                }
            }
            if k > 0 {
                ctx.field.eval_batch(&us[..k], &vs[..k], &mut hs[..k]);
                self.stats.refine_evals += k as u64;
            }
            let mut at = 0;
            for i in 0..m {
                n += 1;
                let lb = ls[i];
                // (the batch holds the steps inside the domain, in order)
                let gb = if inside[i] {
                    at += 1;
                    let h = &hs[at - 1];
                    h.is_finite().then_some(zs[i] - h.f)
                } else {
                    None
                };
                let Some(gb) = gb else {
                    la = lb;
                    continue;
                };
                if ga * gb <= 0.0 {
                    return self.crossing(e, dir, (la, ga), (lb, gb), fp, outside);
                }
                la = lb;
                ga = gb;
            }
        }
        None
    }

    /// The crossing of the ray `dir` with the surface between distances a
    /// (on the `outside` side: g·outside > 0 for g = w_ray − f) and b (not),
    /// to 10⁻⁶ footprints: Newton on g inside the bracket, bisection where a
    /// step would leave it; with the surface sample there.
    fn crossing(
        &mut self,
        e: DVec3,
        dir: DVec3,
        (mut a, ga): (f64, f64),
        (mut b, gb): (f64, f64),
        fp: f64,
        outside: f64,
    ) -> Option<(f64, HeightSample)> {
        let ctx = self.ctx;
        let eval = |s: &mut Self, l: f64| -> Option<(f64, f64)> {
            let p = e + l * dir;
            s.stats.refine_evals += 1;
            let hs = ctx.field.eval(p.x, p.y);
            hs.is_finite()
                .then_some((p.z - hs.f, dir.z - (hs.fu * dir.x + hs.fv * dir.y)))
        };
        // (the secant's point first: the bracket is half a footprint)
        let d = ga - gb;
        let mut x = if d != 0.0 && d.is_finite() {
            (a + (b - a) * ga / d).clamp(a, b)
        } else {
            0.5 * (a + b)
        };
        for _ in 0..60 {
            let (g, dg) = eval(self, x)?;
            if g * outside > 0.0 {
                a = x;
            } else {
                b = x;
            }
            let next = x - g / dg;
            if next > a && next < b {
                if (next - x).abs() < 1e-6 * fp {
                    x = next;
                    break;
                }
                x = next;
            } else {
                x = 0.5 * (a + b);
            }
            if b - a < 1e-6 * fp {
                x = 0.5 * (a + b);
                break;
            }
        }
        let p = e + x * dir;
        self.stats.refine_evals += 1;
        let hs = ctx.field.eval(p.x, p.y);
        hs.is_finite().then_some((x, hs))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Projection, View};

    /// A perspective camera of field of view 45° looking at the origin.
    fn persp45(el: f64, az: f64, dist: f64, w: usize, h: usize) -> crate::camera::Camera {
        let view = View {
            elevation: el,
            azimuth: az,
            projection: Projection::Perspective {
                distance: dist,
                fov: 45.0,
            },
            target: DVec3::ZERO,
        };
        crate::camera::Camera::new(&view, w, h).unwrap()
    }

    /// The sweep's local pixel rate ([`PxRate`]) never understates the
    /// screen's rate along a bin's plane by more than the 10 % margin of
    /// [`bin_ppr`], and stays at most 1 (`rho` measures pixels at the
    /// largest probed rate): every bin of views from above, level and
    /// nearly straight down, at elevations across its wedge and beyond.
    #[test]
    fn local_pixel_rate_bounds_the_screen_rate() {
        let mut checked = 0;
        for (el, az, dist, w, h) in [
            (30.0, 40.0, 24.0, 480, 477),
            (8.0, 200.0, 12.0, 70, 41),
            (75.0, 10.0, 14.0, 48, 52),
        ] {
            let cam = persp45(el, az, dist, w, h);
            let nb = 97;
            let bins = Bins::new(nb);
            let runs = Runs::new(&cam, &bins, (0.0, 0.0));
            for b in 0..nb {
                let phi = bins.centre(b);
                let Some((th0, th1)) = runs.wedge(phi) else {
                    continue;
                };
                let (ppr, rate) = bin_ppr(&cam, phi, th0, th1);
                let c = DVec2::new(phi.cos(), phi.sin());
                let at = |s: f64| cam.to_screen(cam.eye + direction(c, s));
                for k in -4..=44 {
                    let s = th0 + (th1 - th0) * k as f64 / 40.0;
                    let (p1, p2) = (at(s - 5e-7), at(s + 5e-7));
                    let true_rate = (p2.x - p1.x).hypot(p2.y - p1.y) / 1e-6 / ppr;
                    let r = rate.at(s * ppr);
                    assert!(
                        r > 0.0 && r <= 1.0 + 1e-12,
                        "view ({el}, {az}) bin {b}: {r}"
                    );
                    if (0..=40).contains(&k) && true_rate.is_finite() {
                        assert!(
                            true_rate <= r * (1.0 + 1e-6),
                            "view ({el}, {az}) bin {b} s {s}: {true_rate} > {r}"
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    /// With the exact solve, every pixel a perspective render sets lies on
    /// the surface where its own ray meets it: pixels whose ray passes by
    /// the sheet their bin's plane met are dropped or solved behind it (see
    /// [`behind_missed`]), none keeps interpolated values.
    #[test]
    fn set_pixels_lie_on_their_rays_hit() {
        let d = crate::surface::Domain::new(-5.0, 5.0, -5.0, 5.0).unwrap();
        let f = crate::source::ExprHeight::new("3*sin(u*cos(v))", &[], 0.0, d).unwrap();
        let sh = crate::shade::Shading::default();
        let opts = super::super::FloatingOptions::default();
        let mut checked = 0;
        let mut dropped = 0;
        for (el, az, dist, w, h) in [(30.0, 40.0, 24.0, 240, 238), (12.0, 200.0, 14.0, 200, 120)] {
            let cam = persp45(el, az, dist, w, h);
            let ctx = Ctx {
                cam: &cam,
                frame: super::super::sampling::Frame::new(&cam, d),
                field: &f,
                shading: &sh,
                opts: &opts,
                refine: true,
                fallback: true,
                searched: false,
            };
            let (lists, stats) = render_radial(&ctx, (0.0, 0.0), None, &Cancel::new()).unwrap();
            dropped += stats.refine_fail;
            for (k, p) in lists.into_iter().flatten() {
                assert!(p.set);
                let (_, dir) = cam.ray((k / w) as f64, (k % w) as f64);
                let q = cam.eye + (p.depth / dir.dot(cam.d)) * dir;
                let z = (3.0 * (q.x * q.y.cos()).sin()).clamp(-3.0, 3.0);
                assert!(
                    (q.z - z).abs() < 1e-6,
                    "view ({el}, {az}) pixel {k}: {} vs {z}",
                    q.z
                );
                checked += 1;
            }
        }
        assert!(checked > 20_000 && dropped > 0, "{checked} {dropped}");
    }

    /// A render whose bins are swept before their rays exist (rays only up
    /// to the covered elevations, spans replayed) holds exactly the pixels,
    /// bit for bit, of one whose bins have all their rays during the sweep:
    /// views from above, level, straight down (the vanishing point of the
    /// verticals in the image), sub-pixel offsets, exact solve on and off.
    #[test]
    fn two_pass_bins_equal_bins_with_all_rays() {
        let d = crate::surface::Domain::new(-5.0, 5.0, -5.0, 5.0).unwrap();
        let f = crate::source::ExprHeight::new("3*sin(u*cos(v))", &[], 0.0, d).unwrap();
        let sh = crate::shade::Shading::default();
        let mut compared = 0;
        for (el, az, dist, w, h) in [
            (30.0, 40.0, 24.0, 96, 80),
            (8.0, 200.0, 12.0, 70, 41),
            (89.5, 10.0, 14.0, 48, 52),
            (55.0, 310.0, 9.0, 61, 64),
        ] {
            let cam = persp45(el, az, dist, w, h);
            for refine in [true, false] {
                let opts = super::super::FloatingOptions {
                    refine,
                    ..Default::default()
                };
                let ctx = Ctx {
                    cam: &cam,
                    frame: super::super::sampling::Frame::new(&cam, d),
                    field: &f,
                    shading: &sh,
                    opts: &opts,
                    refine,
                    fallback: true,
                    searched: false,
                };
                for off in [(0.0, 0.0), (0.25, -0.375)] {
                    let pixels = |two_pass: bool| {
                        let (lists, _) =
                            render_radial_with(&ctx, off, None, &Cancel::new(), two_pass).unwrap();
                        let mut all: Vec<(usize, [u64; 9], i8, bool)> = lists
                            .into_iter()
                            .flatten()
                            .map(|(k, p)| {
                                let b = [
                                    p.depth, p.n.x, p.n.y, p.n.z, p.uv.x, p.uv.y, p.inten, p.cover,
                                    0.0,
                                ]
                                .map(f64::to_bits);
                                (k, b, p.side, p.set)
                            })
                            .collect();
                        all.sort_unstable();
                        all
                    };
                    let (a, b) = (pixels(true), pixels(false));
                    assert!(!a.is_empty(), "view ({el}, {az}): nothing seen");
                    assert_eq!(a, b, "view ({el}, {az}), refine {refine}, offset {off:?}");
                    compared += a.len();
                }
            }
        }
        assert!(compared > 10_000);
    }

    /// Each bin's generated rays are the pixels whose ray [`Bins::of`]
    /// puts in it, every pixel in exactly one bin among the candidates,
    /// with `Camera::ray`'s elevation bit for bit (the sweeps depend on
    /// them): views from above, below and level, the ±π cut of the azimuth
    /// in the image, the vanishing point inside it, bins wide and narrow.
    #[test]
    fn bin_runs_are_the_bins_of_the_rays() {
        let mut wedges_checked = 0;
        for (el, az, w, h, nb) in [
            (30.0, 40.0, 37, 23, 1000),
            (30.0, 40.0, 64, 48, 100_000),
            (-10.0, 200.0, 8, 61, 555),
            (0.0, 180.0, 41, 17, 3000),
            (12.0, 179.0, 41, 17, 20_000),
            (89.0, 0.0, 5, 5, 64),
            (90.0, 30.0, 21, 19, 500),
            (-90.0, 30.0, 20, 18, 777),
            (60.0, 300.0, 33, 35, 7),
            (45.0, 90.0, 13, 11, 12),
        ] {
            let view = View {
                elevation: el,
                azimuth: az,
                projection: Projection::Perspective {
                    distance: 7.5,
                    fov: 50.0,
                },
                target: DVec3::new(0.3, -0.2, 0.1),
            };
            let cam = crate::camera::Camera::new(&view, w, h).unwrap();
            let bins = Bins::new(nb);
            for off in [(0.0, 0.0), (0.25, -0.375)] {
                let runs = Runs::new(&cam, &bins, off);
                let mut seen = vec![usize::MAX; w * h];
                let mut gs = GroupScratch::default();
                let cands = runs.candidates();
                let groups = runs.groups(&cands);
                assert_eq!(groups.iter().map(|g| g.1 - g.0).sum::<usize>(), cands.len());
                for (g0, g1) in groups {
                    runs.group_rays(g0, g1, None, &mut gs);
                    for b in g0..g1 {
                        let rays = &gs.lists[b - g0];
                        if !rays.is_empty() && nb >= bin_count(&cam, 1.25) {
                            wedges_checked += 1;
                            // The bin's wedge holds its rays' elevations.
                            let phi = bins.centre(b);
                            let (lo, hi) =
                                runs.wedge(phi).expect("a bin with rays meets the image");
                            for r in rays {
                                assert!(r.theta >= lo && r.theta <= hi, "view ({el}, {az}) nb {nb} bin {b} ray {} theta {} wedge {lo} {hi}", r.k, r.theta);
                            }
                        }
                        if !rays.is_empty() && nb >= bin_count(&cam, 1.25) && !runs.exact_only {
                            // Generated between two elevations (up to half
                            // its rays; its middle half): every ray of the
                            // bin between them is among them.
                            let phi = bins.centre(b);
                            let range = runs.wedge(phi).expect("wedge");
                            let mut th: Vec<f64> = rays.iter().map(|r| r.theta).collect();
                            th.sort_by(f64::total_cmp);
                            let n = th.len();
                            for (bottom, top) in
                                [(f64::NEG_INFINITY, th[n / 2]), (th[n / 4], th[3 * n / 4])]
                            {
                                let mut rows = vec![None; g1 - g0];
                                rows[b - g0] = runs.rows_within(
                                    DVec2::new(phi.cos(), phi.sin()),
                                    (bottom, top),
                                    range,
                                );
                                let mut capped = GroupScratch::default();
                                runs.group_rays(g0, g1, Some(&rows), &mut capped);
                                for r in rays.iter().filter(|r| r.theta >= bottom && r.theta <= top)
                                {
                                    assert!(
                                        capped.lists[b - g0].iter().any(|c| c.k == r.k),
                                        "view ({el}, {az}) bin {b} ray {} within {bottom} {top}",
                                        r.k
                                    );
                                }
                            }
                        }
                        for ray in rays {
                            let k = ray.k as usize;
                            assert_eq!(seen[k], usize::MAX, "pixel {k} twice");
                            seen[k] = b;
                            let (i, j) = (k / w, k % w);
                            let (_, d) = cam.ray(i as f64 + off.0, j as f64 + off.1);
                            let t = elevation(d.z, (d.x * d.x + d.y * d.y).sqrt());
                            assert_eq!(ray.theta.to_bits(), t.to_bits());
                            assert_eq!(
                                ray.dir.to_array().map(f64::to_bits),
                                d.to_array().map(f64::to_bits)
                            );
                        }
                    }
                }
                for (k, &b) in seen.iter().enumerate() {
                    let (i, j) = (k / w, k % w);
                    let (_, d) = cam.ray(i as f64 + off.0, j as f64 + off.1);
                    assert_eq!(b, bins.of(d.x, d.y), "view ({el}, {az}), pixel ({i}, {j})");
                }
            }
        }
        assert!(wedges_checked > 1000);
    }
}
