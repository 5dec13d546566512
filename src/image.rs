//! Output buffers of a render (SPEC §2). Only the buffers asked for exist.
//! All are row-major, row 0 on top; the binding layer moves them into NumPy
//! arrays without copying.

use crate::error::{FcolError, Result};
use rayon::prelude::*;

/// A vector of n copies of `x`. Large ones are filled by the worker threads
/// in parallel: the fill is the first touch of fresh pages, whose faults
/// would otherwise run one after the other on the calling thread (about
/// 40 MB for the four usual buffers of a 1920×1080 render).
fn filled<T: Copy + Send + Sync>(n: usize, x: T) -> Vec<T> {
    const PARALLEL: usize = 1 << 16;
    if n < PARALLEL {
        return vec![x; n];
    }
    let mut v = Vec::with_capacity(n);
    // Huge pages behind it where the system grants them: the fill's faults
    // then come 2 MiB at a time, not 4 KiB.
    crate::scratch::advise_huge(v.as_ptr(), n);
    // Chunks filled by plain stores (a rayon collect writes element by
    // element through its consumer: several times the instructions).
    v.spare_capacity_mut()[..n]
        .par_chunks_mut(1 << 14)
        .for_each(|c| c.iter_mut().for_each(|s| _ = s.write(x)));
    // SAFETY: the first n elements were initialised just above.
    unsafe { v.set_len(n) };
    v
}

/// n pixels of colour `rgb` (3 bytes each), filled as [`filled`] does.
fn filled_rgb(n: usize, rgb: [u8; 3]) -> Vec<u8> {
    if 3 * n < 1 << 18 {
        return rgb.repeat(n);
    }
    // Zeroed pages are mapped lazily: the colour fill is their first touch.
    let mut v = vec![0u8; 3 * n];
    crate::scratch::advise_huge(v.as_ptr(), 3 * n);
    v.par_chunks_mut(3 << 12).for_each(|c| fill_rgb(c, rgb));
    v
}

/// Pixels of colour `rgb` over `dst` (3 bytes each): 16 pixels at a time,
/// 48 bytes copied whole (a 3-byte copy per pixel costs several times as
/// much).
pub(crate) fn fill_rgb(dst: &mut [u8], rgb: [u8; 3]) {
    let mut pat = [0u8; 48];
    for px in pat.chunks_exact_mut(3) {
        px.copy_from_slice(&rgb);
    }
    let mut it = dst.chunks_exact_mut(48);
    for b in &mut it {
        b.copy_from_slice(&pat);
    }
    let rest = it.into_remainder();
    let m = rest.len();
    rest.copy_from_slice(&pat[..m]);
}

/// Room for n values, none written yet (see [`Buffers::deferred`]).
fn unfilled<T>(n: usize) -> Vec<T> {
    let v = Vec::with_capacity(n);
    crate::scratch::advise_huge(v.as_ptr(), n);
    v
}

/// n zeros (pages mapped lazily, on their first write), with huge pages
/// behind them where the system grants them (see [`filled`]).
fn zeros<T: Copy + Default + PartialEq>(n: usize) -> Vec<T> {
    let v = vec![T::default(); n];
    crate::scratch::advise_huge(v.as_ptr(), n);
    v
}

/// Which buffers a caller asked for.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Outputs {
    pub rgb: bool,
    pub intensity: bool,
    pub depth: bool,
    pub normal: bool,
    pub uv: bool,
    pub side: bool,
    pub mask: bool,
    pub lines: bool,
}

impl Outputs {
    pub const NAMES: [&'static str; 8] = [
        "rgb",
        "intensity",
        "depth",
        "normal",
        "uv",
        "side",
        "mask",
        "lines",
    ];

    /// Parse a list of buffer names; unknown or repeated names are errors.
    pub fn from_names<S: AsRef<str>>(names: &[S]) -> Result<Outputs> {
        let mut o = Outputs::default();
        if names.is_empty() {
            return Err(FcolError::value(
                "outputs",
                format!("ask for at least one buffer of {:?}", Self::NAMES),
            ));
        }
        for n in names {
            let flag = match n.as_ref() {
                "rgb" => &mut o.rgb,
                "intensity" => &mut o.intensity,
                "depth" => &mut o.depth,
                "normal" => &mut o.normal,
                "uv" => &mut o.uv,
                "side" => &mut o.side,
                "mask" => &mut o.mask,
                "lines" => &mut o.lines,
                other => {
                    return Err(FcolError::value(
                        "outputs",
                        format!("unknown buffer {other:?}; choose from {:?}", Self::NAMES),
                    ))
                }
            };
            if *flag {
                return Err(FcolError::value(
                    "outputs",
                    format!("buffer {:?} named twice", n.as_ref()),
                ));
            }
            *flag = true;
        }
        Ok(o)
    }

    /// Does any buffer need shading (intensity or colour)?
    pub fn needs_shading(&self) -> bool {
        self.rgb || self.intensity
    }
}

/// The buffers of one render plus its counters.
#[derive(Debug, Clone, Default)]
pub struct Buffers {
    pub width: usize,
    pub height: usize,
    /// (H, W, 3) colour; background colour where no surface.
    pub rgb: Option<Vec<u8>>,
    /// (H, W) shading intensity before colour; NaN background.
    pub intensity: Option<Vec<f32>>,
    /// (H, W) camera depth; NaN background.
    pub depth: Option<Vec<f32>>,
    /// (H, W, 3) unit normal in world axes; NaN background.
    pub normal: Option<Vec<f32>>,
    /// (H, W, 2) surface parameters (u, v); NaN background.
    pub uv: Option<Vec<f32>>,
    /// (H, W) +1 upper side, −1 under side, 0 none.
    pub side: Option<Vec<i8>>,
    /// (H, W) surface present.
    pub mask: Option<Vec<bool>>,
    /// (H, W) line drawing, 255 on lines.
    pub lines: Option<Vec<u8>>,
    /// Function evaluations made (the seed's Table 1 count).
    pub samples: u64,
    /// Renderer-specific counters (Newton iterations, failures, …).
    pub stats: Vec<(String, f64)>,
}

impl Buffers {
    /// The requested buffers as [`Self::new`] has them, but for the
    /// colour, intensity, depth, normal and (u, v) buffers, which are
    /// allocated and not written (length 0): a renderer that writes every
    /// pixel of them once (its surface's pixels, then the background's)
    /// saves a pass over the image. Until [`Self::set_filled`], they are
    /// written through pointers to their allocations only.
    pub(crate) fn deferred(width: usize, height: usize, outputs: &Outputs) -> Buffers {
        let n = width * height;
        Buffers {
            width,
            height,
            rgb: outputs.rgb.then(|| unfilled(3 * n)),
            intensity: outputs.intensity.then(|| unfilled(n)),
            depth: outputs.depth.then(|| unfilled(n)),
            normal: outputs.normal.then(|| unfilled(3 * n)),
            uv: outputs.uv.then(|| unfilled(2 * n)),
            side: outputs.side.then(|| zeros(n)),
            mask: outputs.mask.then(|| zeros(n)),
            lines: outputs.lines.then(|| zeros(n)),
            samples: 0,
            stats: Vec::new(),
        }
    }

    /// The buffers of [`Self::deferred`] at their full length.
    ///
    /// # Safety
    /// Every value of them has been written.
    pub(crate) unsafe fn set_filled(&mut self) {
        let n = self.width * self.height;
        fn full<T>(v: &mut Option<Vec<T>>, len: usize) {
            if let Some(v) = v {
                assert!(v.capacity() >= len, "a buffer of the image's size");
                // SAFETY: the caller's guarantee; the capacity holds len.
                unsafe { v.set_len(len) };
            }
        }
        full(&mut self.rgb, 3 * n);
        full(&mut self.intensity, n);
        full(&mut self.depth, n);
        full(&mut self.normal, 3 * n);
        full(&mut self.uv, 2 * n);
    }

    /// Allocate the requested buffers filled with their background values.
    pub fn new(width: usize, height: usize, outputs: &Outputs, background: [u8; 3]) -> Buffers {
        let n = width * height;
        Buffers {
            width,
            height,
            rgb: outputs.rgb.then(|| filled_rgb(n, background)),
            intensity: outputs.intensity.then(|| filled(n, f32::NAN)),
            depth: outputs.depth.then(|| filled(n, f32::NAN)),
            normal: outputs.normal.then(|| filled(3 * n, f32::NAN)),
            uv: outputs.uv.then(|| filled(2 * n, f32::NAN)),
            side: outputs.side.then(|| zeros(n)),
            mask: outputs.mask.then(|| zeros(n)),
            lines: outputs.lines.then(|| zeros(n)),
            samples: 0,
            stats: Vec::new(),
        }
    }

    pub fn stat(&mut self, name: &str, value: f64) {
        self.stats.push((name.to_string(), value));
    }
}
