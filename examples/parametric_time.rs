//! Timing harness for the parametric scan line (no Python needed), on the
//! bench surfaces of `fcol.bench` section `parametric`:
//! `cargo run --release --example parametric_time -- <sphere|torus> [size repeat] [key=value ...]`
//! with keys x_scan (newton | sampled), per_turn, max_error (degrees) and
//! outputs (comma-separated buffer names); `stats=1` prints the render's
//! counters, `dump=<path>` writes the depth, normal and mask buffers of the
//! last render (raw little-endian f32, f32×3 and u8, row-major).

use _fcol::camera::Projection;
use _fcol::parametric::{render, Options, XScanMode};
use _fcol::shade::Shading;
use _fcol::source::ExprParametric;
use _fcol::surface::Domain;
use _fcol::{Cancel, Outputs, View};
use glam::DVec3;
use std::f64::consts::PI;
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let which = a.get(1).map_or("sphere", |v| v.as_str());
    let num = |k: usize, d: usize| a.get(k).and_then(|v| v.parse().ok()).unwrap_or(d);
    let (px, rep) = (num(2, 512), num(3, 5));
    let (mut sampled, mut per_turn, mut max_error) = (true, 16usize, 0.5f64);
    let mut outs = "rgb".to_string();
    let mut show_stats = false;
    let mut dump: Option<String> = None;
    for kv in a.iter().skip(4) {
        let (k, v) = kv.split_once('=').expect("key=value");
        match k {
            "x_scan" => sampled = v == "sampled",
            "per_turn" => per_turn = v.parse().unwrap(),
            "max_error" => max_error = v.parse().unwrap(),
            "outputs" => outs = v.to_string(),
            "stats" => show_stats = v == "1",
            "dump" => dump = Some(v.to_string()),
            _ => panic!("unknown option {k}"),
        }
    }
    let (exprs, dom, view) = if which == "torus" {
        (
            [
                "(1 + 0.4*cos(v))*cos(u)",
                "(1 + 0.4*cos(v))*sin(u)",
                "0.4*sin(v)",
            ],
            Domain::new(0.0, 2.0 * PI, 0.0, 2.0 * PI).unwrap(),
            View {
                elevation: 35.0,
                azimuth: 30.0,
                projection: Projection::Perspective {
                    distance: 5.0,
                    fov: 40.0,
                },
                target: DVec3::ZERO,
            },
        )
    } else {
        (
            ["cos(v)*cos(u)", "cos(v)*sin(u)", "sin(v)"],
            Domain::new(0.0, 2.0 * PI, -PI / 2.0, PI / 2.0).unwrap(),
            View {
                elevation: 30.0,
                azimuth: 20.0,
                projection: Projection::Orthographic { view_height: 2.4 },
                target: DVec3::ZERO,
            },
        )
    };
    let surf = ExprParametric::new(exprs, &[], 0.0, dom).unwrap();
    let names: Vec<&str> = outs.split(',').collect();
    let outputs = Outputs::from_names(&names).unwrap();
    let opts = Options {
        x_scan: if sampled {
            XScanMode::Sampled {
                per_turn,
                max_error,
            }
        } else {
            XScanMode::Newton
        },
        ..Options::default()
    };
    let sh = Shading::default();
    let mut times = Vec::new();
    let mut samples = 0;
    let mut lines = 0;
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let mut stats = Vec::new();
    for _ in 0..rep {
        let t0 = Instant::now();
        let b = render(&surf, &view, px, px, &outputs, &sh, &opts, &Cancel::new()).unwrap();
        times.push(t0.elapsed().as_secs_f64());
        samples = b.samples;
        stats = b.stats.clone();
        if let Some(path) = dump.as_ref() {
            let mut bytes: Vec<u8> = Vec::new();
            b.depth
                .iter()
                .flatten()
                .chain(b.normal.iter().flatten())
                .for_each(|v| bytes.extend_from_slice(&v.to_le_bytes()));
            bytes.extend(b.mask.iter().flatten().map(|&m| m as u8));
            std::fs::write(path, bytes).expect("dump");
        }
        if let Some(m) = b.mask.as_ref() {
            lines = m.chunks(px).filter(|r| r.iter().any(|&x| x)).count();
        }
        // FNV-1a of the depth, normal and mask bits (output identity).
        hash = 0xcbf2_9ce4_8422_2325u64;
        let mut mix = |x: u64| hash = (hash ^ x).wrapping_mul(0x100_0000_01b3);
        b.depth
            .iter()
            .flatten()
            .for_each(|v| mix(v.to_bits() as u64));
        b.normal
            .iter()
            .flatten()
            .for_each(|v| mix(v.to_bits() as u64));
        b.mask.iter().flatten().for_each(|&m| mix(m as u64));
    }
    if show_stats {
        for (k, v) in &stats {
            println!("  {k}: {v}");
        }
    }
    times.sort_by(f64::total_cmp);
    let med = 1e3 * times[times.len() / 2];
    let per_line = if lines > 0 {
        format!(", {:.4} ms/line", med / lines as f64)
    } else {
        String::new()
    };
    println!(
        "{which} {px}²: median {med:.2} ms, min {:.2} ms, samples {samples}{per_line}, output {hash:016x}",
        1e3 * times[0]
    );
}
