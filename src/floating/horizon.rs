//! The modified floating horizon of Gordon 2001 §4.1 / A.1: sampling planes of
//! constant t (parallel to the screen x axis) advance front to back; every
//! pixel column keeps its minimum, maximum and last drawn row; each visible
//! new point is joined to the previous column by a line, and a partial line is
//! drawn against the previous column's dangling end.
//!
//! Rows here are A.1's y (screen up, integer): y = H − 1 − row.

use super::sampling::{Frame, Sampler};
use super::FloatingOptions;
use crate::camera::{Camera, View};
use crate::cancel::Cancel;
use crate::error::{FcolError, Result};
use crate::image::{Buffers, Outputs};
use crate::shade::Shading;
use crate::surface::HeightField;

/// Line between integer pixels (x0, y0) and (x1, y1), y up, drawn with
/// fcol's raster line (Bresenham, as scikit-image's `draw.line`), plotting
/// only the pixels inside the image.
pub fn line(lines: &mut [u8], w: usize, h: usize, x0: i64, y0: i64, x1: i64, y1: i64) {
    let top = h as i64 - 1;
    let Ok((rows, cols)) = crate::raster::line(top - y0, x0, top - y1, x1) else {
        return;
    };
    for (r, c) in rows.into_iter().zip(cols) {
        if r >= 0 && c >= 0 && (r as usize) < h && (c as usize) < w {
            lines[r as usize * w + c as usize] = 255;
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Fhr {
    ymin: i64,
    ymax: i64,
    yprev: i64,
    started: bool,
    /// Sampled (inside the domain) at the current plane.
    here: bool,
    w: f64,
}

/// Render the line drawing of w = f(u, v) (`lines`, and `mask` = lines).
#[allow(clippy::too_many_arguments)]
pub fn render_floating_horizon(
    field: &dyn HeightField,
    view: &View,
    width: usize,
    height: usize,
    outputs: &Outputs,
    shading: &Shading,
    opts: &FloatingOptions,
    cancel: &Cancel,
) -> Result<Buffers> {
    opts.validate()?;
    let extra = outputs.rgb
        || outputs.intensity
        || outputs.depth
        || outputs.normal
        || outputs.uv
        || outputs.side;
    if extra || !(outputs.lines || outputs.mask) {
        return Err(FcolError::value(
            "outputs",
            "method=\"floating_horizon\" draws lines: ask for (\"lines\",) (and optionally \"mask\")",
        ));
    }
    let cam = Camera::new(view, width, height)?;
    let fr = Frame::new(&cam, field.domain());
    let mut lines = vec![0u8; width * height];
    let (w, h) = (width, height);
    let (tmin, tmax) = if fr.persp {
        fr.domain_t_range()
    } else {
        // Orthographic: the t-range over the columns' lines in the domain.
        fr.domain_t_range()
    };
    let n = opts.planes;
    let dt = (tmax - tmin) / (n - 1) as f64;
    let mut samples = 0u64;
    // Halves: front (t increasing) and, in perspective, back (from the eye
    // backwards) for rays pointing behind the eye's vertical.
    let mut halves: Vec<Vec<f64>> = Vec::new();
    if fr.persp {
        let front: Vec<f64> = (0..n)
            .map(|k| tmin + k as f64 * dt)
            .filter(|&t| t > 0.0)
            .collect();
        let mut back: Vec<f64> = (0..n)
            .map(|k| tmin + k as f64 * dt)
            .filter(|&t| t < 0.0)
            .collect();
        back.reverse();
        halves.push(front);
        let hh = 0.5 * h as f64;
        if fr.focal * fr.d_t - hh * fr.up_t.abs() < 0.0 {
            halves.push(back);
        }
    } else {
        halves.push((0..n).map(|k| tmin + k as f64 * dt).collect());
    }
    let w0 = view.target.z - fr.origin.z;
    let lines_cols: Vec<_> = (0..w).map(|j| fr.column(fr.xpix(j as f64))).collect();
    for ts in halves {
        let mut fhr = vec![
            Fhr {
                ymin: i64::MAX,
                ymax: i64::MIN,
                yprev: 0,
                started: false,
                here: false,
                w: w0,
            };
            w
        ];
        for (pi, &t1) in ts.iter().enumerate() {
            if pi % 8 == 0 {
                cancel.check()?;
            }
            for col in 0..w {
                let mut sampler = Sampler {
                    frame: &fr,
                    field,
                    line: lines_cols[col],
                    evals: 0,
                    folds: 0,
                    lateral_tol: 0.02,
                    d: cam.d,
                    shading,
                    shade: false,
                };
                let s = sampler.sample(t1, fhr[col].w);
                samples += sampler.evals;
                let Some(s) = s.filter(|s| s.rho.is_finite()) else {
                    fhr[col].here = false;
                    continue;
                };
                fhr[col].w = s.wr;
                let row = s.rho.round().clamp(-1.0, h as f64);
                let y = (h as f64 - 1.0 - row) as i64;
                let prev_here = col > 0 && fhr[col - 1].here;
                let f = fhr[col];
                let (px, pmin, pmax, pprev) = if col > 0 {
                    let p = fhr[col - 1];
                    (col as i64 - 1, p.ymin, p.ymax, p.yprev)
                } else {
                    (0, 0, 0, 0)
                };
                let mut put = |ya: Option<i64>, yb: i64| match ya {
                    Some(ya) if prev_here => line(&mut lines, w, h, px, ya, col as i64, yb),
                    _ => line(&mut lines, w, h, col as i64, yb, col as i64, yb),
                };
                let c = &mut fhr[col];
                c.here = true;
                if !f.started {
                    // First pixel in the column.
                    c.started = true;
                    c.ymin = y;
                    c.ymax = y;
                    c.yprev = y;
                    put(Some(pprev), y);
                } else {
                    if y < f.ymin {
                        c.ymin = y;
                        c.yprev = y;
                        put(Some(pmin), y);
                    } else if y > f.ymax {
                        c.ymax = y;
                        c.yprev = y;
                        put(Some(pmax), y);
                    }
                    // Partial line against the previous column's dangling end.
                    if prev_here {
                        if pprev > c.ymax && y <= c.ymax {
                            line(&mut lines, w, h, px, pprev, col as i64, c.ymax);
                        } else if pprev < c.ymin && y >= c.ymin {
                            line(&mut lines, w, h, px, pprev, col as i64, c.ymin);
                        }
                    }
                }
            }
        }
    }
    let mut buf = Buffers::new(width, height, outputs, shading.background);
    if let Some(m) = buf.mask.as_mut() {
        for (m, l) in m.iter_mut().zip(&lines) {
            *m = *l != 0;
        }
    }
    if outputs.lines {
        buf.lines = Some(lines);
    }
    buf.samples = samples;
    buf.stat("planes", n as f64);
    Ok(buf)
}
