//! A texture over a surface's (u, v) domain, applied after a render: each
//! shaded pixel's intensity and colour are multiplied by the texture,
//! sampled bilinearly at the pixel's surface parameters (u, v).
//!
//! The texture is an (H, W) array laid out like a height grid's z (SPEC
//! §1): texel (i, j) sits at (u0 + j·(u1 − u0)/(W − 1), v0 + i·(v1 − v0)/(H − 1)),
//! row i along v, column j along u; (u0, u1, v0, v1) are the positions of
//! the first and last texels (v0 > v1 for a north-up grid). A single row or
//! column is constant along that axis. Outside the texel range the border
//! texel is used. Non-finite texels (NaN, ±inf) count as 0: the pixel goes
//! dark, and the colour stays NaN-free.
//!
//! The pass reads the (u, v) buffer of the render (float32, NaN where no
//! surface) and leaves background pixels untouched.

use crate::cancel::Cancel;
use crate::error::{FcolError, Result};
use rayon::prelude::*;

#[derive(Debug, Clone)]
pub struct Texture {
    texels: Vec<f64>,
    rows: usize,
    cols: usize,
    /// Positions of the first and last texel columns (u) and rows (v).
    u0: f64,
    u1: f64,
    v0: f64,
    v1: f64,
}

/// Texel index and fraction of coordinate x on n texels spanning [a, b].
#[inline]
fn locate(x: f64, a: f64, b: f64, n: usize) -> (usize, usize, f64) {
    if n == 1 {
        return (0, 0, 0.0);
    }
    let last = (n - 1) as f64;
    let t = ((x - a) / (b - a) * last).clamp(0.0, last);
    let i0 = (t.floor() as usize).min(n - 2);
    (i0, i0 + 1, t - i0 as f64)
}

impl Texture {
    /// `texels` row-major (rows, cols); `(u0, u1, v0, v1)` the positions of
    /// the first and last texels along each axis.
    pub fn new(
        mut texels: Vec<f64>,
        rows: usize,
        cols: usize,
        (u0, u1, v0, v1): (f64, f64, f64, f64),
    ) -> Result<Texture> {
        if rows == 0 || cols == 0 || texels.len() != rows * cols {
            return Err(FcolError::value(
                "texture",
                format!("expected a non-empty 2-D array, got {rows}x{cols}"),
            ));
        }
        for (name, a, b) in [("u", u0, u1), ("v", v0, v1)] {
            if !(a.is_finite() && b.is_finite()) || a == b {
                return Err(FcolError::value(
                    "texture",
                    format!("the surface's {name} range [{a}, {b}] cannot place a texture"),
                ));
            }
        }
        for t in texels.iter_mut() {
            if !t.is_finite() {
                *t = 0.0;
            }
        }
        Ok(Texture {
            texels,
            rows,
            cols,
            u0,
            u1,
            v0,
            v1,
        })
    }

    /// Bilinear value at (u, v).
    #[inline]
    pub fn sample(&self, u: f64, v: f64) -> f64 {
        let (j0, j1, fx) = locate(u, self.u0, self.u1, self.cols);
        let (i0, i1, fy) = locate(v, self.v0, self.v1, self.rows);
        let t = |i: usize, j: usize| self.texels[i * self.cols + j];
        let top = (1.0 - fx) * t(i0, j0) + fx * t(i0, j1);
        let bottom = (1.0 - fx) * t(i1, j0) + fx * t(i1, j1);
        (1.0 - fy) * top + fy * bottom
    }

    /// Multiply the shaded buffers of a `width`-wide render by the texture
    /// at each pixel's (u, v) (`uv`: 2 floats per pixel, NaN where no
    /// surface): `intensity` (float) and `rgb` (3 bytes per pixel, rounded
    /// and clamped to 0–255).
    pub fn apply(
        &self,
        width: usize,
        uv: &[f32],
        intensity: Option<&mut [f32]>,
        rgb: Option<&mut [u8]>,
        cancel: &Cancel,
    ) -> Result<()> {
        if width == 0 {
            return Ok(());
        }
        let n = uv.len() / 2;
        let mut factor = vec![f64::NAN; n];
        factor
            .par_chunks_mut(width)
            .zip(uv.par_chunks(2 * width))
            .try_for_each(|(row, uvr)| -> Result<()> {
                cancel.check()?;
                for (f, p) in row.iter_mut().zip(uvr.chunks_exact(2)) {
                    let (u, v) = (p[0] as f64, p[1] as f64);
                    if u.is_finite() && v.is_finite() {
                        *f = self.sample(u, v);
                    }
                }
                Ok(())
            })?;
        if let Some(inten) = intensity {
            inten.par_iter_mut().zip(&factor).for_each(|(i, &f)| {
                if !f.is_nan() {
                    *i = (*i as f64 * f) as f32;
                }
            });
        }
        if let Some(rgb) = rgb {
            rgb.par_chunks_mut(3).zip(&factor).for_each(|(c, &f)| {
                if !f.is_nan() {
                    for x in c.iter_mut() {
                        *x = (*x as f64 * f).round().clamp(0.0, 255.0) as u8;
                    }
                }
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_reproduces_a_plane_and_clamps() {
        // t = 2 + 3u − v on a 3×4 grid over u ∈ [0, 3], v ∈ [10, 0] (north-up)
        let (rows, cols) = (3, 4);
        let mut data = vec![];
        for i in 0..rows {
            for j in 0..cols {
                let (u, v) = (j as f64, 10.0 - 5.0 * i as f64);
                data.push(2.0 + 3.0 * u - v);
            }
        }
        let t = Texture::new(data, rows, cols, (0.0, 3.0, 10.0, 0.0)).unwrap();
        for (u, v) in [(0.0, 0.0), (1.3, 7.2), (3.0, 10.0), (2.9, 0.1)] {
            assert!((t.sample(u, v) - (2.0 + 3.0 * u - v)).abs() < 1e-12);
        }
        // outside: the border value
        assert!((t.sample(-1.0, 11.0) - (2.0 - 10.0)).abs() < 1e-12);
    }

    #[test]
    fn non_finite_texels_are_zero_and_background_untouched() {
        let t = Texture::new(vec![f64::NAN, 1.0], 1, 2, (0.0, 1.0, 0.0, 1.0)).unwrap();
        let uv = [0.0f32, 0.5, 0.5, 0.5, f32::NAN, f32::NAN];
        let mut inten = [0.8f32, 0.8, f32::NAN];
        let mut rgb = [200u8, 100, 50, 200, 100, 50, 255, 255, 255];
        t.apply(3, &uv, Some(&mut inten), Some(&mut rgb), &Cancel::new())
            .unwrap();
        assert_eq!(inten[0], 0.0);
        assert!((inten[1] - 0.4).abs() < 1e-7);
        assert!(inten[2].is_nan());
        assert_eq!(rgb, [0, 0, 0, 100, 50, 25, 255, 255, 255]);
    }
}
