//! Timing harness for the horizon-map methods (no Python needed):
//! `cargo run --release --example horizon_time -- <side> <sectors> <method> [max_distance]`.
//! The terrain is smoothed noise at several scales, like the Python bench.
//! `SUBSET=k` computes only k sectors spread evenly over the s;
//! `SECTORS=i,j,..` exactly those sectors. CPU time is reported beside the
//! wall time (the figure to compare on a shared machine).
//!
//! `REPEAT=n`: after the first call (which allocates its output, as
//! `fcol.horizon_map` does), the same map computed n more times into that
//! output with `compute_into` (a reused buffer, as with `out=`: no page to
//! fault in; set to NaN before each run, untimed); a second line gives the
//! median and the fastest of those n runs. The checksum is the first
//! call's; the repeats are checked equal to it bit for bit. `DUMP=path`
//! writes the first call's values to `path`
//! (raw little-endian float32, plane-major) for comparing maps.

use _fcol::horizon::{compute, compute_into, Method, Options, Progress, Terrain};
use _fcol::Cancel;
use std::time::Instant;

fn terrain(side: usize, seed: u64) -> Vec<f64> {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut z = vec![0.0; side * side];
    let mut k = 1;
    while k < side {
        let c = side / k + 2;
        let coarse: Vec<f64> = (0..c * c).map(|_| rnd() * 3.4 * k as f64).collect();
        for i in 0..side {
            for j in 0..side {
                z[i * side + j] += coarse[(i / k) * c + j / k];
            }
        }
        k *= 2;
    }
    z
}

/// CPU time of the whole process (all threads), in seconds.
fn cpu_seconds() -> f64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_PROCESS_CPUTIME_ID: i32 = 2;
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: clock_gettime writes one timespec to a valid pointer.
    let r = unsafe { clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    if r != 0 {
        return f64::NAN;
    }
    ts.sec as f64 + ts.nsec as f64 * 1e-9
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let side: usize = a.get(1).map_or(256, |v| v.parse().unwrap());
    let s: usize = a.get(2).map_or(64, |v| v.parse().unwrap());
    let m = Method::parse(a.get(3).map_or("stewart", |v| v.as_str())).unwrap();
    let mut o = Options::new(s, m);
    o.max_distance = a.get(4).map(|v| v.parse().unwrap());
    let mut k: usize = std::env::var("SUBSET").map_or(s, |v| v.parse().unwrap());
    if k < s {
        o.subset = Some((0..k).map(|i| i * s / k).collect());
    }
    if let Ok(v) = std::env::var("SECTORS") {
        let list: Vec<usize> = v.split(',').map(|i| i.trim().parse().unwrap()).collect();
        k = list.len();
        o.subset = Some(list);
    }
    let t = Terrain::from_grid(terrain(side, 1), side, side, 1.0, 1.0).unwrap();
    if std::env::var_os("HULLS").is_some() {
        for i in [0, 5, 13] {
            let f = _fcol::horizon::Frame::new(i, s);
            let (mean, max) = _fcol::horizon::stewart::hull_stats(&t, &f, &o);
            println!("sector {i}: hull mean {mean:.2} max {max}");
        }
    }
    let t0 = Instant::now();
    let c0 = cpu_seconds();
    let out = compute(&t, &o, &Cancel::new(), &Progress::default()).unwrap();
    let dt = t0.elapsed().as_secs_f64();
    let dc = cpu_seconds() - c0;
    let sum: f64 = out.iter().map(|&v| v as f64).sum();
    let per = 1e9 / (side * side * k.min(s)) as f64;
    println!(
        "side {side} s {s} {m:?}: {dt:.3} s wall, {dc:.3} s CPU, {:.1} ns/point-dir wall, \
         {:.1} ns/point-dir CPU, checksum {sum:.6}",
        dt * per,
        dc * per
    );
    if let Ok(path) = std::env::var("DUMP") {
        let bytes: Vec<u8> = out.iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(path, bytes).unwrap();
    }
    let repeat: usize = std::env::var("REPEAT").map_or(0, |v| v.parse().unwrap());
    if repeat > 0 {
        let mut buf = vec![0.0f32; out.len()];
        let (mut walls, mut cpus) = (vec![], vec![]);
        for _ in 0..repeat {
            // (untimed: the check below must see values this run wrote)
            buf.fill(f32::NAN);
            let t0 = Instant::now();
            let c0 = cpu_seconds();
            compute_into(&t, &o, &Cancel::new(), &Progress::default(), &mut buf).unwrap();
            walls.push(t0.elapsed().as_secs_f64() * per);
            cpus.push((cpu_seconds() - c0) * per);
            assert!(buf
                .iter()
                .zip(&out)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        let med = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            (v[v.len() / 2], v[0])
        };
        let ((mw, fw), (mc, fc)) = (med(&mut walls), med(&mut cpus));
        println!(
            "  reused output, {repeat} runs: {mw:.1} ns/point-dir wall (fastest {fw:.1}), \
             {mc:.1} ns/point-dir CPU (fastest {fc:.1})"
        );
    }
}
