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

const INLINE: usize = 3;
const PREFETCH_AHEAD: usize = 8;
const NO_SPILL: u32 = u32::MAX;

/// One slot of the tree: the count of unprocessed leaves in its left
/// subtree and its hull, inline up to three points (one cache line), in a
/// recycled spill vector beyond.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    open: u32,
    len: u32,
    spill: u32,
    _pad: u32,
    pts: [Proj; INLINE],
}

struct Tree {
    node: Vec<Node>,
    spill: Vec<Vec<Proj>>,
    free: Vec<u32>,
    scratch: Vec<Proj>,
}

impl Tree {
    fn new(n: usize, big_n: usize) -> Tree {
        let empty = Node {
            open: 0,
            len: 0,
            spill: NO_SPILL,
            _pad: 0,
            pts: [Proj { w: 0.0, zz: 0.0 }; INLINE],
        };
        let mut node = vec![empty; big_n.max(1)];
        // open[m] = real leaves (k < n) under the left child 2m, whose
        // leaves are k in [m·2^t − N, m·2^t − N + 2^(t−1)), t the height of m.
        let log_n = big_n.trailing_zeros();
        for (m, nd) in node.iter_mut().enumerate().skip(1) {
            let t = log_n - m.ilog2();
            let start = (m << t) - big_n;
            let span = 1usize << (t - 1);
            nd.open = n.saturating_sub(start).min(span) as u32;
        }
        Tree {
            node,
            spill: Vec::new(),
            free: Vec::new(),
            scratch: Vec::with_capacity(INLINE + 1),
        }
    }

    #[inline]
    fn prefetch(&self, m: usize) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: a prefetch hint never faults; the pointer is in bounds.
        unsafe {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            _mm_prefetch(self.node.as_ptr().add(m) as *const i8, _MM_HINT_T0);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = m;
    }

    #[inline]
    fn hull(&self, m: usize) -> &[Proj] {
        let nd = &self.node[m];
        if nd.spill == NO_SPILL {
            &nd.pts[..nd.len as usize]
        } else {
            &self.spill[nd.spill as usize]
        }
    }

    /// A leaf of m's left subtree was processed; discard the hull when none
    /// is left (the slot becomes inactive, §IV-C).
    #[inline]
    fn close_one(&mut self, m: usize) {
        let nd = &mut self.node[m];
        nd.open -= 1;
        if nd.open == 0 {
            nd.len = 0;
            if nd.spill != NO_SPILL {
                self.spill[nd.spill as usize].clear();
                self.free.push(nd.spill);
                nd.spill = NO_SPILL;
            }
        }
    }

    fn insert(&mut self, m: usize, q: Proj) {
        let nd = &mut self.node[m];
        if nd.spill != NO_SPILL {
            insert(&mut self.spill[nd.spill as usize], q);
            return;
        }
        let len = nd.len as usize;
        // Fast path: most points fall under the hull and change nothing.
        if len >= 2 {
            let pos = nd.pts[..len].partition_point(|v| v.w < q.w);
            if pos < len {
                let r = nd.pts[pos];
                if r.w == q.w {
                    if r.zz >= q.zz {
                        return; // as `insert`: a higher point at the same w
                    }
                } else if pos > 0 && o3(nd.pts[pos - 1], r, q) <= 0 {
                    return; // as `insert`: on or below the hull
                }
            }
        }
        self.scratch.clear();
        self.scratch.extend_from_slice(&nd.pts[..len]);
        insert(&mut self.scratch, q);
        if self.scratch.len() <= INLINE {
            nd.pts[..self.scratch.len()].copy_from_slice(&self.scratch);
            nd.len = self.scratch.len() as u32;
        } else {
            let id = match self.free.pop() {
                Some(id) => id,
                None => {
                    self.spill.push(Vec::new());
                    (self.spill.len() - 1) as u32
                }
            };
            let v = &mut self.spill[id as usize];
            v.clear();
            v.extend_from_slice(&self.scratch);
            nd.spill = id;
            nd.len = 0;
        }
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
    let ids: Vec<usize> = (0..t.len()).filter(|&q| t.z[q].is_finite()).collect();
    for (q, v) in plane.iter_mut().enumerate() {
        if !t.z[q].is_finite() {
            *v = f32::NAN;
        }
    }
    let n = ids.len();
    if n == 0 {
        return Ok(());
    }
    let a: Vec<f64> = ids.iter().map(|&q| f.key_a(t.kx[q], t.ky[q])).collect();
    let b: Vec<f64> = ids.iter().map(|&q| f.key_b(t.kx[q], t.ky[q])).collect();
    let pr: Vec<Proj> = ids
        .iter()
        .map(|&q| project(f, t.x[q], t.y[q], t.z[q], o.curvature))
        .collect();
    // First index: a⊥ ascending, ties b⊥ descending, then input order.
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_unstable_by(|&i, &j| {
        let (i, j) = (i as usize, j as usize);
        a[i].total_cmp(&a[j])
            .then(b[j].total_cmp(&b[i]))
            .then(i.cmp(&j))
    });
    // Second index: b⊥ ascending, ties a⊥ descending, then input order.
    let mut by_b: Vec<u32> = (0..n as u32).collect();
    by_b.sort_unstable_by(|&i, &j| {
        let (i, j) = (i as usize, j as usize);
        b[i].total_cmp(&b[j])
            .then(a[j].total_cmp(&a[i]))
            .then(i.cmp(&j))
    });
    let mut rank = vec![0u32; n];
    for (k, &i) in by_b.iter().enumerate() {
        rank[i as usize] = k as u32;
    }
    drop(by_b);
    let big_n = n.next_power_of_two();
    let mut tree = Tree::new(n, big_n);
    for (step, &i) in order.iter().enumerate() {
        if step % 4096 == 4095 {
            cancel.check()?;
            progress.add(4096);
        }
        // The walk is bound by memory latency (one slot per level, far
        // apart): fetch the slots of a point a few steps ahead.
        if let Some(&ahead) = order.get(step + PREFETCH_AHEAD) {
            let mut x = big_n + rank[ahead as usize] as usize;
            while x > 1 {
                tree.prefetch(x >> 1);
                x >>= 1;
            }
        }
        let i = i as usize;
        let p = pr[i];
        let mut best: Option<Proj> = None;
        let mut x = big_n + rank[i] as usize;
        while x > 1 {
            let m = x >> 1;
            if x & 1 == 0 {
                // Step 1: the left child's hull covers part of Σ_{*,k}.
                let h = tree.hull(m);
                if !h.is_empty() {
                    let c = h[tangent(h, p)];
                    best = match best {
                        Some(bq) if !better(p, bq, c) => Some(bq),
                        _ => Some(c),
                    };
                }
                tree.close_one(m);
            } else if tree.node[m].open > 0 {
                // Step 2: join the covering sets of Σ_{*,t}, t < k.
                tree.insert(m, p);
            }
            x = m;
        }
        plane[ids[i]] = match best {
            None => EMPTY,
            Some(q) => elevation(p, q, o.curvature),
        };
    }
    progress.add(n % 4096);
    Ok(())
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
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_unstable_by(|&i, &j| {
        a[i].total_cmp(&a[j])
            .then(b[j].total_cmp(&b[i]))
            .then(i.cmp(&j))
    });
    let mut by_b: Vec<usize> = (0..n).collect();
    by_b.sort_unstable_by(|&i, &j| {
        b[i].total_cmp(&b[j])
            .then(a[j].total_cmp(&a[i]))
            .then(i.cmp(&j))
    });
    let mut rank = vec![0usize; n];
    for (k, &i) in by_b.iter().enumerate() {
        rank[i] = k;
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
