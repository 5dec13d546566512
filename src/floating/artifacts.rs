//! Artifact detection and correction of Gordon 2001 §5, for orthographic and
//! perspective columns alike.
//!
//! Between two consecutive samples a and b of a column (Appendix A.2,
//! `Problem()`):
//! * ridge: V·N changes sign (the column's curve passes a silhouette);
//! * intensity jump: |I_b − I_a| above a threshold;
//! * bump: (V×N_Π)·(V×N_Π)' < 0 with N_Π the normal projected into the
//!   column's plane Π (§5.3): the normal swings past the view direction, so
//!   interpolated intensity misses the highlight at the extremum.
//!
//! Corrections: local supersampling (`rate` samples per problem span), or a
//! cubic fitted to the two samples and their slopes (§5.2, eqs. 13–22), whose
//! extremum is sampled exactly. §5.2 fits w(t) against the slope tan α, which
//! holds only for orthographic columns; its last paragraph asks, for
//! perspective, to work with the part of N in Π. Both are the statement "the
//! ray through the top is tangent to the curve", i.e. the screen row is
//! extremal along the column's curve, so we fit the cubic to the row ρ(t)
//! with the exact slopes dρ/dt of both samples (which the sampler derives in
//! either projection) and sample its extremum. For a bump (both sides
//! visible) the top is where (V×N)·m vanishes (m the normal of Π), located
//! by the same kind of interpolation.

use super::sampling::Sample;
use glam::DVec3;

/// Which corrections are enabled (each switchable).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corrections {
    pub ridges: bool,
    pub jumps: bool,
    pub bumps: bool,
    /// Detect walls (big row jumps between samples) and shade them (§5.1).
    pub walls: bool,
    /// Correct by the cubic's extremum (true) or supersampling (false).
    pub spline: bool,
    /// Supersampling rate (samples per problem span).
    pub rate: usize,
    /// Intensity jump threshold.
    pub threshold: f64,
}

impl Default for Corrections {
    fn default() -> Self {
        Corrections {
            ridges: false,
            jumps: false,
            bumps: false,
            walls: true,
            spline: false,
            rate: 8,
            threshold: 0.0625,
        }
    }
}

impl Corrections {
    pub fn any_detection(&self) -> bool {
        self.ridges || self.jumps || self.bumps
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Problem {
    Ridge,
    Jump,
    Bump,
}

/// The §5 tests between consecutive samples; `m` is the plane normal.
pub fn detect(c: &Corrections, a: &Sample, b: &Sample, m: DVec3) -> Option<Problem> {
    if c.ridges && a.ldotn * b.ldotn < 0.0 {
        return Some(Problem::Ridge);
    }
    if c.bumps && a.ldotn * b.ldotn > 0.0 && a.lxn.dot(m) * b.lxn.dot(m) < 0.0 {
        return Some(Problem::Bump);
    }
    if c.jumps && (a.inten - b.inten).abs() > c.threshold {
        return Some(Problem::Jump);
    }
    None
}

/// Extremum in (0, 1) of the cubic Hermite through (0, p0), (1, p1) with
/// slopes m0, m1 (per unit of the normalised parameter), if any.
pub fn hermite_extremum(p0: f64, p1: f64, m0: f64, m1: f64) -> Option<f64> {
    // p(x) = a x³ + b x² + c x + d, eqs. (13)–(17) with Δt = 1.
    let a = 2.0 * (p0 - p1) + m0 + m1;
    let b = 3.0 * (p1 - p0) - 2.0 * m0 - m1;
    let c = m0;
    // p'(x) = 3a x² + 2b x + c = 0 (eq. 22 with the slope target 0).
    let mut roots = Vec::with_capacity(2);
    if a.abs() < 1e-14 * (b.abs() + c.abs() + 1e-300) {
        if b != 0.0 {
            roots.push(-c / (2.0 * b));
        }
    } else {
        let disc = b * b - 3.0 * a * c;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            // Stable quadratic roots.
            let q = -(b + b.signum() * sq);
            if q != 0.0 {
                roots.push(q / (3.0 * a));
                roots.push(c / q);
            } else {
                roots.push(-b / (3.0 * a));
            }
        }
    }
    let p = |x: f64| ((a * x + b) * x + c) * x + p0;
    roots
        .into_iter()
        .filter(|x| *x > 0.0 && *x < 1.0)
        .max_by(|x, y| {
            let dx = (p(*x) - 0.5 * (p0 + p1)).abs();
            let dy = (p(*y) - 0.5 * (p0 + p1)).abs();
            dx.total_cmp(&dy)
        })
}

/// The parameter t of the top of a ridge (row extremum) or bump (normal
/// facing the viewer) between a and b.
pub fn spline_top(problem: Problem, a: &Sample, b: &Sample, m: DVec3) -> Option<f64> {
    let dt = b.t - a.t;
    match problem {
        Problem::Bump => {
            let (ca, cb) = (a.lxn.dot(m), b.lxn.dot(m));
            (ca != cb).then(|| a.t + dt * ca / (ca - cb))
        }
        _ => {
            if !(a.drho_dt.is_finite() && b.drho_dt.is_finite()) {
                return Some(a.t + 0.5 * dt);
            }
            hermite_extremum(a.rho, b.rho, a.drho_dt * dt, b.drho_dt * dt)
                .map(|x| a.t + x * dt)
                .or(Some(a.t + 0.5 * dt))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_extremum_of_a_parabola() {
        // p(x) = 1 − 4(x − 0.5)² + 0: p0 = 0, p1 = 0, slopes 4, −4: top at 0.5.
        let x = hermite_extremum(0.0, 0.0, 4.0, -4.0).unwrap();
        assert!((x - 0.5).abs() < 1e-12);
        // Asymmetric cubic: p(x) = x − x³ on [0,1]... top at 1/√3.
        // p0 = 0, p1 = 0, m0 = 1, m1 = −2.
        let x = hermite_extremum(0.0, 0.0, 1.0, -2.0).unwrap();
        assert!((x - 1.0 / 3f64.sqrt()).abs() < 1e-12);
        // Monotone: no extremum.
        assert!(hermite_extremum(0.0, 1.0, 1.0, 1.0).is_none());
    }
}
