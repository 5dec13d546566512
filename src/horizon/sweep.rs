//! The exact horizon along each sector's centre direction by a line sweep
//! (Dozier, Bruno and Downey 1981; Timonen and Westerholm 2010).
//!
//! The grid is cut into digital lines of the direction r_i: for a direction
//! within 45° of the columns, line c holds the cells (c + round(m·j), j) for
//! every column j, with m the slope in rows per column (rows and columns
//! swap roles otherwise). Every cell lies on exactly one line per direction.
//! A line's profile is its cells at their distance w = (u, v)·r_i along the
//! direction, heights linear in between, so a cell's horizon is the highest
//! elevation of the cells ahead of it on its line. Walking the line from its
//! far end keeps the upper convex hull of the profile ahead as a stack: a new
//! cell pops the vertices under its tangent and the top is its horizon
//! point, O(1) amortised per cell. The slopes are rounded to float32 (the
//! output's type: at most 3e-8 rad once turned into an angle) and turned
//! into elevations by a float32 arctangent ([`atan_f32`], at most 1.12e-7
//! rad off), eight values per vector: by the 4-lane walk below as soon as
//! a run of cells is finished (still in cache), by the one-line walk in a
//! pass over the plane.
//!
//! The lines are walked a block of neighbours at a time, a few steps of one
//! line before the same steps of the next (16 when the lines run along the
//! rows, so those steps are adjacent cells of a row; 4 when they run along
//! the columns, where the block's cells at one step are adjacent cells of a
//! row): every cache line of the grid is loaded once instead of once per
//! line. The distances along the direction are tabulated per step, and the
//! top of each line's hull stack stays in registers while the line is walked.
//!
//! On x86-64 with AVX2 the lines are instead walked four neighbours at a
//! time in the lanes of f64 vectors, each lane with its own stack (see
//! `lines_avx2`): the data-dependent pop loop then branches once per four
//! cells. The values are bit-identical to the one-line walk's (same
//! operations per lane, no FMA).
//!
//! With `max_distance`, the cells ahead are scanned up to that distance
//! along the line (no hull).

use super::{Frame, Options, Progress, Terrain, EMPTY};
use crate::cancel::Cancel;
use crate::error::Result;

/// tan(3π/8) and tan(π/8), the reduction's thresholds.
const TAN_3PI_8: f32 = 2.414_213_7;
const TAN_PI_8: f32 = 0.414_213_57;
/// π/2 − `FRAC_PI_2` (the float32 π/2 is 4.4e-8 too high).
const PI_2_LO: f32 = -4.371_139e-8;

/// atan(x) in float32 (Cephes `atanf`: reduction to |t| ≤ tan(π/8) by
/// atan x = π/4 + atan((x − 1)/(x + 1)) or π/2 + atan(−1/x), then an odd
/// degree-9 polynomial), with the low part of π/2 (or π/4) added before its
/// high part. Branch-free (selects only) and without FMA, so that a loop
/// over a slice vectorises to the same values on any CPU. Measured against
/// the f64 `atan` over every float32 x: at most 1.12e-7 rad off (2.34 ulps
/// of the result at worst, near x = 0.4144; 99.5 % of the values are the
/// correctly rounded ones, none is 3 ulps away); ±∞ gives ±π/2 (the f32
/// nearest, so −∞ gives [`EMPTY`]), ±0 itself, NaN stays NaN.
#[inline(always)]
pub fn atan_f32(x: f32) -> f32 {
    use std::f32::consts::FRAC_PI_2;
    let a = x.abs();
    let big = a > TAN_3PI_8;
    let mid = a > TAN_PI_8;
    let num = if big {
        -1.0
    } else if mid {
        a - 1.0
    } else {
        a
    };
    let den = if big {
        a
    } else if mid {
        a + 1.0
    } else {
        1.0
    };
    let (hi, lo) = if big {
        (FRAC_PI_2, PI_2_LO)
    } else if mid {
        (0.5 * FRAC_PI_2, 0.5 * PI_2_LO)
    } else {
        (0.0, 0.0)
    };
    let t = num / den;
    let z = t * t;
    let p =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t;
    (hi + ((t + p) + lo)).copysign(x)
}

/// Replace slopes by their elevation angles (−∞ gives −π/2, NaN stays).
/// The same operations in the same order whatever the vector width, so the
/// result does not depend on the CPU.
pub(super) fn slopes_to_angles(out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX (checked just above).
        unsafe { slopes_to_angles_avx(out) };
        return;
    }
    slopes_to_angles_plain(out);
}

#[inline(always)]
fn slopes_to_angles_plain(out: &mut [f32]) {
    for v in out.iter_mut() {
        *v = atan_f32(*v);
    }
}

/// [`slopes_to_angles_plain`] compiled for 8-wide f32 vectors (AVX) (no FMA: the
/// values are bit-identical to the plain pass).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline(never)]
unsafe fn slopes_to_angles_avx(out: &mut [f32]) {
    slopes_to_angles_plain(out);
}

/// Lines walked together (one cache line of output per step and line).
const BLOCK: i64 = 64;

/// Steps walked on one line before the next line of the block when the
/// block's cells at one step are a column (lines along the rows): a line's
/// next `CHUNK` cells are then adjacent in memory and every cache line of
/// the grid is used up before it can be evicted; the stacks stay the same.
const CHUNK: usize = 16;

/// The same when the block's cells at one step are a run of a row (lines
/// along the columns): a few steps per line amortise the per-line set-up
/// while the rows touched stay few.
const CHUNK_ROWS: usize = 4;

/// Groups of four lines walked together by the 4-lane walk when the lines
/// run along the columns (256 lines: two KiB of one row of the grid per
/// step; 64 and 1024 lines measured slower, 512 no faster).
#[cfg(target_arch = "x86_64")]
const LANE_GROUPS: usize = 64;

/// Steps of one group of the 4-lane walk before the next group when the
/// lines run along the columns: 8 rows of the block at a time (at 1024²
/// and 2048², 8 measured 11–20 % faster than 4 and 16; the group's state
/// is saved and restored half as often as with 4).
#[cfg(target_arch = "x86_64")]
const LANE_CHUNK_ROWS: usize = 8;

/// Steps ahead that the 4-lane walk along the rows prefetches its cells.
#[cfg(target_arch = "x86_64")]
const PF: usize = 16;

/// A step of the lines of one direction (in walking order).
#[derive(Clone, Copy)]
struct Step {
    /// Cell index of line 0 at this step (line l: q0 + l·sv).
    q0: i64,
    /// Perpendicular index of line 0 (line l: sh + l).
    sh: i64,
    /// Distance along r of line 0 (line l: w + l·wperp).
    w: f64,
}

/// Walk line `l` over `steps`, with its hull stack of `k` vertices at
/// `sw`, `sz` (distances and heights); returns the new stack length. `CURV`:
/// whether c ≠ 0 (then `wl` = l·wperp is added to the distances). The top
/// vertex is kept in registers: the stack in memory is only read below it,
/// so no load waits on the store of the cell just before.
///
/// # Safety
/// `z` and `out` hold the grid, whose cell at perpendicular index v of a step
/// is `q0 + (v − sh)·sv` for 0 ≤ v < nperp; `sw` and `sz` have room for `k`
/// plus one value per step.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn walk<const CURV: bool>(
    z: &[f64],
    out: &mut [f32],
    steps: &[Step],
    l: i64,
    nperp: i64,
    sv: usize,
    c: f64,
    wl: f64,
    sw: *mut f64,
    sz: *mut f64,
    mut k: usize,
) -> usize {
    let off = l * sv as i64;
    let (mut tw, mut tz) = if k > 0 {
        (*sw.add(k - 1), *sz.add(k - 1))
    } else {
        (0.0, 0.0)
    };
    for s in steps {
        // the line's cell at this step is on the grid when 0 ≤ l + sh < nperp
        if ((l + s.sh) as u64) >= nperp as u64 {
            continue;
        }
        let q = (s.q0 + off) as usize;
        let h = *z.get_unchecked(q);
        if !h.is_finite() {
            // ±inf or NaN: no data
            *out.get_unchecked_mut(q) = f32::NAN;
            continue;
        }
        let (w, zz) = if CURV {
            let w = s.w + wl;
            (w, h - c * w * w) // Z = z − c·w²
        } else {
            (s.w, h)
        };
        // pop the top t while it is on or under the segment from the new
        // point to the vertex p below it
        while k >= 2 {
            let (pw, pz) = (*sw.add(k - 2), *sz.add(k - 2));
            if (pz - zz) * (tw - w) >= (tz - zz) * (pw - w) {
                k -= 1;
                (tw, tz) = (pw, pz);
            } else {
                break;
            }
        }
        // The slope for now (rounded to f32: ≤ 3e-8 rad once turned into an
        // angle); the angles are taken in one vector pass.
        *out.get_unchecked_mut(q) = if k > 0 {
            let slope = (tz - zz) / (tw - w);
            (if CURV { slope + 2.0 * c * w } else { slope }) as f32
        } else {
            f32::NEG_INFINITY
        };
        *sw.add(k) = w;
        *sz.add(k) = zz;
        k += 1;
        (tw, tz) = (w, zz);
    }
    k
}

/// The four values at the lane indices `i` of `p` (scalar loads: faster
/// than a gather here, and forwarded from the stores just before).
///
/// # Safety
/// The CPU has AVX2; every index is in bounds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn load4(p: *const f64, i: std::arch::x86_64::__m256i) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let mut a = [0i64; 4];
    _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, i);
    _mm256_set_pd(
        *p.add(a[3] as usize),
        *p.add(a[2] as usize),
        *p.add(a[1] as usize),
        *p.add(a[0] as usize),
    )
}

/// The (distance, height) pairs at the lane indices `i` of `p`, as a vector
/// of distances and one of heights (four 16-byte loads).
///
/// # Safety
/// The CPU has AVX2; every index and the one after it are in bounds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn load_pairs(
    p: *const f64,
    i: std::arch::x86_64::__m256i,
) -> (std::arch::x86_64::__m256d, std::arch::x86_64::__m256d) {
    use std::arch::x86_64::*;
    let a: [i64; 4] = std::mem::transmute(i);
    let lo = _mm256_set_m128d(
        _mm_loadu_pd(p.add(a[2] as usize)),
        _mm_loadu_pd(p.add(a[0] as usize)),
    );
    let hi = _mm256_set_m128d(
        _mm_loadu_pd(p.add(a[3] as usize)),
        _mm_loadu_pd(p.add(a[1] as usize)),
    );
    (_mm256_unpacklo_pd(lo, hi), _mm256_unpackhi_pd(lo, hi))
}

/// Store lane j's pair (w[j], z[j]) at `p` + i[j] (four 16-byte stores).
///
/// # Safety
/// The CPU has AVX2; every index and the one after it are in bounds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store_pairs(
    p: *mut f64,
    i: std::arch::x86_64::__m256i,
    w: std::arch::x86_64::__m256d,
    z: std::arch::x86_64::__m256d,
) {
    use std::arch::x86_64::*;
    let a: [i64; 4] = std::mem::transmute(i);
    let lo = _mm256_unpacklo_pd(w, z);
    let hi = _mm256_unpackhi_pd(w, z);
    _mm_storeu_pd(p.add(a[0] as usize), _mm256_castpd256_pd128(lo));
    _mm_storeu_pd(p.add(a[1] as usize), _mm256_castpd256_pd128(hi));
    _mm_storeu_pd(p.add(a[2] as usize), _mm256_extractf128_pd::<1>(lo));
    _mm_storeu_pd(p.add(a[3] as usize), _mm256_extractf128_pd::<1>(hi));
}

/// Every line of one direction walked four at a time, one line per lane of
/// 4-wide f64 vectors (AVX2), each from its far end to its near end with
/// its own hull stack: the pop loop runs while any lane pops, so its
/// unpredictable exit is taken once per four cells. Each lane keeps its top
/// three vertices t, p and q in registers, so the pop test needs no load
/// and the vertex below q, read when a lane pops, is off the chain of
/// comparisons; the stacks hold (distance, height) pairs, one 16-byte store
/// or load per lane. The four lines are neighbours: with the lines along
/// the rows each lane reads and writes its own row forwards (four
/// sequential streams) and a whole line is walked at once; along the
/// columns (`ADJ`) the group's cells at one step are adjacent, read and
/// written as one vector. The steps where all four lanes are on the grid
/// (all but a few near the grid's edges) skip the per-lane range test and
/// address their cells from one base. Per lane
/// the operations and their order are those of [`walk`] (no FMA), so the
/// slopes are bit-identical.
///
/// # Safety
/// The CPU has AVX2; `steps` are the direction's steps in walking order,
/// with the cells as in `walk`; `sv` = 1 when `ADJ`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
unsafe fn lines_avx2<const CURV: bool, const ADJ: bool>(
    z: &[f64],
    out: &mut [f32],
    steps: &[Step],
    (smin, smax): (i64, i64),
    nperp: i64,
    sv: usize,
    c: f64,
    wperp: f64,
    finite: bool,
    cancel: &Cancel,
) -> Result<()> {
    use std::arch::x86_64::*;
    let zp = z.as_ptr();
    let op = out.as_mut_ptr();
    // Groups of four lines: `ng` groups (a block) walked a chunk of `chunk`
    // steps each, in turn; with the lines along the rows a whole line at
    // once (each lane streams through its own row), along the columns a
    // block of 256 lines 8 steps at a time (the block's cells at one step
    // are a run of one row: every cache line of the grid used up at once,
    // and few pages at a time). The stacks of group g: lane i's vertex j
    // as a (distance, height) pair at st[(8g + 2i)·cap + 2(j + 3)], below
    // them three pairs of NaN that are never written: a NaN vertex fails
    // every pop test, so a lane with fewer than two vertices needs no test
    // of its length, and the vertex below q (j = k − 4) is read unclamped.
    let (ng, chunk) = if ADJ {
        (LANE_GROUPS, LANE_CHUNK_ROWS)
    } else {
        (1, steps.len())
    };
    let cap = steps.len() + 6;
    let mut st = vec![f64::NAN; 8 * ng * cap];
    let np = _mm256_set1_epi64x(nperp);
    let abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
    let inf = _mm256_set1_pd(f64::INFINITY);
    let ninf = _mm256_set1_pd(f64::NEG_INFINITY);
    let cv = _mm256_set1_pd(c);
    let c2 = _mm256_set1_pd(2.0 * c);
    let lane = _mm256_set_epi64x(3, 2, 1, 0);
    let svi = sv as i64;
    let bw = _mm256_set_epi64x(6 * cap as i64, 4 * cap as i64, 2 * cap as i64, 0);
    // A lane's stack length k is kept as the offset of its pair k − 1 (the
    // vertex below q), kb = bw + 2(k − 1); the push goes to pair k + 3.
    let kb0 = _mm256_sub_epi64(bw, _mm256_set1_epi64x(2));
    let eight = _mm256_set1_epi64x(8);
    let two = _mm256_set1_epi64x(2);
    let nan = _mm256_set1_pd(f64::NAN);
    // the shifts are monotone along the walk
    let rising = steps.first().map(|s| s.sh) <= steps.last().map(|s| s.sh);
    // per group of the block: its state (stack length as kb, top t, the vertex
    // p below it and the vertex q below p, NaN where the stack has none)
    // and its range of steps
    let zi = _mm256_setzero_si256();
    let zd = _mm256_setzero_pd();
    let mut state = vec![(kb0, nan, nan, nan, nan, nan, nan); ng];
    let mut range = vec![(0usize, 0usize); ng];
    let mut full = vec![(0usize, 0usize); ng];
    let mut l0 = -smax;
    let mut nb = 0usize;
    // without `ADJ`: the rows whose elevations are taken
    let mut rows_done = 0usize;
    while l0 < nperp - smin {
        if nb % (16 / ng).max(1) == 0 {
            cancel.check()?;
        }
        nb += 1;
        let ngb = (((nperp - smin - l0 + 3) / 4) as usize).min(ng);
        // the steps with lo ≤ sh < hi (a range: the shifts are monotone)
        let between = |lo: i64, hi: i64| {
            if rising {
                (
                    steps.partition_point(|s| s.sh < lo),
                    steps.partition_point(|s| s.sh < hi),
                )
            } else {
                (
                    steps.partition_point(|s| s.sh >= hi),
                    steps.partition_point(|s| s.sh >= lo),
                )
            }
        };
        for gi in 0..ngb {
            let l = l0 + 4 * gi as i64;
            // the steps where some lane l..l+3 is on the grid: −l − 3 ≤ sh < nperp − l,
            // and where all are: −l ≤ sh < nperp − l − 3
            range[gi] = between(-l - 3, nperp - l);
            full[gi] = between(-l, nperp - l - 3);
            state[gi] = (kb0, nan, nan, nan, nan, nan, nan);
        }
        let mut c0 = 0;
        while c0 < steps.len() {
            let c1 = (c0 + chunk).min(steps.len());
            if ADJ {
                // the block's row runs of the next chunk (heights, outputs)
                let lend = l0 + 4 * ngb as i64;
                for s in steps.get_unchecked(c1..(c1 + chunk).min(steps.len())) {
                    let (la, lb) = (l0.max(-s.sh), lend.min(nperp - s.sh));
                    let mut l = la;
                    while l < lb {
                        let q = (s.q0 + l) as isize;
                        _mm_prefetch::<_MM_HINT_T0>(zp.wrapping_offset(q) as *const i8);
                        _mm_prefetch::<_MM_HINT_T0>(zp.wrapping_offset(q + 8) as *const i8);
                        _mm_prefetch::<_MM_HINT_T0>(op.wrapping_offset(q) as *const i8);
                        l += 16;
                    }
                }
            }
            for gi in 0..ngb {
                let (s0, s1) = (range[gi].0.max(c0), range[gi].1.min(c1));
                if s0 >= s1 {
                    continue;
                }
                let l = l0 + 4 * gi as i64;
                let sp = st.as_mut_ptr().add(8 * gi * cap);
                let lv = _mm256_add_epi64(_mm256_set1_epi64x(l), lane);
                let ob = l * svi;
                let off = _mm256_set_epi64x(ob + 3 * svi, ob + 2 * svi, ob + svi, ob);
                let wl = if CURV {
                    let f = |i: i64| (l + i) as f64 * wperp;
                    _mm256_set_pd(f(3), f(2), f(1), f(0))
                } else {
                    _mm256_setzero_pd()
                };
                // each lane's stack length (as kb), top t, p below it and q below p
                let (mut kb, mut tw, mut tz, mut pw, mut pz, mut qw, mut qz) = state[gi];
                // One step of the group's four lines; `$full`: every lane's
                // cell is on the grid; `$finite`: and every height is known
                // to be finite.
                macro_rules! step {
                    ($s:expr, $full:literal, $finite:literal) => {{
                        let s: &Step = $s;
                        // the cells of lanes 0..4 at this step: base + i·sv
                        let base = s.q0 + ob;
                        let (minr, inr, h, qa) = if $full {
                            // every lane on the grid
                            let h = if ADJ {
                                _mm256_loadu_pd(zp.add(base as usize))
                            } else {
                                _mm256_set_pd(
                                    *zp.add((base + 3 * svi) as usize),
                                    *zp.add((base + 2 * svi) as usize),
                                    *zp.add((base + svi) as usize),
                                    *zp.add(base as usize),
                                )
                            };
                            let qa = [base, base + svi, base + 2 * svi, base + 3 * svi];
                            (15, zd, h, qa)
                        } else {
                            // lanes whose cell at this step is on the grid: 0 ≤ l + sh < nperp
                            let v = _mm256_add_epi64(lv, _mm256_set1_epi64x(s.sh));
                            let inr = _mm256_castsi256_pd(_mm256_andnot_si256(
                                _mm256_cmpgt_epi64(zi, v),
                                _mm256_cmpgt_epi64(np, v),
                            ));
                            let q = _mm256_add_epi64(_mm256_set1_epi64x(s.q0), off);
                            // (a lane off the grid reads the first cell)
                            let h = load4(zp, _mm256_and_si256(q, _mm256_castpd_si256(inr)));
                            let qa: [i64; 4] = std::mem::transmute(q);
                            (_mm256_movemask_pd(inr), inr, h, qa)
                        };
                        let fin = if $finite {
                            _mm256_castsi256_pd(_mm256_set1_epi64x(-1))
                        } else {
                            _mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_and_pd(h, abs_mask), inf)
                        };
                        let fin = if $full { fin } else { _mm256_and_pd(inr, fin) };
                        let mfin = if $finite { 15 } else { _mm256_movemask_pd(fin) };
                        if mfin != minr {
                            // ±inf or NaN: no data
                            for (i, &qi) in qa.iter().enumerate() {
                                if (minr & !mfin) >> i & 1 != 0 {
                                    *op.add(qi as usize) = f32::NAN;
                                }
                            }
                            if mfin == 0 {
                                continue;
                            }
                        }
                        // a lane without a cell here gets height NaN: it fails
                        // every pop test
                        let h = _mm256_blendv_pd(nan, h, fin);
                        let (w, zz) = if CURV {
                            let w = _mm256_add_pd(_mm256_set1_pd(s.w), wl);
                            // Z = z − c·w²
                            (w, _mm256_sub_pd(h, _mm256_mul_pd(_mm256_mul_pd(cv, w), w)))
                        } else {
                            (_mm256_set1_pd(s.w), h)
                        };
                        // pop each lane's top while it is on or under the segment from
                        // the new point to the vertex p below it (t, p and q in
                        // registers; the vertex below q is read for the lanes that
                        // pop, off the chain of comparisons). A lane with fewer than
                        // two vertices has p = NaN, one without a cell zz = NaN: the
                        // ordered comparison is false for both.
                        loop {
                            let lhs = _mm256_mul_pd(_mm256_sub_pd(pz, zz), _mm256_sub_pd(tw, w));
                            let rhs = _mm256_mul_pd(_mm256_sub_pd(tz, zz), _mm256_sub_pd(pw, w));
                            let mut pop = _mm256_cmp_pd::<_CMP_GE_OQ>(lhs, rhs);
                            // an opaque mask: used as it is by the blends and the
                            // length update (not rebuilt from a vector of booleans)
                            std::arch::asm!(
                                "/* {0} */",
                                inout(ymm_reg) pop,
                                options(pure, nomem, nostack)
                            );
                            if _mm256_testz_pd(pop, pop) != 0 {
                                break;
                            }
                            // the vertex below q: vertex k − 4, pair k − 1 (a NaN
                            // sentinel when the lane has fewer than four)
                            let (rw, rz) = load_pairs(sp, kb);
                            tw = _mm256_blendv_pd(tw, pw, pop);
                            tz = _mm256_blendv_pd(tz, pz, pop);
                            pw = _mm256_blendv_pd(pw, qw, pop);
                            pz = _mm256_blendv_pd(pz, qz, pop);
                            qw = _mm256_blendv_pd(qw, rw, pop);
                            qz = _mm256_blendv_pd(qz, rz, pop);
                            let pop = _mm256_castpd_si256(pop);
                            kb = _mm256_add_epi64(kb, _mm256_add_epi64(pop, pop));
                        }
                        let slope = _mm256_div_pd(_mm256_sub_pd(tz, zz), _mm256_sub_pd(tw, w));
                        let slope = if CURV {
                            _mm256_add_pd(slope, _mm256_mul_pd(c2, w))
                        } else {
                            slope
                        };
                        // −∞ where the stack is empty: the slope is then NaN (t is
                        // NaN) and only there (a cell's height and its stack's are
                        // finite, their distances distinct), and maxpd returns its
                        // second operand when the first is NaN
                        let val = _mm256_cvtpd_ps(_mm256_max_pd(slope, ninf));
                        // push on every lane (above the top of a lane without a cell
                        // here, the value is never read)
                        store_pairs(sp, _mm256_add_epi64(kb, eight), w, zz);
                        let mut va = [0f32; 4];
                        _mm_storeu_ps(va.as_mut_ptr(), val);
                        if ADJ && mfin == 15 {
                            _mm_storeu_ps(op.add(qa[0] as usize), val);
                        } else if mfin == 15 {
                            for i in 0..4 {
                                *op.add(qa[i] as usize) = va[i];
                            }
                        } else {
                            for i in 0..4 {
                                if mfin >> i & 1 != 0 {
                                    *op.add(qa[i] as usize) = va[i];
                                }
                            }
                        }
                        kb = if $finite {
                            _mm256_add_epi64(kb, two)
                        } else {
                            let fin = _mm256_castpd_si256(fin);
                            _mm256_sub_epi64(kb, _mm256_add_epi64(fin, fin))
                        };
                        qw = _mm256_blendv_pd(qw, pw, fin);
                        qz = _mm256_blendv_pd(qz, pz, fin);
                        pw = _mm256_blendv_pd(pw, tw, fin);
                        pz = _mm256_blendv_pd(pz, tz, fin);
                        tw = _mm256_blendv_pd(tw, w, fin);
                        tz = _mm256_blendv_pd(tz, zz, fin);
                    }};
                }
                // the steps where all four lanes are on the grid
                let a = full[gi].0.clamp(s0, s1);
                let b = full[gi].1.clamp(a, s1);
                for s in steps.get_unchecked(s0..a) {
                    step!(s, false, false);
                }
                // Without `ADJ` the four lanes' cells are rows apart, each
                // in its own cache line, and along a steep line a new one
                // nearly every step: the heights and output cells `PF`
                // steps ahead are prefetched while this step waits on its
                // hull.
                macro_rules! ahead {
                    ($j:expr) => {
                        if !ADJ {
                            let s = steps.get_unchecked(($j + PF).min(steps.len() - 1));
                            let p = zp.wrapping_offset((s.q0 + ob) as isize);
                            let o = op.wrapping_offset((s.q0 + ob) as isize);
                            for i in 0..4 {
                                _mm_prefetch::<_MM_HINT_T0>(
                                    p.wrapping_offset(i * svi as isize) as *const i8
                                );
                                _mm_prefetch::<_MM_HINT_T0>(
                                    o.wrapping_offset(i * svi as isize) as *const i8
                                );
                            }
                        }
                    };
                }
                if finite {
                    for j in a..b {
                        ahead!(j);
                        step!(steps.get_unchecked(j), true, true);
                    }
                } else {
                    for j in a..b {
                        ahead!(j);
                        step!(steps.get_unchecked(j), true, false);
                    }
                }
                for s in steps.get_unchecked(b..s1) {
                    step!(s, false, false);
                }
                state[gi] = (kb, tw, tz, pw, pz, qw, qz);
            }
            if ADJ {
                // The block's cells at these steps are finished: their
                // elevations now, from the runs of a row just written (in
                // cache) rather than in a pass over the plane.
                let lend = l0 + 4 * ngb as i64;
                for s in steps.get_unchecked(c0..c1) {
                    let (la, lb) = (l0.max(-s.sh), lend.min(nperp - s.sh));
                    if la < lb {
                        slopes_to_angles_plain(std::slice::from_raw_parts_mut(
                            op.add((s.q0 + la) as usize),
                            (lb - la) as usize,
                        ));
                    }
                }
            }
            c0 = c1;
        }
        l0 += 4 * ng as i64;
        if !ADJ {
            // Rows whose every line is walked (row i holds a cell of line
            // i − sh for each shift sh): their elevations while the last
            // lines' writes may still be in cache.
            let done = (l0 + smin).clamp(0, nperp) as usize;
            if done > rows_done {
                slopes_to_angles_plain(std::slice::from_raw_parts_mut(
                    op.add(rows_done * sv),
                    (done - rows_done) * sv,
                ));
                rows_done = done;
            }
        }
    }
    debug_assert!(ADJ || rows_done == nperp as usize);
    Ok(())
}

/// One direction without a distance limit. The lines step along columns
/// (`along_cols`, one cell per column, |m| ≤ 1 rows per column) or along
/// rows; `fwd` says whether "ahead" is towards higher steps; `wstep`,
/// `wperp` are the distances along r per step and per perpendicular index.
///
/// Line l holds, at step u, the cell at perpendicular index v = l + sh(u),
/// so its distance along r is w = (u·wstep + sh(u)·wperp) + l·wperp: the
/// first term is the same for every line of a direction and is tabulated
/// once; the line's constant l·wperp is left out without curvature (the
/// slopes only see differences of w along one line). `finite`: every
/// height is finite (the 4-lane walk then skips its finiteness test).
#[allow(clippy::too_many_arguments)]
fn lines_blocked(
    z: &[f64],
    rows: usize,
    cols: usize,
    along_cols: bool,
    m: f64,
    fwd: bool,
    wstep: f64,
    wperp: f64,
    c: f64,
    finite: bool,
    out: &mut [f32],
    cancel: &Cancel,
    simd: bool,
) -> Result<()> {
    #[cfg(target_arch = "x86_64")]
    let simd = simd && std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (simd, finite);
    let (nsteps, nperp) = if along_cols {
        (cols, rows as i64)
    } else {
        (rows, cols as i64)
    };
    // The steps in walking order (the far end first), with their shift and
    // tabulated distance.
    let order: Vec<usize> = if fwd {
        (0..nsteps).rev().collect()
    } else {
        (0..nsteps).collect()
    };
    let shift: Vec<i64> = order
        .iter()
        .map(|&u| (m * u as f64).round() as i64)
        .collect();
    let wtab: Vec<f64> = order
        .iter()
        .zip(&shift)
        .map(|(&u, &sh)| u as f64 * wstep + sh as f64 * wperp)
        .collect();
    let smin = *shift.iter().min().unwrap_or(&0);
    let smax = *shift.iter().max().unwrap_or(&0);
    let (sv, su) = if along_cols { (cols, 1) } else { (1, cols) };
    // per step: the cell index of line 0 (i64: it may lie off the grid), the
    // shift and the distance
    let steps: Vec<Step> = order
        .iter()
        .zip(&shift)
        .zip(&wtab)
        .map(|((&u, &sh), &w)| Step {
            q0: (u * su) as i64 + sh * sv as i64,
            sh,
            w,
        })
        .collect();
    #[cfg(target_arch = "x86_64")]
    if simd {
        let sm = (smin, smax);
        // SAFETY: AVX2 checked above; the steps and cells as in `walk`.
        return unsafe {
            match (c == 0.0, along_cols) {
                (true, true) => lines_avx2::<false, false>(
                    z, out, &steps, sm, nperp, sv, c, wperp, finite, cancel,
                ),
                (true, false) => lines_avx2::<false, true>(
                    z, out, &steps, sm, nperp, sv, c, wperp, finite, cancel,
                ),
                (false, true) => lines_avx2::<true, false>(
                    z, out, &steps, sm, nperp, sv, c, wperp, finite, cancel,
                ),
                (false, false) => lines_avx2::<true, true>(
                    z, out, &steps, sm, nperp, sv, c, wperp, finite, cancel,
                ),
            }
        };
    }
    let chunk = if along_cols { CHUNK } else { CHUNK_ROWS };
    assert!(z.len() >= rows * cols && out.len() >= rows * cols);
    // The hull stacks of the block's lines, flat: line b's distances are
    // st[2b·cap ..][.. len[b]] and its heights st[(2b + 1)·cap ..][.. len[b]]
    // (a line has at most `nsteps` cells; the spare values stagger the
    // stacks over the cache sets).
    let cap = nsteps + 3;
    let mut st = vec![0.0f64; 2 * cap * BLOCK as usize];
    let mut len = [0usize; BLOCK as usize];
    let mut l0 = -smax;
    while l0 < nperp - smin {
        cancel.check()?;
        let l1 = (l0 + BLOCK).min(nperp - smin);
        len.fill(0);
        let mut s0 = 0;
        while s0 < nsteps {
            let s1 = (s0 + chunk).min(nsteps);
            // lines of the block that have a cell at some step of the chunk
            let (cmin, cmax) = shift[s0..s1]
                .iter()
                .fold((i64::MAX, i64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            let (la, lb) = (l0.max(-cmax), l1.min(nperp - cmin));
            for l in la..lb {
                let b = (l - l0) as usize;
                let (sw, sz) = st[2 * b * cap..(2 * b + 2) * cap].split_at_mut(cap);
                let (sw, sz) = (sw.as_mut_ptr(), sz.as_mut_ptr());
                // SAFETY: b < BLOCK since l0 ≤ la ≤ l < lb ≤ l1 ≤ l0 + BLOCK;
                // the chunk is a range of `steps`; see `walk` for the cells.
                unsafe {
                    let k = len.get_unchecked_mut(b);
                    *k = if c == 0.0 {
                        walk::<false>(z, out, &steps[s0..s1], l, nperp, sv, 0.0, 0.0, sw, sz, *k)
                    } else {
                        let wl = l as f64 * wperp;
                        walk::<true>(z, out, &steps[s0..s1], l, nperp, sv, c, wl, sw, sz, *k)
                    };
                }
            }
            s0 = s1;
        }
        l0 = l1;
    }
    slopes_to_angles(out);
    Ok(())
}

/// One direction on a (possibly transposed) grid whose lines step along
/// columns: `m` rows per column (|m| ≤ 1), `fwd` whether "ahead" is towards
/// higher columns, `wc`, `wr` the distance along r per column and per row.
#[allow(clippy::too_many_arguments)]
fn lines(
    z: &[f64],
    rows: usize,
    cols: usize,
    m: f64,
    fwd: bool,
    wc: f64,
    wr: f64,
    c: f64,
    dmax: Option<f64>,
    out: &mut [f32],
    cancel: &Cancel,
) -> Result<()> {
    let shift: Vec<i64> = (0..cols).map(|j| (m * j as f64).round() as i64).collect();
    let (smin, smax) = (
        *shift.iter().min().unwrap_or(&0),
        *shift.iter().max().unwrap_or(&0),
    );
    let order: Vec<usize> = if fwd {
        (0..cols).rev().collect()
    } else {
        (0..cols).collect()
    };
    let mut stack: Vec<(f64, f64)> = Vec::with_capacity(64);
    let mut seen: Vec<(f64, f64)> = Vec::new();
    for (li, line) in (-smax..(rows as i64 - smin)).enumerate() {
        if li % 256 == 0 {
            cancel.check()?;
        }
        stack.clear();
        seen.clear();
        for &j in &order {
            let i = line + shift[j];
            if i < 0 || i >= rows as i64 {
                continue;
            }
            let q = i as usize * cols + j;
            let h = z[q];
            if !h.is_finite() {
                out[q] = f32::NAN;
                continue;
            }
            let w = j as f64 * wc + i as f64 * wr;
            let zz = if c == 0.0 { h } else { h - c * w * w };
            if let Some(d) = dmax {
                let mut best: Option<f64> = None;
                for &(qw, qz) in seen.iter().rev() {
                    if qw - w > d {
                        break;
                    }
                    let s = (qz - zz) / (qw - w);
                    if best.is_none_or(|b| s > b) {
                        best = Some(s);
                    }
                }
                out[q] = match best {
                    Some(s) => atan_f32((s + 2.0 * c * w) as f32),
                    None => EMPTY,
                };
                seen.push((w, zz));
                continue;
            }
            while stack.len() >= 2 {
                let (tw, tz) = stack[stack.len() - 1];
                let (sw, sz) = stack[stack.len() - 2];
                if (sz - zz) * (tw - w) >= (tz - zz) * (sw - w) {
                    stack.pop();
                } else {
                    break;
                }
            }
            out[q] = match stack.last() {
                Some(&(tw, tz)) => atan_f32(((tz - zz) / (tw - w) + 2.0 * c * w) as f32),
                None => EMPTY,
            };
            stack.push((w, zz));
        }
    }
    Ok(())
}

pub fn sector(
    t: &Terrain,
    f: &Frame,
    o: &Options,
    plane: &mut [f32],
    cancel: &Cancel,
    progress: &Progress,
) -> Result<()> {
    sector_with(t, f, o, plane, cancel, progress, true)
}

/// [`sector`], with the 4-lane walk when `simd` and the CPU has AVX2, the
/// one-line walk otherwise (the same values bit for bit).
pub(crate) fn sector_with(
    t: &Terrain,
    f: &Frame,
    o: &Options,
    plane: &mut [f32],
    cancel: &Cancel,
    progress: &Progress,
    simd: bool,
) -> Result<()> {
    let (rows, cols, du, dv) = t.grid.expect("validated: sweep needs a grid");
    let (gc, gr) = (f.r.0 / du, f.r.1 / dv);
    if o.max_distance.is_none() {
        let (wc, wr) = (f.r.0 * du, f.r.1 * dv);
        if gc.abs() >= gr.abs() {
            lines_blocked(
                &t.z,
                rows,
                cols,
                true,
                gr / gc,
                gc > 0.0,
                wc,
                wr,
                o.curvature,
                t.finite,
                plane,
                cancel,
                simd,
            )?;
        } else {
            lines_blocked(
                &t.z,
                rows,
                cols,
                false,
                gc / gr,
                gr > 0.0,
                wr,
                wc,
                o.curvature,
                t.finite,
                plane,
                cancel,
                simd,
            )?;
        }
        progress.add(rows * cols);
        return Ok(());
    }
    if gc.abs() >= gr.abs() {
        lines(
            &t.z,
            rows,
            cols,
            gr / gc,
            gc > 0.0,
            f.r.0 * du,
            f.r.1 * dv,
            o.curvature,
            o.max_distance,
            plane,
            cancel,
        )?;
    } else {
        // Transpose so that lines step along contiguous memory.
        let mut zt = vec![0.0; rows * cols];
        for i in 0..rows {
            for j in 0..cols {
                zt[j * rows + i] = t.z[i * cols + j];
            }
        }
        let mut tmp = vec![0.0f32; rows * cols];
        lines(
            &zt,
            cols,
            rows,
            gc / gr,
            gr > 0.0,
            f.r.1 * dv,
            f.r.0 * du,
            o.curvature,
            o.max_distance,
            &mut tmp,
            cancel,
        )?;
        for i in 0..rows {
            for j in 0..cols {
                plane[i * cols + j] = tmp[j * rows + i];
            }
        }
    }
    progress.add(rows * cols);
    Ok(())
}
