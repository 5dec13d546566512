use super::*;

fn rng(seed: u64) -> impl FnMut() -> u64 {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    }
}

fn run(t: &Terrain, o: &Options) -> Vec<f32> {
    compute(t, o, &Cancel::new(), &Progress::default()).unwrap()
}

fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn stewart_equals_brute_random_points() {
    let mut r = rng(7);
    for trial in 0..4 {
        // Integer lattice coordinates: many exact border alignments.
        let n = 150;
        let mut seen = std::collections::HashSet::new();
        let (mut x, mut y, mut z) = (vec![], vec![], vec![]);
        while x.len() < n {
            let (a, b) = ((r() % 40) as i64, (r() % 40) as i64);
            if seen.insert((a, b)) {
                x.push(a as f64);
                y.push(b as f64);
                z.push(if trial == 3 { 0.0 } else { (r() % 7) as f64 });
            }
        }
        let t = Terrain::from_points(x, y, z).unwrap();
        for s in [3usize, 8, 64, 256] {
            let a = run(&t, &Options::new(s, Method::Brute));
            let b = run(&t, &Options::new(s, Method::Stewart));
            assert!(same_bits(&a, &b), "trial {trial} s {s}");
        }
    }
}

#[test]
fn stewart_equals_brute_around_block_sizes() {
    // Sizes around the leaf block (32 ranks) and the merge widths above it,
    // real-valued scattered points with repeated heights and a few exact
    // duplicates of x or y.
    let mut r = rng(19);
    for n in [1usize, 2, 3, 31, 32, 33, 63, 64, 65, 96, 97, 129, 300] {
        let mut unit = || (r() >> 11) as f64 / (1u64 << 53) as f64;
        let (mut x, mut y, mut z) = (vec![], vec![], vec![]);
        for i in 0..n {
            let (a, b) = (unit() * 20.0, unit() * 20.0);
            x.push(if i % 7 == 3 { x[0] } else { a });
            y.push(if i % 11 == 5 { y[0] } else { b });
            z.push((unit() * 6.0).floor());
        }
        let t = Terrain::from_points(x, y, z).unwrap();
        for s in [3usize, 8, 64] {
            let a = run(&t, &Options::new(s, Method::Brute));
            let b = run(&t, &Options::new(s, Method::Stewart));
            assert!(same_bits(&a, &b), "n {n} s {s}");
        }
    }
}

#[test]
fn sort_keys_is_the_exact_order() {
    let mut r = rng(23);
    for n in [1usize, 2, 5, 100, 2047, 2048, 2049, 5000, 70001] {
        // few distinct values (many ties on both keys), and spread values
        for distinct in [3u64, 1 << 40] {
            let k1: Vec<f64> = (0..n).map(|_| (r() % distinct) as f64 * 0.37).collect();
            let k2: Vec<f64> = (0..n).map(|_| (r() % distinct) as f64 - 7.0).collect();
            let mut out = Vec::new();
            stewart::sort_keys(&k1, &k2, &mut out);
            let mut want: Vec<u32> = (0..n as u32).collect();
            want.sort_by(|&i, &j| {
                let (i, j) = (i as usize, j as usize);
                k1[i]
                    .total_cmp(&k1[j])
                    .then(k2[j].total_cmp(&k2[i]))
                    .then(i.cmp(&j))
            });
            assert_eq!(out, want, "n {n} distinct {distinct}");
        }
    }
}

#[test]
fn stewart_equals_brute_grid_nan_curvature() {
    let mut r = rng(3);
    let (h, w) = (13, 17);
    let mut z: Vec<f64> = (0..h * w).map(|_| (r() % 1000) as f64 / 100.0).collect();
    z[40] = f64::NAN;
    z[41] = f64::NAN;
    let t = Terrain::from_grid(z, h, w, 1.0, 1.0).unwrap();
    for s in [8usize, 64] {
        for c in [0.0, 1e-3] {
            let mut o = Options::new(s, Method::Brute);
            o.curvature = c;
            let a = run(&t, &o);
            o.method = Method::Stewart;
            let b = run(&t, &o);
            assert!(same_bits(&a, &b), "s {s} c {c}");
            assert!(a[40].is_nan() && a[41].is_nan());
        }
    }
}

#[test]
fn flat_is_zero_and_borders_empty() {
    let t = Terrain::from_grid(vec![2.0; 9 * 11], 9, 11, 0.5, 2.0).unwrap();
    for m in [Method::Brute, Method::Stewart, Method::Cms, Method::Sweep] {
        let e = run(&t, &Options::new(8, m));
        // sector 0 (azimuth 0..45°) from the rightmost column holds no point
        for i in 0..9 {
            assert_eq!(e[i * 11 + 10], EMPTY, "{m:?}");
            // the centre line leaves the grid at once from the top row
            if i < 8 || m != Method::Cms {
                assert_eq!(e[i * 11], 0.0, "{m:?} row {i}");
            }
        }
    }
}

#[test]
fn spike_shadows_whole_sector() {
    let n = 30;
    let mut z = vec![0.0; n * n];
    z[(n - 3) * n + 2] = 50.0;
    let t = Terrain::from_grid(z, n, n, 1.0, 1.0).unwrap();
    let s = 64;
    let a = run(&t, &Options::new(s, Method::Stewart));
    let b = run(&t, &Options::new(s, Method::Brute));
    assert!(same_bits(&a, &b));
    // every point whose sector holds the spike sees it above the horizon
    for i in 0..n {
        for j in 0..n {
            let (dx, dy) = (2.0 - j as f64, (n - 3) as f64 - i as f64);
            if dx == 0.0 && dy == 0.0 {
                continue;
            }
            let az = dy.atan2(dx).rem_euclid(2.0 * std::f64::consts::PI);
            let sec = ((az / (2.0 * std::f64::consts::PI) * s as f64) as usize).min(s - 1);
            let f = (az / (2.0 * std::f64::consts::PI) * s as f64).fract();
            if f > 1e-9 && f < 1.0 - 1e-9 {
                assert!(a[sec * n * n + i * n + j] > 0.0);
            }
        }
    }
}

#[test]
fn sweep_matches_line_brute() {
    let mut r = rng(11);
    // (the larger grid has more lines than one block of the sweep)
    for (h, w, s, c) in [(20, 23, 16, 0.0), (150, 131, 24, 1e-3)] {
        let mut z: Vec<f64> = (0..h * w).map(|_| (r() % 500) as f64 / 50.0).collect();
        z[w + 3] = f64::NAN;
        let t = Terrain::from_grid(z.clone(), h, w, 1.0, 1.5).unwrap();
        let mut o = Options::new(s, Method::Sweep);
        o.curvature = c;
        let a = run(&t, &o);
        o.max_distance = Some(1e9); // the direct scan path
        let b = run(&t, &o);
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x - y).abs() < 1e-6 || (x.is_nan() && y.is_nan()),
                "{x} {y}"
            );
        }
        assert_eq!(a.iter().filter(|v| v.is_nan()).count(), s);
    }
}

#[test]
fn sweep_lanes_equal_one_line_walk() {
    // The 4-lane walk (AVX2 where the CPU has it) against the one-line walk,
    // bit for bit: both orientations, both walking senses, several blocks of
    // lines, partial groups of four, no-data cells (NaN, ±inf) or none (the
    // walk without finiteness tests), flat runs (ties in the pop test),
    // curvature.
    let mut r = rng(23);
    let cases = [
        (37, 150, 1.0, 0.0, true),
        (141, 67, 0.7, 0.0, true),
        (90, 90, -1.3, 2e-3, true),
        (23, 300, 1.0, 1e-3, true), // more than one block of lines along the columns
        (37, 150, 1.0, 0.0, false),
        (90, 90, -1.3, 2e-3, false),
        (23, 300, 1.0, 1e-3, false),
    ];
    for (h, w, dv, c, holes) in cases {
        let mut z: Vec<f64> = (0..h * w)
            .map(|_| match r() % 10 {
                0 => 1.0,
                _ => (r() % 1000) as f64 / 37.0,
            })
            .collect();
        for (k, bad) in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY]
            .into_iter()
            .enumerate()
        {
            for q in 0..5 * usize::from(holes) {
                z[(q * 997 + k * 131) % (h * w)] = bad;
            }
        }
        let t = Terrain::from_grid(z, h, w, 1.0, dv).unwrap();
        assert_eq!(t.finite, !holes);
        let mut o = Options::new(29, Method::Sweep);
        o.curvature = c;
        let mut mism = 0;
        for i in 0..29 {
            let f = Frame::new(i, 29);
            let (mut a, mut b) = (vec![0.0f32; h * w], vec![0.0f32; h * w]);
            let (cn, pr) = (Cancel::new(), Progress::default());
            sweep::sector_with(&t, &f, &o, &mut a, &cn, &pr, true).unwrap();
            sweep::sector_with(&t, &f, &o, &mut b, &cn, &pr, false).unwrap();
            assert_eq!(
                a.iter().filter(|v| v.is_nan()).count(),
                15 * usize::from(holes)
            );
            mism += usize::from(!same_bits(&a, &b));
        }
        assert_eq!(mism, 0, "{h}x{w}");
    }
}

/// Largest error of `sweep::atan_f32` against the f64 arctangent over the
/// float32 values `bits`, in radians and in ulps of the result.
fn atan_f32_error(bits: impl Iterator<Item = u32>) -> (f64, f64) {
    let (mut rad, mut ulps) = (0.0f64, 0.0f64);
    for b in bits {
        let x = f32::from_bits(b);
        let got = sweep::atan_f32(x);
        if x.is_nan() {
            assert!(got.is_nan());
            continue;
        }
        let want = (x as f64).atan();
        let e = (got as f64 - want).abs();
        let w = (want as f32).abs();
        let ulp = if w == 0.0 {
            f32::from_bits(1)
        } else {
            f32::from_bits(w.to_bits() + 1) - w
        };
        rad = rad.max(e);
        ulps = ulps.max(e / ulp as f64);
    }
    (rad, ulps)
}

#[test]
fn atan_f32_accuracy() {
    use std::f32::consts::FRAC_PI_2;
    assert_eq!(sweep::atan_f32(f32::NEG_INFINITY), EMPTY);
    assert_eq!(sweep::atan_f32(f32::INFINITY), FRAC_PI_2);
    assert_eq!(sweep::atan_f32(f32::MAX), FRAC_PI_2);
    assert_eq!(sweep::atan_f32(-f32::MAX), -FRAC_PI_2);
    assert!(sweep::atan_f32(f32::NAN).is_nan());
    assert_eq!(sweep::atan_f32(0.0).to_bits(), 0.0f32.to_bits());
    assert_eq!(sweep::atan_f32(-0.0).to_bits(), (-0.0f32).to_bits());
    let d = f32::from_bits(3); // a denormal: atan x = x
    assert_eq!(sweep::atan_f32(d), d);
    assert_eq!(sweep::atan_f32(-d), -d);
    // one float32 in 4099, all signs and exponents (the whole range is
    // checked by `atan_f32_accuracy_everywhere`); the documented bounds
    let (rad, ulps) = atan_f32_error((0..=u32::MAX).step_by(4099));
    assert!(rad <= 1.12e-7 && ulps <= 2.34, "{rad:e} rad, {ulps} ulps");
    // the vector pass gives the scalar function's values bit for bit
    let mut v: Vec<f32> = (0..=u32::MAX).step_by(4099).map(f32::from_bits).collect();
    v.extend([
        f32::INFINITY,
        f32::NEG_INFINITY,
        1.0,
        -1.0,
        2.414_213_7,
        0.414_213_57,
    ]);
    let want: Vec<f32> = v.iter().map(|&x| sweep::atan_f32(x)).collect();
    sweep::slopes_to_angles(&mut v);
    assert!(same_bits(&v, &want));
}

/// Every float32 (slow unoptimised: `cargo test --release -- --ignored`).
#[test]
#[ignore]
fn atan_f32_accuracy_everywhere() {
    let (rad, ulps) = atan_f32_error(0..=u32::MAX);
    assert!(rad <= 1.12e-7 && ulps <= 2.34, "{rad:e} rad, {ulps} ulps");
}

#[test]
fn hull_insert_is_upper_hull() {
    let mut r = rng(5);
    for _ in 0..50 {
        let mut h = Vec::new();
        let pts: Vec<Proj> = (0..40)
            .map(|_| Proj {
                w: (r() % 30) as f64,
                zz: (r() % 30) as f64,
            })
            .collect();
        for &p in &pts {
            stewart::insert(&mut h, p);
        }
        for k in 0..h.len() {
            if k + 1 < h.len() {
                assert!(h[k].w < h[k + 1].w);
            }
            if k + 2 < h.len() {
                assert!(
                    exact::orient(
                        (h[k].w, h[k].zz),
                        (h[k + 1].w, h[k + 1].zz),
                        (h[k + 2].w, h[k + 2].zz)
                    ) < 0
                );
            }
        }
        // every point lies on or below the hull
        for p in &pts {
            let k = h.partition_point(|v| v.w < p.w);
            if k < h.len() && h[k].w == p.w {
                assert!(p.zz <= h[k].zz);
            } else {
                assert!(k > 0 && k < h.len());
                let (a, b) = (h[k - 1], h[k]);
                assert!(exact::orient((a.w, a.zz), (b.w, b.zz), (p.w, p.zz)) <= 0);
            }
        }
    }
}

#[test]
fn hull_insert_desc_is_insert_reversed() {
    let mut r = rng(11);
    for trial in 0..400 {
        let (mut asc, mut desc) = (Vec::new(), Vec::new());
        // Small integer ranges: many equal w, collinear triples and points
        // on the hull; some sequences mostly by decreasing w (new nearest
        // points), as in a merge.
        let span = [4u64, 12, 40][trial % 3];
        for i in 0..60u64 {
            let w = if trial % 2 == 0 {
                (r() % span) as f64
            } else {
                (span * 2) as f64 - (i / 2) as f64 - (r() % 3) as f64
            };
            let q = Proj {
                w,
                zz: (r() % span) as f64,
            };
            stewart::insert(&mut asc, q);
            stewart::insert_desc(&mut desc, q);
            let back: Vec<Proj> = desc.iter().rev().copied().collect();
            assert_eq!(asc, back, "trial {trial} step {i}");
        }
    }
}

#[test]
fn stewart_max_distance_equals_brute() {
    let mut r = rng(21);
    // Grids: anisotropic, north-up, with a hole and curvature.
    let (h, w) = (19, 23);
    let mut z: Vec<f64> = (0..h * w).map(|_| (r() % 900) as f64 / 60.0).collect();
    z[57] = f64::NAN;
    for (du, dv) in [(1.0, 1.0), (0.7, -1.3)] {
        let t = Terrain::from_grid(z.clone(), h, w, du, dv).unwrap();
        for s in [8usize, 64] {
            for d in [0.5, 1.0, 2.9, 6.0, 15.0, 1e6] {
                for c in [0.0, 2e-3] {
                    let mut o = Options::new(s, Method::Brute);
                    o.max_distance = Some(d);
                    o.curvature = c;
                    let a = run(&t, &o);
                    o.method = Method::Stewart;
                    let b = run(&t, &o);
                    assert!(same_bits(&a, &b), "du {du} dv {dv} s {s} d {d} c {c}");
                }
            }
        }
    }
    // Scattered points, lattice coordinates (exact border alignments).
    let mut seen = std::collections::HashSet::new();
    let (mut x, mut y, mut zz) = (vec![], vec![], vec![]);
    while x.len() < 300 {
        let (a, b) = ((r() % 50) as i64, (r() % 50) as i64);
        if seen.insert((a, b)) {
            x.push(a as f64 * 0.5);
            y.push(b as f64 * 0.5);
            zz.push((r() % 9) as f64);
        }
    }
    let t = Terrain::from_points(x, y, zz).unwrap();
    for s in [8usize, 64] {
        for d in [0.5, 2.0, 5.0, 11.0, 100.0] {
            let mut o = Options::new(s, Method::Brute);
            o.max_distance = Some(d);
            let a = run(&t, &o);
            o.method = Method::Stewart;
            let b = run(&t, &o);
            assert!(same_bits(&a, &b), "points s {s} d {d}");
            // the limit matters: some horizons differ from the unlimited map
            if d < 5.0 {
                let full = run(&t, &Options::new(s, Method::Stewart));
                assert!(!same_bits(&full, &b), "points s {s} d {d}");
            }
        }
    }
}

#[test]
fn sort_keys_reports_the_runs_of_equal_first_keys() {
    let mut r = rng(31);
    let mut sb = stewart::SortBuf::default();
    for n in [1usize, 2, 9, 3000, 70001] {
        for distinct in [3u64, 5000, 1 << 40] {
            let k1: Vec<f64> = (0..n).map(|_| (r() % distinct) as f64 * 0.37).collect();
            let k2: Vec<f64> = (0..n).map(|_| (r() % 7) as f64).collect();
            let (mut out, mut ties) = (Vec::new(), Vec::new());
            stewart::sort_keys_with(&k1, &k2, &mut out, &mut sb, Some(&mut ties));
            let mut want = Vec::new();
            let mut start = 0;
            while start < n {
                let mut end = start + 1;
                while end < n && k1[out[end] as usize] == k1[out[start] as usize] {
                    end += 1;
                }
                if end - start > 1 {
                    want.push((start as u32, end as u32));
                }
                start = end;
            }
            assert_eq!(ties, want, "n {n} distinct {distinct}");
            if distinct == 3 && n > 2 {
                assert!(!ties.is_empty());
            }
        }
    }
}

#[test]
fn sort_runs_finishes_an_order_on_the_same_first_key() {
    // An order sorted by k1 with other tie rules (as the previous sector
    // leaves it), its runs of equal k1 re-sorted by k2, becomes sort_keys'
    // order by (k1, k2).
    let mut r = rng(29);
    let mut sb = stewart::SortBuf::default();
    for n in [1usize, 2, 7, 1000] {
        for distinct in [3u64, 1 << 40] {
            let k1: Vec<f64> = (0..n).map(|_| (r() % distinct) as f64 * 0.37).collect();
            let k2: Vec<f64> = (0..n).map(|_| (r() % distinct) as f64 - 7.0).collect();
            let k3: Vec<f64> = (0..n).map(|_| (r() % 5) as f64).collect();
            let (mut out, mut ties) = (Vec::new(), Vec::new());
            stewart::sort_keys_with(&k1, &k3, &mut out, &mut sb, Some(&mut ties));
            stewart::sort_runs(&k2, &mut out, &ties);
            let mut want = Vec::new();
            stewart::sort_keys(&k1, &k2, &mut want);
            assert_eq!(out, want, "n {n} distinct {distinct}");
        }
    }
}

#[test]
fn stewart_equals_brute_grid_consecutive_sectors() {
    // 2304 points (7 merge levels above the leaf blocks), integer heights on
    // a grid (exact ties on the 45° borders), consecutive sectors on one
    // thread (the first-index order carried over from the previous sector).
    let mut r = rng(31);
    let side = 48;
    let z: Vec<f64> = (0..side * side).map(|_| (r() % 9) as f64).collect();
    let t = Terrain::from_grid(z, side, side, 1.0, 1.0).unwrap();
    for s in [8usize, 16] {
        let a = run(&t, &Options::new(s, Method::Brute));
        let b = run(&t, &Options::new(s, Method::Stewart));
        assert!(same_bits(&a, &b), "s {s}");
    }
}

#[test]
fn tangent_from_any_guess_is_tangent() {
    // Hulls with collinear-free vertices on a small lattice (many exact ties
    // of elevation, settled by distance), seen from points left of them.
    let mut r = rng(23);
    for _ in 0..300 {
        let mut h = Vec::new();
        for _ in 0..(1 + r() % 40) {
            let q = Proj {
                w: (r() % 40) as f64,
                zz: (r() % 25) as f64,
            };
            stewart::insert(&mut h, q);
        }
        for _ in 0..20 {
            let p = Proj {
                w: -1.0 - (r() % 30) as f64,
                zz: (r() % 60) as f64 - 20.0,
            };
            let want = stewart::tangent(&h, p);
            for g in 0..h.len() + 3 {
                assert_eq!(stewart::tangent_from(&h, p, g), want, "guess {g}");
            }
        }
    }
}

#[test]
fn atan2_f32_is_libm_rounded() {
    let mut r = rng(31);
    let mut unit = move || (r() >> 11) as f64 / (1u64 << 53) as f64;
    let check = |y: f64, x: f64| {
        let (got, want) = (atan2_f32(y, x), y.atan2(x) as f32);
        assert!(
            got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
            "atan2({y:e}, {x:e}): {got:e} != {want:e}"
        );
    };
    for _ in 0..400_000 {
        // wide magnitudes, both signs, near-equal legs (u near 1)
        let x = 10f64.powf(unit() * 40.0 - 20.0);
        let y = (unit() - 0.5) * 10f64.powf(unit() * 40.0 - 20.0);
        check(y, x);
        check(x * (1.0 + (unit() - 0.5) * 1e-6), x);
        check(-x, x * (1.0 + (unit() - 0.5) * 1e-9));
        // grid-like integer legs (terrain heights over sample distances)
        let (a, b) = (
            (unit() * 2000.0).floor() - 1000.0,
            (unit() * 1500.0).floor() + 1.0,
        );
        check(a, b);
        check(a * 0.25, b);
    }
    for (y, x) in [
        (0.0, 1.0),
        (-0.0, 1.0),
        (1.0, 1.0),
        (-1.0, 1.0),
        (5e-324, 1.0),
        (1.0, 5e-324),
        (1e-300, 1e300),
        (f64::MAX, 1.0),
        (1.0, f64::MAX),
        (f64::INFINITY, 1.0),
        (1.0, f64::INFINITY),
        (f64::NAN, 1.0),
        (1.0, 0.0),
        (1.0, -2.0),
        (0.0, 0.0),
    ] {
        check(y, x);
    }
}

#[test]
fn compute_into_any_buffer_equals_compute() {
    // Every value of a reused buffer is written: its old contents (NaN,
    // values, the previous map) never show through, for every method and
    // option; a buffer of the wrong length is an error.
    let mut r = rng(31);
    let (h, w) = (23, 29);
    let mut z: Vec<f64> = (0..h * w).map(|_| (r() % 700) as f64 / 60.0).collect();
    z[5 * w + 7] = f64::NAN;
    let grid = Terrain::from_grid(z.clone(), h, w, 1.0, -1.5).unwrap();
    let pts = Terrain::from_points(grid.x.clone(), grid.y.clone(), z).unwrap();
    let (cn, pr) = (Cancel::new(), Progress::default());
    for m in [Method::Stewart, Method::Cms, Method::Brute, Method::Sweep] {
        for (subset, dmax, c, nv) in [
            (None, None, 0.0, false),
            (Some(vec![5, 0, 11]), None, 1e-3, false),
            (None, Some(6.0), 0.0, false),
            (Some(vec![2, 9]), None, 0.0, true),
        ] {
            let mut o = Options::new(12, m);
            o.subset = subset;
            o.max_distance = dmax;
            o.curvature = c;
            o.near_vertex = nv;
            for t in [&grid, &pts] {
                if t.grid.is_none() && (matches!(m, Method::Cms | Method::Sweep) || nv) {
                    continue;
                }
                let want = run(t, &o);
                let mut buf = vec![f32::NAN; want.len()];
                for fill in [f32::NAN, 7.5, f32::NEG_INFINITY] {
                    buf.fill(fill);
                    compute_into(t, &o, &cn, &pr, &mut buf).unwrap();
                    assert!(same_bits(&buf, &want), "{m:?} {o:?}");
                }
                // again into the finished map
                compute_into(t, &o, &cn, &pr, &mut buf).unwrap();
                assert!(same_bits(&buf, &want), "{m:?} {o:?}");
                let mut short = vec![0.0f32; want.len() - 1];
                assert!(compute_into(t, &o, &cn, &pr, &mut short).is_err());
            }
        }
    }
}
