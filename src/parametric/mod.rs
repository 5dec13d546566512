//! Parametric surfaces X(u, v), Y(u, v), Z(u, v) drawn by Blinn's scan line
//! algorithm (Blinn 1978, "A scan line algorithm for displaying
//! parametrically defined surfaces"), without tessellation.
//!
//! * [`screen`]: the surface in screen space (the perspective transform
//!   applied to the defining functions, §2), derivatives by the chain rule;
//! * [`maxima`]: local maxima of screen y (§3.2.2.1), also along each edge
//!   and at edge ends;
//! * [`folds`]: the §3.4 pre-scan for curtain folds (maxima of y along the
//!   silhouette);
//! * [`trackers`]: the Y scan — boundary-edge and silhouette trackers
//!   updated by Newton with extrapolation (§3.2.1, §3.5), created at maxima
//!   folded edges, curtain folds, seams and the left image border, deleted
//!   at minima (§3.2.2–3.2.4), with a safety net as a fallback;
//! * [`xscan_exact`]: the exact X scan (§3.3);
//! * [`xscan_sampled`]: the sampled X scan (§4) — samples at equal steps of
//!   the cross-section normal angle, normals interpolated between them.
//!
//! Scan lines run in bands of fixed height in parallel (rayon); each band
//! seeds its trackers afresh, so the output does not depend on the number
//! of threads.

pub mod folds;
pub mod maxima;
pub mod screen;
pub mod shapes;
pub mod trackers;
pub mod xscan_exact;
pub mod xscan_sampled;

use crate::camera::{Camera, View};
use crate::cancel::Cancel;
use crate::error::{FcolError, Result};
use crate::image::{Buffers, Outputs};
use crate::shade::Shading;
use crate::surface::ParametricSurface;
use rayon::prelude::*;
use screen::Screen;
use trackers::{Tracker, YScan, YStats};
use xscan_exact::{Hit, XScan, XStats};

/// How each scan line is filled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum XScanMode {
    /// Newton per pixel (§3.3).
    Newton,
    /// Samples at equal steps of the normal angle (§4), `per_turn` per full
    /// turn at least, more where the interpolated normal would deviate by
    /// more than `max_error` degrees.
    Sampled { per_turn: usize, max_error: f64 },
}

/// Options of a parametric scan-line render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    pub x_scan: XScanMode,
    /// Grid nodes per parameter for the maxima search and the safety net.
    pub grid: usize,
    /// Extrapolate tracker positions between scan lines (§3.5).
    pub extrapolate: bool,
    /// Scan lines per parallel band.
    pub band: usize,
    /// Let the safety net add trackers the tracking missed (after the
    /// first scan line of a band). Off only to check the tracking alone.
    pub safety_net: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            x_scan: XScanMode::Newton,
            grid: 97,
            extrapolate: true,
            band: 16,
            safety_net: true,
        }
    }
}

impl Options {
    pub fn validate(&self) -> Result<()> {
        if !(5..=2049).contains(&self.grid) {
            return Err(FcolError::value(
                "grid",
                format!("must be in 5..=2049, got {}", self.grid),
            ));
        }
        if self.band == 0 {
            return Err(FcolError::value("band", "must be at least 1"));
        }
        if let XScanMode::Sampled {
            per_turn,
            max_error,
        } = self.x_scan
        {
            if !(4..=4096).contains(&per_turn) {
                return Err(FcolError::value(
                    "samples_per_turn",
                    format!("must be in 4..=4096, got {per_turn}"),
                ));
            }
            if !(max_error.is_finite() && max_error > 0.0) {
                return Err(FcolError::value(
                    "max_normal_error",
                    format!("must be a positive number of degrees, got {max_error}"),
                ));
            }
        }
        Ok(())
    }
}

/// What the renderer knows about one pixel.
#[derive(Debug, Clone, Copy)]
pub struct Pixel {
    pub z: f64,
    pub u: f64,
    pub v: f64,
    /// Unit normal P_u × P_v (world axes).
    pub n: glam::DVec3,
    /// World point (for shading).
    pub p: glam::DVec3,
}

impl Pixel {
    fn from_hit(h: &Hit) -> Option<Pixel> {
        let n = if h.n != glam::DVec3::ZERO {
            h.n
        } else {
            let l = h.pn.length();
            if l > 0.0 && l.is_finite() {
                h.pn / l
            } else {
                glam::DVec3::NAN
            }
        };
        Some(Pixel {
            z: h.z,
            u: h.u,
            v: h.v,
            n,
            p: h.p,
        })
    }
}

#[derive(Debug, Clone, Default)]
struct BandStats {
    y: YStats,
    x: XStats,
}

/// Render a parametric surface. Only the buffers in `outputs` are computed.
#[allow(clippy::too_many_arguments)]
pub fn render(
    surf: &(dyn ParametricSurface + Sync),
    view: &View,
    width: usize,
    height: usize,
    outputs: &Outputs,
    shading: &Shading,
    opts: &Options,
    cancel: &Cancel,
) -> Result<Buffers> {
    opts.validate()?;
    shading.validate()?;
    let cam = Camera::new(view, width, height)?;
    let sc = Screen::new(surf, &cam);
    let x_left = -0.5 * width as f64;
    // The pre-scans are independent: run them side by side.
    let g = opts.grid.min(129);
    let ((maxima, net), ((saddles, folds), seams)) = rayon::join(
        || {
            rayon::join(
                || maxima::find_maxima(&sc, g),
                || trackers::Net::build(&sc, opts.grid, 4 * opts.grid, x_left),
            )
        },
        || {
            rayon::join(
                || {
                    rayon::join(
                        || maxima::find_saddles(&sc, g),
                        || folds::find_folds(&sc, g),
                    )
                },
                || trackers::seams(&sc),
            )
        },
    );
    // Depth unit of the sampled scan's cross-section angle: one pixel at
    // the view distance.
    let zs = match view.projection {
        crate::camera::Projection::Perspective { distance, .. } => cam.pixel_size_at(distance),
        crate::camera::Projection::Orthographic { .. } => cam.pixel_size_at(1.0),
    };
    let sampled = matches!(opts.x_scan, XScanMode::Sampled { .. });
    cancel.check()?;
    let ys_of = |i: usize| 0.5 * height as f64 - i as f64 - 0.5;
    let bands: Vec<(usize, usize)> = (0..height)
        .step_by(opts.band)
        .map(|r0| (r0, (r0 + opts.band).min(height)))
        .collect();
    // Each band returns its covered pixels only (image index, pixel).
    type BandOut = (Vec<(usize, Pixel)>, BandStats);
    let results: Vec<Result<BandOut>> = bands
        .par_iter()
        .map(|&(r0, r1)| {
            let mut yscan = YScan::new(&sc, x_left, opts.extrapolate);
            yscan.rescue = opts.safety_net;
            yscan.seams = seams;
            let mut xscan = XScan::new(&sc, width);
            xscan.saddles = saddles.clone();
            xscan.cancel = Some(cancel);
            // Pixel solves to first order in both scans: the sampled scan
            // completes a solution to second order only where it starts
            // a span from it (dϑ/dx needs ∇J and ∇K).
            xscan.first_order = true;
            if let XScanMode::Sampled {
                per_turn,
                max_error,
            } = opts.x_scan
            {
                xscan.sampled = Some(xscan_sampled::Params {
                    step: std::f64::consts::TAU / per_turn as f64,
                    max_error: max_error.to_radians(),
                });
                xscan.zs = zs;
            }
            let mut st = BandStats::default();
            let mut trackers: Vec<Tracker> = Vec::new();
            let mut seeds = Vec::new();
            let mut pix: Vec<(usize, Pixel)> = Vec::with_capacity((r1 - r0) * width);
            let mut hits: Vec<Option<Hit>> = vec![None; width];
            for i in r0..r1 {
                cancel.check()?;
                let ys = ys_of(i);
                yscan.step(
                    &mut trackers,
                    ys,
                    i == r0,
                    &maxima.maxima,
                    &saddles,
                    &folds,
                    &net,
                    &mut seeds,
                    &mut st.y,
                );
                if sampled {
                    xscan.sampled_begin(&trackers, ys, opts.extrapolate, &mut st.x);
                }
                xscan.row(&trackers, ys, &mut hits, &mut st.x);
                if sampled {
                    xscan.sampled_end(&mut st.x);
                }
                // Only the pixels given a hit on this row (cleared for the
                // next one as they are read).
                for j in xscan.take_touched() {
                    if let Some(px) = hits[j].take().as_ref().and_then(Pixel::from_hit) {
                        pix.push((i * width + j, px));
                    }
                }
            }
            Ok((pix, st))
        })
        .collect();
    let mut b = Buffers::new(width, height, outputs, shading.background);
    let mut total = BandStats::default();
    for (&(r0, r1), r) in bands.iter().zip(results) {
        let (pix, st) = r?;
        total.y.add(&st.y);
        total.x.add(&st.x);
        for (idx, px) in &pix {
            debug_assert!((r0 * width..r1 * width).contains(idx));
            write_pixel(&mut b, *idx, px, &sc, shading);
        }
    }
    b.samples = sc.evals();
    let y = &total.y;
    let x = &total.x;
    let per = |a: u64, n: u64| if n == 0 { 0.0 } else { a as f64 / n as f64 };
    b.stat("maxima", maxima.maxima.len() as f64);
    b.stat("maxima_search_failures", maxima.failed as f64);
    b.stat("parabolic_maxima", maxima.parabolic as f64);
    b.stat("saddles", saddles.len() as f64);
    b.stat("silhouette_y_extrema", net.sil_peaks as f64);
    b.stat("tracker_updates", y.updates as f64);
    b.stat("newton_per_update", per(y.iters, y.updates));
    b.stat("newton_per_update_tenth_px", per(y.iters_blinn, y.updates));
    b.stat("trackers_lost", y.lost as f64);
    b.stat("trackers_exited", y.exited as f64);
    b.stat("created_at_maxima", y.created_maxima as f64);
    b.stat("created_at_folds", y.created_fold as f64);
    b.stat("created_at_saddles", y.created_saddles as f64);
    b.stat("curtain_folds", folds.len() as f64);
    b.stat("created_at_curtain_folds", y.created_curtain as f64);
    b.stat("created_at_left_border", y.created_left as f64);
    b.stat("created_at_seams", y.created_seam as f64);
    b.stat("net_added", y.net_added as f64);
    b.stat("band_seeds", y.band_seeds as f64);
    b.stat("pieces", x.pieces as f64);
    b.stat("pixel_solves", x.pixel_solves as f64);
    // Newton corrections per point solved in the X scan (pixels, and for
    // the sampled scan its samples and error probes).
    b.stat(
        "newton_per_pixel",
        per(
            x.pixel_iters,
            x.pixel_solves + x.fallback_solves + x.sample_solves,
        ),
    );
    b.stat("fallback_solves", x.fallback_solves as f64);
    b.stat("continuation_steps", x.continuation_steps as f64);
    b.stat("convergence_failures", x.continuation_failures as f64);
    b.stat("fold_walks", x.fold_walks as f64);
    b.stat("border_walks", x.border_walks as f64);
    if let XScanMode::Sampled { .. } = opts.x_scan {
        let s = &total.x;
        b.stat("x_samples", s.samples as f64);
        b.stat("x_samples_refined", s.refined as f64);
        b.stat("turn_points", s.turns as f64);
        b.stat("x_span_tests", s.span_tests as f64);
        b.stat("x_links_kept", s.links_kept as f64);
        b.stat("x_wrong_arc", s.wrong_arc as f64);
        b.stat("x_sideways", s.sideways as f64);
        b.stat("x_fold_starts", s.fold_starts as f64);
        // Normal-angle trackers (§4): Newton corrections per update from
        // the previous position (plain) and from the §3.5 extrapolation.
        b.stat(
            "theta_updates",
            (s.theta_updates + s.theta_updates_ex) as f64,
        );
        b.stat(
            "theta_newton_per_update",
            per(
                s.theta_iters + s.theta_iters_ex,
                s.theta_updates + s.theta_updates_ex,
            ),
        );
        b.stat(
            "theta_newton_per_update_plain",
            per(s.theta_iters, s.theta_updates),
        );
        b.stat(
            "theta_newton_per_update_extrapolated",
            per(s.theta_iters_ex, s.theta_updates_ex),
        );
        b.stat("theta_trackers_created", s.theta_created as f64);
        b.stat("theta_trackers_deleted", s.theta_deleted as f64);
        b.stat("theta_trackers_lost", s.theta_lost as f64);
    }
    Ok(b)
}

fn write_pixel(b: &mut Buffers, idx: usize, px: &Pixel, sc: &Screen<'_>, shading: &Shading) {
    let to_eye = sc.to_eye(px.p);
    let ok_n = px.n.is_finite();
    // A degenerate normal (a pole) counts as facing the viewer.
    let side: i8 = if !ok_n || px.n.dot(to_eye) >= 0.0 {
        1
    } else {
        -1
    };
    if let Some(m) = b.mask.as_mut() {
        m[idx] = true;
    }
    if let Some(d) = b.depth.as_mut() {
        d[idx] = px.z as f32;
    }
    if let Some(uv) = b.uv.as_mut() {
        uv[2 * idx] = px.u as f32;
        uv[2 * idx + 1] = px.v as f32;
    }
    if let Some(s) = b.side.as_mut() {
        s[idx] = side;
    }
    if let Some(nb) = b.normal.as_mut() {
        nb[3 * idx] = px.n.x as f32;
        nb[3 * idx + 1] = px.n.y as f32;
        nb[3 * idx + 2] = px.n.z as f32;
    }
    if b.intensity.is_some() || b.rgb.is_some() {
        let i = if ok_n {
            shading.intensity(px.n, to_eye)
        } else {
            shading.ambient
        };
        if let Some(ib) = b.intensity.as_mut() {
            ib[idx] = i as f32;
        }
        if let Some(c) = b.rgb.as_mut() {
            let col = shading.colour(i, side);
            c[3 * idx..3 * idx + 3].copy_from_slice(&col);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use glam::DVec3;

    fn view(el: f64, az: f64, persp: bool) -> View {
        View {
            elevation: el,
            azimuth: az,
            projection: if persp {
                Projection::Perspective {
                    distance: 6.0,
                    fov: 30.0,
                }
            } else {
                Projection::Orthographic { view_height: 2.6 }
            },
            target: DVec3::new(0.05, -0.03, 0.02),
        }
    }

    fn all() -> Outputs {
        Outputs::from_names(&["depth", "normal", "mask", "uv", "side"]).unwrap()
    }

    /// Spheres of radius 1, 1e-6 and 1e6 against exact ray–sphere
    /// intersection (SPEC §5: tiny and huge scales).
    #[test]
    fn sphere_matches_ray_intersection() {
        for scale in [1.0, 1e-6, 1e6] {
            sphere_case(scale);
        }
    }

    fn sphere_case(scale: f64) {
        let s = shapes::sphere(scale);
        for (el, az, persp) in [
            (30.0, 20.0, false),
            (90.0, 0.0, false),
            (-40.0, 200.0, true),
            (10.0, 75.0, true),
        ] {
            let mut v = view(el, az, persp);
            v.target *= scale;
            v.projection = match v.projection {
                Projection::Orthographic { view_height } => Projection::Orthographic {
                    view_height: view_height * scale,
                },
                Projection::Perspective { distance, fov } => Projection::Perspective {
                    distance: distance * scale,
                    fov,
                },
            };
            let (w, h) = (120, 100);
            let b = render(
                &s,
                &v,
                w,
                h,
                &all(),
                &Shading::default(),
                &Options::default(),
                &Cancel::new(),
            )
            .unwrap();
            let cam = Camera::new(&v, w, h).unwrap();
            let mask = b.mask.as_ref().unwrap();
            let depth = b.depth.as_ref().unwrap();
            let normal = b.normal.as_ref().unwrap();
            let mut bad = 0;
            let mut worst_d: f64 = 0.0;
            let mut worst_n: f64 = 0.0;
            for i in 0..h {
                for j in 0..w {
                    let (o, dir) = cam.ray(i as f64, j as f64);
                    let o = o / scale; // in units of the radius
                                       // |o + t dir|² = 1
                    let bq = o.dot(dir);
                    let c = o.dot(o) - 1.0;
                    let disc = bq * bq - c;
                    let hit = disc > 0.0;
                    let idx = i * w + j;
                    if hit != mask[idx] {
                        // Only within a pixel of the silhouette.
                        let d_sil = scale * disc.abs().sqrt() / cam.pixel_size_at(6.0 * scale);
                        if d_sil > 1.5 {
                            bad += 1;
                        }
                        continue;
                    }
                    if !hit {
                        continue;
                    }
                    let t = -bq - disc.sqrt();
                    let p = (o + t * dir) * scale;
                    let z = cam.camera_coords(p).z;
                    let dz = (z - depth[idx] as f64).abs() / cam.pixel_size_at(z);
                    let n = DVec3::new(
                        normal[3 * idx] as f64,
                        normal[3 * idx + 1] as f64,
                        normal[3 * idx + 2] as f64,
                    );
                    if disc > 1e-3 {
                        worst_d = worst_d.max(dz);
                        worst_n = worst_n.max(n.angle_between(p / scale).to_degrees());
                    }
                }
            }
            assert_eq!(bad, 0, "view {el} {az} {persp}: {bad} mask errors");
            assert!(worst_d < 1e-3, "depth error {worst_d} px");
            assert!(worst_n < 0.05, "normal error {worst_n}°");
        }
    }

    #[test]
    fn identical_for_any_thread_count() {
        for x_scan in [
            XScanMode::Newton,
            XScanMode::Sampled {
                per_turn: 16,
                max_error: 0.5,
            },
        ] {
            identical_for_any_thread_count_with(x_scan);
        }
    }

    fn identical_for_any_thread_count_with(x_scan: XScanMode) {
        let s = shapes::torus(1.0, 0.4);
        let v = view(35.0, 30.0, true);
        let opts = Options {
            x_scan,
            ..Options::default()
        };
        let run = |n: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            pool.install(|| {
                render(
                    &s,
                    &v,
                    90,
                    70,
                    &all(),
                    &Shading::default(),
                    &opts,
                    &Cancel::new(),
                )
                .unwrap()
            })
        };
        let a = run(1);
        let b = run(3);
        let bits = |v: &Option<Vec<f32>>| {
            v.as_ref()
                .unwrap()
                .iter()
                .map(|x| x.to_bits())
                .collect::<Vec<_>>()
        };
        assert!(bits(&a.depth) == bits(&b.depth));
        assert!(bits(&a.normal) == bits(&b.normal));
        assert_eq!(a.samples, b.samples);
        assert!(a.mask.unwrap().iter().filter(|&&m| m).count() > 500);
    }
}
