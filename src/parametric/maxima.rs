//! Local maxima of screen y over the patch (Blinn 1978 §3.2.2.1).
//!
//! Starts: every node of a coarse grid that is at least as high as its
//! neighbours (plus the corners and the centre, as in the seed). Each start
//! climbs uphill along (y_u, y_v) with a trust region, switching to Newton
//! on (y_u, y_v) = 0 when the Hessian is negative definite; steps that would
//! leave the patch are clipped at its boundary, where the variable pushed
//! outwards is frozen: the climb then ends at an edge maximum
//! (y_v = 0 with y_u pushing out of a u edge, …) or a corner maximum.

use super::screen::{Screen, ScreenSample};

/// Where a maximum lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaxKind {
    /// Strict interior maximum: y_u = y_v = 0, Hessian negative definite.
    Interior,
    /// Maximum along an edge: 0 = u0, 1 = u1, 2 = v0, 3 = v1.
    Edge(u8),
    /// Corner (u0|u1, v0|v1) as edge indices (0|1, 2|3).
    Corner(u8, u8),
    /// End of edge e where y along the edge is highest but the corner is
    /// not a maximum (y rises into the patch along the other edge): a
    /// tracker of the other edge reaches the corner and goes on along e.
    EdgeEnd(u8),
}

#[derive(Debug, Clone, Copy)]
pub struct Maximum {
    pub u: f64,
    pub v: f64,
    pub y: f64,
    pub kind: MaxKind,
    /// y_uu y_vv − y_uv² (> 0 strict maximum, ≈ 0 parabolic cylinder §3.4).
    pub det: f64,
    pub s: ScreenSample,
}

/// Result of the search.
#[derive(Debug, Clone, Default)]
pub struct MaximaList {
    pub maxima: Vec<Maximum>,
    /// Climbs that did not converge within their iteration budget.
    pub failed: usize,
    /// Interior maxima whose Hessian is nearly singular (§3.4 parabolic
    /// cylinder, a ridge of equal maxima): the level curve below is two
    /// curves running to the patch edges, whose four boundary trackers
    /// start at the maxima of y along those edges ([`edge_maxima`]).
    pub parabolic: usize,
}

/// Climb from (u, v) to a constrained local maximum of y.
pub fn climb(sc: &Screen<'_>, mut u: f64, mut v: f64) -> Option<Maximum> {
    let d = sc.dom;
    let ext = (d.u1 - d.u0).max(d.v1 - d.v0);
    let mut s = sc.eval(u, v)?;
    let mut radius = 0.05 * ext;
    let clampu = |x: f64| x.clamp(d.u0, d.u1);
    let clampv = |x: f64| x.clamp(d.v0, d.v1);
    for _ in 0..200 {
        let (gu, gv) = (s.yu, s.yv);
        // A variable sitting on its bound with the gradient pushing out is frozen.
        let fu = !((u <= d.u0 && gu <= 0.0) || (u >= d.u1 && gu >= 0.0));
        let fv = !((v <= d.v0 && gv <= 0.0) || (v >= d.v1 && gv >= 0.0));
        let (huu, huv, hvv) = (s.yuu, s.yuv, s.yvv);
        // Proposed step (du, dv).
        let (mut du, mut dv, newton) = match (fu, fv) {
            (false, false) => break,
            (true, true) => {
                let det = huu * hvv - huv * huv;
                if huu < 0.0 && det > 0.0 {
                    (
                        (-hvv * gu + huv * gv) / det,
                        (huv * gu - huu * gv) / det,
                        true,
                    )
                } else {
                    (gu, gv, false)
                }
            }
            (true, false) => {
                if huu < 0.0 {
                    (-gu / huu, 0.0, true)
                } else {
                    (gu, 0.0, false)
                }
            }
            (false, true) => {
                if hvv < 0.0 {
                    (0.0, -gv / hvv, true)
                } else {
                    (0.0, gv, false)
                }
            }
        };
        let len = du.hypot(dv);
        if !len.is_finite() {
            return None;
        }
        if len < 1e-14 * ext {
            break;
        }
        if !newton || len > radius {
            let k = radius / len;
            du *= k;
            dv *= k;
        }
        // Backtrack until y does not decrease.
        let mut accepted = false;
        for _ in 0..40 {
            let (nu, nv) = (clampu(u + du), clampv(v + dv));
            if let Some(ns) = sc.eval(nu, nv) {
                if ns.y >= s.y - 1e-12 * (1.0 + s.y.abs()) {
                    let moved = (nu - u).hypot(nv - v);
                    u = nu;
                    v = nv;
                    s = ns;
                    accepted = true;
                    if newton {
                        radius = (2.0 * moved).max(radius);
                    } else {
                        radius = (radius * 1.5).min(0.25 * ext);
                    }
                    break;
                }
            }
            du *= 0.5;
            dv *= 0.5;
            radius *= 0.5;
        }
        if !accepted {
            break;
        }
        if newton && du.hypot(dv) < 1e-13 * ext {
            break;
        }
    }
    let eps = 1e-12 * ext;
    let on = |x: f64, a: f64| (x - a).abs() <= eps;
    let eu = if on(u, d.u0) && s.yu <= 0.0 {
        Some(0u8)
    } else if on(u, d.u1) && s.yu >= 0.0 {
        Some(1)
    } else {
        None
    };
    let ev = if on(v, d.v0) && s.yv <= 0.0 {
        Some(2u8)
    } else if on(v, d.v1) && s.yv >= 0.0 {
        Some(3)
    } else {
        None
    };
    let kind = match (eu, ev) {
        (Some(a), Some(b)) => MaxKind::Corner(a, b),
        (Some(a), None) => MaxKind::Edge(a),
        (None, Some(b)) => MaxKind::Edge(b),
        (None, None) => MaxKind::Interior,
    };
    // Convergence check: the free gradient components must vanish.
    let scale = 1.0 + s.yu.abs().max(s.yv.abs()).max(1.0);
    let tol = 1e-6 * scale;
    let ok = match kind {
        MaxKind::Interior => s.yu.abs() < tol && s.yv.abs() < tol,
        MaxKind::Edge(e) if e < 2 => s.yv.abs() < tol,
        MaxKind::Edge(_) => s.yu.abs() < tol,
        MaxKind::Corner(..) | MaxKind::EdgeEnd(_) => true,
    };
    if !ok {
        return None;
    }
    Some(Maximum {
        u,
        v,
        y: s.y,
        kind,
        det: s.yuu * s.yvv - s.yuv * s.yuv,
        s,
    })
}

/// Find the local maxima of screen y. `n` is the number of grid nodes along
/// each parameter (≥ 3).
pub fn find_maxima(sc: &Screen<'_>, n: usize) -> MaximaList {
    let d = sc.dom;
    let n = n.max(3);
    let node = |i: usize, k: usize| {
        (
            d.u0 + (d.u1 - d.u0) * i as f64 / (n - 1) as f64,
            d.v0 + (d.v1 - d.v0) * k as f64 / (n - 1) as f64,
        )
    };
    let mut us = Vec::with_capacity(n * n);
    let mut vs = Vec::with_capacity(n * n);
    for k in 0..n {
        for i in 0..n {
            let (u, v) = node(i, k);
            us.push(u);
            vs.push(v);
        }
    }
    let ys: Vec<f64> = sc
        .eval_batch(&us, &vs)
        .iter()
        .map(|s| s.map_or(f64::NAN, |s| s.y))
        .collect();
    let mut starts = vec![(d.u0, d.v0), (d.u1, d.v0), (d.u0, d.v1), (d.u1, d.v1)];
    starts.push((0.5 * (d.u0 + d.u1), 0.5 * (d.v0 + d.v1)));
    for k in 0..n {
        for i in 0..n {
            let y = ys[k * n + i];
            if !y.is_finite() {
                continue;
            }
            let mut top = true;
            for dk in -1i64..=1 {
                for di in -1i64..=1 {
                    let (ii, kk) = (i as i64 + di, k as i64 + dk);
                    if (di, dk) == (0, 0) || ii < 0 || kk < 0 || ii >= n as i64 || kk >= n as i64 {
                        continue;
                    }
                    let yn = ys[kk as usize * n + ii as usize];
                    if yn > y {
                        top = false;
                    }
                }
            }
            if top {
                starts.push(node(i, k));
            }
        }
    }
    let ext_u = d.u1 - d.u0;
    let ext_v = d.v1 - d.v0;
    let mut out = MaximaList::default();
    for (u, v) in starts {
        match climb(sc, u, v) {
            Some(m) => {
                // The same point, or the same screen point of the same
                // kind (a degenerate edge such as a sphere's pole, where
                // P_u = 0). The two edges of a closed surface's seam map
                // to the same screen points but carry trackers of their
                // own: their maxima are all kept.
                let dup = out.maxima.iter().any(|o| {
                    o.kind == m.kind
                        && ((((o.u - m.u) / ext_u).abs() < 1e-7
                            && ((o.v - m.v) / ext_v).abs() < 1e-7)
                            || ((o.s.x - m.s.x).abs() < 1e-7 && (o.y - m.y).abs() < 1e-7))
                });
                if !dup {
                    out.maxima.push(m);
                }
            }
            None => out.failed += 1,
        }
    }
    edge_maxima(sc, 4 * n, &mut out);
    for m in &out.maxima {
        if m.kind == MaxKind::Interior {
            let h = m.s.yuu.abs().max(m.s.yvv.abs()).max(m.s.yuv.abs());
            if m.det <= 1e-6 * h * h {
                out.parabolic += 1;
            }
        }
    }
    // Highest first; ties broken by position so that the order is fixed.
    out.maxima.sort_by(|a, b| {
        b.y.total_cmp(&a.y)
            .then(a.u.total_cmp(&b.u))
            .then(a.v.total_cmp(&b.v))
    });
    out
}

/// Local maxima of y along each boundary edge, whichever way y moves into
/// the patch there. Where y rises into the patch (not a constrained
/// maximum of §3.2.2.1) a level curve from the interior reaches the edge
/// as the scan passes: it is cut there and two boundary trackers must
/// start, as below an edge maximum. On a closed surface's seam this is
/// the twin of the other seam edge's constrained maximum. Samples at `m`
/// points per edge, refined by Newton on y_t = 0 inside the bracketing
/// samples.
fn edge_maxima(sc: &Screen<'_>, m: usize, out: &mut MaximaList) {
    let d = sc.dom;
    let m = m.max(5);
    let ext = (d.u1 - d.u0).max(d.v1 - d.v0);
    for e in 0..4u8 {
        let (t0, t1) = if e < 2 { (d.v0, d.v1) } else { (d.u0, d.u1) };
        let at = |t: f64| match e {
            0 => (d.u0, t),
            1 => (d.u1, t),
            2 => (t, d.v0),
            _ => (t, d.v1),
        };
        let ts: Vec<f64> = (0..m)
            .map(|k| t0 + (t1 - t0) * k as f64 / (m - 1) as f64)
            .collect();
        let (us, vs): (Vec<f64>, Vec<f64>) = ts.iter().map(|&t| at(t)).unzip();
        let ys: Vec<f64> = sc
            .eval_batch(&us, &vs)
            .iter()
            .map(|s| s.map_or(f64::NAN, |s| s.y))
            .collect();
        // The ends: y along the edge highest at a corner.
        for (k, kn) in [(0, 1), (m - 1, m - 2)] {
            let (b, a) = (ys[k], ys[kn]);
            if !(a.is_finite() && b.is_finite() && b > a) {
                continue;
            }
            let (u, v) = at(ts[k]);
            let corner_max = out.maxima.iter().any(|o| {
                matches!(o.kind, MaxKind::Corner(..))
                    && (o.u - u).abs().max((o.v - v).abs()) < 1e-9 * ext
            });
            let dup = out.maxima.iter().any(|o| {
                o.kind == MaxKind::EdgeEnd(e) && (o.u - u).abs().max((o.v - v).abs()) < 1e-9 * ext
            });
            if corner_max || dup {
                continue;
            }
            if let Some(s) = sc.eval(u, v) {
                out.maxima.push(Maximum {
                    u,
                    v,
                    y: s.y,
                    kind: MaxKind::EdgeEnd(e),
                    det: s.yuu * s.yvv - s.yuv * s.yuv,
                    s,
                });
            }
        }
        for k in 1..m - 1 {
            let (a, b, c) = (ys[k - 1], ys[k], ys[k + 1]);
            if !(a.is_finite() && b.is_finite() && c.is_finite() && b >= a && b > c) {
                continue;
            }
            let (lo, hi) = (ts[k - 1], ts[k + 1]);
            let mut t = ts[k];
            let mut best = None;
            for _ in 0..40 {
                let (u, v) = at(t);
                let Some(s) = sc.eval(u, v) else { break };
                let (yt, ytt) = if e < 2 { (s.yv, s.yvv) } else { (s.yu, s.yuu) };
                best = Some(s);
                let dt = if ytt < 0.0 {
                    -yt / ytt
                } else {
                    0.25 * (hi - lo) * yt.signum()
                };
                let nt = (t + dt).clamp(lo, hi);
                if !nt.is_finite() || (nt - t).abs() <= 1e-14 * ext {
                    break;
                }
                t = nt;
            }
            let Some(s) = best else { continue };
            let yt = if e < 2 { s.yv } else { s.yu };
            let scale = 1.0 + s.yu.abs().max(s.yv.abs()).max(1.0);
            if yt.abs() >= 1e-6 * scale || t <= t0 || t >= t1 {
                continue; // no stationary point inside the edge
            }
            let kind = MaxKind::Edge(e);
            let dup = out.maxima.iter().any(|o| {
                o.kind == kind
                    && ((o.u - s.u).abs().max((o.v - s.v).abs()) < 1e-7 * ext
                        || ((o.s.x - s.x).abs() < 1e-7 && (o.y - s.y).abs() < 1e-7))
            });
            if !dup {
                out.maxima.push(Maximum {
                    u: s.u,
                    v: s.v,
                    y: s.y,
                    kind,
                    det: s.yuu * s.yvv - s.yuv * s.yuv,
                    s,
                });
            }
        }
    }
}

/// Saddle points of screen y inside the patch (§3.2.2.4): Newton on
/// (y_u, y_v) = 0 from every grid node whose eight neighbours change sign
/// around it at least four times; kept when y_uv² − y_uu y_vv > 0.
pub fn find_saddles(sc: &Screen<'_>, n: usize) -> Vec<ScreenSample> {
    let d = sc.dom;
    let n = n.max(3);
    let node = |i: usize, k: usize| {
        (
            d.u0 + (d.u1 - d.u0) * i as f64 / (n - 1) as f64,
            d.v0 + (d.v1 - d.v0) * k as f64 / (n - 1) as f64,
        )
    };
    let (us, vs): (Vec<f64>, Vec<f64>) = (0..n * n).map(|q| node(q % n, q / n)).unzip();
    let ys: Vec<f64> = sc
        .eval_batch(&us, &vs)
        .iter()
        .map(|s| s.map_or(f64::NAN, |s| s.y))
        .collect();
    let ext = (d.u1 - d.u0).max(d.v1 - d.v0);
    let ring = [
        (1i64, 0i64),
        (1, 1),
        (0, 1),
        (-1, 1),
        (-1, 0),
        (-1, -1),
        (0, -1),
        (1, -1),
    ];
    let mut out: Vec<ScreenSample> = Vec::new();
    for k in 1..n - 1 {
        for i in 1..n - 1 {
            let y0 = ys[k * n + i];
            let vals: Vec<f64> = ring
                .iter()
                .map(|(di, dk)| ys[(k as i64 + dk) as usize * n + (i as i64 + di) as usize] - y0)
                .collect();
            if vals.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let changes = (0..8)
                .filter(|&q| (vals[q] < 0.0) != (vals[(q + 1) % 8] < 0.0))
                .count();
            if changes < 4 {
                continue;
            }
            let (mut u, mut v) = node(i, k);
            let mut found = None;
            for _ in 0..30 {
                let Some(s) = sc.eval(u, v) else { break };
                let det = s.yuu * s.yvv - s.yuv * s.yuv;
                if det >= 0.0 {
                    break;
                }
                let du = -(s.yvv * s.yu - s.yuv * s.yv) / det;
                let dv = -(s.yuu * s.yv - s.yuv * s.yu) / det;
                if !(du.is_finite() && dv.is_finite()) || du.abs().max(dv.abs()) > 0.1 * ext {
                    break;
                }
                u += du;
                v += dv;
                if !d.contains(u, v) {
                    break;
                }
                if du.abs().max(dv.abs()) < 1e-14 * ext {
                    found = sc.eval(u, v);
                    break;
                }
            }
            if let Some(s) = found {
                if !out
                    .iter()
                    .any(|o| (o.u - s.u).abs().max((o.v - s.v).abs()) < 1e-7 * ext)
                {
                    out.push(s);
                }
            }
        }
    }
    out.sort_by(|a, b| a.u.total_cmp(&b.u).then(a.v.total_cmp(&b.v)));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Camera, Projection, View};
    use crate::parametric::shapes;
    use crate::surface::ParametricSurface;
    use glam::DVec3;

    fn view(el: f64, az: f64, persp: bool) -> View {
        View {
            elevation: el,
            azimuth: az,
            projection: if persp {
                Projection::Perspective {
                    distance: 8.0,
                    fov: 35.0,
                }
            } else {
                Projection::Orthographic { view_height: 4.0 }
            },
            target: DVec3::ZERO,
        }
    }

    /// Every maximum a dense 801² grid search finds (a node above its eight
    /// neighbours, or an edge node above its edge neighbours and its inner
    /// neighbour) lies close to one the search reported, and the values agree.
    fn check_against_dense(surf: &dyn ParametricSurface, v: View) {
        let cam = Camera::new(&v, 256, 256).unwrap();
        let sc = Screen::new(surf, &cam);
        let found = find_maxima(&sc, 33);
        let d = sc.dom;
        let n = 801;
        let mut ys = vec![f64::NAN; n * n];
        for k in 0..n {
            for i in 0..n {
                let u = d.u0 + (d.u1 - d.u0) * i as f64 / (n - 1) as f64;
                let vv = d.v0 + (d.v1 - d.v0) * k as f64 / (n - 1) as f64;
                ys[k * n + i] = sc.eval(u, vv).map_or(f64::NAN, |s| s.y);
            }
        }
        let cell = ((d.u1 - d.u0) / (n - 1) as f64).max((d.v1 - d.v0) / (n - 1) as f64);
        for k in 0..n {
            for i in 0..n {
                let y = ys[k * n + i];
                if !y.is_finite() {
                    continue;
                }
                let mut strict = true;
                for dk in -1i64..=1 {
                    for di in -1i64..=1 {
                        let (ii, kk) = (i as i64 + di, k as i64 + dk);
                        if (di, dk) == (0, 0)
                            || ii < 0
                            || kk < 0
                            || ii >= n as i64
                            || kk >= n as i64
                        {
                            continue;
                        }
                        // Next to a hole (perspective: behind the eye) y is
                        // unbounded; no maximum is claimed there.
                        let yn = ys[kk as usize * n + ii as usize];
                        if yn >= y || yn.is_nan() {
                            strict = false;
                        }
                    }
                }
                if !strict {
                    continue;
                }
                let u = d.u0 + (d.u1 - d.u0) * i as f64 / (n - 1) as f64;
                let vv = d.v0 + (d.v1 - d.v0) * k as f64 / (n - 1) as f64;
                let near = found.maxima.iter().any(|m| {
                    (m.u - u).abs() <= 2.0 * cell
                        && (m.v - vv).abs() <= 2.0 * cell
                        && m.y >= y - 1e-9
                });
                assert!(
                    near,
                    "dense grid maximum at ({u}, {vv}) y={y} missed; found {:?}",
                    found
                        .maxima
                        .iter()
                        .map(|m| (m.u, m.v, m.y, m.kind))
                        .collect::<Vec<_>>()
                );
            }
        }
    }

    #[test]
    fn no_maximum_missed_on_test_surfaces() {
        let surfs: Vec<Box<dyn ParametricSurface + Send + Sync>> = [
            "sphere",
            "torus",
            "monkey_saddle",
            "bezier",
            "helicoid",
            "enneper",
        ]
        .iter()
        .map(|n| shapes::by_name(n).unwrap())
        .collect();
        for s in &surfs {
            for (el, az, p) in [
                (30.0, 20.0, false),
                (60.0, 135.0, true),
                (-20.0, 250.0, false),
                (5.0, 40.0, true),
            ] {
                check_against_dense(s.as_ref(), view(el, az, p));
            }
        }
    }

    #[test]
    fn torus_maxima_are_classified() {
        let t = shapes::torus(1.0, 0.4);
        let cam = Camera::new(&view(30.0, 0.0, false), 200, 200).unwrap();
        let sc = Screen::new(&t, &cam);
        let m = find_maxima(&sc, 33);
        // The top of the outer rim is an interior maximum of y.
        assert!(m
            .maxima
            .iter()
            .any(|m| m.kind == MaxKind::Interior && m.det > 0.0));
    }
}
