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
//! The tree has a leaf C_k per second index. Node m with left subtree L and
//! right subtree R holds the hull of R's points processed so far (§IV-C:
//! only left children need hulls); when a point of L is processed that hull
//! is part of the covering set of its sector and is queried for its tangent,
//! and a point of R joins it (§IV-A step 2). The paper processes the points
//! one by one in first-index order, walking each leaf-to-root path. Here the
//! same work is done node by node, from the leaves up: a node sees its
//! subtrees' points in first-index order by merging the two lists its
//! children produced (a merge sort on the first index over the leaves in
//! second-index order), so each of its hulls receives the same inserts and
//! the same queries in the same order as in the paper, and every point ends
//! with the maximum over the same covering sets (the order in which a point
//! meets its covering sets does not change that maximum: the comparison is
//! exact and a tie goes to the nearer point, so equal candidates are equal
//! projections). Two levels are one sequential pass over the points with
//! three hulls live, where the paper's walk meets one node per level far
//! apart in memory. Hulls are sorted arrays (the paper's choice; their
//! average size stays below three points, though the queried ones are
//! larger), searched from the node's previous answer.
//!
//! Every orientation test of a sector first compares the rounded
//! determinant with one error bound valid for all triples of the sector's
//! points ([`super::exact::BoxFilter`], from their extent in w and Z); the
//! per-triple filter and the exact sign decide the rest, so every answer is
//! the exact sign and the horizons stay those of `brute`, bit for bit.
//!
//! The near-vertex check of §IV-E is applied by the caller (see
//! [`super::cms::near_vertex`]) when asked for.

use super::exact::{orient, BoxFilter};
use super::{
    better, better_near, elevation, project, Frame, Options, Progress, Proj, Terrain, EMPTY,
};
use crate::cancel::Cancel;
use crate::error::Result;

/// Index of the tangent vertex of upper hull `h` seen from `p` (strictly to
/// its left): the highest elevation, ties to the nearer vertex. The
/// elevations along an upper hull seen from outside are unimodal, and stay
/// so with ties settled by distance, so `h` may be sorted by w either way.
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

/// [`tangent`] searched from a guess `g` (any index) instead of by
/// bisection: the answer is the first i with `better(p, h[i], h[i + 1])`
/// false, a predicate true then false along the hull, so stepping from `g`
/// towards the change (by doubling strides, then bisecting the last stride)
/// finds the same index. Two comparisons when `g` is the answer.
pub fn tangent_from(h: &[Proj], p: Proj, g: usize) -> usize {
    tangent_from_in(h, p, g, BoxFilter::NONE)
}

/// [`tangent_from`] for points inside the box of `bx`.
#[inline(always)]
fn tangent_from_in(h: &[Proj], p: Proj, g: usize, bx: BoxFilter) -> usize {
    let last = h.len() - 1;
    let g = g.min(last);
    let up = |i: usize| better_in(bx, p, h[i], h[i + 1]);
    let (mut lo, mut hi); // the answer lies in lo..=hi
    if g < last && up(g) {
        // the answer is above g
        lo = g + 1;
        let mut step = 1;
        loop {
            if lo == last || !up(lo) {
                return lo;
            }
            let next = (lo + step).min(last);
            if next == last || !up(next) {
                hi = next;
                lo += 1;
                break;
            }
            lo = next + 1;
            step *= 2;
        }
    } else {
        // the answer is g or below
        hi = g;
        let mut step = 1;
        loop {
            if hi == 0 || up(hi - 1) {
                return hi;
            }
            hi -= 1;
            let next = hi.saturating_sub(step);
            if next == 0 || up(next - 1) {
                lo = next;
                break;
            }
            hi = next - 1;
            step *= 2;
        }
    }
    while lo < hi {
        let mid = (lo + hi) / 2;
        if up(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// [`better`] for points inside the box of `bx` (the same answer).
#[inline(always)]
fn better_in(bx: BoxFilter, p: Proj, cur: Proj, cand: Proj) -> bool {
    let (a, b, c) = ((p.w, p.zz), (cur.w, cur.zz), (cand.w, cand.zz));
    match bx.sign(a, b, c) {
        Some(s) => s,
        None => better_near(a, b, c),
    }
}

/// Do a, b, c turn clockwise or lie on a line (orientation ≤ 0)?
#[inline(always)]
fn cw_or_flat(bx: BoxFilter, a: Proj, b: Proj, c: Proj) -> bool {
    let (a, b, c) = ((a.w, a.zz), (b.w, b.zz), (c.w, c.zz));
    match bx.sign(a, b, c) {
        Some(pos) => !pos,
        None => orient(a, b, c) <= 0,
    }
}

/// Do a, b, c turn counter-clockwise or lie on a line (orientation ≥ 0)?
#[inline(always)]
fn ccw_or_flat(bx: BoxFilter, a: Proj, b: Proj, c: Proj) -> bool {
    let (a, b, c) = ((a.w, a.zz), (b.w, b.zz), (c.w, c.zz));
    match bx.sign(a, b, c) {
        Some(pos) => pos,
        None => orient(a, b, c) >= 0,
    }
}

/// Insert `q` into the strictly convex upper hull `h` (sorted by w).
pub fn insert(h: &mut Vec<Proj>, q: Proj) {
    insert_ordered::<false>(h, q, BoxFilter::NONE);
}

/// [`insert`] for a hull sorted by decreasing w (the same hull, reversed:
/// mirroring w flips every orientation). In a merge the new point is most
/// often the nearest so far (its a⊥ key is the largest yet), which is then a
/// push at the end, or lies strictly under the hull between its end points,
/// which the end points show (an upper hull over [w_min, w_max] is concave,
/// so it is nowhere lower than its lower end, nor than the chord joining
/// its ends): then the hull is unchanged, as the general insertion finds
/// after a search.
pub fn insert_desc(h: &mut Vec<Proj>, q: Proj) {
    insert_desc_in(h, q, BoxFilter::NONE);
}

/// [`insert_desc`] for points inside the box of `bx`.
#[inline(always)]
fn insert_desc_in(h: &mut Vec<Proj>, q: Proj, bx: BoxFilter) {
    let n = h.len();
    if n == 0 {
        h.push(q);
        return;
    }
    let (far, near) = (h[0], h[n - 1]);
    if q.w < near.w {
        // a new nearest vertex: pop the vertices on or under segment q–h[k−2]
        let mut k = n;
        while k >= 2 && cw_or_flat(bx, h[k - 2], h[k - 1], q) {
            k -= 1;
        }
        h.truncate(k);
        h.push(q);
        return;
    }
    if q.w > near.w && q.w < far.w {
        // strictly under the hull: under its lower end, or (exactly) under
        // the chord between its end points, which it lies on or above
        if q.zz < far.zz.min(near.zz) || !ccw_or_flat(bx, near, far, q) {
            return;
        }
        // or on or under the edge over it (most such points, in a merge):
        // [`insert_ordered`]'s first test, made here without a call (then
        // 0 < pos < n, and h[pos].w < q.w < h[pos − 1].w)
        let pos = place_desc(h, q);
        if h[pos].w != q.w && ccw_or_flat(bx, h[pos - 1], h[pos], q) {
            return;
        }
    }
    insert_ordered::<true>(h, q, bx);
}

/// The first vertex of `h` (sorted by decreasing w) with w ≤ q.w. In a
/// merge a point that is not the nearest most often falls a few vertices
/// from the near end: a bounded scan from there, then bisection of the
/// rest.
#[inline(always)]
fn place_desc(h: &[Proj], q: Proj) -> usize {
    let n = h.len();
    let mut pos = n;
    while pos > 0 && h[pos - 1].w <= q.w {
        pos -= 1;
        if n - pos == SCAN {
            return h[..pos].partition_point(|v| v.w > q.w);
        }
    }
    pos
}

/// Vertices [`insert_ordered`] scans from the near end before bisecting.
const SCAN: usize = 8;

/// The general insertion into a hull sorted by increasing w, or by
/// decreasing w when `DESC` (every orientation then flips sign).
#[inline]
fn insert_ordered<const DESC: bool>(h: &mut Vec<Proj>, q: Proj, bx: BoxFilter) {
    // orientation ≤ 0 and ≥ 0 in the hull's order (mirrored when DESC)
    let le0 = |a, b, c| {
        if DESC {
            ccw_or_flat(bx, a, b, c)
        } else {
            cw_or_flat(bx, a, b, c)
        }
    };
    let ge0 = |a, b, c| {
        if DESC {
            cw_or_flat(bx, a, b, c)
        } else {
            ccw_or_flat(bx, a, b, c)
        }
    };
    let n = h.len();
    // The first vertex not before q (w ≥ q.w, or ≤ when DESC).
    let mut pos = if DESC {
        place_desc(h, q)
    } else {
        h.partition_point(|v| v.w < q.w)
    };
    let mut end = pos; // h[pos..end] will be replaced by q
    if pos < n && h[pos].w == q.w {
        if h[pos].zz >= q.zz {
            return;
        }
        end = pos + 1;
    }
    if pos > 0 && end < n && le0(h[pos - 1], h[end], q) {
        return; // on or below the hull
    }
    while end + 1 < n && ge0(q, h[end], h[end + 1]) {
        end += 1;
    }
    while pos >= 2 && ge0(h[pos - 2], h[pos - 1], q) {
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
/// descending, then index ascending, written to `out` (see
/// [`sort_keys_with`]).
pub fn sort_keys(k1: &[f64], k2: &[f64], out: &mut Vec<u32>) {
    sort_keys_with(k1, k2, out, &mut SortBuf::default(), None);
}

/// Scratch buffers of [`sort_keys_with`], kept between calls.
#[derive(Default)]
pub struct SortBuf {
    count: Vec<u32>,
    bucket: Vec<u32>,
    pairs: Vec<(u32, u32)>,
    sorted: Vec<u32>,
}

/// [`sort_keys`] with caller-kept buffers; when `ties` is given, it
/// receives the runs `start..end` of `out` whose `k1` are equal (same
/// bits), in order.
///
/// A sort on a bucket number that is a monotone function of `k1` (computed
/// in floating point with monotone operations only, so k1 ≤ k1' gives
/// bucket ≤ bucket'), then the exact comparison inside each bucket. On a
/// grid the keys are spread almost evenly over the n buckets, which hold
/// one or two points; O(n) instead of a comparison sort's O(n log n). The
/// bucket numbers are sorted by two stable counting passes on their low and
/// high halves (least significant first), each scattering into at most a
/// few thousand sequential streams, where one pass over n buckets would
/// scatter into n places of a multi-megabyte array; indices stay ascending
/// inside a bucket either way.
pub fn sort_keys_with(
    k1: &[f64],
    k2: &[f64],
    out: &mut Vec<u32>,
    sb: &mut SortBuf,
    mut ties: Option<&mut Vec<(u32, u32)>>,
) {
    let n = k1.len();
    out.resize(n, 0);
    if let Some(t) = ties.as_deref_mut() {
        t.clear();
    }
    if n == 0 {
        return;
    }
    // (plain comparisons, which ignore a NaN as min and max do)
    // in four interleaved chains (a comparison waits on the previous one)
    let mut l4 = [f64::INFINITY; 4];
    let mut h4 = [f64::NEG_INFINITY; 4];
    let mut quads = k1.chunks_exact(4);
    for q in &mut quads {
        for ((l, h), &v) in l4.iter_mut().zip(h4.iter_mut()).zip(q) {
            (*l, *h) = (if v < *l { v } else { *l }, if v > *h { v } else { *h });
        }
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in l4.iter().chain(h4.iter()).chain(quads.remainder()) {
        (lo, hi) = (if v < lo { v } else { lo }, if v > hi { v } else { hi });
    }
    let nb = n;
    let scale = if hi > lo {
        (nb - 1) as f64 / (hi - lo)
    } else {
        0.0
    };
    // (capped before the conversion, which gives the same numbers: a NaN
    // still converts to 0)
    let top = (nb - 1) as f64;
    let bucket = |v: f64| {
        let x = (v - lo) * scale;
        (if x > top { top } else { x }) as u32
    };
    // bits of the largest bucket number, split into a low and a high digit
    let bits = usize::BITS - (nb - 1).leading_zeros();
    let shift = bits.div_ceil(2);
    let mask = (1u32 << shift) - 1;
    let h = 1usize << shift;
    let count = &mut sb.count;
    count.clear();
    count.resize(3 * h, 0);
    // The bucket numbers, counted as they are made.
    // Points in input order (on a grid, along its rows) mostly share their
    // high digit with the previous point: its count is kept in two copies,
    // for even and odd positions, so that consecutive increments of one
    // counter do not wait on each other.
    sb.bucket.resize(n, 0);
    let mut pairs = sb.bucket.chunks_exact_mut(2).zip(k1.chunks_exact(2));
    for (b, v) in &mut pairs {
        let (b0, b1) = (bucket(v[0]), bucket(v[1]));
        (b[0], b[1]) = (b0, b1);
        count[(b0 & mask) as usize] += 1;
        count[(b1 & mask) as usize] += 1;
        count[h + (b0 >> shift) as usize] += 1;
        count[2 * h + (b1 >> shift) as usize] += 1;
    }
    if n % 2 == 1 {
        let b = bucket(k1[n - 1]);
        sb.bucket[n - 1] = b;
        count[(b & mask) as usize] += 1;
        count[h + (b >> shift) as usize] += 1;
    }
    let (count, odd) = count.split_at_mut(2 * h);
    for (c, o) in count[h..].iter_mut().zip(odd.iter()) {
        *c += *o;
    }
    for half in count.chunks_mut(h) {
        let mut sum = 0;
        for c in half {
            (*c, sum) = (sum, sum + *c);
        }
    }
    sb.pairs.resize(n, (0, 0));
    for (i, &b) in sb.bucket.iter().enumerate() {
        let d = (b & mask) as usize;
        sb.pairs[count[d] as usize] = (b, i as u32);
        count[d] += 1;
    }
    sb.sorted.resize(n, 0);
    for &(b, i) in &sb.pairs[..n] {
        let d = h + (b >> shift) as usize;
        let at = count[d] as usize;
        out[at] = i;
        sb.sorted[at] = b;
        count[d] += 1;
    }
    let cmp = |i: &u32, j: &u32| {
        let (i, j) = (*i as usize, *j as usize);
        k1[i]
            .total_cmp(&k1[j])
            .then(k2[j].total_cmp(&k2[i]))
            .then(i.cmp(&j))
    };
    // Buckets of more than one point: the exact order, and the runs of
    // equal keys (which only a shared bucket can hold).
    let sorted = &sb.sorted[..n];
    let mut start = 0usize;
    while start < n {
        let mut end = start + 1;
        while end < n && sorted[end] == sorted[start] {
            end += 1;
        }
        // the keys of a shared bucket are read in an order far from their own
        for &i in out.iter().skip(start + AHEAD).take(end - start) {
            prefetch(k1, i as usize);
        }
        if end - start > 1 {
            let run = &mut out[start..end];
            // most shared buckets hold two points: one comparison, no sort call
            if let [x, y] = run {
                if cmp(y, x).is_lt() {
                    std::mem::swap(x, y);
                }
            } else {
                run.sort_unstable_by(cmp);
            }
            if let Some(t) = ties.as_deref_mut() {
                equal_runs(k1, run, |a, b| {
                    t.push(((start + a) as u32, (start + b) as u32))
                });
            }
        }
        start = end;
    }
}

/// Each run `a..b` of two or more consecutive entries of `idx` with
/// bit-equal `k1`, in order.
fn equal_runs(k1: &[f64], idx: &[u32], mut f: impl FnMut(usize, usize)) {
    let mut a = 0;
    while a < idx.len() {
        let key = k1[idx[a] as usize].to_bits();
        let mut b = a + 1;
        while b < idx.len() && k1[idx[b] as usize].to_bits() == key {
            b += 1;
        }
        if b - a > 1 {
            f(a, b);
        }
        a = b;
    }
}

/// The runs `start..end` of `out` (points of equal first key, as
/// [`sort_keys_with`] reports them) sorted by `k2` descending, then index
/// ascending: an order by the same first key with other tie rules becomes
/// [`sort_keys`]' order by (k1, k2).
pub fn sort_runs(k2: &[f64], out: &mut [u32], runs: &[(u32, u32)]) {
    let cmp = |i: &u32, j: &u32| {
        let (i, j) = (*i as usize, *j as usize);
        k2[j].total_cmp(&k2[i]).then(i.cmp(&j))
    };
    for &(start, end) in runs {
        out[start as usize..end as usize].sort_unstable_by(cmp);
    }
}

/// Ranks per leaf block: the lowest levels of the tree (right subtrees of at
/// most `BLOCK`/2 ranks) keep no hull. Inside a block the covering sets met
/// from rank k are the block's processed points of rank > k, whose maximum is
/// taken directly: the tangent of a hull is the maximum of the points it was
/// built from (§IV-B). 32 measured faster than 16. At most 64: a block's
/// processed ranks are the bits of one u64.
const BLOCK: usize = 32;
const _: () = assert!(BLOCK <= 64);

/// A point on its way through the levels: its projection, its best horizon
/// point so far (`ABSENT`: none) and its a⊥ rank (processing order).
/// Packed to 36 bytes (no padding after `a`): every merge pass streams the
/// records through memory.
#[derive(Clone, Copy)]
#[repr(C, packed(4))]
struct Rec {
    p: Proj,
    best: Proj,
    a: u32,
}

const ABSENT: Proj = Proj {
    w: f64::NAN,
    zz: f64::NAN,
};

/// The upper hull of one node (vertices by decreasing w), with the largest
/// Z of every point inserted so far (the extreme points of a set are
/// vertices of its hull: its smallest and largest w are those of the
/// hull's ends).
struct Hull {
    h: Vec<Proj>,
    zmax: f64,
    /// The sector's box (every point's w and Z inside it).
    bx: BoxFilter,
    /// The last tangent index found: consecutive queries of one node come
    /// in a⊥ order and mostly share their answer (about 3 in 4 on a terrain
    /// grid, most others one vertex off), so the next search starts there.
    guess: usize,
}

impl Hull {
    fn clear(&mut self) {
        self.h.clear();
        self.zmax = f64::NEG_INFINITY;
        self.guess = 0;
    }

    #[inline(always)]
    fn add(&mut self, q: Proj) {
        // (plain comparisons: every coordinate is a number)
        self.zmax = if q.zz > self.zmax { q.zz } else { self.zmax };
        insert_desc_in(&mut self.h, q, self.bx);
    }

    /// Can no point of this hull beat `best` (a point of p's sector) seen
    /// from `p`? Every point q of the hull lies under the corner
    /// c = (w_min, Z_max) seen from p when Z_max ≥ Z_p, and under
    /// c = (w_max, Z_max) otherwise (the slope (Z_q − Z_p)/(w_q − w_p) grows
    /// with Z_q and, for a positive numerator, as w_q shrinks; for a
    /// negative one, as w_q grows). So when c lies strictly under the line
    /// from p through `best` (exact orientation, filtered: an uncertain
    /// sign does not skip) no hull point reaches `best`'s elevation, not
    /// even in a tie, and the hull can be skipped. This is the comparison
    /// of the slopes themselves, without their quotients. (All of this
    /// needs w_q > w_p for every q, which w_min > w_p ensures.)
    #[inline(always)]
    fn cannot_beat(&self, p: Proj, best: Proj) -> bool {
        let (wmax, wmin) = match (self.h.first(), self.h.last()) {
            (Some(far), Some(near)) => (far.w, near.w),
            _ => return false,
        };
        let cw = if self.zmax >= p.zz { wmin } else { wmax };
        wmin > p.w
            && best.w > p.w
            && self
                .bx
                .sign((p.w, p.zz), (best.w, best.zz), (cw, self.zmax))
                == Some(false)
    }

    /// The best of `r.best` and this hull's tangent point for `r.p`.
    #[inline(always)]
    fn query(&mut self, r: &mut Rec) {
        let p = r.p;
        // Skip a hull that cannot beat the best so far without searching it
        // (no best yet: `best.w` is NaN, never skipped).
        if self.cannot_beat(p, r.best) {
            return;
        }
        self.guess = tangent_from_in(&self.h, p, self.guess, self.bx);
        r.best = pick(self.bx, p, r.best, self.h[self.guess]);
    }
}

impl Default for Hull {
    fn default() -> Hull {
        let mut h = Hull {
            h: Vec::new(),
            zmax: 0.0,
            bx: BoxFilter::NONE,
            guess: 0,
        };
        h.clear();
        h
    }
}

/// Buffers of one sector computation, reused across the sectors a thread
/// computes (the allocation and first touch of ~100 MB per sector at n = 1M
/// is otherwise a visible share of the time).
#[derive(Default)]
pub struct Work {
    ids: Vec<usize>,
    a: Vec<f64>,
    b: Vec<f64>,
    /// Every point's projection and a⊥ rank side by side: the leaf blocks'
    /// gather reads one place per point.
    pa: Vec<(Proj, u32)>,
    order: Vec<u32>,
    by_b: Vec<u32>,
    /// Runs of equal b⊥ keys in `by_b` (the a⊥ ties of the next sector).
    ties: Vec<(u32, u32)>,
    sort: SortBuf,
    src: Vec<Rec>,
    kin: Vec<u8>,
    dst: Vec<Rec>,
    hull: Hull,
    hulls: [Hull; 3],
    /// The terrain (its key array and point count) and b⊥ vector of the
    /// sector these buffers last computed: `b` and `by_b` still hold its
    /// b⊥ keys and order. Cleared by [`release`] at the end of every
    /// computation, so the array's address is only ever compared within
    /// one terrain's computation.
    last: Option<(usize, usize, u64, u64)>,
}

impl Work {
    /// Room for `n` points in every buffer. Buffers too small are replaced
    /// by fresh ones (their contents dropped, so the next sector does not
    /// follow on from the last) backed by huge pages where the system
    /// offers them: the gathers and scatters by a⊥ or b⊥ order touch a
    /// different 4 KiB page at almost every step, and miss the TLB.
    fn reserve(&mut self, n: usize) {
        if self.src.capacity() >= n {
            return;
        }
        fn fresh<T>(v: &mut Vec<T>, n: usize) {
            *v = Vec::with_capacity(n);
            crate::scratch::advise_huge(v.as_ptr(), v.capacity());
        }
        fresh(&mut self.ids, n);
        fresh(&mut self.a, n);
        fresh(&mut self.b, n);
        fresh(&mut self.pa, n);
        fresh(&mut self.order, n);
        fresh(&mut self.by_b, n);
        fresh(&mut self.src, n);
        fresh(&mut self.kin, n);
        fresh(&mut self.dst, n);
        fresh(&mut self.sort.bucket, n);
        fresh(&mut self.sort.pairs, n);
        fresh(&mut self.sort.sorted, n);
        self.last = None;
    }
}

/// The best of `best` (`ABSENT`: none) and `c` for `p` (exact; ties to the
/// nearer point), for points inside the box of `bx`.
#[inline(always)]
fn pick(bx: BoxFilter, p: Proj, best: Proj, c: Proj) -> Proj {
    if best.w.is_nan() || better_in(bx, p, best, c) {
        c
    } else {
        best
    }
}

/// One block of ranks by the definition: `r` holds the block's points in a⊥
/// order and `kin` their ranks inside the block; each point against the
/// block's points already processed with a higher rank.
///
/// The maximum over those points is taken in four independent chains
/// (candidates dealt round-robin), combined at the end: the maximum does
/// not depend on the order of comparison (the comparison is exact and a
/// tie goes to the nearer point, so equal candidates are equal
/// projections). Each step selects a rank without branching on the
/// outcome, which follows no pattern; one chain's steps would wait on
/// each other.
fn leaf_block(r: &mut [Rec], kin: &[u8], bx: BoxFilter) {
    // The block's processed points by rank, so that a candidate is read
    // directly by its rank.
    let mut by_rank = [ABSENT; BLOCK];
    let mut done = 0u64; // bit k: rank k of the block processed
    for (rec, &k) in r.iter_mut().zip(kin) {
        let k = k as usize % BLOCK;
        let p = rec.p;
        // the processed ranks above k (none for k = 63: 2 << 63 is 0)
        let mut rest = done & !(2u64 << k).wrapping_sub(1);
        if rest != 0 {
            // the better of ranks i and j for p (exact; ties to the nearer)
            let sel = |i: usize, j: usize| {
                let (cur, cand) = (by_rank[i], by_rank[j]);
                let (a, b, c) = ((p.w, p.zz), (cur.w, cur.zz), (cand.w, cand.zz));
                let take = match bx.sign_flat(a, b, c) {
                    Some(s) => s,
                    None => better_near(a, b, c),
                };
                if take {
                    j
                } else {
                    i
                }
            };
            // the lowest rank left (rest ≠ 0), removed from rest
            let next = |rest: &mut u64| {
                let j = rest.trailing_zeros() as usize;
                *rest &= *rest - 1;
                j
            };
            let mut c = [next(&mut rest); 4];
            let mut m = 1;
            while rest != 0 && m < 4 {
                c[m] = next(&mut rest);
                m += 1;
            }
            while rest != 0 {
                for cj in c.iter_mut() {
                    if rest == 0 {
                        break;
                    }
                    let j = next(&mut rest);
                    *cj = sel(*cj, j);
                }
            }
            // (m chains are in use: a point against itself would be a
            // flat triple, which the filters leave to the exact sign)
            let x = if m > 1 { sel(c[0], c[1]) } else { c[0] };
            let y = if m > 3 { sel(c[2], c[3]) } else { c[2] };
            let z = if m > 2 { sel(x, y) } else { x };
            rec.best = pick(bx, p, rec.best, by_rank[z]);
        }
        by_rank[k] = p;
        done |= 1 << k;
    }
}

/// One node of the tree: `src` holds its left subtree's points (lower
/// ranks) then its right subtree's, each in a⊥ order. Merging them in a⊥
/// order into `dst`, the right points join the hull (§IV-A step 2) and each
/// left point queries the hull of the right points before it (the covering
/// set of its sector at this node, step 1).
#[inline(never)]
fn merge(src: &[Rec], mid: usize, dst: &mut [Rec], hull: &mut Hull) {
    let (left, right) = src.split_at(mid);
    hull.clear();
    let (mut i, mut j, mut o) = (0, 0, 0);
    while i < left.len() && j < right.len() {
        if right[j].a < left[i].a {
            hull.add(right[j].p);
            dst[o] = right[j];
            j += 1;
        } else {
            let mut r = left[i];
            if !hull.h.is_empty() {
                hull.query(&mut r);
            }
            dst[o] = r;
            i += 1;
        }
        o += 1;
    }
    for &l in &left[i..] {
        let mut r = l;
        if !hull.h.is_empty() {
            hull.query(&mut r);
        }
        dst[o] = r;
        o += 1;
    }
    dst[o..].copy_from_slice(&right[j..]);
}

/// a⊥ rank of `s[i]`, `u32::MAX` past the end.
#[inline(always)]
fn head(s: &[Rec], i: usize) -> u32 {
    match s.get(i) {
        Some(r) => r.a,
        None => u32::MAX,
    }
}

/// Two levels of the tree in one pass: `src` holds up to four runs of
/// `width` points (subtrees LL, LR, RL, RR in rank order), each in a⊥ order.
/// Merging LL with LR and RL with RR is [`merge`] at nodes A = (LL, LR) and
/// B = (RL, RR); merging the two results is [`merge`] at their parent C.
/// Here the three merges run as one, each point taken once from its run in
/// a⊥ order and written once, with the three hulls live together: every
/// hull sees the same inserts and queries in the same order as in two
/// separate passes (a hull whose queries are all done takes no more
/// points), and every point queries its lower node's hull before
/// its upper node's, as there.
///
/// Kept out of line: inlined into [`sector_with`] its loop was compiled
/// with more spills (4 % more instructions for the whole sector).
#[inline(never)]
fn merge4(src: &[Rec], width: usize, dst: &mut [Rec], hulls: &mut [Hull; 3]) {
    let (ll, rest) = src.split_at(width.min(src.len()));
    let (lr, rest) = rest.split_at(width.min(rest.len()));
    let (rl, rr) = rest.split_at(width.min(rest.len()));
    let [ha, hb, hc] = hulls;
    ha.clear();
    hb.clear();
    hc.clear();
    let (mut i0, mut i1, mut j0, mut j1) = (0, 0, 0, 0);
    // the runs' next a⊥ ranks, and the smaller of each pair
    let (mut a0, mut a1, mut b0, mut b1) = (head(ll, 0), head(lr, 0), head(rl, 0), head(rr, 0));
    let (mut x, mut y) = (a0.min(a1), b0.min(b1));
    for d in dst.iter_mut() {
        let mut r;
        if x < y {
            // from node A's side of C: queries C's hull
            if a0 < a1 {
                r = ll[i0];
                i0 += 1;
                a0 = head(ll, i0);
                if !ha.h.is_empty() {
                    ha.query(&mut r);
                }
            } else {
                r = lr[i1];
                i1 += 1;
                a1 = head(lr, i1);
                if i0 < ll.len() {
                    ha.add(r.p);
                }
            }
            x = a0.min(a1);
            if !hc.h.is_empty() {
                hc.query(&mut r);
            }
        } else {
            // from node B's side of C: joins C's hull
            if b0 < b1 {
                r = rl[j0];
                j0 += 1;
                b0 = head(rl, j0);
                if !hb.h.is_empty() {
                    hb.query(&mut r);
                }
            } else {
                r = rr[j1];
                j1 += 1;
                b1 = head(rr, j1);
                if j0 < rl.len() {
                    hb.add(r.p);
                }
            }
            y = b0.min(b1);
            if x != u32::MAX {
                hc.add(r.p);
            }
        }
        *d = r;
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
    w.reserve(t.len());
    // When every height is finite the points are the terrain's own, in
    // order: no list of them is made, and their keys and projections are
    // read in sequence.
    let all = t.finite;
    let n = if all {
        w.ids.clear();
        t.len()
    } else {
        t.split_no_data(plane, &mut w.ids);
        w.ids.len()
    };
    if n == 0 {
        return Ok(());
    }
    let ids = std::mem::take(&mut w.ids);
    // a⊥ of sector i + 1 is b⊥ of sector i, bit for bit (the shared border
    // ray): after sector i this thread holds those keys and their order,
    // which is the first-index order here except inside runs of equal keys
    // (ties go by the other key: the runs found by the last b⊥ sort are
    // re-sorted).
    let this = |v: (f64, f64)| (t.kx.as_ptr() as usize, n, v.0.to_bits(), v.1.to_bits());
    let follows = w.last == Some(this(f.aperp));
    w.last = None;
    if follows {
        std::mem::swap(&mut w.a, &mut w.b);
        std::mem::swap(&mut w.order, &mut w.by_b);
    } else {
        w.a.clear();
        if all {
            w.a.extend(t.kx.iter().zip(&t.ky).map(|(&x, &y)| f.key_a(x, y)));
        } else {
            w.a.extend(ids.iter().map(|&q| f.key_a(t.kx[q], t.ky[q])));
        }
    }
    w.b.clear();
    if all {
        w.b.extend(t.kx.iter().zip(&t.ky).map(|(&x, &y)| f.key_b(x, y)));
    } else {
        w.b.extend(ids.iter().map(|&q| f.key_b(t.kx[q], t.ky[q])));
    }
    // The projections, and their extent in w and Z for the sector's
    // orientation bound below (plain comparisons, which ignore a NaN as
    // min and max do).
    let (mut wr, mut zr) = (
        (f64::INFINITY, f64::NEG_INFINITY),
        (f64::INFINITY, f64::NEG_INFINITY),
    );
    let mut proj = |x: f64, y: f64, z: f64| {
        let pr = project(f, x, y, z, o.curvature);
        wr.0 = if pr.w < wr.0 { pr.w } else { wr.0 };
        wr.1 = if pr.w > wr.1 { pr.w } else { wr.1 };
        zr.0 = if pr.zz < zr.0 { pr.zz } else { zr.0 };
        zr.1 = if pr.zz > zr.1 { pr.zz } else { zr.1 };
        (pr, 0)
    };
    w.pa.clear();
    if all {
        let xyz = t.x.iter().zip(&t.y).zip(&t.z);
        w.pa.extend(xyz.map(|((&x, &y), &z)| proj(x, y, z)));
    } else {
        w.pa.extend(ids.iter().map(|&q| proj(t.x[q], t.y[q], t.z[q])));
    }

    // First index: a⊥ ascending, ties b⊥ descending, then input order.
    if follows {
        sort_runs(&w.b, &mut w.order, &w.ties);
    } else {
        sort_keys_with(&w.a, &w.b, &mut w.order, &mut w.sort, None);
    }
    // Second index: b⊥ ascending, ties a⊥ descending, then input order.
    sort_keys_with(&w.b, &w.a, &mut w.by_b, &mut w.sort, Some(&mut w.ties));
    w.last = Some(this(f.bperp));
    // a⊥ rank of every point (`pa` read and written in an order far from
    // its own: each entry is fetched ahead, see [`prefetch`])
    for (s, &i) in w.order.iter().enumerate() {
        if let Some(&j) = w.order.get(s + AHEAD) {
            prefetch(&w.pa, j as usize);
        }
        w.pa[i as usize].1 = s as u32;
    }
    // The points by block of leaves (second-index order, written in
    // sequence), then each block in a⊥ order, with their rank inside the
    // block. Every slot of `src`, `kin` and (by the first pass) `dst` is
    // written before it is read, so their old contents stay.
    let blank = Rec {
        p: ABSENT,
        best: ABSENT,
        a: 0,
    };
    w.src.resize(n, blank);
    w.kin.resize(n, 0);
    w.dst.resize(n, blank);
    let mut keys = [0u64; BLOCK];
    for (c, ((src, kin), ids)) in w
        .src
        .chunks_mut(BLOCK)
        .zip(w.kin.chunks_mut(BLOCK))
        .zip(w.by_b.chunks(BLOCK))
        .enumerate()
    {
        for &j in w.by_b.iter().skip((c + 2) * BLOCK).take(BLOCK) {
            prefetch(&w.pa, j as usize);
        }
        let keys = &mut keys[..ids.len()];
        for (k, (key, &i)) in keys.iter_mut().zip(ids).enumerate() {
            *key = (w.pa[i as usize].1 as u64) << 8 | k as u64;
        }
        keys.sort_unstable();
        for ((r, kk), &key) in src.iter_mut().zip(kin.iter_mut()).zip(keys.iter()) {
            let k = (key & 0xff) as u8;
            *r = Rec {
                p: w.pa[ids[k as usize] as usize].0,
                best: ABSENT,
                a: (key >> 8) as u32,
            };
            *kk = k;
        }
    }

    // The tree level by level from the leaves up, instead of point by point
    // from the root down (the same hulls meet the same queries, so the same
    // answers): two levels per sequential pass, with at most three hulls
    // live at a time, instead of one walk per point through nodes far
    // apart in memory. The leaf blocks are computed by the first pass just
    // before it merges them, while they are in cache.
    // One error bound for every orientation test of this sector (see
    // [`BoxFilter`]): its points' extent in w and Z.
    let bx = BoxFilter::new(wr, zr);
    w.hull.bx = bx;
    for h in &mut w.hulls {
        h.bx = bx;
    }
    let levels = (n.div_ceil(BLOCK)).next_power_of_two().trailing_zeros() as usize + 1;
    let share = n / levels;
    if n <= BLOCK {
        leaf_block(&mut w.src, &w.kin, bx);
    }
    progress.add(share);
    let mut width = BLOCK;
    while width < n {
        // Two levels per pass while two remain, then the last one alone.
        let two = 2 * width < n;
        let span = if two { 4 * width } else { 2 * width };
        let chunks = w.src.chunks_mut(span).zip(w.kin.chunks(span));
        for ((s, k), d) in chunks.zip(w.dst.chunks_mut(span)) {
            if width == BLOCK {
                for (c, k) in s.chunks_mut(BLOCK).zip(k.chunks(BLOCK)) {
                    leaf_block(c, k, bx);
                }
            }
            let s = &*s;
            if s.len() <= width {
                d.copy_from_slice(s);
            } else if two {
                merge4(s, width, d, &mut w.hulls);
            } else {
                merge(s, width, d, &mut w.hull);
            }
        }
        std::mem::swap(&mut w.src, &mut w.dst);
        width = span;
        cancel.check()?;
        progress.add(if two { 2 * share } else { share });
    }
    // w.src is now in a⊥ order: w.src[s].a == s.
    let limit = o.max_distance.map(|d| Limit::new(t, f, o, d));
    let dense = n == t.len(); // every point has data: ids[i] == i
    for (s, (r, &i)) in w.src.iter().zip(&w.order).enumerate() {
        if let (true, Some(&j)) = (dense, w.order.get(s + AHEAD)) {
            prefetch(plane, j as usize);
        }
        let i = if dense { i as usize } else { ids[i as usize] };
        let best = match &limit {
            Some(lim) if !r.best.w.is_nan() && !lim.surely_within(r.p, r.best) => {
                lim.search(i, r.p)
            }
            _ => (!r.best.w.is_nan()).then_some(r.best),
        };
        plane[i] = match best {
            None => EMPTY,
            Some(q) => elevation(r.p, q, o.curvature),
        };
    }
    progress.add(n - share * (levels));
    w.ids = ids;
    Ok(())
}

/// How far ahead [`prefetch`] is asked for in a gather by a permutation.
const AHEAD: usize = 64;

/// Ask for `v[i]`'s cache line ahead of its use (no effect on results; a
/// no-op off x86-64 or past the end). On a grid, an order by a⊥ or b⊥ key
/// walks the points along lines across the rows, so consecutive entries of
/// a gather lie on different pages of a multi-megabyte array: without this
/// each one waits for its own page walk and cache miss.
#[inline(always)]
fn prefetch<T>(v: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(x) = v.get(i) {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch hint reads nothing and cannot fault; SSE is
        // part of every x86-64 target.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (v, i);
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
        let mut best = ABSENT;
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
            best = pick(
                BoxFilter::NONE,
                p,
                best,
                project(f, t.x[q], t.y[q], t.z[q], self.c),
            );
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
        (!best.w.is_nan()).then_some(best)
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
    let (mut order, mut by_b) = (Vec::new(), Vec::new());
    sort_keys(&a, &b, &mut order);
    sort_keys(&b, &a, &mut by_b);
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
