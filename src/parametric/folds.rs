//! The pre-scan for curtain folds (Blinn 1978 §3.4).
//!
//! A curtain fold is a point where the silhouette curve J = 0 in (u, v)
//! comes tangent to a level curve y = const inside the patch without y
//! being stationary there: along the silhouette y has an extremum, i.e.
//! T = y_u J_v − y_v J_u = 0 (∇y ∥ ∇J). Where that extremum is a maximum,
//! a new silhouette piece appears as the scan passes below it: two
//! silhouette trackers must be created, as at a strict maximum
//! (§3.2.2.2); at a minimum the two arriving trackers meet and one is
//! dropped (§3.2.3).
//!
//! The pre-scan, "similar to the scan for local maxima in Y" (§3.4):
//! the silhouette is traced over a coarse grid by marching squares, every
//! grid segment of it along which T changes sign gives a start, and
//! Newton on (J, T) = 0 refines it (∇J exact, ∇T by central differences:
//! T already holds second derivatives). The second derivative of y along
//! the silhouette, and the curve's own second-order term, come from the
//! silhouette points at ±h along its tangent.

use super::screen::{Screen, ScreenSample};
use super::trackers::march;

/// A maximum of y along the silhouette (a curtain fold).
#[derive(Debug, Clone, Copy)]
pub struct Fold {
    pub s: ScreenSample,
    /// Unit tangent of the silhouette at the fold (in u, v).
    pub w: (f64, f64),
    /// Second-order term of the silhouette curve c(t) = q + t w + ½ t² k.
    pub k: (f64, f64),
    /// d²y/dt² along the silhouette (< 0).
    pub ydd: f64,
}

impl Fold {
    /// Starting guesses of the two silhouette trackers on scan line `ys`
    /// below the fold: y(c(t)) ≈ y_q + ½ ydd t² = ys.
    pub fn starts(&self, ys: f64) -> [(f64, f64); 2] {
        let t = (2.0 * (ys - self.s.y) / self.ydd).max(0.0).sqrt();
        let q = &self.s;
        let at = |t: f64| {
            (
                q.u + t * self.w.0 + 0.5 * t * t * self.k.0,
                q.v + t * self.w.1 + 0.5 * t * t * self.k.1,
            )
        };
        [at(t), at(-t)]
    }
}

/// T = y_u J_v − y_v J_u: zero where the silhouette is tangent to a level
/// curve of y (the seed's turn-point function of §4.3 for the silhouette
/// direction).
#[inline]
pub fn tangency(s: &ScreenSample) -> f64 {
    let (ju, jv) = s.jac_grad();
    s.yu * jv - s.yv * ju
}

/// Project (u, v) onto J = 0 along ∇J (a few Newton steps, all points in
/// one batch per step).
fn onto_silhouette(sc: &Screen<'_>, pts: &mut [(f64, f64)], ext: f64) -> Vec<Option<ScreenSample>> {
    let mut out = vec![None; pts.len()];
    for round in 0..8 {
        let (us, vs): (Vec<f64>, Vec<f64>) = pts.iter().copied().unzip();
        let ss = sc.eval_batch(&us, &vs);
        let mut moved = false;
        for (i, s) in ss.into_iter().enumerate() {
            out[i] = None;
            let Some(s) = s else { continue };
            let (ju, jv) = s.jac_grad();
            let n2 = ju * ju + jv * jv;
            if n2.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                continue;
            }
            let j = s.jac();
            let (du, dv) = (-j * ju / n2, -j * jv / n2);
            if du.abs().max(dv.abs()) <= 1e-13 * ext || round == 7 {
                out[i] = Some(s);
            } else {
                pts[i].0 += du;
                pts[i].1 += dv;
                moved = true;
            }
        }
        if !moved {
            break;
        }
    }
    out
}

/// Find the curtain folds of the patch on an n×n grid: the maxima of y
/// along the silhouette that are not stationary points of y (those are
/// the strict maxima and saddles, found by their own searches).
pub fn find_folds(sc: &Screen<'_>, n: usize) -> Vec<Fold> {
    let d = sc.dom;
    let n = n.max(3);
    let ext = (d.u1 - d.u0).max(d.v1 - d.v0);
    let (us, vs): (Vec<f64>, Vec<f64>) = (0..n * n)
        .map(|q| {
            let (i, k) = (q % n, q / n);
            (
                d.u0 + (d.u1 - d.u0) * i as f64 / (n - 1) as f64,
                d.v0 + (d.v1 - d.v0) * k as f64 / (n - 1) as f64,
            )
        })
        .unzip();
    let ss = sc.eval_batch(&us, &vs);
    let j: Vec<f64> = ss.iter().map(|s| s.map_or(f64::NAN, |s| s.jac())).collect();
    let t: Vec<f64> = ss
        .iter()
        .map(|s| s.map_or(f64::NAN, |s| tangency(&s)))
        .collect();
    // Starts: where T changes sign along a marching-squares segment of J = 0.
    let mut starts: Vec<(f64, f64)> = march(n, &us, &vs, &j, &t)
        .iter()
        .filter(|g| (g.ya < 0.0) != (g.yb < 0.0) && g.ya.is_finite() && g.yb.is_finite())
        .map(|g| {
            let a = g.ya / (g.ya - g.yb);
            (g.a.0 + a * (g.b.0 - g.a.0), g.a.1 + a * (g.b.1 - g.a.1))
        })
        .collect();
    let cell = ext / (n - 1) as f64;
    let h = 1e-6 * ext;
    let mut found: Vec<ScreenSample> = Vec::new();
    for (mut u, mut v) in starts.drain(..) {
        let mut conv = None;
        for _ in 0..25 {
            // T and its gradient by central differences, in one batch.
            let bu = [u, u + h, u - h, u, u];
            let bv = [v, v, v, v + h, v - h];
            let b = sc.eval_batch(&bu, &bv);
            let (Some(s), Some(a), Some(bm), Some(c), Some(cm)) = (b[0], b[1], b[2], b[3], b[4])
            else {
                break;
            };
            let (ju, jv) = s.jac_grad();
            let (jj, tt) = (s.jac(), tangency(&s));
            let tu = (tangency(&a) - tangency(&bm)) / (2.0 * h);
            let tv = (tangency(&c) - tangency(&cm)) / (2.0 * h);
            let det = ju * tv - jv * tu;
            let du = -(jj * tv - jv * tt) / det;
            let dv = -(ju * tt - jj * tu) / det;
            if !(du.is_finite() && dv.is_finite()) || du.abs().max(dv.abs()) > cell {
                break;
            }
            u += du;
            v += dv;
            if !d.contains(u, v) {
                break;
            }
            if du.abs().max(dv.abs()) <= 1e-11 * ext {
                conv = sc.eval(u, v);
                break;
            }
        }
        let Some(s) = conv else { continue };
        // A stationary point of y (a maximum or a saddle) is not a fold.
        let g = s.yu.hypot(s.yv) * ext;
        let hy = s.yuu.abs().max(s.yuv.abs()).max(s.yvv.abs()) * ext * ext;
        if g <= 1e-6 * hy.max(1e-300) {
            continue;
        }
        if found
            .iter()
            .any(|o| (o.u - s.u).abs().max((o.v - s.v).abs()) < 1e-7 * ext)
        {
            continue;
        }
        found.push(s);
    }
    // Classify: y along the silhouette at ±e around each fold point.
    let e = (0.05 * cell).max(1e-4 * ext);
    let mut folds = Vec::new();
    for s in found {
        let (ju, jv) = s.jac_grad();
        let l = ju.hypot(jv);
        if l.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let w = (-jv / l, ju / l);
        let mut pts = [
            (s.u + e * w.0, s.v + e * w.1),
            (s.u - e * w.0, s.v - e * w.1),
        ];
        let pr = onto_silhouette(sc, &mut pts, ext);
        let (Some(p), Some(m)) = (pr[0], pr[1]) else {
            continue;
        };
        let ydd = (p.y + m.y - 2.0 * s.y) / (e * e);
        if ydd.partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) {
            continue; // a minimum along the silhouette: trackers meet there
        }
        let k = (
            (p.u + m.u - 2.0 * s.u) / (e * e),
            (p.v + m.v - 2.0 * s.v) / (e * e),
        );
        folds.push(Fold { s, w, k, ydd });
    }
    folds.sort_by(|a, b| a.s.u.total_cmp(&b.s.u).then(a.s.v.total_cmp(&b.s.v)));
    folds
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Camera, Projection, View};
    use crate::parametric::shapes;
    use glam::DVec3;

    /// The torus seen from 35° above: its inner silhouette arcs begin at
    /// two curtain folds, where J = 0, T = 0, ∇y ≠ 0 and y is a maximum
    /// along the silhouette (checked against silhouette points nearby).
    #[test]
    fn torus_curtain_folds() {
        let t = shapes::torus(1.0, 0.4);
        let view = View {
            elevation: 35.0,
            azimuth: 30.0,
            projection: Projection::Orthographic { view_height: 3.2 },
            target: DVec3::ZERO,
        };
        let cam = Camera::new(&view, 96, 72).unwrap();
        let sc = Screen::new(&t, &cam);
        let folds = find_folds(&sc, 97);
        assert_eq!(folds.len(), 2);
        for f in &folds {
            let s = &f.s;
            let (ju, jv) = s.jac_grad();
            let scale = (ju.abs() + jv.abs()) * 1e-9;
            assert!(s.jac().abs() < scale, "J = {}", s.jac());
            assert!(tangency(s).abs() < 1e-6 * (s.yu.hypot(s.yv) * ju.hypot(jv)));
            assert!(s.yu.hypot(s.yv) > 1.0 && f.ydd < 0.0);
            for t in [-0.05, 0.05] {
                let mut p = [(s.u + t * f.w.0, s.v + t * f.w.1)];
                let q = onto_silhouette(&sc, &mut p, 1.0)[0].unwrap();
                assert!(q.y < s.y, "{} ≥ {}", q.y, s.y);
            }
        }
    }
}
