//! The Y scan: edge trackers (Blinn 1978 §3.2).
//!
//! An edge tracker is a point (u, v) on the level curve y(u, v) = y_scan of
//! the current scan line that also lies on
//! * a patch boundary (boundary-edge tracker, univariate Newton on
//!   y(u0, v) = y_scan, … §3.2.1),
//! * the silhouette J = x_u y_v − x_v y_u = 0 (Blinn's Zn = 0, bivariate
//!   Newton on (y − y_scan, J) §3.2.1), or
//! * the left border of the image x = x_left (bivariate Newton on
//!   (y − y_scan, x − x_left)): a level curve that comes in from beyond the
//!   left border (perspective curves running off to x = −∞, or a patch wider
//!   than the image) starts its X scan there.
//!
//! Between scan lines each tracker is updated by Newton from its previous
//! position, extrapolated from the two previous ones (§3.5). Trackers are
//! created at the local maxima of y the scan passes (second-order start
//! §3.2.2.2) — interior, along an edge (whichever way y moves into the
//! patch: where it rises inwards an interior level curve is cut by the
//! edge), at an edge's end and at corners —, where a boundary tracker's J
//! changes sign (folded edge §3.2.2.3, also between a new edge piece and
//! its maximum), below curtain folds (§3.4, [`super::folds`]), across a
//! closed surface's seam, and where a tracked curve crosses the left image
//! border; they are deleted when Newton fails to converge (minima §3.2.3)
//! or a silhouette tracker leaves the patch.
//!
//! Silhouette trackers are also started at saddles of y where y has a
//! maximum along the silhouette (§3.2.2.4).
//!
//! Safety net: every scan line the curves are also intersected with a
//! coarse precomputed picture of them — y sampled along each boundary edge,
//! and the silhouette and the left-border curve traced by marching squares
//! over a grid — and every crossing without a tracker is refined by the
//! same Newton iteration and added (`net_added`). It seeds the first scan
//! line of each band; after that it is a fallback: over the 23 test views
//! at 96×72 it adds 4 trackers in all (a pole on the silhouette, a
//! silhouette born at a Bézier patch corner, a silhouette at the left
//! border with the eye close to the surface), and with it switched off
//! (`safety_net=False`) 21 of them render without a mask error.

use super::folds::Fold;
use super::maxima::{MaxKind, Maximum};
use super::screen::{Screen, ScreenSample};
use crate::surface::Domain;

/// What a tracker follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Boundary edge: 0 = (u0, ·), 1 = (u1, ·), 2 = (·, v0), 3 = (·, v1).
    Edge(u8),
    /// Silhouette J = 0.
    Sil,
    /// Left image border x = x_left.
    Left,
}

#[derive(Debug, Clone, Copy)]
pub struct Tracker {
    pub kind: Kind,
    pub s: ScreenSample,
    /// Position on the previous scan line (for the §3.5 extrapolation).
    pub prev: Option<(f64, f64)>,
}

/// Counters of the Y scan.
#[derive(Debug, Clone, Default)]
pub struct YStats {
    /// Tracker updates from one scan line to the next.
    pub updates: u64,
    /// Newton corrections made by those updates (to full precision).
    pub iters: u64,
    /// Corrections larger than a tenth of a pixel (the seed's stopping rule).
    pub iters_blinn: u64,
    /// Updates that failed to converge (tracker deleted, §3.2.3).
    pub lost: u64,
    /// Silhouette trackers that left the patch.
    pub exited: u64,
    pub created_maxima: u64,
    pub created_fold: u64,
    /// Silhouette trackers started at saddles of y (§3.2.2.4).
    pub created_saddles: u64,
    /// Silhouette trackers started below curtain folds (§3.4).
    pub created_curtain: u64,
    /// Left-border trackers started where a tracked curve crossed the
    /// left image border.
    pub created_left: u64,
    /// Silhouette trackers continued across a seam.
    pub created_seam: u64,
    /// Trackers the safety net had to add on a scan line after the first of
    /// a band.
    pub net_added: u64,
    /// Trackers seeded by the net on the first scan line of a band.
    pub band_seeds: u64,
}

impl YStats {
    pub fn add(&mut self, o: &YStats) {
        self.updates += o.updates;
        self.iters += o.iters;
        self.iters_blinn += o.iters_blinn;
        self.lost += o.lost;
        self.exited += o.exited;
        self.created_maxima += o.created_maxima;
        self.created_fold += o.created_fold;
        self.created_saddles += o.created_saddles;
        self.created_curtain += o.created_curtain;
        self.created_left += o.created_left;
        self.created_seam += o.created_seam;
        self.net_added += o.net_added;
        self.band_seeds += o.band_seeds;
    }
}

/// A segment of a curve traced by marching squares, with y at its ends.
#[derive(Debug, Clone, Copy)]
pub(super) struct Seg {
    pub a: (f64, f64),
    pub b: (f64, f64),
    pub ya: f64,
    pub yb: f64,
}

/// The coarse picture of the tracked curves (the safety net).
pub struct Net {
    /// Samples (t, y) along each boundary edge.
    edges: [Vec<(f64, f64)>; 4],
    sil: Vec<Seg>,
    left: Vec<Seg>,
    /// Local maxima of y along the silhouette polylines: curtain folds
    /// (§3.4) and the strict maxima they pass through.
    pub sil_peaks: usize,
    /// For each unit band of y, the pieces (edge windows, then silhouette
    /// and left-border segments) whose y range meets it, so that a scan
    /// line looks at those only.
    rows: [RowIndex; 6],
}

/// Items whose closed y range [lo, hi] meets the unit band
/// [k, k + 1) for k = k0, k0 + 1, … (compressed rows, items in order).
#[derive(Debug, Default)]
struct RowIndex {
    k0: i64,
    start: Vec<u32>,
    items: Vec<u32>,
}

impl RowIndex {
    /// Index items i with y range `range(i)` (`None`: never met) over the
    /// bands covering [ylo, yhi].
    fn build(n: usize, ylo: f64, yhi: f64, range: impl Fn(usize) -> Option<(f64, f64)>) -> Self {
        let k0 = ylo.floor() as i64 - 1;
        let nk = (yhi.floor() as i64 + 2 - k0).max(1) as usize;
        let span = |i: usize| {
            let (lo, hi) = range(i)?;
            // NaN-safe: a range that is not ordered meets nothing.
            if lo
                .partial_cmp(&hi)
                .is_none_or(|o| o == std::cmp::Ordering::Greater)
            {
                return None;
            }
            let a = (lo.floor().max(k0 as f64) as i64 - k0).max(0) as usize;
            let b = (hi.floor().min((k0 + nk as i64 - 1) as f64) as i64 - k0).max(-1);
            (b >= a as i64).then_some((a, b as usize))
        };
        let mut count = vec![0u32; nk + 1];
        for i in 0..n {
            if let Some((a, b)) = span(i) {
                for c in &mut count[a..=b] {
                    *c += 1;
                }
            }
        }
        let mut start = vec![0u32; nk + 1];
        for k in 0..nk {
            start[k + 1] = start[k] + count[k];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; start[nk] as usize];
        for i in 0..n {
            if let Some((a, b)) = span(i) {
                for f in &mut fill[a..=b] {
                    items[*f as usize] = i as u32;
                    *f += 1;
                }
            }
        }
        RowIndex { k0, start, items }
    }

    /// The items that may meet y = ys (`None`: outside the indexed bands,
    /// look at all).
    fn at(&self, ys: f64) -> Option<&[u32]> {
        let k = ys.floor();
        let nk = self.start.len().saturating_sub(1);
        if !(k >= self.k0 as f64 && k < (self.k0 + nk as i64) as f64) {
            return None;
        }
        let k = (k as i64 - self.k0) as usize;
        Some(&self.items[self.start[k] as usize..self.start[k + 1] as usize])
    }
}

/// Position of edge `e` at parameter t.
#[inline]
pub fn edge_point(d: &Domain, e: u8, t: f64) -> (f64, f64) {
    match e {
        0 => (d.u0, t),
        1 => (d.u1, t),
        2 => (t, d.v0),
        _ => (t, d.v1),
    }
}

pub(super) fn march(n: usize, us: &[f64], vs: &[f64], g: &[f64], y: &[f64]) -> Vec<Seg> {
    let mut segs = Vec::new();
    let idx = |i: usize, k: usize| k * n + i;
    for k in 0..n - 1 {
        for i in 0..n - 1 {
            let c = [idx(i, k), idx(i + 1, k), idx(i + 1, k + 1), idx(i, k + 1)];
            if c.iter().any(|&q| !g[q].is_finite() || !y[q].is_finite()) {
                continue;
            }
            let mut pts: Vec<((f64, f64), f64)> = Vec::with_capacity(4);
            for e in 0..4 {
                let (p, q) = (c[e], c[(e + 1) % 4]);
                let (gp, gq) = (g[p], g[q]);
                // A zero counts as positive so that each crossing is seen once.
                if (gp < 0.0) != (gq < 0.0) {
                    let t = gp / (gp - gq);
                    let pt = (us[p] + t * (us[q] - us[p]), vs[p] + t * (vs[q] - vs[p]));
                    pts.push((pt, y[p] + t * (y[q] - y[p])));
                }
            }
            for pair in pts.chunks(2) {
                if let [a, b] = pair {
                    segs.push(Seg {
                        a: a.0,
                        b: b.0,
                        ya: a.1,
                        yb: b.1,
                    });
                }
            }
        }
    }
    segs
}

/// Trace the curves g = 0 through the given points with exact y at every
/// vertex: predictor along (−g_v, g_u), Newton corrector along ∇g, steps
/// that move y by at most 2 px and (u, v) by at most half a grid cell.
/// Cells already crossed are not traced again. Stops at the patch edge,
/// at holes, or when y leaves the image by far.
fn trace<G: Fn(&ScreenSample) -> (f64, f64, f64)>(
    sc: &Screen<'_>,
    g: &G,
    starts: &[(f64, f64)],
    cell: f64,
    image_h: f64,
) -> Vec<Seg> {
    let d = sc.dom;
    let mut segs = Vec::new();
    let key = |u: f64, v: f64| {
        (
            ((u - d.u0) / cell).floor() as i64,
            ((v - d.v0) / cell).floor() as i64,
        )
    };
    let mut visited = std::collections::HashSet::new();
    let correct = |mut u: f64, mut v: f64| -> Option<ScreenSample> {
        for _ in 0..12 {
            let s = sc.eval(u, v)?;
            let (gv, gu, gvv) = g(&s);
            let n2 = gu * gu + gvv * gvv;
            if n2.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            let (du, dv) = (-gv * gu / n2, -gv * gvv / n2);
            if du.abs().max(dv.abs()) > cell {
                return None;
            }
            // Converged: the point just evaluated is the answer (the step
            // left is below 1e-12 of a cell; no evaluation for it).
            if du.abs().max(dv.abs()) < 1e-12 * cell {
                return d.contains(u + du, v + dv).then_some(s);
            }
            u += du;
            v += dv;
            if !d.contains(u, v) {
                return None;
            }
        }
        let s = sc.eval(u, v)?;
        (g(&s).0.abs() < 1e-6 * (1.0 + g(&s).1.abs() + g(&s).2.abs()) * cell).then_some(s)
    };
    for &(u0, v0) in starts {
        if visited.contains(&key(u0, v0)) {
            continue;
        }
        let Some(s0) = correct(u0, v0) else { continue };
        let mut mine = Vec::new();
        for dir in [1.0, -1.0] {
            let mut q = s0;
            for step in 0..4000 {
                mine.push(key(q.u, q.v));
                if q.y.abs() > 8.0 * image_h {
                    break;
                }
                let (_, gu, gv) = g(&q);
                let l = gu.hypot(gv);
                if l.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    break;
                }
                let (tu, tv) = (-dir * gv / l, dir * gu / l);
                let ydot = (q.yu * tu + q.yv * tv).abs();
                let mut h = (0.5 * cell).min(if ydot > 0.0 {
                    2.0 / ydot
                } else {
                    f64::INFINITY
                });
                let mut next = None;
                for _ in 0..20 {
                    let (pu, pv) = (q.u + h * tu, q.v + h * tv);
                    if d.contains(pu, pv) {
                        if let Some(n) = correct(pu, pv) {
                            let moved = (n.u - q.u).hypot(n.v - q.v);
                            if moved > 0.0 && moved <= 2.0 * h && (n.y - q.y).abs() <= 4.0 {
                                next = Some(n);
                                break;
                            }
                        }
                    }
                    h *= 0.5;
                }
                let Some(n) = next else { break };
                segs.push(Seg {
                    a: (q.u, q.v),
                    b: (n.u, n.v),
                    ya: q.y,
                    yb: n.y,
                });
                q = n;
                // Joined a part traced from an earlier start, or closed a loop.
                let closed = step > 4 && (q.u - s0.u).abs().max((q.v - s0.v).abs()) < h;
                if visited.contains(&key(q.u, q.v)) || closed {
                    break;
                }
            }
        }
        visited.extend(mine);
    }
    segs
}

impl Net {
    /// Sample the patch on an n×n grid and each edge at `m` points.
    pub fn build(sc: &Screen<'_>, n: usize, m: usize, x_left: f64) -> Net {
        let d = sc.dom;
        let n = n.max(3);
        let mut us = Vec::with_capacity(n * n);
        let mut vs = Vec::with_capacity(n * n);
        for k in 0..n {
            for i in 0..n {
                us.push(d.u0 + (d.u1 - d.u0) * i as f64 / (n - 1) as f64);
                vs.push(d.v0 + (d.v1 - d.v0) * k as f64 / (n - 1) as f64);
            }
        }
        let ss = sc.eval_batch(&us, &vs);
        let y: Vec<f64> = ss.iter().map(|s| s.map_or(f64::NAN, |s| s.y)).collect();
        let j: Vec<f64> = ss.iter().map(|s| s.map_or(f64::NAN, |s| s.jac())).collect();
        let gx: Vec<f64> = ss
            .iter()
            .map(|s| s.map_or(f64::NAN, |s| s.x - x_left))
            .collect();
        let mut sil = march(n, &us, &vs, &j, &y);
        let mut left = march(n, &us, &vs, &gx, &y);
        // Follow each curve from its marching-squares crossings with exact
        // y along it: where y varies fast (an eye close to the surface) the
        // linear interpolation of a coarse cell is not good enough.
        let cell = ((d.u1 - d.u0).max(d.v1 - d.v0)) / (n - 1) as f64;
        let hmax = sc.cam.height as f64;
        let gj = |s: &ScreenSample| {
            let (ju, jv) = s.jac_grad();
            (s.jac(), ju, jv)
        };
        let gl = |s: &ScreenSample| (s.x - x_left, s.xu, s.xv);
        let starts_sil: Vec<(f64, f64)> = sil.iter().map(|g| g.a).collect();
        let starts_left: Vec<(f64, f64)> = left.iter().map(|g| g.a).collect();
        sil.extend(trace(sc, &gj, &starts_sil, cell, hmax));
        left.extend(trace(sc, &gl, &starts_left, cell, hmax));
        let m = m.max(3);
        let edges: [Vec<(f64, f64)>; 4] = std::array::from_fn(|e| {
            let (t0, t1) = if e < 2 { (d.v0, d.v1) } else { (d.u0, d.u1) };
            let ts: Vec<f64> = (0..m)
                .map(|k| t0 + (t1 - t0) * k as f64 / (m - 1) as f64)
                .collect();
            let (eu, ev): (Vec<f64>, Vec<f64>) =
                ts.iter().map(|&t| edge_point(&d, e as u8, t)).unzip();
            let ys = sc.eval_batch(&eu, &ev);
            ts.into_iter()
                .zip(ys)
                .map(|(t, s)| (t, s.map_or(f64::NAN, |s| s.y)))
                .collect()
        });
        // Extrema of y along the silhouette (curtain folds §3.4, and the
        // stationary points of y it passes through): T = y_u J_v − y_v J_u
        // changes sign along a silhouette segment.
        let t: Vec<f64> = ss
            .iter()
            .map(|s| {
                s.map_or(f64::NAN, |s| {
                    let (ju, jv) = s.jac_grad();
                    s.yu * jv - s.yv * ju
                })
            })
            .collect();
        let sil_peaks = march(n, &us, &vs, &j, &t)
            .iter()
            .filter(|s| (s.ya < 0.0) != (s.yb < 0.0))
            .count();
        // Row index over the image rows (scan lines outside look at all).
        let h = 0.5 * sc.cam.height as f64;
        let mm = |a: f64, b: f64| (a.is_finite() && b.is_finite()).then(|| (a.min(b), a.max(b)));
        let rows = std::array::from_fn(|g| match g {
            0..=3 => {
                let w = &edges[g];
                RowIndex::build(w.len().saturating_sub(1), -h, h, |i| mm(w[i].1, w[i + 1].1))
            }
            _ => {
                let segs = if g == 4 { &sil } else { &left };
                // Infinite ends are ordered too (the test is on products).
                RowIndex::build(segs.len(), -h, h, |i| {
                    let (a, b) = (segs[i].ya, segs[i].yb);
                    (!(a.is_nan() || b.is_nan())).then(|| (a.min(b), a.max(b)))
                })
            }
        });
        Net {
            edges,
            sil,
            left,
            sil_peaks,
            rows,
        }
    }

    /// Seeds (kind, u, v) for every net crossing of scan line `ys`.
    pub fn seeds(&self, d: &Domain, ys: f64, out: &mut Vec<(Kind, f64, f64)>) {
        // The indexed pieces of group g (of n), in order.
        let pick = |g: usize, n: usize| {
            let (some, all) = match self.rows[g].at(ys) {
                Some(r) => (r, None),
                None => (&[][..], Some(0..n)),
            };
            some.iter()
                .map(|&i| i as usize)
                .chain(all.into_iter().flatten())
        };
        for (e, samples) in self.edges.iter().enumerate() {
            for i in pick(e, samples.len().saturating_sub(1)) {
                let w = &samples[i..i + 2];
                let ((t0, y0), (t1, y1)) = (w[0], w[1]);
                if !(y0.is_finite() && y1.is_finite()) {
                    continue;
                }
                if (y0 - ys) * (y1 - ys) <= 0.0 && y0 != y1 {
                    let t = t0 + (t1 - t0) * (ys - y0) / (y1 - y0);
                    let (u, v) = edge_point(d, e as u8, t);
                    out.push((Kind::Edge(e as u8), u, v));
                }
            }
        }
        for (g, kind, segs) in [(4, Kind::Sil, &self.sil), (5, Kind::Left, &self.left)] {
            for i in pick(g, segs.len()) {
                let s = &segs[i];
                if (s.ya - ys) * (s.yb - ys) <= 0.0 && s.ya != s.yb {
                    let t = (ys - s.ya) / (s.yb - s.ya);
                    out.push((
                        kind,
                        s.a.0 + t * (s.b.0 - s.a.0),
                        s.a.1 + t * (s.b.1 - s.a.1),
                    ));
                }
            }
        }
    }
}

/// Whether the edges u0 and u1 (v0 and v1) are the same curve, point by
/// point: the seam of a closed surface. Checked at 9 points per edge.
pub fn seams(sc: &Screen<'_>) -> (bool, bool) {
    let d = sc.dom;
    let k = 9;
    let mut us = Vec::new();
    let mut vs = Vec::new();
    for i in 0..k {
        let f = (i as f64 + 0.37) / k as f64;
        let (u, v) = (d.u0 + f * (d.u1 - d.u0), d.v0 + f * (d.v1 - d.v0));
        us.extend([d.u0, d.u1, u, u]);
        vs.extend([v, v, d.v0, d.v1]);
    }
    let mut p = vec![crate::surface::ParamSample::default(); us.len()];
    sc.surf.eval_batch(&us, &vs, &mut p);
    let scale = p
        .iter()
        .map(|s| s.p.abs().max_element())
        .fold(0.0f64, f64::max);
    let same = |a: usize, b: usize| {
        p[a].p.is_finite()
            && p[b].p.is_finite()
            && (p[a].p - p[b].p).abs().max_element() <= 1e-9 * scale
    };
    let mut su = true;
    let mut sv = true;
    for i in 0..k {
        su &= same(4 * i, 4 * i + 1);
        sv &= same(4 * i + 2, 4 * i + 3);
    }
    (su, sv)
}

/// Starting guesses of the two silhouette trackers below a stationary
/// point q of y where y has a maximum along the silhouette (§3.2.2.2):
/// the level curve ½ΔᵀH_yΔ = ys − y_q meets the silhouette line ∇J·Δ = 0.
fn sil_starts(q: &ScreenSample, ys: f64, cands: &mut Vec<(Kind, f64, f64)>) {
    let (ju, jv) = q.jac_grad();
    let l = ju.hypot(jv);
    if l > 0.0 {
        let (wu, wv) = (-jv / l, ju / l);
        let c = q.yuu * wu * wu + 2.0 * q.yuv * wu * wv + q.yvv * wv * wv;
        if c < 0.0 {
            let a = (2.0 * (ys - q.y) / c).sqrt();
            cands.push((Kind::Sil, q.u + a * wu, q.v + a * wv));
            cands.push((Kind::Sil, q.u - a * wu, q.v - a * wv));
        }
    }
}

/// Outcome of one Newton step of a Y-scan tracker (the flag: a correction
/// of at least a tenth of a pixel).
enum SolveStep {
    Done,
    Fail,
    Next(f64, f64, bool),
}

/// Context of the Y scan shared by a band.
pub struct YScan<'a> {
    pub sc: &'a Screen<'a>,
    pub x_left: f64,
    pub ext: f64,
    pub extrapolate: bool,
    /// Edges u0/u1 (and v0/v1) are the same curve (a closed surface).
    pub seams: (bool, bool),
    /// Let the safety net add trackers after the first scan line of a band
    /// (off only to check that the tracking finds every curve alone).
    pub rescue: bool,
}

impl<'a> YScan<'a> {
    pub fn new(sc: &'a Screen<'a>, x_left: f64, extrapolate: bool) -> Self {
        let d = sc.dom;
        YScan {
            sc,
            x_left,
            ext: (d.u1 - d.u0).max(d.v1 - d.v0),
            extrapolate,
            seams: (false, false),
            rescue: true,
        }
    }

    /// Size in pixels of a parameter step (du, dv) at s.
    #[inline]
    fn px(&self, s: &ScreenSample, du: f64, dv: f64) -> f64 {
        let dx = s.xu * du + s.xv * dv;
        let dy = s.yu * du + s.yv * dv;
        dx.abs().max(dy.abs())
    }

    /// Newton for a tracker of `kind` on scan line `ys` from (u, v). Returns
    /// the solution and the number of corrections made (and how many were
    /// larger than 0.1 px).
    pub fn solve(&self, kind: Kind, u: f64, v: f64, ys: f64) -> Option<(ScreenSample, u32, u32)> {
        let (mut u, mut v) = self.start(kind, u, v);
        let mut big = 0u32;
        for iters in 0..30u32 {
            let s = self.sc.eval(u, v)?;
            match self.solve_step(kind, &s, ys, u, v) {
                SolveStep::Done => return Some((s, iters, big)),
                SolveStep::Fail => return None,
                SolveStep::Next(nu, nv, b) => {
                    u = nu;
                    v = nv;
                    big += b as u32;
                }
            }
        }
        None
    }

    /// [`solve`](Self::solve) for many trackers at once: every Newton
    /// round evaluates all unfinished trackers in one batch (one call per
    /// round for a Python-callable surface).
    pub fn solve_many(
        &self,
        items: &[(Kind, f64, f64)],
        ys: f64,
    ) -> Vec<Option<(ScreenSample, u32, u32)>> {
        let mut out = vec![None; items.len()];
        let active = items
            .iter()
            .enumerate()
            .map(|(i, &(k, u, v))| {
                let (u, v) = self.start(k, u, v);
                (u, v, (i, 0u32))
            })
            .collect();
        self.sc
            .lockstep(active, 30, false, |iters, s, u, v, (i, big)| {
                match self.solve_step(items[i].0, s, ys, u, v) {
                    SolveStep::Done => {
                        out[i] = Some((*s, iters, big));
                        None
                    }
                    SolveStep::Fail => None,
                    SolveStep::Next(nu, nv, b) => Some((nu, nv, (i, big + b as u32))),
                }
            });
        out
    }

    /// Starting point of [`solve`](Self::solve): inside the patch, on the
    /// tracked edge.
    fn start(&self, kind: Kind, u: f64, v: f64) -> (f64, f64) {
        let d = self.sc.dom;
        let (u, v) = (u.clamp(d.u0, d.u1), v.clamp(d.v0, d.v1));
        match kind {
            Kind::Edge(0) => (d.u0, v),
            Kind::Edge(1) => (d.u1, v),
            Kind::Edge(2) => (u, d.v0),
            Kind::Edge(_) => (u, d.v1),
            _ => (u, v),
        }
    }

    /// One Newton step of [`solve`](Self::solve) at (u, v), evaluated as s.
    fn solve_step(&self, kind: Kind, s: &ScreenSample, ys: f64, u: f64, v: f64) -> SolveStep {
        let d = self.sc.dom;
        let f = s.y - ys;
        let (du, dv) = match kind {
            Kind::Edge(e) => {
                if e < 2 {
                    (0.0, -f / s.yv)
                } else {
                    (-f / s.yu, 0.0)
                }
            }
            Kind::Sil | Kind::Left => {
                let (g, gu, gv) = if kind == Kind::Sil {
                    let (ju, jv) = s.jac_grad();
                    (s.jac(), ju, jv)
                } else {
                    (s.x - self.x_left, s.xu, s.xv)
                };
                // Blinn §3.2.1: u −= (F G_v − F_v G)/det, v −= (F_u G − F G_u)/det.
                let det = s.yu * gv - s.yv * gu;
                (-(f * gv - s.yv * g) / det, -(s.yu * g - f * gu) / det)
            }
        };
        if !(du.is_finite() && dv.is_finite()) {
            return SolveStep::Fail;
        }
        let step_px = self.px(s, du, dv);
        let small = du.abs().max(dv.abs()) <= 1e-13 * self.ext;
        if step_px < 1e-9 || small {
            // Converged: the remaining correction is negligible.
            if f.abs() > 1e-6 {
                return SolveStep::Fail;
            }
            return SolveStep::Done;
        }
        // Failure to converge (§3.2.3): a wild step.
        if du.abs().max(dv.abs()) > 0.3 * self.ext {
            return SolveStep::Fail;
        }
        let big = step_px >= 0.1;
        let (nu, nv) = (u + du, v + dv);
        // Silhouette and border trackers leave through the patch edges.
        let slack = 1e-9 * self.ext;
        if nu < d.u0 - slack || nu > d.u1 + slack || nv < d.v0 - slack || nv > d.v1 + slack {
            // Allow one clamped step before giving up (solution on the edge).
            let (cu, cv) = (nu.clamp(d.u0, d.u1), nv.clamp(d.v0, d.v1));
            if (cu, cv) == (u, v) {
                return SolveStep::Fail;
            }
            SolveStep::Next(cu, cv, big)
        } else {
            SolveStep::Next(nu.clamp(d.u0, d.u1), nv.clamp(d.v0, d.v1), big)
        }
    }

    /// Starting guesses of the two border trackers where the level curve
    /// through silhouette point q (an extremum of x along the level curve)
    /// meets x = x_left: along the curve c(s), c' = t = (−y_v, y_u)/|∇y|,
    /// c'' = −(tᵀH_y t) ∇y/|∇y|², x(s) ≈ x_q + ½ s² (tᵀH_x t + ∇x·c'').
    fn left_starts(&self, q: &ScreenSample) -> [(f64, f64); 2] {
        let g2 = q.yu * q.yu + q.yv * q.yv;
        let l = g2.sqrt();
        if l.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return [(q.u, q.v); 2];
        }
        let (tu, tv) = (-q.yv / l, q.yu / l);
        let quad = |a: f64, b: f64, c: f64| a * tu * tu + 2.0 * b * tu * tv + c * tv * tv;
        let ky = -quad(q.yuu, q.yuv, q.yvv) / g2;
        let (cu, cv) = (ky * q.yu, ky * q.yv);
        let xss = quad(q.xuu, q.xuv, q.xvv) + q.xu * cu + q.xv * cv;
        let a2 = 2.0 * (self.x_left - q.x) / xss;
        let a = if a2.is_finite() && a2 > 0.0 {
            a2.sqrt()
        } else {
            0.0
        };
        let at = |s: f64| {
            (
                q.u + s * tu + 0.5 * s * s * cu,
                q.v + s * tv + 0.5 * s * s * cv,
            )
        };
        [at(a), at(-a)]
    }

    /// Starting guess on edge e below a maximum m at the edge's end (a
    /// corner): the step s ≥ 0 into the edge with y_t σ s + ½ y_tt s² =
    /// ys − y_m (σ = ±1 into the edge), to second order because y_t may
    /// be small there (the end of a seam edge, a nearby minimum).
    fn edge_start(&self, m: &Maximum, e: u8, ys: f64) -> Option<(f64, f64)> {
        let d = self.sc.dom;
        let (yt, ytt) = if e < 2 {
            (m.s.yv, m.s.yvv)
        } else {
            (m.s.yu, m.s.yuu)
        };
        let at_start = if e < 2 { m.v <= d.v0 } else { m.u <= d.u0 };
        let sg = if at_start { 1.0 } else { -1.0 };
        let (a, b, c) = (0.5 * ytt, sg * yt, m.y - ys);
        let step = if a.abs() * c.abs() <= 1e-12 * b * b {
            -c / b
        } else {
            let q = (b * b - 4.0 * a * c).sqrt();
            [(-b + q) / (2.0 * a), (-b - q) / (2.0 * a)]
                .into_iter()
                .filter(|r| r.is_finite() && *r >= 0.0)
                .fold(f64::NAN, f64::min)
        };
        if !(step.is_finite() && step >= 0.0) {
            return None;
        }
        let dt = sg * step;
        Some(if e < 2 {
            (m.u, m.v + dt)
        } else {
            (m.u + dt, m.v)
        })
    }

    /// Advance all trackers to scan line `ys` and create new ones; `first`
    /// marks the first scan line of a band (no previous trackers).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &self,
        trackers: &mut Vec<Tracker>,
        ys: f64,
        first: bool,
        maxima: &[Maximum],
        saddles: &[ScreenSample],
        folds: &[Fold],
        net: &Net,
        seeds: &mut Vec<(Kind, f64, f64)>,
        st: &mut YStats,
    ) {
        let d = self.sc.dom;
        let old = std::mem::take(trackers);
        let mut out: Vec<Tracker> = Vec::with_capacity(old.len() + 8);
        let tol = 1e-7 * self.ext;
        let same = |a: &Tracker, kind: Kind, s: &ScreenSample| {
            a.kind == kind && (a.s.u - s.u).abs() <= tol && (a.s.v - s.v).abs() <= tol
        };
        // A new tracker, unless one of its kind is already there: whether it
        // was added.
        let add = |out: &mut Vec<Tracker>, kind: Kind, s: ScreenSample| {
            let new = !out.iter().any(|o| same(o, kind, &s));
            if new {
                out.push(Tracker {
                    kind,
                    s,
                    prev: None,
                });
            }
            new
        };
        // §3.2.1 update with the §3.5 extrapolation, all trackers in one
        // batch per Newton round.
        let guess = |t: &Tracker| match (self.extrapolate, t.prev) {
            (true, Some((pu, pv))) => (2.0 * t.s.u - pu, 2.0 * t.s.v - pv),
            _ => (t.s.u, t.s.v),
        };
        let items: Vec<(Kind, f64, f64)> = old
            .iter()
            .map(|t| {
                let (u, v) = guess(t);
                (t.kind, u, v)
            })
            .collect();
        let updated = self.solve_many(&items, ys);
        for (t, r) in old.into_iter().zip(updated) {
            let (gu, gv) = guess(&t);
            st.updates += 1;
            let mut r = r;
            if r.is_none() && (gu, gv) != (t.s.u, t.s.v) {
                r = self.solve(t.kind, t.s.u, t.s.v, ys);
            }
            match r {
                Some((s, it, big)) => {
                    st.iters += it as u64;
                    st.iters_blinn += big as u64;
                    if out.iter().any(|o| same(o, t.kind, &s)) {
                        continue; // two trackers met (a minimum): keep one
                    }
                    // §3.2.2.3 folded edge: J changed sign along a boundary tracker.
                    if let Kind::Edge(_) = t.kind {
                        if (s.jac() < 0.0) != (t.s.jac() < 0.0) {
                            if let Some((fs, _, _)) = self.solve(Kind::Sil, s.u, s.v, ys) {
                                if add(&mut out, Kind::Sil, fs) {
                                    st.created_fold += 1;
                                }
                            }
                        }
                    }
                    // The level curve crossed the left image border: a
                    // boundary tracker passing it starts a border tracker,
                    // a silhouette tracker passing it two.
                    if (s.x < self.x_left) != (t.s.x < self.x_left) {
                        let starts: Vec<(f64, f64)> = match t.kind {
                            Kind::Edge(_) => vec![(s.u, s.v)],
                            Kind::Sil => self.left_starts(&s).to_vec(),
                            Kind::Left => Vec::new(),
                        };
                        for (u, v) in starts {
                            if let Some((ls, _, _)) = self.solve(Kind::Left, u, v, ys) {
                                if add(&mut out, Kind::Left, ls) {
                                    st.created_left += 1;
                                }
                            }
                        }
                    }
                    out.push(Tracker {
                        kind: t.kind,
                        s,
                        prev: Some((t.s.u, t.s.v)),
                    });
                }
                None => {
                    let inside = d.contains(gu, gv);
                    if t.kind != Kind::Sil || inside {
                        st.lost += 1;
                        continue;
                    }
                    st.exited += 1;
                    // Across a closed surface's seam the silhouette goes on
                    // from the twin edge.
                    let (pu, pv) = (d.u1 - d.u0, d.v1 - d.v0);
                    let mut twin = (gu, gv);
                    if self.seams.0 && gu < d.u0 {
                        twin.0 += pu;
                    } else if self.seams.0 && gu > d.u1 {
                        twin.0 -= pu;
                    }
                    if self.seams.1 && gv < d.v0 {
                        twin.1 += pv;
                    } else if self.seams.1 && gv > d.v1 {
                        twin.1 -= pv;
                    }
                    if twin != (gu, gv) && d.contains(twin.0, twin.1) {
                        if let Some((s, _, _)) = self.solve(Kind::Sil, twin.0, twin.1, ys) {
                            if add(&mut out, Kind::Sil, s) {
                                st.created_seam += 1;
                            }
                        }
                    }
                }
            }
        }
        // §3.2.2.2 creation at maxima passed (and kept alive for a few scan
        // lines while the new level curve is smaller than the net's cells).
        for m in maxima {
            let dy = m.y - ys;
            if !(0.0..8.0).contains(&dy) {
                continue;
            }
            // A silhouette tracker between the maximum and (u, v), from
            // either end of the segment, unless one is there already.
            let sil_between = |out: &mut Vec<Tracker>, st: &mut YStats, (u, v): (f64, f64)| {
                let mid = (0.5 * (u + m.u), 0.5 * (v + m.v));
                let fs = self
                    .solve(Kind::Sil, u, v, ys)
                    .or_else(|| self.solve(Kind::Sil, mid.0, mid.1, ys));
                if let Some((fs, _, _)) = fs {
                    if add(out, Kind::Sil, fs) {
                        st.created_fold += 1;
                    }
                }
            };
            let mut cands: Vec<(Kind, f64, f64)> = Vec::new();
            match m.kind {
                MaxKind::Interior => sil_starts(&m.s, ys, &mut cands),
                MaxKind::Edge(e) => {
                    let ytt = if e < 2 { m.s.yvv } else { m.s.yuu };
                    if ytt < 0.0 {
                        let a = (2.0 * (ys - m.y) / ytt).sqrt();
                        for sgn in [-1.0, 1.0] {
                            let (u, v) = if e < 2 {
                                (m.u, m.v + sgn * a)
                            } else {
                                (m.u + sgn * a, m.v)
                            };
                            cands.push((Kind::Edge(e), u, v));
                        }
                    }
                }
                MaxKind::EdgeEnd(e) => {
                    if let Some((u, v)) = self.edge_start(m, e, ys) {
                        cands.push((Kind::Edge(e), u, v));
                    }
                }
                MaxKind::Corner(eu, ev) => {
                    for e in [eu, ev] {
                        if let Some((u, v)) = self.edge_start(m, e, ys) {
                            cands.push((Kind::Edge(e), u, v));
                        }
                    }
                }
            }
            let mut made = 0;
            let mut missed = Vec::new();
            for (kind, u, v) in cands {
                let r = self.solve(kind, u, v, ys);
                if r.is_none() {
                    missed.push((u, v));
                }
                if let Some((s, _, _)) = r {
                    made += 1;
                    if add(&mut out, kind, s) {
                        st.created_maxima += 1;
                        // A silhouette inside the new piece: J changed
                        // sign between the maximum and its boundary
                        // tracker (§3.2.2.3 at creation).
                        if matches!(kind, Kind::Edge(_)) && (s.jac() < 0.0) != (m.s.jac() < 0.0) {
                            sil_between(&mut out, st, (s.u, s.v));
                        }
                    }
                }
            }
            // A corner piece with one boundary end only: its other end is
            // a silhouette point (y along the second edge turned up again).
            if let (MaxKind::Corner(..), 1, [(u, v)]) = (m.kind, made, missed.as_slice()) {
                sil_between(&mut out, st, (u.clamp(d.u0, d.u1), v.clamp(d.v0, d.v1)));
            }
        }
        // §3.2.2.4 saddles: every stationary point of y lies on the
        // silhouette (J = 0 there), and along the silhouette y has an
        // extremum at it. A maximum along the silhouette (its tangent w
        // with wᵀ H_y w < 0) starts two silhouette trackers below it, as at
        // a strict maximum; at a minimum the two arriving trackers meet and
        // one is dropped (above, or Newton fails: §3.2.3).
        for q in saddles {
            let dy = q.y - ys;
            if !(0.0..8.0).contains(&dy) {
                continue;
            }
            let mut cands: Vec<(Kind, f64, f64)> = Vec::new();
            sil_starts(q, ys, &mut cands);
            for (kind, u, v) in cands {
                if let Some((s, _, _)) = self.solve(kind, u, v, ys) {
                    if add(&mut out, kind, s) {
                        st.created_saddles += 1;
                    }
                }
            }
        }
        // §3.4 curtain folds: a maximum of y along the silhouette starts
        // two silhouette trackers below it.
        for f in folds {
            let dy = f.s.y - ys;
            if !(0.0..8.0).contains(&dy) {
                continue;
            }
            for (u, v) in f.starts(ys) {
                if let Some((s, _, _)) = self.solve(Kind::Sil, u, v, ys) {
                    if add(&mut out, Kind::Sil, s) {
                        st.created_curtain += 1;
                    }
                }
            }
        }
        // Safety net.
        seeds.clear();
        if first || self.rescue {
            net.seeds(&d, ys, seeds);
        }
        // All crossings solved together (one evaluation batch per Newton
        // round), then added in order.
        let solved = if seeds.is_empty() {
            Vec::new()
        } else {
            self.solve_many(seeds, ys)
        };
        for (&(kind, _, _), r) in seeds.iter().zip(solved) {
            if let Some((s, _, _)) = r {
                if add(&mut out, kind, s) {
                    if first {
                        st.band_seeds += 1;
                    } else {
                        st.net_added += 1;
                    }
                }
            }
        }
        // A fixed order, whatever happened before.
        out.sort_by(|a, b| a.s.x.total_cmp(&b.s.x).then(a.s.u.total_cmp(&b.s.u)));
        *trackers = out;
    }
}
