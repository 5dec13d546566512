//! Classic parametric surfaces with exact first and second derivatives
//! written by hand, for tests, benchmarks and Rust users.

use crate::surface::{Domain, FnParametric, ParamSample, ParametricSurface};
use glam::DVec3;
use std::f64::consts::PI;

type Boxed = Box<dyn ParametricSurface + Send + Sync>;

fn dom(u0: f64, u1: f64, v0: f64, v1: f64) -> Domain {
    Domain::new(u0, u1, v0, v1).expect("valid built-in domain")
}

/// Sphere of radius `r` about the origin: (r cos v cos u, r cos v sin u,
/// r sin v), u ∈ [0, 2π], v ∈ [−π/2, π/2]; P_u × P_v points outwards and
/// vanishes at the poles.
pub fn sphere(r: f64) -> FnParametric<impl Fn(f64, f64) -> ParamSample + Sync> {
    FnParametric {
        domain: dom(0.0, 2.0 * PI, -0.5 * PI, 0.5 * PI),
        f: move |u: f64, v: f64| {
            let (su, cu) = u.sin_cos();
            let (sv, cv) = v.sin_cos();
            ParamSample {
                p: r * DVec3::new(cv * cu, cv * su, sv),
                pu: r * DVec3::new(-cv * su, cv * cu, 0.0),
                pv: r * DVec3::new(-sv * cu, -sv * su, cv),
                puu: r * DVec3::new(-cv * cu, -cv * su, 0.0),
                puv: r * DVec3::new(sv * su, -sv * cu, 0.0),
                pvv: r * DVec3::new(-cv * cu, -cv * su, -sv),
            }
        },
    }
}

/// Torus with major radius `a` and minor radius `b` about the w axis,
/// u, v ∈ [0, 2π]; P_u × P_v points outwards.
pub fn torus(a: f64, b: f64) -> FnParametric<impl Fn(f64, f64) -> ParamSample + Sync> {
    FnParametric {
        domain: dom(0.0, 2.0 * PI, 0.0, 2.0 * PI),
        f: move |u: f64, v: f64| {
            let (su, cu) = u.sin_cos();
            let (sv, cv) = v.sin_cos();
            let w = a + b * cv;
            ParamSample {
                p: DVec3::new(w * cu, w * su, b * sv),
                pu: DVec3::new(-w * su, w * cu, 0.0),
                pv: DVec3::new(-b * sv * cu, -b * sv * su, b * cv),
                puu: DVec3::new(-w * cu, -w * su, 0.0),
                puv: DVec3::new(b * sv * su, -b * sv * cu, 0.0),
                pvv: DVec3::new(-b * cv * cu, -b * cv * su, -b * sv),
            }
        },
    }
}

/// Monkey saddle (u, v, u³ − 3uv²) over [−1, 1]².
pub fn monkey_saddle() -> FnParametric<impl Fn(f64, f64) -> ParamSample + Sync> {
    FnParametric {
        domain: dom(-1.0, 1.0, -1.0, 1.0),
        f: |u: f64, v: f64| ParamSample {
            p: DVec3::new(u, v, u * u * u - 3.0 * u * v * v),
            pu: DVec3::new(1.0, 0.0, 3.0 * u * u - 3.0 * v * v),
            pv: DVec3::new(0.0, 1.0, -6.0 * u * v),
            puu: DVec3::new(0.0, 0.0, 6.0 * u),
            puv: DVec3::new(0.0, 0.0, -6.0 * v),
            pvv: DVec3::new(0.0, 0.0, -6.0 * u),
        },
    }
}

/// Helicoid (v cos u, v sin u, c u), u ∈ [0, turns·2π], v ∈ [−1, 1].
pub fn helicoid(c: f64, turns: f64) -> FnParametric<impl Fn(f64, f64) -> ParamSample + Sync> {
    FnParametric {
        domain: dom(0.0, turns * 2.0 * PI, -1.0, 1.0),
        f: move |u: f64, v: f64| {
            let (su, cu) = u.sin_cos();
            ParamSample {
                p: DVec3::new(v * cu, v * su, c * u),
                pu: DVec3::new(-v * su, v * cu, c),
                pv: DVec3::new(cu, su, 0.0),
                puu: DVec3::new(-v * cu, -v * su, 0.0),
                puv: DVec3::new(-su, cu, 0.0),
                pvv: DVec3::ZERO,
            }
        },
    }
}

/// Enneper's minimal surface (u − u³/3 + uv², v − v³/3 + vu², u² − v²)
/// over [−s, s]²; it intersects itself for s > √3.
pub fn enneper(s: f64) -> FnParametric<impl Fn(f64, f64) -> ParamSample + Sync> {
    FnParametric {
        domain: dom(-s, s, -s, s),
        f: |u: f64, v: f64| ParamSample {
            p: DVec3::new(
                u - u * u * u / 3.0 + u * v * v,
                v - v * v * v / 3.0 + v * u * u,
                u * u - v * v,
            ),
            pu: DVec3::new(1.0 - u * u + v * v, 2.0 * u * v, 2.0 * u),
            pv: DVec3::new(2.0 * u * v, 1.0 - v * v + u * u, -2.0 * v),
            puu: DVec3::new(-2.0 * u, 2.0 * v, 2.0),
            puv: DVec3::new(2.0 * v, 2.0 * u, 0.0),
            pvv: DVec3::new(2.0 * u, -2.0 * v, -2.0),
        },
    }
}

/// Cubic Bernstein basis and its first two derivatives at t.
fn bernstein(t: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    let s = 1.0 - t;
    (
        [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t],
        [
            -3.0 * s * s,
            3.0 * s * s - 6.0 * t * s,
            6.0 * t * s - 3.0 * t * t,
            3.0 * t * t,
        ],
        [6.0 * s, -12.0 * s + 6.0 * t, 6.0 * s - 12.0 * t, 6.0 * t],
    )
}

/// Bicubic Bézier patch over [0, 1]² from 4×4 control points `c[i][j]`
/// (i along u, j along v).
pub fn bezier(c: [[DVec3; 4]; 4]) -> FnParametric<impl Fn(f64, f64) -> ParamSample + Sync> {
    FnParametric {
        domain: dom(0.0, 1.0, 0.0, 1.0),
        f: move |u: f64, v: f64| {
            let (bu, du, ddu) = bernstein(u);
            let (bv, dv, ddv) = bernstein(v);
            let mut s = ParamSample::default();
            for i in 0..4 {
                for j in 0..4 {
                    let p = c[i][j];
                    s.p += bu[i] * bv[j] * p;
                    s.pu += du[i] * bv[j] * p;
                    s.pv += bu[i] * dv[j] * p;
                    s.puu += ddu[i] * bv[j] * p;
                    s.puv += du[i] * dv[j] * p;
                    s.pvv += bu[i] * ddv[j] * p;
                }
            }
            s
        },
    }
}

/// A wavy bicubic Bézier patch used in tests and the gallery.
pub fn bezier_demo() -> FnParametric<impl Fn(f64, f64) -> ParamSample + Sync> {
    let h = [
        [0.0, 0.6, -0.4, 0.2],
        [0.5, 1.6, -1.2, 0.0],
        [-0.3, -1.0, 1.8, 0.6],
        [0.1, 0.4, 0.2, -0.5],
    ];
    let mut c = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            c[i][j] = DVec3::new(i as f64 - 1.5, j as f64 - 1.5, h[i][j]);
        }
    }
    bezier(c)
}

/// All built-in shapes by name (boxed), for benchmarks and tests.
pub fn by_name(name: &str) -> Option<Boxed> {
    Some(match name {
        "sphere" => Box::new(sphere(1.0)),
        "torus" => Box::new(torus(1.0, 0.4)),
        "monkey_saddle" => Box::new(monkey_saddle()),
        "helicoid" => Box::new(helicoid(0.15, 1.5)),
        "enneper" => Box::new(enneper(2.0)),
        "bezier" => Box::new(bezier_demo()),
        _ => return None,
    })
}
