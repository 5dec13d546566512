//! Timing harness for the horizon-map methods (no Python needed):
//! `cargo run --release --example horizon_time -- <side> <sectors> <method> [max_distance]`.
//! The terrain is smoothed noise at several scales, like the Python bench.
//! `SUBSET=k` computes only k sectors spread evenly over the s.

use _fcol::horizon::{compute, Method, Options, Progress, Terrain};
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

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let side: usize = a.get(1).map_or(256, |v| v.parse().unwrap());
    let s: usize = a.get(2).map_or(64, |v| v.parse().unwrap());
    let m = Method::parse(a.get(3).map_or("stewart", |v| v.as_str())).unwrap();
    let mut o = Options::new(s, m);
    o.max_distance = a.get(4).map(|v| v.parse().unwrap());
    let k: usize = std::env::var("SUBSET").map_or(s, |v| v.parse().unwrap());
    if k < s {
        o.subset = Some((0..k).map(|i| i * s / k).collect());
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
    let out = compute(&t, &o, &Cancel::new(), &Progress::default()).unwrap();
    let dt = t0.elapsed().as_secs_f64();
    let sum: f64 = out.iter().map(|&v| v as f64).sum();
    println!(
        "side {side} s {s} {m:?}: {dt:.3} s, {:.1} ns/point-dir, checksum {sum:.6}",
        dt * 1e9 / (side * side * k.min(s)) as f64
    );
}
