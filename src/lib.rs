//! fcol: render mathematical surfaces straight from their definitions.
//!
//! The crate is a pure-Rust core (no PyO3 types in any algorithm) under a thin
//! binding layer in [`py`], compiled only with the `python` feature. Every
//! renderer writes into [`image::Buffers`], computing only the buffers asked for.
//!
//! Conventions (SPEC §1): world axes (u, v, w), w up; images are row-major,
//! row 0 on top; pixel (i, j) has its centre at x_pix = j + 0.5 − W/2,
//! y_pix = H/2 − i − 0.5.

pub mod camera;
pub mod cancel;
pub mod error;
pub mod expr;
pub mod floating;
pub mod horizon;

pub mod image;
pub mod parametric;
pub mod raster;
mod scratch;
pub mod shade;
pub mod source;
pub mod surface;
#[cfg(test)]
mod test_rng;
pub mod texture;

#[cfg(feature = "python")]
mod py;

pub use camera::{Camera, Projection, View};
pub use cancel::Cancel;
pub use error::{FcolError, Result};
pub use image::{Buffers, Outputs};
