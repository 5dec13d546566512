//! The shading model shared by every renderer (SPEC §2): by default a
//! headlight (light at the eye), two-sided, with separate colours for the
//! upper and the under side.
//!
//! intensity = ambient + diffuse·max(0, N·L) + specular·max(0, R·V)^shininess
//! where N is the unit normal turned towards the viewer, L the unit direction
//! towards the light, V towards the eye and R = 2(N·L)N − L.

use crate::error::{finite, FcolError, Result};
use glam::DVec3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    /// Light at the eye (for orthographic views: along −d).
    Headlight,
    /// A directional light; the vector points from the surface to the light.
    Directional(DVec3),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shading {
    pub light: Light,
    pub ambient: f64,
    pub diffuse: f64,
    pub specular: f64,
    pub shininess: f64,
    /// Colour of the upper side (normal with positive w, or P_u × P_v facing
    /// the viewer for parametric surfaces), sRGB 0–255.
    pub upper: [f64; 3],
    /// Colour of the under side.
    pub under: [f64; 3],
    pub background: [u8; 3],
}

impl Default for Shading {
    fn default() -> Self {
        Shading {
            light: Light::Headlight,
            ambient: 0.12,
            diffuse: 0.88,
            specular: 0.0,
            shininess: 32.0,
            upper: [235.0, 200.0, 120.0],
            under: [110.0, 150.0, 230.0],
            background: [255, 255, 255],
        }
    }
}

impl Shading {
    pub fn validate(&self) -> Result<()> {
        for (name, x) in [
            ("ambient", self.ambient),
            ("diffuse", self.diffuse),
            ("specular", self.specular),
            ("shininess", self.shininess),
        ] {
            finite(name, x)?;
            if x < 0.0 {
                return Err(FcolError::value(name, "must not be negative"));
            }
        }
        if let Light::Directional(l) = self.light {
            if !l.is_finite() || l.length() == 0.0 {
                return Err(FcolError::value(
                    "light",
                    "must be a finite non-zero direction (u, v, w) towards the light",
                ));
            }
        }
        Ok(())
    }

    /// Intensity at a point with unit normal `n` (either orientation), unit
    /// direction `to_eye` from the point towards the viewer.
    #[inline]
    pub fn intensity(&self, n: DVec3, to_eye: DVec3) -> f64 {
        self.intensity_cos(n, to_eye, n.dot(to_eye))
    }

    /// [`Self::intensity`] given `c` = n·to_eye, for callers that have it
    /// (−(d·n) for to_eye = −d is the same value, but for the sign of a
    /// zero, which the intensity does not depend on).
    #[inline]
    pub fn intensity_cos(&self, n: DVec3, to_eye: DVec3, c: f64) -> f64 {
        // Two-sided: the normal turned to face the viewer.
        let facing = || if c < 0.0 { -n } else { n };
        let (l, nl) = match self.light {
            // N·L with L = V is |c|, bit for bit (negating a product or a
            // sum is exact).
            Light::Headlight => (to_eye, if c < 0.0 { -c } else { c }),
            Light::Directional(l) => {
                let l = l.normalize();
                (l, facing().dot(l))
            }
        };
        let mut i = self.ambient + self.diffuse * nl.max(0.0);
        if self.specular > 0.0 && nl > 0.0 {
            let r = 2.0 * nl * facing() - l;
            i += self.specular * r.dot(to_eye).max(0.0).powf(self.shininess);
        }
        i
    }

    /// Colour of an intensity on a side (+1 upper, −1 under), each channel
    /// rounded to the nearest level without a call to `round`: for x ≥ −½,
    /// `(x + ½) as u8` rounds half away from zero and saturates at 255 as
    /// `round().clamp(0, 255)` does (but for x within an ulp below k + ½);
    /// below, and for NaN, both give 0.
    #[inline]
    pub fn colour(&self, intensity: f64, side: i8) -> [u8; 3] {
        let base = if side >= 0 { &self.upper } else { &self.under };
        let q = |c: f64| (c * intensity + 0.5) as u8;
        [q(base[0]), q(base[1]), q(base[2])]
    }
}
