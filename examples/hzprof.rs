//! Profiling helper: `cargo run --release --example hzprof -- N METHOD [S]`.
use _fcol::horizon::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(256);
    let m = Method::parse(args.get(2).map(|s| s.as_str()).unwrap_or("stewart")).unwrap();
    let sectors: usize = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(64);
    let mut s = 1u64;
    let z: Vec<f64> = (0..n * n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % 10000) as f64 / 100.0
        })
        .collect();
    let t = Terrain::from_grid(z, n, n, 1.0, 1.0).unwrap();
    let mut o = Options::new(sectors, m);
    let k: usize = args.get(4).map(|s| s.parse().unwrap()).unwrap_or(1);
    o.subset = Some((0..k).map(|i| (3 + i * 7) % sectors).collect());
    let t0 = std::time::Instant::now();
    let _ = compute(&t, &o, &_fcol::Cancel::new(), &Progress::default()).unwrap();
    println!(
        "{m:?} {k} sectors {:.1} ns/pt/dir (wall)",
        t0.elapsed().as_secs_f64() * 1e9 / (n * n * k) as f64
    );
}
