use super::*;
use crate::camera::Projection;
use crate::surface::{Domain, FnHeight};
use glam::DVec3;

fn sinuv() -> FnHeight<impl Fn(f64, f64) -> [f64; 3] + Sync> {
    FnHeight {
        domain: Domain::new(-5.0, 5.0, -5.0, 5.0).unwrap(),
        f: |u: f64, v: f64| {
            let a = u * v.cos();
            let c = 3.0 * a.cos();
            [3.0 * a.sin(), c * v.cos(), -c * u * v.sin()]
        },
    }
}

fn bump() -> FnHeight<impl Fn(f64, f64) -> [f64; 3] + Sync> {
    FnHeight {
        domain: Domain::new(-2.0, 2.0, -2.0, 2.0).unwrap(),
        f: |u: f64, v: f64| {
            let e = (-(u * u + v * v)).exp();
            [e, -2.0 * u * e, -2.0 * v * e]
        },
    }
}

fn ortho(el: f64, az: f64, vh: f64) -> View {
    View {
        elevation: el,
        azimuth: az,
        projection: Projection::Orthographic { view_height: vh },
        target: DVec3::ZERO,
    }
}

fn persp(el: f64, az: f64, dist: f64) -> View {
    View {
        elevation: el,
        azimuth: az,
        projection: Projection::Perspective {
            distance: dist,
            fov: 40.0,
        },
        target: DVec3::ZERO,
    }
}

fn all() -> Outputs {
    Outputs::from_names(&["rgb", "depth", "normal", "uv", "side", "mask"]).unwrap()
}

/// Brute-force first hit along a ray: dense march + bisection (independent of
/// the column sweep). Returns (depth, normal, side).
fn brute(field: &dyn HeightField, cam: &Camera, i: usize, j: usize) -> Option<(f64, DVec3, i8)> {
    let (o, dir) = cam.ray(i as f64, j as f64);
    let d = field.domain();
    // Ray parameter range where it is over the domain and in front.
    let (mut l0, mut l1) = (if cam.perspective { 0.0 } else { -1e3 }, 1e3);
    for (oc, dc, a, b) in [(o.x, dir.x, d.u0, d.u1), (o.y, dir.y, d.v0, d.v1)] {
        if dc.abs() < 1e-300 {
            if oc < a || oc > b {
                return None;
            }
        } else {
            let (p, q) = ((a - oc) / dc, (b - oc) / dc);
            l0 = f64::max(l0, p.min(q));
            l1 = f64::min(l1, p.max(q));
        }
    }
    if l0 >= l1 {
        return None;
    }
    let g = |l: f64| {
        let p = o + l * dir;
        p.z - field.eval(p.x, p.y).f
    };
    let n = 20000;
    let mut prev = g(l0);
    let mut lp = l0;
    for k in 1..=n {
        let l = l0 + (l1 - l0) * k as f64 / n as f64;
        let cur = g(l);
        if prev == 0.0 || prev * cur < 0.0 {
            let (mut a, mut b) = (lp, l);
            for _ in 0..80 {
                let m = 0.5 * (a + b);
                if g(a) * g(m) <= 0.0 {
                    b = m;
                } else {
                    a = m;
                }
            }
            let l = 0.5 * (a + b);
            let p = o + l * dir;
            let hs = field.eval(p.x, p.y);
            let nrm = hs.normal();
            let side = if -dir.dot(nrm) > 0.0 { 1 } else { -1 };
            return Some((cam.camera_coords(p).z, nrm, side));
        }
        prev = cur;
        lp = l;
    }
    None
}

fn check_against_brute(
    field: &dyn HeightField,
    view: &View,
    w: usize,
    h: usize,
) -> (f64, f64, usize) {
    let cam = Camera::new(view, w, h).unwrap();
    let b = render_floating_column(
        field,
        view,
        w,
        h,
        &all(),
        &Shading::default(),
        &FloatingOptions::default(),
        &Cancel::new(),
    )
    .unwrap();
    let mask = b.mask.as_ref().unwrap();
    let depth = b.depth.as_ref().unwrap();
    let normal = b.normal.as_ref().unwrap();
    let mut mask_bad = 0;
    let mut errs = Vec::new();
    let mut nerrs = Vec::new();
    let truth: Vec<Option<(f64, DVec3, i8)>> = (0..h * w)
        .map(|k| brute(field, &cam, k / w, k % w))
        .collect();
    for i in 0..h {
        for j in 0..w {
            let k = i * w + j;
            let t = truth[k];
            // Pixels whose 4-neighbourhood disagrees on hit/miss or depth
            // (jumps) form the 1-pixel band excluded from the comparison.
            let band = [
                (0i64, 1i64),
                (0, -1),
                (1, 0),
                (-1, 0),
                (1, 1),
                (1, -1),
                (-1, 1),
                (-1, -1),
            ]
            .iter()
            .any(|(di, dj)| {
                let (ii, jj) = (i as i64 + di, j as i64 + dj);
                if ii < 0 || jj < 0 || ii >= h as i64 || jj >= w as i64 {
                    return false;
                }
                let q = truth[ii as usize * w + jj as usize];
                match (t, q) {
                    (Some(a), Some(b)) => (a.0 - b.0).abs() > 5.0 * cam.pixel_size_at(a.0.abs()),
                    (None, None) => false,
                    _ => true,
                }
            });
            if band {
                continue;
            }
            if mask[k] != t.is_some() {
                mask_bad += 1;
                continue;
            }
            if let Some((z, n, _)) = t {
                let e = (depth[k] as f64 - z).abs() / cam.pixel_size_at(z.abs());
                errs.push(e);
                let m = DVec3::new(
                    normal[3 * k] as f64,
                    normal[3 * k + 1] as f64,
                    normal[3 * k + 2] as f64,
                );
                nerrs.push(m.cross(n).length().atan2(m.dot(n)).to_degrees());
            }
        }
    }
    errs.sort_by(f64::total_cmp);
    nerrs.sort_by(f64::total_cmp);
    let med = errs[errs.len() / 2];
    let nmed = nerrs[nerrs.len() / 2];
    (med, nmed, mask_bad)
}

#[test]
fn plane_from_above_is_exact() {
    let field = FnHeight {
        domain: Domain::new(-1.0, 1.0, -1.0, 1.0).unwrap(),
        f: |u: f64, v: f64| [0.3 * u + 0.2 * v, 0.3, 0.2],
    };
    let (med, nmed, bad) = check_against_brute(&field, &ortho(90.0, 0.0, 2.5), 40, 40);
    assert!(med < 1e-3 && nmed < 1e-3 && bad == 0, "{med} {nmed} {bad}");
}

#[test]
fn sinuv_ortho_oblique_matches_brute_force() {
    let (med, nmed, bad) = check_against_brute(&sinuv(), &ortho(30.0, 30.0, 16.0), 64, 60);
    assert!(med < 0.02 && nmed < 0.05 && bad == 0, "{med} {nmed} {bad}");
}

#[test]
fn bump_perspective_matches_brute_force() {
    let (med, nmed, bad) = check_against_brute(&bump(), &persp(35.0, 20.0, 8.0), 60, 50);
    assert!(med < 0.02 && nmed < 0.05 && bad == 0, "{med} {nmed} {bad}");
}

#[test]
fn sinuv_perspective_matches_brute_force() {
    let (med, nmed, bad) = check_against_brute(&sinuv(), &persp(30.0, 40.0, 30.0), 64, 60);
    assert!(med < 0.02 && nmed < 0.05 && bad == 0, "{med} {nmed} {bad}");
}

#[test]
fn perspective_looking_straight_down_both_halves() {
    let (med, nmed, bad) = check_against_brute(&bump(), &persp(90.0, 10.0, 6.0), 40, 40);
    assert!(med < 0.02 && nmed < 0.05 && bad == 0, "{med} {nmed} {bad}");
}

#[test]
fn identical_for_any_thread_count() {
    let f = sinuv();
    let v = ortho(25.0, 60.0, 16.0);
    let run = |t| {
        let o = FloatingOptions {
            threads: Some(t),
            ..Default::default()
        };
        render_floating_column(
            &f,
            &v,
            50,
            40,
            &all(),
            &Shading::default(),
            &o,
            &Cancel::new(),
        )
        .unwrap()
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.rgb, b.rgb);
    assert_eq!(
        a.depth
            .unwrap()
            .iter()
            .map(|x| x.to_bits())
            .collect::<Vec<_>>(),
        b.depth
            .unwrap()
            .iter()
            .map(|x| x.to_bits())
            .collect::<Vec<_>>()
    );
    assert_eq!(a.samples, b.samples);
}

#[test]
fn cancelled_render_stops() {
    let c = Cancel::new();
    c.cancel();
    let r = render_floating_column(
        &sinuv(),
        &ortho(30.0, 0.0, 16.0),
        20,
        20,
        &all(),
        &Shading::default(),
        &FloatingOptions::default(),
        &c,
    );
    assert!(matches!(r, Err(FcolError::Interrupted)));
}

#[test]
fn nan_hole_is_a_hole() {
    let field = FnHeight {
        domain: Domain::new(-1.0, 1.0, -1.0, 1.0).unwrap(),
        f: |u: f64, v: f64| {
            if u * u + v * v < 0.25 {
                [f64::NAN; 3]
            } else {
                [0.0, 0.0, 0.0]
            }
        },
    };
    let b = render_floating_column(
        &field,
        &ortho(90.0, 0.0, 2.5),
        40,
        40,
        &all(),
        &Shading::default(),
        &FloatingOptions::default(),
        &Cancel::new(),
    )
    .unwrap();
    let m = b.mask.unwrap();
    assert!(!m[20 * 40 + 20], "centre of the hole must be empty");
    assert!(m[20 * 40 + 6], "outside the hole is surface");
    assert!(b
        .depth
        .unwrap()
        .iter()
        .zip(&m)
        .all(|(d, m)| d.is_nan() != *m));
}

#[test]
fn bresenham_endpoints_and_connectivity() {
    let (w, h) = (10, 10);
    let mut l = vec![0u8; w * h];
    horizon::line(&mut l, w, h, 1, 1, 8, 4);
    let on: Vec<(usize, usize)> = (0..w * h)
        .filter(|k| l[*k] != 0)
        .map(|k| (h - 1 - k / w, k % w))
        .collect();
    assert_eq!(on.len(), 8); // one pixel per x step (|dx| > |dy|)
    assert!(on.contains(&(1, 1)) && on.contains(&(4, 8)));
}

#[test]
fn horizon_draws_lines_in_both_projections() {
    for v in [ortho(30.0, 20.0, 16.0), persp(30.0, 20.0, 30.0)] {
        let o = Outputs::from_names(&["lines"]).unwrap();
        let b = render_floating_horizon(
            &sinuv(),
            &v,
            80,
            60,
            &o,
            &Shading::default(),
            &FloatingOptions::default(),
            &Cancel::new(),
        )
        .unwrap();
        let n = b.lines.unwrap().iter().filter(|x| **x == 255).count();
        assert!(n > 400, "{n}");
    }
}

#[test]
fn fast_atan2_matches_libm() {
    let mut prev = f64::NEG_INFINITY;
    for k in -2000..=2000 {
        // Monotone in y for x > 0, and within 2e-15 rad of libm everywhere.
        let y = (k as f64 * 0.01).sinh();
        let a = radial::fast_atan2(y, 1.0);
        assert!(a >= prev, "not monotone at y = {y}");
        prev = a;
        for x in [
            1e-300, 1e-3, 0.7, 1.0, 3.0, 1e6, -1e-3, -0.7, -1.0, -1e6, 0.0,
        ] {
            for s in [1.0, -1.0] {
                let (got, want) = (radial::fast_atan2(s * y, x), (s * y).atan2(x));
                assert!(
                    (got - want).abs() <= 2e-15,
                    "atan2({}, {x}): {got} vs {want}",
                    s * y
                );
            }
        }
    }
}

#[test]
fn batched_look_ahead_samples_equal_point_samples() {
    // The look-ahead evaluates a column's samples in one batch; each must be
    // the sample the sweep would get point by point, bit for bit (and
    // `None` off the domain).
    let d = Domain::new(-5.0, 5.0, -5.0, 5.0).unwrap();
    let f = crate::source::ExprHeight::new("3*sin(u*cos(v)) + exp(-u*v/9)", &[], 0.0, d).unwrap();
    let cam = Camera::new(&ortho(30.0, 30.0, 13.0), 120, 100).unwrap();
    let frame = sampling::Frame::new(&cam, d);
    let shading = crate::shade::Shading::default();
    for col in [20.0, 37.0, 61.5, 99.0] {
        let mut sampler = sampling::Sampler {
            frame: &frame,
            field: &f,
            line: frame.column(frame.xpix(col)),
            evals: 0,
            folds: 0,
            lateral_tol: 0.02,
            d: cam.d,
            shading: &shading,
            shade: true,
        };
        let ts: Vec<f64> = (0..120).map(|k| -9.0 + 0.155 * k as f64).collect();
        let mut raw = Vec::new();
        let mut scratch = sampling::Scratch::default();
        sampler.sample_many(&ts, &mut raw, &mut scratch);
        let mut some = 0;
        for (t, r) in ts.iter().zip(&raw) {
            let one = sampler.sample(*t, 0.0);
            match (r, one) {
                (Some(x), Some(y)) => {
                    let x = sampler.finish(x.t, x.s, x.uv, x.h, false);
                    assert_eq!(x.rho.to_bits(), y.rho.to_bits());
                    assert_eq!(x.z.to_bits(), y.z.to_bits());
                    assert_eq!(x.drho_dt.to_bits(), y.drho_dt.to_bits());
                    assert_eq!((x.uv, x.n, x.inten), (y.uv, y.n, y.inten));
                    some += 1;
                }
                (None, None) => {}
                _ => panic!("column {col}, t = {t}: batch {r:?} vs point {one:?}"),
            }
        }
        assert!(
            some > 10,
            "column {col}: only {some} samples on the surface"
        );
    }
}

/// §6.4 coverage of a flat square seen from above: its rows span
/// 2 ± 2·sin α in a 5-row image, so the first and last rows are covered by
/// ½ − 2(1 − sin α) (½ when the edges fall on those rows' centres, α = 90°,
/// where the sweep's first sample lies on a pixel centre).
#[test]
fn coverage_of_a_flat_square() {
    let f = FnHeight {
        domain: Domain::new(-0.5, 0.5, -0.5, 0.5).unwrap(),
        f: |_u: f64, _v: f64| [0.0, 0.0, 0.0],
    };
    for el in [90.0f64, 80.0, 70.0] {
        let cam = Camera::new(&ortho(el, 0.0, 1.25), 4, 5).unwrap();
        let frame = sampling::Frame::new(&cam, f.domain());
        let sh = Shading::default();
        let opts = FloatingOptions {
            coverage: true,
            ..Default::default()
        };
        let ctx = Ctx {
            cam: &cam,
            frame,
            field: &f,
            shading: &sh,
            opts: &opts,
            refine: false,
            fallback: false,
            searched: false,
        };
        let end = 0.5 - 2.0 * (1.0 - el.to_radians().sin());
        for j in 0..4 {
            let mut out = vec![Pixel::default(); 5];
            column::render_column(&ctx, j as f64, &mut out);
            let got: Vec<f64> = out.iter().map(|p| p.cover).collect();
            let want = [end, 1.0, 1.0, 1.0, end];
            for (g, w) in got.iter().zip(want) {
                assert!(
                    (g - w).abs() < 1e-6,
                    "α = {el}, column {j}: {got:?} vs {want:?}"
                );
            }
        }
    }
}

/// The range of a Hermite cubic includes its interior extremum: the
/// parabola-like arc through rows 0 and 0 with slopes ±1 peaks at ¼.
#[test]
fn hermite_range_finds_the_extremum() {
    let (lo, hi) = column::hermite_range(0.0, 0.0, 1.0, -1.0);
    assert!(lo == 0.0 && (hi - 0.25).abs() < 1e-12, "{lo} {hi}");
    let (lo, hi) = column::hermite_range(1.0, 3.0, 2.0, 2.0);
    assert!(lo == 1.0 && hi == 3.0, "{lo} {hi}");
}

#[test]
fn azimuth_bins_match_the_exact_angle() {
    use std::f64::consts::PI;
    // Bins::of agrees with the bin of the exact azimuth wherever that angle
    // is not within rounding of a bin edge, for bin counts large and small.
    for n in [1usize, 3, 7, 8, 64, 1000, 4099] {
        let bins = radial::Bins::new(n);
        let width = 2.0 * PI / n as f64;
        for k in 0..20_000 {
            let phi = -PI + (k as f64 + 0.37) * 2.0 * PI / 20_000.0;
            let (y, x) = phi.sin_cos();
            let f = (y.atan2(x) + PI) / width;
            if (f - f.round()).abs() < 1e-9 {
                continue;
            }
            let want = (f as usize).min(n - 1);
            for r in [1.0, 1e-3, 7e4] {
                assert_eq!(bins.of(r * x, r * y), want, "n = {n}, phi = {phi}");
            }
        }
        // Walked to from nearby bins (or from none): the same bin.
        for k in 0..5_000 {
            let phi = -std::f64::consts::PI + 2e-6 + k as f64 * 1.2566e-3;
            let (y, x) = phi.sin_cos();
            let b = bins.of(x, y);
            for d in [0usize, 1, 2, 3, 7, 50] {
                for b0 in [b.saturating_sub(d), (b + d).min(n - 1), usize::MAX] {
                    assert_eq!(bins.near(b0, x, y), b, "n = {n}, phi = {phi}, from {b0}");
                }
            }
        }
        // The negative x axis on either side of the ±π cut.
        assert_eq!(bins.of(-1.0, 1e-12), n - 1);
        assert_eq!(bins.of(-1.0, -1e-12), 0);
    }
}

#[test]
fn pseudo_elevation_is_tan_half_angle_and_monotone() {
    let mut prev = f64::NEG_INFINITY;
    for k in -2000..=2000 {
        let th = k as f64 * (std::f64::consts::FRAC_PI_2 / 2000.0);
        let (z, h) = th.sin_cos();
        for r in [1.0, 1e-6, 3e5] {
            let s = radial::elevation(r * z, r * h.max(0.0));
            assert!((s - (0.5 * th).tan()).abs() <= 4e-16, "θ = {th}: {s}");
        }
        let s = radial::elevation(z, h.max(0.0));
        assert!(s >= prev, "not monotone at θ = {th}");
        prev = s;
    }
}

/// An orthographic render's columns, run in groups sharing their batched
/// evaluations (before the searches after the columns), hold exactly the
/// pixels each column gives alone (a width not a multiple of the group, a
/// compiled expression so that the shared batches take the vectorised
/// path).
#[test]
fn grouped_columns_equal_single_columns() {
    let d = Domain::new(-5.0, 5.0, -5.0, 5.0).unwrap();
    let f = crate::source::ExprHeight::new("3*sin(u*cos(v))", &[], 0.0, d).unwrap();
    let (w, h) = (column::GROUP + 13, 37);
    let cam = Camera::new(&ortho(30.0, 30.0, 13.0), w, h).unwrap();
    let sh = Shading::default();
    let opts = FloatingOptions::default();
    let ctx = Ctx {
        cam: &cam,
        frame: sampling::Frame::new(&cam, f.domain()),
        field: &f,
        shading: &sh,
        opts: &opts,
        refine: true,
        fallback: true,
        searched: true,
    };
    let mut b = Buffers::new(w, h, &all(), sh.background);
    {
        let out = SharedOut::new(&mut b, &sh);
        for g in 0..w.div_ceil(column::GROUP) {
            let js = g * column::GROUP..((g + 1) * column::GROUP).min(w);
            with_scratch(js.len(), |scs| ortho_group(&ctx, js, scs, &out));
        }
    }
    let (depth, normal, mask) = (b.depth.unwrap(), b.normal.unwrap(), b.mask.unwrap());
    let mut seen = 0;
    for j in 0..w {
        let mut out = vec![Pixel::default(); h];
        column::render_column(&ctx, j as f64, &mut out);
        for (i, p) in out.iter().enumerate() {
            let k = i * w + j;
            assert_eq!(mask[k], p.set, "mask at ({i}, {j})");
            if p.set {
                seen += 1;
                assert_eq!(
                    depth[k].to_bits(),
                    (p.depth as f32).to_bits(),
                    "depth at ({i}, {j})"
                );
                let n = [p.n.x as f32, p.n.y as f32, p.n.z as f32];
                assert_eq!(&normal[3 * k..3 * k + 3], &n, "normal at ({i}, {j})");
            }
        }
    }
    assert!(seen > w * h / 4, "too little surface seen: {seen}");
}

/// A worker keeps its column buffers from render to render: the pixels a
/// plain render leaves behind (all interpolated, `refine` off) must not leak
/// into a coverage or supersampled column rendered next with the same
/// buffers. Each column is rendered after a plain render of a column 1, 5
/// or 11 places on, and must equal the column rendered with fresh buffers.
#[test]
fn column_buffers_carry_nothing_between_renders() {
    let d = Domain::new(-5.0, 5.0, -5.0, 5.0).unwrap();
    let f = crate::source::ExprHeight::new("3*sin(u*cos(v))", &[], 0.0, d).unwrap();
    let (w, h) = (24, 37);
    let cam = Camera::new(&ortho(30.0, 30.0, 13.0), w, h).unwrap();
    let sh = Shading::default();
    let outs =
        Outputs::from_names(&["rgb", "intensity", "depth", "normal", "side", "mask"]).unwrap();
    let plain = FloatingOptions {
        refine: false,
        ..Default::default()
    };
    // The column a render of these options runs.
    fn ortho_or_sub(
        ctx: &Ctx<'_>,
        j: usize,
        sc: &mut column::ColumnScratch,
        out: &SharedOut<'_>,
        shade_aa: bool,
    ) -> ColumnStats {
        if shade_aa {
            ortho_subcolumns(ctx, j, sc, out)
        } else {
            ortho_column(ctx, j, sc, out)
        }
    }
    fn ctx_of<'a>(
        cam: &'a Camera,
        f: &'a dyn HeightField,
        sh: &'a Shading,
        opts: &'a FloatingOptions,
    ) -> Ctx<'a> {
        Ctx {
            cam,
            frame: sampling::Frame::new(cam, f.domain()),
            field: f,
            shading: sh,
            opts,
            refine: opts.refine,
            fallback: true,
            searched: false,
        }
    }
    let ctx_plain = ctx_of(&cam, &f, &sh, &plain);
    for opts in [
        FloatingOptions {
            coverage: true,
            ..Default::default()
        },
        FloatingOptions {
            antialias: 3,
            ..Default::default()
        },
    ] {
        let ctx = ctx_of(&cam, &f, &sh, &opts);
        let shade_aa = opts.antialias > 1;
        let mut want = Buffers::new(w, h, &outs, sh.background);
        {
            let out = SharedOut::new(&mut want, &sh);
            for j in 0..w {
                let mut sc = column::ColumnScratch::default();
                ortho_or_sub(&ctx, j, &mut sc, &out, shade_aa);
            }
        }
        for k in [1, 5, 11] {
            let mut got = Buffers::new(w, h, &outs, sh.background);
            let mut waste = Buffers::new(w, h, &outs, sh.background);
            let mut sc = column::ColumnScratch::default();
            {
                let out = SharedOut::new(&mut got, &sh);
                let junk = SharedOut::new(&mut waste, &sh);
                for j in 0..w {
                    ortho_column(&ctx_plain, (j + k) % w, &mut sc, &junk);
                    ortho_or_sub(&ctx, j, &mut sc, &out, shade_aa);
                }
            }
            let what = if shade_aa { "antialias" } else { "coverage" };
            assert_eq!(got.rgb, want.rgb, "{what}, plain column {k} on: rgb");
            assert_eq!(got.side, want.side, "{what}, plain column {k} on: side");
            assert_eq!(got.mask, want.mask, "{what}, plain column {k} on: mask");
            for (name, g, wv) in [
                ("intensity", &got.intensity, &want.intensity),
                ("depth", &got.depth, &want.depth),
                ("normal", &got.normal, &want.normal),
            ] {
                let bits = |v: &Option<Vec<f32>>| -> Vec<u32> {
                    v.as_ref().unwrap().iter().map(|x| x.to_bits()).collect()
                };
                assert_eq!(bits(g), bits(wv), "{what}, plain column {k} on: {name}");
            }
        }
    }
}

/// Every buffer of a render as bits (NaN compared by its bits).
fn bits(b: &Buffers) -> Vec<u64> {
    let f = |v: &Option<Vec<f32>>| -> Vec<u64> {
        v.iter().flatten().map(|x| x.to_bits() as u64).collect()
    };
    let mut out: Vec<u64> = b.rgb.iter().flatten().map(|&x| x as u64).collect();
    for v in [&b.intensity, &b.depth, &b.normal, &b.uv] {
        out.extend(f(v));
    }
    out.extend(b.side.iter().flatten().map(|&x| x as u8 as u64));
    out.extend(b.mask.iter().flatten().map(|&x| x as u64));
    out
}

/// A 64 × 48 render of every buffer with `o`.
fn render_small(field: &dyn HeightField, view: &View, o: &FloatingOptions) -> Buffers {
    render_floating_column(
        field,
        view,
        64,
        48,
        &all(),
        &Shading::default(),
        o,
        &Cancel::new(),
    )
    .unwrap()
}

fn stat(b: &Buffers, name: &str) -> f64 {
    b.stats
        .iter()
        .find(|(k, _)| k == name)
        .map_or(f64::NAN, |s| s.1)
}

/// The height bound's early exit changes no pixel, in any buffer, for
/// expressions and both grid interpolations, views from above, from a low
/// eye (where a near ridge hides the rest) and from below the surface's
/// top, with refinement, without it, with the §5 corrections and with
/// perspective supersampling; and a landscape seen from a low eye behind a
/// ridge stops most sweeps soon after that ridge.
#[test]
fn height_bound_exit_changes_no_pixel() {
    use crate::source::{ExprHeight, HeightGrid, Interpolation};
    let dom = Domain::new(-10.0, 10.0, -10.0, 10.0).unwrap();
    let land = "2*exp(-16*(v + 8.5)**2) + 0.3*sin(1.3*u)*cos(0.7*v) + 0.002*u*v";
    let expr = ExprHeight::new(land, &[], 0.0, dom).unwrap();
    let n = 81;
    let mut z = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let (u, v) = (-10.0 + 0.25 * j as f64, -10.0 + 0.25 * i as f64);
            z.push(expr.eval(u, v).f);
        }
    }
    // A hole, which casts and receives nothing.
    z[40 * n + 40] = f64::NAN;
    let grids: Vec<HeightGrid> = [Interpolation::Bilinear, Interpolation::Bicubic]
        .into_iter()
        .map(|m| HeightGrid::new(z.clone(), n, n, -10.0, 0.25, -10.0, 0.25, m).unwrap())
        .collect();
    let fields: [&dyn HeightField; 3] = [&expr, &grids[0], &grids[1]];
    let low = |el: f64, az: f64, dist: f64, t: (f64, f64)| View {
        elevation: el,
        azimuth: az,
        projection: Projection::Perspective {
            distance: dist,
            fov: 50.0,
        },
        target: DVec3::new(0.0, t.0, t.1),
    };
    // (azimuth 0: the eye near the −v edge, the ridge at v = −8.5 ahead)
    let views = [
        low(3.0, 0.0, 2.0, (-8.0, 1.5)),
        low(1.0, 0.0, 8.0, (0.0, 0.5)),
        low(10.0, -60.0, 14.0, (0.0, 0.0)),
        low(35.0, 20.0, 30.0, (0.0, 0.0)),
        low(-4.0, 150.0, 12.0, (0.0, 0.0)),
        // The eye above the bound, over the domain: the near ground below
        // the image, the far ground in it.
        low(8.0, 30.0, 3.0, (-3.0, 3.2)),
        // Looking up from above the bound: only sky.
        low(-30.0, 0.0, 3.0, (-3.0, 6.0)),
    ];
    let variants = [
        FloatingOptions::default(),
        FloatingOptions {
            refine: false,
            ..Default::default()
        },
        FloatingOptions {
            corrections: Corrections {
                ridges: true,
                bumps: true,
                jumps: true,
                ..Corrections::default()
            },
            shading: ShadingMode::Intensity,
            ..Default::default()
        },
        FloatingOptions {
            antialias: 2,
            ..Default::default()
        },
    ];
    let mut saved = 1.0f64;
    for (fi, field) in fields.iter().enumerate() {
        for (vi, view) in views.iter().enumerate() {
            for (oi, o) in variants.iter().enumerate() {
                if oi > 1 && (fi > 0 || vi > 1) {
                    continue;
                }
                let run = |hb: bool| {
                    let o = FloatingOptions {
                        height_bound: hb,
                        ..*o
                    };
                    render_small(*field, view, &o)
                };
                let (with, without) = (run(true), run(false));
                assert!(
                    bits(&with) == bits(&without),
                    "field {fi}, view {vi}, variant {oi}: the bound changed pixels"
                );
                let (a, b) = (
                    stat(&with, "sweep_samples"),
                    stat(&without, "sweep_samples"),
                );
                assert!(
                    a <= b,
                    "field {fi}, view {vi}, variant {oi}: {a} > {b} samples"
                );
                if vi == 6 {
                    assert!(a == 0.0 && b > 0.0, "{a} / {b} samples of the sky");
                }
                if vi == 0 && oi == 0 {
                    // (most of this small scene's samples lie before the
                    // ridge, near the eye: about 10–20 % are saved)
                    let exits = (stat(&with, "early_exits"), stat(&without, "early_exits"));
                    assert!(exits.0 > 4.0 * exits.1, "field {fi}: exits {exits:?}");
                    saved = saved.min(1.0 - a / b);
                }
            }
        }
    }
    assert!(
        saved > 0.05,
        "the landscape's sweeps saved only {saved:.3} of their samples"
    );
}

/// Zoomed views (a small view height, a narrow field of view), where most
/// of each column's or plane's line lies in front of the picture, below
/// it: stepping over the stretches that the local bounds keep outside the
/// picture takes far fewer samples and shows the same surface (the same
/// mask; the depths of a few pixels may move within the exact solve's
/// tolerance, as the samples after a skipped stretch lie elsewhere).
/// Expressions (interval bounds over each stretch) and grids (block
/// maxima); callables, without bounds, sweep as before.
#[test]
fn skipping_what_lies_outside_the_picture_keeps_it() {
    use crate::source::{ExprHeight, HeightGrid, Interpolation};
    let dom = Domain::new(-5.0, 5.0, -5.0, 5.0).unwrap();
    let src = "3*sin(u*cos(v))";
    let expr = ExprHeight::new(src, &[], 0.0, dom).unwrap();
    let n = 101;
    let z: Vec<f64> = (0..n * n)
        .map(|k| {
            expr.eval(-5.0 + 0.1 * (k % n) as f64, -5.0 + 0.1 * (k / n) as f64)
                .f
        })
        .collect();
    let grid = HeightGrid::new(z, n, n, -5.0, 0.1, -5.0, 0.1, Interpolation::Bilinear).unwrap();
    let call = FnHeight {
        domain: dom,
        f: |u: f64, v: f64| {
            let c = 3.0 * (u * v.cos()).cos();
            [3.0 * (u * v.cos()).sin(), c * v.cos(), -c * u * v.sin()]
        },
    };
    let target = DVec3::new(1.0, 0.5, 3.0 * (0.5f64.cos()).sin());
    let views = [
        View {
            elevation: 30.0,
            azimuth: 30.0,
            projection: Projection::Orthographic { view_height: 0.2 },
            target,
        },
        View {
            elevation: -25.0,
            azimuth: 70.0,
            projection: Projection::Orthographic { view_height: 0.05 },
            target: DVec3::new(-1.0, 2.0, 0.0),
        },
        View {
            elevation: 30.0,
            azimuth: 30.0,
            projection: Projection::Perspective {
                distance: 24.0,
                fov: 1.0,
            },
            target,
        },
    ];
    let fields: [&dyn HeightField; 3] = [&expr, &grid, &call];
    for (fi, field) in fields.iter().enumerate() {
        for (vi, view) in views.iter().enumerate() {
            let run = |skip: bool| {
                let o = FloatingOptions {
                    skip_outside: skip,
                    ..Default::default()
                };
                render_small(*field, view, &o)
            };
            let (with, without) = (run(true), run(false));
            assert_eq!(
                with.mask, without.mask,
                "field {fi}, view {vi}: the mask changed"
            );
            let (dw, dwo) = (
                with.depth.as_ref().unwrap(),
                without.depth.as_ref().unwrap(),
            );
            let fp = match view.projection {
                Projection::Orthographic { view_height } => view_height / 48.0,
                Projection::Perspective { distance, fov } => {
                    distance * (0.5 * fov).to_radians().tan() / 24.0
                }
            };
            let moved = dw
                .iter()
                .zip(dwo)
                .filter(|(a, b)| a.is_finite() && (*a - *b).abs() as f64 > 1e-3 * fp)
                .count();
            assert!(moved <= 2, "field {fi}, view {vi}: {moved} depths moved");
            let (a, b) = (
                stat(&with, "sweep_samples"),
                stat(&without, "sweep_samples"),
            );
            if fi < 2 {
                // (measured 7.0–8.2× on these views)
                assert!(
                    2.5 * a < b,
                    "field {fi}, view {vi}: {a} against {b} samples"
                );
            } else {
                assert_eq!(bits(&with), bits(&without), "a callable has no bounds");
            }
        }
    }
}

/// Views zoomed a million times (view height 1e-6 over a domain 5 wide):
/// level, low and straight down into a grid's hole. Each column's line
/// crosses the domain in some 10⁷ of its pixel's steps; the sweep takes a
/// bounded number of samples (it once took the 4 million step limit per
/// column): the stretches that the bounds keep outside the picture (a
/// bilinear cell's exact range over the stretch, a bicubic cell's
/// Bernstein bound, an expression's interval bound) and those in the hole
/// (no finite value) are stepped over. A bicubic grid once took 281 M
/// samples (18 s) for the level view.
#[test]
fn extreme_zoom_sweeps_stay_bounded() {
    use crate::source::{ExprHeight, HeightGrid, Interpolation};
    let dom = Domain::new(0.0, 5.0, 0.0, 4.0).unwrap();
    let expr = ExprHeight::new("0.3*u*u + sin(3*v)", &[], 0.0, dom).unwrap();
    let (nx, ny) = (50, 40);
    let mut rnd = crate::test_rng::uniform(3);
    let mut z = vec![0.0; nx * ny];
    for i in 0..ny {
        for j in 0..nx {
            z[i * nx + j] = if i == 0 { 0.0 } else { z[(i - 1) * nx + j] } + rnd();
        }
    }
    for i in 10..14 {
        for j in 20..26 {
            z[i * nx + j] = f64::NAN;
        }
    }
    let (du, dv) = (5.0 / (nx - 1) as f64, 4.0 / (ny - 1) as f64);
    let grid =
        HeightGrid::new(z.clone(), ny, nx, 0.0, du, 0.0, dv, Interpolation::Bilinear).unwrap();
    let cubic = HeightGrid::new(z, ny, nx, 0.0, du, 0.0, dv, Interpolation::Bicubic).unwrap();
    let view = |projection, elevation, azimuth, (x, y, z): (f64, f64, f64)| View {
        elevation,
        azimuth,
        projection,
        target: DVec3::new(x, y, z),
    };
    let ortho = Projection::Orthographic { view_height: 1e-6 };
    // (a field of view of 1e-4°: some 10⁸ azimuth bins around the circle,
    // of which the picture meets a few hundred)
    let persp = Projection::Perspective {
        distance: 6.0,
        fov: 1e-4,
    };
    let views = [
        view(ortho, 0.0, -323.0, (0.79, -0.89, 2.34)),
        view(ortho, 5.0, 65.0, (1.0, 1.3, 2.7)),
        // (straight down into the hole: nothing to see)
        view(ortho, 89.99, -224.3, (2.12, 1.12, 2.05)),
        view(ortho, 23.4, -224.6, (0.3, 0.2, 0.5)),
        view(persp, 10.0, 60.0, (1.0, 1.3, 2.7)),
        view(persp, 0.0, -30.0, (0.79, -0.89, 2.34)),
    ];
    let fields: [&dyn HeightField; 3] = [&expr, &grid, &cubic];
    for (fi, field) in fields.iter().enumerate() {
        for (vi, view) in views.iter().enumerate() {
            let b = render_small(*field, view, &FloatingOptions::default());
            let samples = stat(&b, "sweep_samples");
            assert!(
                samples < 100.0 * 64.0 * 48.0,
                "field {fi}, view {vi}: {samples} sweep samples"
            );
        }
    }
}

/// A wall (floor(u): a jump of the height) seen at a zoom where a pixel is
/// near the last place of the coordinates: the sweep retries a step that
/// jumps rows ever shorter, and once did so until the step rounded to
/// none and the wall was retried in place without end (4 million steps
/// per column or plane, 48 s for 8×6 pixels, and a blank picture). It is
/// now a wall: every pixel sees it, in a bounded number of samples. The
/// same for a pole in perspective.
#[test]
fn walls_at_extreme_zoom_are_walls_not_endless_retries() {
    use crate::source::ExprHeight;
    let dom = Domain::new(-3.0, 3.0, -2.0, 4.0).unwrap();
    let f = ExprHeight::new("floor(u) + 0.2*v", &[], 0.0, dom).unwrap();
    let target = DVec3::new(1.874066031997815, 0.9340173249050849, -1.8485922892370181);
    let views = [
        Projection::Orthographic { view_height: 1e-10 },
        Projection::Perspective {
            distance: 0.001,
            fov: 1e-4,
        },
        Projection::Perspective {
            distance: 0.001,
            fov: 1e-5,
        },
    ];
    for projection in views {
        let view = View {
            elevation: 0.01,
            azimuth: -58.65299905027592,
            projection,
            target,
        };
        let b = render_small(&f, &view, &FloatingOptions::default());
        let seen = b.mask.as_ref().unwrap().iter().filter(|&&m| m).count();
        let samples = stat(&b, "sweep_samples");
        assert_eq!(seen, 64 * 48, "{projection:?}: {seen} pixels seen");
        assert!(stat(&b, "walls") > 0.0, "{projection:?}: no wall");
        assert!(
            samples < 100.0 * 64.0 * 48.0,
            "{projection:?}: {samples} sweep samples"
        );
    }
    // A pole (tan(u) at u = π/2) seen from 10⁴ away through a field of
    // view of 4e-5°: every ray crosses it inside the domain. Beside the
    // pole a sample's distance from the eye grows without bound, and steps
    // sized by it overshot the pole again and again (212 M samples, none
    // of the picture seen); beyond the rays' elevations the step is now
    // sized by the rays' own footprint there.
    let tan = ExprHeight::new("tan(u)", &[], 0.0, dom).unwrap();
    let view = View {
        elevation: 0.01,
        azimuth: 244.835,
        projection: Projection::Perspective {
            distance: 1e4,
            fov: 4.25e-5,
        },
        target: DVec3::new(2.6178, -1.187, 1.2996),
    };
    let b = render_small(&tan, &view, &FloatingOptions::default());
    let seen = b.mask.as_ref().unwrap().iter().filter(|&&m| m).count();
    let samples = stat(&b, "sweep_samples");
    assert_eq!(seen, 64 * 48, "pole: {seen} pixels seen");
    assert!(
        samples < 100.0 * 64.0 * 48.0,
        "pole: {samples} sweep samples"
    );
}

/// The plain renders write their colour and NaN buffers once, without a
/// fill before ([`Buffers::deferred`]): every pixel off the mask holds the
/// background, every pixel on it a hit, in both projections, for views
/// that fill the picture in part, with and without the exact solve. (The
/// heap is first strewn with a pattern that is none of these values, so
/// that a pixel left unwritten shows.)
#[test]
fn plain_renders_write_every_pixel() {
    let outs = Outputs::from_names(&["rgb", "intensity", "depth", "normal", "uv", "side", "mask"])
        .unwrap();
    let sh = Shading::default();
    let (w, h) = (97, 61);
    let views = [
        ortho(30.0, 30.0, 13.0),
        ortho(20.0, 75.0, 30.0),
        persp(30.0, 40.0, 24.0),
        persp(15.0, 200.0, 40.0),
    ];
    for view in &views {
        for refine in [true, false] {
            for field in [&sinuv() as &dyn HeightField, &bump()] {
                for len in [3 * w * h, w * h, 2 * w * h] {
                    drop(std::hint::black_box(vec![0x55u8; 4 * len]));
                }
                let o = FloatingOptions {
                    refine,
                    ..Default::default()
                };
                let b = render_floating_column(field, view, w, h, &outs, &sh, &o, &Cancel::new())
                    .unwrap();
                let (rgb, inten, depth) = (b.rgb.unwrap(), b.intensity.unwrap(), b.depth.unwrap());
                let (normal, uv, side, mask) = (
                    b.normal.unwrap(),
                    b.uv.unwrap(),
                    b.side.unwrap(),
                    b.mask.unwrap(),
                );
                assert_eq!(
                    (rgb.len(), normal.len(), uv.len()),
                    (3 * w * h, 3 * w * h, 2 * w * h)
                );
                assert!(
                    mask.iter().any(|&m| m) && mask.iter().any(|&m| !m),
                    "{view:?}"
                );
                for k in 0..w * h {
                    let (c, nrm) = (&rgb[3 * k..3 * k + 3], &normal[3 * k..3 * k + 3]);
                    let floats = || {
                        [depth[k], inten[k]]
                            .into_iter()
                            .chain(nrm.iter().copied())
                            .chain(uv[2 * k..2 * k + 2].iter().copied())
                    };
                    // On the mask a hit (every value finite, a side), off
                    // it the background (its colour, NaN, no side).
                    let good = if mask[k] {
                        floats().all(f32::is_finite) && side[k] != 0
                    } else {
                        c == sh.background && floats().all(f32::is_nan) && side[k] == 0
                    };
                    assert!(
                        good,
                        "pixel {k} of {view:?}: mask {}, rgb {c:?}, depth {}, intensity {}, normal {nrm:?}, side {}",
                        mask[k], depth[k], inten[k], side[k]
                    );
                }
            }
        }
    }
}

#[test]
fn run_end_finds_each_run() {
    // Every flag pattern of up to 19 flags (runs across the eight-flag
    // steps and the tail), from every start, against a flag-by-flag scan.
    let mut rng = crate::test_rng::uniform(7);
    for len in 0..20usize {
        for _ in 0..200 {
            let flags: Vec<bool> = (0..len).map(|_| rng() < 0.7).collect();
            for j in 0..=len {
                for x in [true, false] {
                    let naive = (j..len).find(|&q| flags[q] != x).unwrap_or(len);
                    assert_eq!(run_end(&flags, j, x), naive, "{flags:?} from {j}, {x}");
                }
            }
        }
    }
}
