//! The camera of SPEC §1, exactly.
//!
//! With elevation α and azimuth β (degrees):
//!   d  = ( cos α sin β,  cos α cos β, −sin α)   view direction, into the scene
//!   r  = ( cos β,        −sin β,        0    )   screen right
//!   up = ( sin α sin β,  sin α cos β,  cos α)   screen up
//! Orthographic: x = (P−T)·r, y = (P−T)·up, z = (P−T)·d, one pixel is
//! view_height / H world units. Perspective: eye E = T − D·d, focal length
//! F = (H/2) / tan(fov/2) pixels, x_pix = F·x/z, depth z = (P−E)·d.
//! Pixel (i, j) has its centre at x_pix = j + 0.5 − W/2, y_pix = H/2 − i − 0.5.

use crate::error::{check_size, finite, FcolError, Result};
use glam::DVec3;

/// How the camera projects.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// `view_height` world units span the image height.
    Orthographic { view_height: f64 },
    /// Eye at `distance` from the target, vertical field of view `fov` degrees.
    Perspective { distance: f64, fov: f64 },
}

/// A view: where the camera looks from, independent of image size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    pub elevation: f64,
    pub azimuth: f64,
    pub projection: Projection,
    pub target: DVec3,
}

impl View {
    /// Validate every field; errors name the argument.
    pub fn validate(&self) -> Result<()> {
        finite("elevation", self.elevation)?;
        finite("azimuth", self.azimuth)?;
        if !self.target.is_finite() {
            return Err(FcolError::value("target", "must be three finite numbers"));
        }
        match self.projection {
            Projection::Orthographic { view_height } => {
                if !(view_height.is_finite() && view_height > 0.0) {
                    return Err(FcolError::value(
                        "view_height",
                        format!("must be a positive finite number, got {view_height}"),
                    ));
                }
            }
            Projection::Perspective { distance, fov } => {
                if !(distance.is_finite() && distance > 0.0) {
                    return Err(FcolError::value(
                        "distance",
                        format!("must be a positive finite number, got {distance}"),
                    ));
                }
                if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
                    return Err(FcolError::value(
                        "fov",
                        format!("must be in (0, 180) degrees, got {fov}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The orthonormal basis (d, r, up) of SPEC §1.
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let (sa, ca) = self.elevation.to_radians().sin_cos();
        let (sb, cb) = self.azimuth.to_radians().sin_cos();
        let d = DVec3::new(ca * sb, ca * cb, -sa);
        let r = DVec3::new(cb, -sb, 0.0);
        let up = DVec3::new(sa * sb, sa * cb, ca);
        (d, r, up)
    }
}

/// A view bound to an image size: everything a renderer needs to map between
/// world points and pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub view: View,
    pub width: usize,
    pub height: usize,
    /// View direction, screen right and screen up (unit, orthonormal).
    pub d: DVec3,
    pub r: DVec3,
    pub up: DVec3,
    /// True for perspective.
    pub perspective: bool,
    /// Orthographic: world units per pixel. Perspective: unused (1).
    pub pixel: f64,
    /// Perspective: focal length in pixels. Orthographic: unused (1).
    pub focal: f64,
    /// Perspective: the eye E = T − D·d. Orthographic: the target.
    pub eye: DVec3,
    /// Perspective: points with depth ≤ near are not drawn (1e-9 · distance).
    pub near: f64,
}

/// Projection of a world point: continuous pixel coordinates (pixel centres at
/// integers) and camera depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projected {
    pub row: f64,
    pub col: f64,
    pub depth: f64,
}

impl Camera {
    pub fn new(view: &View, width: usize, height: usize) -> Result<Camera> {
        view.validate()?;
        check_size(width, height)?;
        let (d, r, up) = view.basis();
        let h = height as f64;
        let (perspective, pixel, focal, eye, near) = match view.projection {
            Projection::Orthographic { view_height } => {
                (false, view_height / h, 1.0, view.target, f64::NEG_INFINITY)
            }
            Projection::Perspective { distance, fov } => {
                let focal = 0.5 * h / (0.5 * fov.to_radians()).tan();
                (
                    true,
                    1.0,
                    focal,
                    view.target - distance * d,
                    1e-9 * distance,
                )
            }
        };
        Ok(Camera {
            view: *view,
            width,
            height,
            d,
            r,
            up,
            perspective,
            pixel,
            focal,
            eye,
            near,
        })
    }

    /// Camera coordinates (x, y, z) of a world point: orthographic relative to
    /// the target, perspective relative to the eye; z is the SPEC depth.
    #[inline]
    pub fn camera_coords(&self, p: DVec3) -> DVec3 {
        let q = p - self.eye;
        DVec3::new(q.dot(self.r), q.dot(self.up), q.dot(self.d))
    }

    /// Screen position in pixel units from the image centre (x_pix, y_pix) and
    /// depth. Perspective points at depth ≤ near give non-finite x, y.
    #[inline]
    pub fn to_screen(&self, p: DVec3) -> DVec3 {
        let c = self.camera_coords(p);
        if self.perspective {
            if c.z <= self.near {
                DVec3::new(f64::NAN, f64::NAN, c.z)
            } else {
                let s = self.focal / c.z;
                DVec3::new(c.x * s, c.y * s, c.z)
            }
        } else {
            let s = 1.0 / self.pixel;
            DVec3::new(c.x * s, c.y * s, c.z)
        }
    }

    /// Continuous (row, col) with pixel centres at integers, and depth.
    #[inline]
    pub fn project(&self, p: DVec3) -> Projected {
        let s = self.to_screen(p);
        Projected {
            row: 0.5 * self.height as f64 - 0.5 - s.y,
            col: s.x + 0.5 * self.width as f64 - 0.5,
            depth: s.z,
        }
    }

    /// Screen coordinates (x_pix, y_pix) of a continuous (row, col).
    #[inline]
    pub fn pixel_to_screen(&self, row: f64, col: f64) -> (f64, f64) {
        (
            col + 0.5 - 0.5 * self.width as f64,
            0.5 * self.height as f64 - 0.5 - row,
        )
    }

    /// The ray through continuous pixel (row, col): origin and unit direction.
    /// Orthographic rays start on the plane through the target perpendicular
    /// to d (depth 0) and are whole lines: surface points in front of that
    /// plane have negative depth and are still seen. Perspective rays start at
    /// the eye.
    #[inline]
    pub fn ray(&self, row: f64, col: f64) -> (DVec3, DVec3) {
        let (x, y) = self.pixel_to_screen(row, col);
        if self.perspective {
            let dir = (self.focal * self.d + x * self.r + y * self.up).normalize();
            (self.eye, dir)
        } else {
            (
                self.eye + (x * self.pixel) * self.r + (y * self.pixel) * self.up,
                self.d,
            )
        }
    }

    /// World size of one pixel at camera depth z (for error in pixels).
    #[inline]
    pub fn pixel_size_at(&self, depth: f64) -> f64 {
        if self.perspective {
            depth / self.focal
        } else {
            self.pixel
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ortho(el: f64, az: f64) -> View {
        View {
            elevation: el,
            azimuth: az,
            projection: Projection::Orthographic { view_height: 10.0 },
            target: DVec3::ZERO,
        }
    }

    #[test]
    fn basis_is_orthonormal_right_handed_screen() {
        for &(a, b) in &[
            (0.0, 0.0),
            (30.0, 40.0),
            (90.0, 10.0),
            (-30.0, 200.0),
            (89.9, 0.5),
        ] {
            let (d, r, up) = ortho(a, b).basis();
            assert!((d.length() - 1.0).abs() < 1e-15);
            assert!(d.dot(r).abs() < 1e-15 && d.dot(up).abs() < 1e-15 && r.dot(up).abs() < 1e-15);
            // Looking along d, r is to the right of up: r × up = −d.
            assert!((r.cross(up) + d).length() < 1e-14);
        }
    }

    #[test]
    fn map_view_from_above() {
        // α = 90, β = 0: +u right, +v up.
        let cam = Camera::new(&ortho(90.0, 0.0), 100, 100).unwrap();
        let p = cam.project(DVec3::new(1.0, 0.0, 0.0));
        assert!((p.col - (49.5 + 10.0)).abs() < 1e-12 && (p.row - 49.5).abs() < 1e-12);
        let p = cam.project(DVec3::new(0.0, 1.0, 0.0));
        assert!((p.row - (49.5 - 10.0)).abs() < 1e-12);
    }

    #[test]
    fn ray_round_trip() {
        let v = View {
            elevation: 25.0,
            azimuth: 130.0,
            projection: Projection::Perspective {
                distance: 20.0,
                fov: 40.0,
            },
            target: DVec3::new(1.0, 2.0, 0.5),
        };
        let cam = Camera::new(&v, 64, 48).unwrap();
        let (o, dir) = cam.ray(10.25, 40.5);
        let p = cam.project(o + 7.0 * dir);
        assert!((p.row - 10.25).abs() < 1e-10 && (p.col - 40.5).abs() < 1e-10);
    }

    #[test]
    fn bad_views_are_refused() {
        let mut v = ortho(30.0, 0.0);
        v.projection = Projection::Orthographic { view_height: 0.0 };
        assert!(
            matches!(Camera::new(&v, 10, 10), Err(FcolError::Value { ref arg, .. }) if arg == "view_height")
        );
        assert!(Camera::new(&ortho(f64::NAN, 0.0), 10, 10).is_err());
        assert!(Camera::new(&ortho(10.0, 0.0), 0, 10).is_err());
        assert!(Camera::new(&ortho(10.0, 0.0), 1 << 20, 1 << 20).is_err());
    }
}
