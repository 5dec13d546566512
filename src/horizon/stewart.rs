//! Stewart §IV: the horizon of every point in one sector in
//! O(n log² n), with a static complete binary tree of upper hulls.
//!
//! Points are ordered by their a⊥ key (first index j) and by their b⊥ key
//! (second index k). Ties follow §IV-D, expressed in the a⊥–b⊥ coordinates:
//! equal a⊥ keys are ordered by decreasing b⊥ key (the paper's order along
//! −a: a point on the clockwise border ray of p comes before p), equal b⊥
//! keys by decreasing a⊥ key (the paper's order along +b: a point on the
//! counter-clockwise border ray of p comes after p), and identical keys by
//! input index (such a pair never shares a sector). With these orders p_{j,k}
//! lies in sector Σ_{s,t} exactly when s > j and t < k (the Observation).
//!
//! The tree has a leaf C_k per second index, padded to a power of two N and
//! stored heap-ordered: node m has children 2m and 2m+1 and leaves are
//! N..2N−1. Only left children hold hulls (§IV-C), so the hull of the left
//! child 2m lives in slot m: `hull[m]` holds the points of m's right subtree
//! processed so far. Walking up from leaf C_k, each ancestor m is met either
//! from its left subtree — then `hull[m]` is part of the covering set of
//! Σ_{*,k} and is queried for its tangent — or from its right subtree — then
//! the point joins `hull[m]` (the sectors Σ_{*,t}, t < k, of §IV-A step 2).
//! A slot whose left subtree has no unprocessed leaf left is inactive: its
//! hull is freed and receives nothing more (§IV-C). Hulls are sorted arrays
//! (the paper's choice; their average size stays below two points).
//!
//! The near-vertex check of §IV-E is applied by the caller (see
//! [`super::cms::near_vertex`]) when asked for.

use super::exact::orient;
use super::{better, elevation, project, Frame, Options, Progress, Proj, Terrain, EMPTY};
use crate::cancel::Cancel;
use crate::error::Result;

/// Index of the tangent vertex of upper hull `h` seen from `p` (strictly to
/// its left): the highest elevation, ties to the nearer vertex. The
/// elevations along an upper hull seen from outside are unimodal.
#[inline]
pub fn tangent(h: &[Proj], p: Proj) -> usize {
    let (mut lo, mut hi) = (0usize, h.len() - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if better(p, h[mid], h[mid + 1]) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

#[inline]
fn o3(a: Proj, b: Proj, c: Proj) -> i32 {
    orient((a.w, a.zz), (b.w, b.zz), (c.w, c.zz))
}

/// Insert `q` into the strictly convex upper hull `h` (sorted by w).
pub fn insert(h: &mut Vec<Proj>, q: Proj) {
    let mut pos = h.partition_point(|v| v.w < q.w);
    let mut end = pos; // h[pos..end] will be replaced by q
    if pos < h.len() && h[pos].w == q.w {
        if h[pos].zz >= q.zz {
            return;
        }
        end = pos + 1;
    }
    if pos > 0 && end < h.len() && o3(h[pos - 1], h[end], q) <= 0 {
        return; // on or below the hull
    }
    while end + 1 < h.len() && o3(q, h[end], h[end + 1]) >= 0 {
        end += 1;
    }
    while pos >= 2 && o3(h[pos - 2], h[pos - 1], q) >= 0 {
        pos -= 1;
    }
    if end == pos {
        h.insert(pos, q);
    } else {
        h[pos] = q;
        h.drain(pos + 1..end);
    }
}

/// Permutation of `0..k1.len()` sorted by `k1` ascending, ties `k2`
/// descending, then index ascending, written to `out`.
///
/// A counting sort on a bucket number that is a monotone function of `k1`
/// (computed in floating point with monotone operations only, so k1 ≤ k1'
/// gives bucket ≤ bucket'), then the exact comparison inside each bucket. On
/// a grid the keys are spread almost evenly and the buckets hold one or two
/// points; O(n) instead of a comparison sort's O(n log n).
pub fn sort_keys(k1: &[f64], k2: &[f64], out: &mut Vec<u32>, count: &mut Vec<u32>) {
    let n = k1.len();
    out.clear();
    out.resize(n, 0);
    if n == 0 {
        return;
    }
    let (lo, hi) = k1
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let nb = n;
    let scale = if hi > lo {
        (nb - 1) as f64 / (hi - lo)
    } else {
        0.0
    };
    let bucket = |v: f64| (((v - lo) * scale) as usize).min(nb - 1);
    count.clear();
    count.resize(nb + 1, 0);
    for &v in k1 {
        count[bucket(v) + 1] += 1;
    }
    for b in 0..nb {
        count[b + 1] += count[b];
    }
    // Stable scatter: inside a bucket, indices stay ascending.
    for (i, &v) in k1.iter().enumerate() {
        let b = bucket(v);
        out[count[b] as usize] = i as u32;
        count[b] += 1;
    }
    let cmp = |i: &u32, j: &u32| {
        let (i, j) = (*i as usize, *j as usize);
        k1[i]
            .total_cmp(&k1[j])
            .then(k2[j].total_cmp(&k2[i]))
            .then(i.cmp(&j))
    };
    // After the scatter, count[b] is the end of bucket b.
    let mut start = 0usize;
    for &end in &count[..nb] {
        let end = end as usize;
        if end - start > 1 {
            out[start..end].sort_unstable_by(cmp);
        }
        start = end;
    }
}

/// Leaves per block: the hulls of the lowest `LOW` levels of the tree (a
/// right subtree of at most 2^(LOW−1) leaves) are not kept. The points
/// processed so far are stored at their leaf, and the covering sets met at
/// those levels from leaf k are exactly the leaves k+1 .. end of k's block,
/// whose maximum is taken directly: the tangent of a hull is the maximum of
/// the points it was built from (§IV-B), and the block (16 points) is four cache
/// lines instead of `LOW` nodes far apart.
const LOW: u32 = 4;
const BLOCK: usize = 1 << LOW;
/// Points kept inline in a node (two cache lines); larger hulls spill.
const INLINE: usize = 8;
const PREFETCH_AHEAD: usize = 12;
const SPILLED: u32 = u32::MAX;

/// The hull of a node, inline (128 bytes, two cache lines).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Pts([Proj; INLINE]);

/// Per-node counters, apart from the hulls so that the walk reads one small
/// array at every level and touches a hull only when it is queried or grows.
#[derive(Clone, Copy)]
struct Meta {
    /// Unprocessed leaves in the left subtree (0: inactive, §IV-C).
    open: u32,
    /// Inline hull length, or `SPILLED` (then `spill` names the vector).
    len: u32,
    spill: u32,
    /// Bounds of every point inserted so far: smallest and largest w,
    /// largest Z (the extreme points of a set are vertices of its hull).
    wmin: f64,
    wmax: f64,
    zmax: f64,
}

impl Meta {
    /// Can no point of this hull beat a current best of slope `bs` seen
    /// from `p`? Its slopes (Z − Z_p)/(w − w_p) are at most the bound
    /// below; the margin (1e-12 relative) is far above the few rounding
    /// errors of the two quotients, so a skip is never wrong (and a tie,
    /// which the exact comparison would settle by distance, is never
    /// skipped).
    #[inline]
    fn cannot_beat(&self, p: Proj, bs: f64) -> bool {
        let num = self.zmax - p.zz;
        let den = if num >= 0.0 { self.wmin } else { self.wmax } - p.w;
        if den <= 0.0 {
            return false;
        }
        let bound = num / den;
        bound < bs - 1e-12 * (bound.abs() + bs.abs())
    }
}

const ABSENT: Proj = Proj {
    w: f64::NAN,
    zz: f64::NAN,
};

/// Buffers of one sector computation, reused across the sectors a thread
/// computes (the allocation and first touch of ~100 MB per sector at n = 1M
/// is otherwise a visible share of the time).
#[derive(Default)]
pub struct Work {
    ids: Vec<usize>,
    a: Vec<f64>,
    b: Vec<f64>,
    pr: Vec<Proj>,
    order: Vec<u32>,
    by_b: Vec<u32>,
    count: Vec<u32>,
    rank: Vec<u32>,
    seq: Vec<(Proj, u32)>,
    leaf: Vec<Proj>,
    meta: Vec<Meta>,
    pts: Vec<Pts>,
    spill: Vec<Vec<Proj>>,
    free: Vec<u32>,
}

#[inline]
fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch hint never faults.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch(p as *const i8, _MM_HINT_T0);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Insert `q` into the inline hull `h[..*len]` (same rules as [`insert`]);
/// false when the result would exceed `INLINE` points (`h` is unchanged).
#[inline]
fn insert_inline(h: &mut [Proj; INLINE], len: &mut u32, q: Proj) -> bool {
    let n = *len as usize;
    let mut pos = h[..n].partition_point(|v| v.w < q.w);
    let mut end = pos;
    if pos < n && h[pos].w == q.w {
        if h[pos].zz >= q.zz {
            return true;
        }
        end = pos + 1;
    }
    if pos > 0 && end < n && o3(h[pos - 1], h[end], q) <= 0 {
        return true;
    }
    while end + 1 < n && o3(q, h[end], h[end + 1]) >= 0 {
        end += 1;
    }
    while pos >= 2 && o3(h[pos - 2], h[pos - 1], q) >= 0 {
        pos -= 1;
    }
    // h[pos..end] is replaced by q.
    let m = n - (end - pos) + 1;
    if m > INLINE {
        return false;
    }
    let mut out = [ABSENT; INLINE];
    out[..pos].copy_from_slice(&h[..pos]);
    out[pos] = q;
    out[pos + 1..m].copy_from_slice(&h[end..n]);
    *h = out;
    *len = m as u32;
    true
}

impl Work {
    /// Reset the tree for `n` points (ranks 0..n).
    fn reset_tree(&mut self, n: usize) -> usize {
        let big_n = n.next_power_of_two().max(BLOCK);
        self.leaf.clear();
        self.leaf.resize(big_n, ABSENT);
        // The tree over blocks: node m (1 ≤ m < nb) with children 2m, 2m+1,
        // blocks nb..2nb−1. open[m] = real leaves (k < n) under the left
        // child 2m, whose blocks are [m·2^t − nb, m·2^t − nb + 2^(t−1)).
        let nb = big_n / BLOCK;
        self.meta.clear();
        self.meta.resize(
            nb.max(1),
            Meta {
                open: 0,
                len: 0,
                spill: 0,
                wmin: f64::INFINITY,
                wmax: f64::NEG_INFINITY,
                zmax: f64::NEG_INFINITY,
            },
        );
        let log_nb = nb.trailing_zeros();
        for (m, md) in self.meta.iter_mut().enumerate().skip(1) {
            let t = log_nb - m.ilog2();
            let start = ((m << t) - nb) * BLOCK;
            let span = (1usize << (t - 1)) * BLOCK;
            md.open = n.saturating_sub(start).min(span) as u32;
        }
        if self.pts.len() < nb.max(1) {
            self.pts.resize(nb.max(1), Pts([ABSENT; INLINE]));
        }
        for v in &mut self.spill {
            v.clear();
        }
        self.free.clear();
        self.free.extend((0..self.spill.len() as u32).rev());
        nb
    }

    #[inline]
    fn hull(&self, m: usize) -> &[Proj] {
        let md = &self.meta[m];
        if md.len == SPILLED {
            &self.spill[md.spill as usize]
        } else {
            &self.pts[m].0[..md.len as usize]
        }
    }

    #[inline]
    fn close_one(&mut self, m: usize) {
        let md = &mut self.meta[m];
        md.open -= 1;
        if md.open == 0 {
            if md.len == SPILLED {
                self.spill[md.spill as usize].clear();
                self.free.push(md.spill);
            }
            md.len = 0;
        }
    }

    #[inline]
    fn insert(&mut self, m: usize, q: Proj) {
        let md = &mut self.meta[m];
        md.wmin = md.wmin.min(q.w);
        md.wmax = md.wmax.max(q.w);
        md.zmax = md.zmax.max(q.zz);
        if md.len == SPILLED {
            insert(&mut self.spill[md.spill as usize], q);
            return;
        }
        if insert_inline(&mut self.pts[m].0, &mut md.len, q) {
            return;
        }
        let id = match self.free.pop() {
            Some(id) => id,
            None => {
                self.spill.push(Vec::new());
                (self.spill.len() - 1) as u32
            }
        };
        let v = &mut self.spill[id as usize];
        v.clear();
        v.extend_from_slice(&self.pts[m].0[..md.len as usize]);
        insert(v, q);
        md.len = SPILLED;
        md.spill = id;
    }
}

/// The best of `best` and `c` for `p` (exact; ties to the nearer point).
#[inline]
fn pick(p: Proj, best: Option<Proj>, c: Proj) -> Option<Proj> {
    match best {
        Some(bq) if !better(p, bq, c) => Some(bq),
        _ => Some(c),
    }
}

/// One sector for every point (`plane` has one value per terrain point).
pub fn sector(
    t: &Terrain,
    f: &Frame,
    o: &Options,
    plane: &mut [f32],
    cancel: &Cancel,
    progress: &Progress,
) -> Result<()> {
    sector_with(t, f, o, plane, cancel, progress, &mut Work::default())
}

thread_local! {
    static WORK: std::cell::RefCell<Work> = std::cell::RefCell::new(Work::default());
}

/// [`sector`] with the calling thread's buffers, kept between calls.
pub fn sector_pooled(
    t: &Terrain,
    f: &Frame,
    o: &Options,
    plane: &mut [f32],
    cancel: &Cancel,
    progress: &Progress,
) -> Result<()> {
    WORK.with(|w| match w.try_borrow_mut() {
        Ok(mut w) => sector_with(t, f, o, plane, cancel, progress, &mut w),
        Err(_) => sector(t, f, o, plane, cancel, progress),
    })
}

/// Free the calling thread's buffers (after the last sector of a map).
pub fn release() {
    WORK.with(|w| {
        if let Ok(mut w) = w.try_borrow_mut() {
            *w = Work::default();
        }
    });
}

/// [`sector`] with caller-provided buffers.
pub fn sector_with(
    t: &Terrain,
    f: &Frame,
    o: &Options,
    plane: &mut [f32],
    cancel: &Cancel,
    progress: &Progress,
    w: &mut Work,
) -> Result<()> {
    t.split_no_data(plane, &mut w.ids);
    let n = w.ids.len();
    if n == 0 {
        return Ok(());
    }
    let ids = std::mem::take(&mut w.ids);
    w.a.clear();
    w.a.extend(ids.iter().map(|&q| f.key_a(t.kx[q], t.ky[q])));
    w.b.clear();
    w.b.extend(ids.iter().map(|&q| f.key_b(t.kx[q], t.ky[q])));
    w.pr.clear();
    w.pr.extend(
        ids.iter()
            .map(|&q| project(f, t.x[q], t.y[q], t.z[q], o.curvature)),
    );
    // First index: a⊥ ascending, ties b⊥ descending, then input order.
    sort_keys(&w.a, &w.b, &mut w.order, &mut w.count);
    // Second index: b⊥ ascending, ties a⊥ descending, then input order.
    sort_keys(&w.b, &w.a, &mut w.by_b, &mut w.count);
    w.rank.clear();
    w.rank.resize(n, 0);
    for (k, &i) in w.by_b.iter().enumerate() {
        w.rank[i as usize] = k as u32;
    }
    // The points in processing order with their leaf, read sequentially.
    w.seq.clear();
    w.seq.extend(
        w.order
            .iter()
            .map(|&i| (w.pr[i as usize], w.rank[i as usize])),
    );
    let nb = w.reset_tree(n);
    let limit = o.max_distance.map(|d| Limit::new(t, f, o, d));
    for step in 0..n {
        if step % 4096 == 4095 {
            cancel.check()?;
            progress.add(4096);
        }
        // The walk is bound by memory latency (one slot per level, far
        // apart): fetch the block and slots of a point a few steps ahead.
        if let Some(&(_, ka)) = w.seq.get(step + PREFETCH_AHEAD) {
            let ka = ka as usize;
            // the block's lines from k to its end (4 points per line)
            let mut kk = ka;
            while kk <= (ka | (BLOCK - 1)) {
                prefetch(w.leaf.as_ptr().wrapping_add(kk));
                kk = (kk | 3) + 1;
            }
            let mut x = nb + ka / BLOCK;
            while x > 1 {
                prefetch(w.meta.as_ptr().wrapping_add(x >> 1));
                prefetch(w.pts.as_ptr().wrapping_add(x >> 1));
                x >>= 1;
            }
        }
        let (p, k) = w.seq[step];
        let k = k as usize;
        let mut best: Option<Proj> = None;
        // Lowest levels: the processed leaves after k in its block.
        for &c in &w.leaf[k + 1..(k | (BLOCK - 1)) + 1] {
            if !c.w.is_nan() {
                best = pick(p, best, c);
            }
        }
        w.leaf[k] = p;
        // Slope of the best so far (−∞: none), to skip hulls that cannot
        // beat it without reading them.
        let slope = |b: Option<Proj>| match b {
            Some(q) if q.w > p.w => (q.zz - p.zz) / (q.w - p.w),
            _ => f64::NEG_INFINITY,
        };
        let mut bs = slope(best);
        let mut x = nb + k / BLOCK;
        while x > 1 {
            let m = x >> 1;
            if x & 1 == 0 {
                // Step 1: the left child's hull covers part of Σ_{*,k}.
                let md = &w.meta[m];
                if md.len != 0 && !md.cannot_beat(p, bs) {
                    let h = w.hull(m);
                    let nbest = pick(p, best, h[tangent(h, p)]);
                    if nbest != best {
                        best = nbest;
                        bs = slope(best);
                    }
                }
                w.close_one(m);
            } else if w.meta[m].open > 0 {
                // Step 2: join the covering sets of Σ_{*,t}, t < k.
                w.insert(m, p);
            }
            x = m;
        }
        let i = w.order[step] as usize;
        let best = match (&limit, best) {
            (Some(lim), Some(q)) if !lim.surely_within(p, q) => lim.search(ids[i], p),
            (_, b) => b,
        };
        plane[ids[i]] = match best {
            None => EMPTY,
            Some(q) => elevation(p, q, o.curvature),
        };
    }
    progress.add(n % 4096);
    w.ids = ids;
    Ok(())
}

/// `max_distance` for [`sector`]: the winner over the whole sector is also
/// the winner over the sector ∩ disc whenever it lies in the disc (it beats
/// every point of the sector). When it may not, the disc part of the sector
/// is searched directly with brute's tests (same keys, same distance test,
/// same exact comparison), which is cheap when the distance is small and
/// rare when it is large.
struct Limit<'a> {
    t: &'a Terrain,
    f: &'a Frame,
    c: f64,
    d2: f64,
    /// d·cos(π/s), shrunk by a relative margin far above the rounding of w.
    sure: f64,
    /// Cells of the disc's bounding box to scan, for scattered points.
    cells: Option<Cells>,
    /// Grid: rows and columns the disc can reach either side.
    reach: (i64, i64),
}

/// Scattered points bucketed on a uniform grid (CSR layout).
struct Cells {
    x0: f64,
    y0: f64,
    size: f64,
    nx: usize,
    ny: usize,
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Cells {
    fn new(t: &Terrain, d: f64) -> Cells {
        let n = t.len();
        let fold = |v: &[f64]| {
            v.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                    (l.min(x), h.max(x))
                })
        };
        let ((x0, x1), (y0, y1)) = (fold(&t.x), fold(&t.y));
        let ext = (x1 - x0).max(y1 - y0).max(f64::MIN_POSITIVE);
        // At least d wide (the disc spans few cells), at most n cells.
        let size = d.max(ext / (n as f64).sqrt().max(1.0));
        let nx = ((x1 - x0) / size) as usize + 1;
        let ny = ((y1 - y0) / size) as usize + 1;
        let cell = |q: usize| {
            let cx = (((t.x[q] - x0) / size) as usize).min(nx - 1);
            let cy = (((t.y[q] - y0) / size) as usize).min(ny - 1);
            cy * nx + cx
        };
        let mut start = vec![0u32; nx * ny + 1];
        for q in 0..n {
            start[cell(q) + 1] += 1;
        }
        for c in 0..nx * ny {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; n];
        for q in 0..n {
            let c = cell(q);
            items[fill[c] as usize] = q as u32;
            fill[c] += 1;
        }
        Cells {
            x0,
            y0,
            size,
            nx,
            ny,
            start,
            items,
        }
    }
}

impl<'a> Limit<'a> {
    fn new(t: &'a Terrain, f: &'a Frame, o: &Options, d: f64) -> Limit<'a> {
        let half = std::f64::consts::PI / o.sectors as f64;
        let reach = match t.grid {
            Some((_, _, du, dv)) => (
                (d / dv.abs()).min(1e15) as i64 + 1,
                (d / du.abs()).min(1e15) as i64 + 1,
            ),
            None => (0, 0),
        };
        Limit {
            t,
            f,
            c: o.curvature,
            d2: d * d,
            sure: d * half.cos() * (1.0 - 1e-9),
            cells: if t.grid.is_none() && d.is_finite() {
                Some(Cells::new(t, d))
            } else {
                None
            },
            reach,
        }
    }

    /// Is q (in p's sector) certainly within the distance? |pq| ≤
    /// (w_q − w_p)/cos(π/s) since pq is at most π/s off the centre ray.
    #[inline]
    fn surely_within(&self, p: Proj, q: Proj) -> bool {
        let tol = 1e-12 * (p.w.abs() + q.w.abs());
        (q.w - p.w) + tol <= self.sure
    }

    /// Brute's answer for point `ip` restricted to the disc.
    fn search(&self, ip: usize, p: Proj) -> Option<Proj> {
        let (t, f) = (self.t, self.f);
        let (ka, kb) = (f.key_a(t.kx[ip], t.ky[ip]), f.key_b(t.kx[ip], t.ky[ip]));
        let mut best: Option<Proj> = None;
        let mut visit = |q: usize| {
            if q == ip || !t.z[q].is_finite() {
                return;
            }
            let (dx, dy) = (t.x[q] - t.x[ip], t.y[q] - t.y[ip]);
            if dx * dx + dy * dy > self.d2 {
                return;
            }
            let (qa, qb) = (f.key_a(t.kx[q], t.ky[q]), f.key_b(t.kx[q], t.ky[q]));
            if !(qa <= ka && qb >= kb) || (qa == ka && qb == kb) {
                return;
            }
            best = pick(p, best, project(f, t.x[q], t.y[q], t.z[q], self.c));
        };
        match (t.grid, &self.cells) {
            (Some((rows, cols, du, dv)), _) => {
                let (pi, pj) = ((ip / cols) as i64, (ip % cols) as i64);
                let (su, sv) = (du / du.abs(), dv / du.abs());
                let (a0, a1) = (f.aperp.0 * su, f.aperp.1);
                let (b0, b1) = (f.bperp.0 * su, f.bperp.1);
                let (r, c) = self.reach;
                for i in (pi - r).max(0)..=(pi + r).min(rows as i64 - 1) {
                    let ky = (i - pi) as f64 * sv;
                    let (mut lo, mut hi) = ((pj - c).max(0), (pj + c).min(cols as i64 - 1));
                    // The sector's half-planes in this row (a⊥·Δk ≤ 0 ≤
                    // b⊥·Δk), widened by a cell; the exact test decides.
                    for (g, h, le) in [(a0, -a1 * ky, true), (b0, -b1 * ky, false)] {
                        if g.abs() > 1e-9 {
                            let e = h / g;
                            if le == (g > 0.0) {
                                hi = hi.min(pj + e.ceil().min(1e15) as i64 + 1);
                            } else {
                                lo = lo.max(pj + e.floor().max(-1e15) as i64 - 1);
                            }
                        }
                    }
                    for j in lo..=hi {
                        visit(i as usize * cols + j as usize);
                    }
                }
            }
            (None, Some(cl)) => {
                let d = self.d2.sqrt();
                let span = |v: f64, v0: f64, m: usize| {
                    let lo = ((v - d - v0) / cl.size).floor().max(0.0) as usize;
                    let hi = (((v + d - v0) / cl.size).floor().max(0.0) as usize).min(m - 1);
                    (lo, hi)
                };
                let (cx0, cx1) = span(t.x[ip], cl.x0, cl.nx);
                let (cy0, cy1) = span(t.y[ip], cl.y0, cl.ny);
                for cy in cy0..=cy1 {
                    let row = cy * cl.nx;
                    let (s0, s1) = (cl.start[row + cx0], cl.start[row + cx1 + 1]);
                    for &q in &cl.items[s0 as usize..s1 as usize] {
                        visit(q as usize);
                    }
                }
            }
            (None, None) => (0..t.len()).for_each(visit),
        }
        best
    }
}

/// Mean and maximum number of points per non-empty hull after inserting all
/// points of one sector without discarding inactive hulls (for reports).
pub fn hull_stats(t: &Terrain, f: &Frame, o: &Options) -> (f64, usize) {
    let ids: Vec<usize> = (0..t.len()).filter(|&q| t.z[q].is_finite()).collect();
    let n = ids.len();
    if n < 2 {
        return (0.0, 0);
    }
    let a: Vec<f64> = ids.iter().map(|&q| f.key_a(t.kx[q], t.ky[q])).collect();
    let b: Vec<f64> = ids.iter().map(|&q| f.key_b(t.kx[q], t.ky[q])).collect();
    let pr: Vec<Proj> = ids
        .iter()
        .map(|&q| project(f, t.x[q], t.y[q], t.z[q], o.curvature))
        .collect();
    let (mut order, mut by_b, mut count) = (Vec::new(), Vec::new(), Vec::new());
    sort_keys(&a, &b, &mut order, &mut count);
    sort_keys(&b, &a, &mut by_b, &mut count);
    let mut rank = vec![0usize; n];
    for (k, &i) in by_b.iter().enumerate() {
        rank[i as usize] = k;
    }
    let big_n = n.next_power_of_two();
    let mut left_open = vec![0u32; big_n];
    for k in 0..n {
        let mut x = big_n + k;
        while x > 1 {
            if x & 1 == 0 {
                left_open[x >> 1] += 1;
            }
            x >>= 1;
        }
    }
    let mut hull: Vec<Vec<Proj>> = vec![Vec::new(); big_n];
    let (mut sum, mut cnt, mut mx) = (0usize, 0usize, 0usize);
    for &i in &order {
        let i = i as usize;
        let mut x = big_n + rank[i];
        while x > 1 {
            let m = x >> 1;
            if x & 1 == 0 {
                left_open[m] -= 1;
                if left_open[m] == 0 && !hull[m].is_empty() {
                    sum += hull[m].len();
                    cnt += 1;
                    mx = mx.max(hull[m].len());
                    hull[m] = Vec::new();
                }
            } else if left_open[m] > 0 {
                insert(&mut hull[m], pr[i]);
            }
            x = m;
        }
    }
    (sum as f64 / cnt.max(1) as f64, mx)
}
