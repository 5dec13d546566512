//! Timing harness for the floating column (no Python needed), on the bench
//! surface 3 sin(u cos v) over [−5, 5]²:
//! `cargo run --release --example floating_time -- <ortho|persp> [width height repeat] [key=value ...]`
//! with keys refine, step, max_step, bin_width, tol (`refine_tol`), outs (comma-separated buffers) (the options
//! of `fcol.render`),
//! hash=1 to print a digest of the buffers (to compare outputs across builds),
//! height_bound=0 to sweep without the height bound's early exit, skip=0 to
//! sweep without stepping over stretches outside the picture, el, az and dist to
//! change the view's elevation, azimuth and (perspective) distance, vh
//! (orthographic view height) and fov (perspective) to zoom, tx, ty, tz for
//! the target, expr and domain (u0,u1,v0,v1) for another surface
//! and stats=1 to print the render's counters (with evaluations per pixel seen).

use _fcol::camera::Projection;
use _fcol::floating::{render_floating_column, FloatingOptions};
use _fcol::image::Buffers;
use _fcol::shade::Shading;
use _fcol::source::ExprHeight;
use _fcol::surface::Domain;
use _fcol::{Cancel, Outputs, View};
use glam::DVec3;
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let which = a.get(1).map_or("ortho", |v| v.as_str());
    let num = |k: usize, d: usize| a.get(k).and_then(|v| v.parse().ok()).unwrap_or(d);
    let (w, h, rep) = (num(2, 480), num(3, 477), num(4, 5));
    let mut o = FloatingOptions::default();
    let mut want_hash = false;
    let mut want_stats = false;
    let (mut el, mut az, mut dist): (Option<f64>, Option<f64>, Option<f64>) = (None, None, None);
    let (mut vh, mut fov): (Option<f64>, Option<f64>) = (None, None);
    let mut target = DVec3::ZERO;
    let mut expr = "3*sin(u*cos(v))".to_string();
    let mut domain = [-5.0, 5.0, -5.0, 5.0];
    let mut names = vec![
        "rgb".to_string(),
        "depth".into(),
        "normal".into(),
        "mask".into(),
    ];
    for kv in a.iter().skip(5) {
        let (k, v) = kv.split_once('=').expect("key=value");
        match k {
            "refine" => o.refine = v == "1" || v == "true",
            "step" => o.step = Some(v.parse().unwrap()),
            "max_step" => o.max_step = Some(v.parse().unwrap()),
            "bin_width" => o.bin_width = Some(v.parse().unwrap()),
            "outs" => names = v.split(',').map(str::to_string).collect(),
            "hash" => want_hash = v == "1" || v == "true",
            "stats" => want_stats = v == "1" || v == "true",
            "height_bound" => o.height_bound = v == "1" || v == "true",
            "skip" => o.skip_outside = v == "1" || v == "true",
            "vh" => vh = Some(v.parse().unwrap()),
            "fov" => fov = Some(v.parse().unwrap()),
            "tx" => target.x = v.parse().unwrap(),
            "ty" => target.y = v.parse().unwrap(),
            "tz" => target.z = v.parse().unwrap(),
            "el" => el = Some(v.parse().unwrap()),
            "az" => az = Some(v.parse().unwrap()),
            "dist" => dist = Some(v.parse().unwrap()),
            "tol" => o.refine_tol = v.parse().unwrap(),
            "expr" => expr = v.to_string(),
            "domain" => {
                let xs: Vec<f64> = v.split(',').map(|x| x.parse().unwrap()).collect();
                domain.copy_from_slice(&xs);
            }
            _ => panic!("unknown option {k}"),
        }
    }
    let mut view = if which == "persp" {
        View {
            elevation: 30.0,
            azimuth: 40.0,
            projection: Projection::Perspective {
                distance: 24.0,
                fov: 40.0,
            },
            target: DVec3::ZERO,
        }
    } else {
        View {
            elevation: 30.0,
            azimuth: 30.0,
            projection: Projection::Orthographic { view_height: 13.0 },
            target: DVec3::ZERO,
        }
    };
    if let Some(x) = el {
        view.elevation = x;
    }
    if let Some(x) = az {
        view.azimuth = x;
    }
    if let (Some(x), Projection::Perspective { distance, .. }) = (dist, &mut view.projection) {
        *distance = x;
    }
    if let (Some(x), Projection::Perspective { fov: f, .. }) = (fov, &mut view.projection) {
        *f = x;
    }
    if let (Some(x), Projection::Orthographic { view_height }) = (vh, &mut view.projection) {
        *view_height = x;
    }
    view.target = target;
    let dom = Domain::new(domain[0], domain[1], domain[2], domain[3]).unwrap();
    let f = ExprHeight::new(&expr, &[], 0.0, dom).unwrap();
    let outs = Outputs::from_names(&names.iter().map(String::as_str).collect::<Vec<_>>()).unwrap();
    let sh = Shading::default();
    let mut times = Vec::new();
    let mut samples = 0;
    let mut hash = 0;
    let mut last = None;
    for _ in 0..rep {
        let t0 = Instant::now();
        let b = render_floating_column(&f, &view, w, h, &outs, &sh, &o, &Cancel::new()).unwrap();
        times.push(t0.elapsed().as_secs_f64());
        samples = b.samples;
        if want_hash {
            hash = digest(&b);
        }
        last = Some(b);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{which} {w}x{h}: median {:.2} ms, min {:.2} ms, samples {samples}{}",
        1e3 * times[times.len() / 2],
        1e3 * times[0],
        if want_hash {
            format!(", buffers {hash:016x}")
        } else {
            String::new()
        }
    );
    if let (true, Some(b)) = (want_stats, &last) {
        let seen = b.mask.iter().flatten().filter(|&&m| m).count();
        let mut line = format!("  pixels seen {seen}");
        for (k, v) in &b.stats {
            line += &format!(", {k} {v}");
            if k == "refine_evals" && seen > 0 {
                line += &format!(" ({:.3} per pixel seen)", v / seen as f64);
            }
        }
        println!("{line}");
    }
}

/// FNV-1a of the bytes of every buffer (to compare outputs across builds).
fn digest(b: &Buffers) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |bytes: &[u8]| {
        for &x in bytes {
            h = (h ^ x as u64).wrapping_mul(0x0100_0000_01b3);
        }
    };
    let f32s = |v: &Option<Vec<f32>>| -> Vec<u8> {
        v.iter()
            .flatten()
            .flat_map(|x| x.to_bits().to_le_bytes())
            .collect()
    };
    eat(b.rgb.as_deref().unwrap_or(&[]));
    eat(&f32s(&b.intensity));
    eat(&f32s(&b.depth));
    eat(&f32s(&b.normal));
    eat(&f32s(&b.uv));
    eat(&b
        .side
        .iter()
        .flatten()
        .map(|&x| x as u8)
        .collect::<Vec<_>>());
    eat(&b
        .mask
        .iter()
        .flatten()
        .map(|&x| x as u8)
        .collect::<Vec<_>>());
    h
}
