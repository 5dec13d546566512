//! Raster primitives (lecture notes on rasterisation: midpoint/Bresenham
//! lines, scan-line polygon fill, anti-aliased lines, z-buffer): the pixels
//! every fcol renderer draws with, and the mesh baseline the mesh-free
//! renderers are benchmarked against.
//!
//! Coordinates are (row, column) with pixel centres at integers, row 0 on
//! top, as in NumPy indexing. Every primitive refuses work beyond
//! [`MAX_PIXELS`](crate::error::MAX_PIXELS) with a clear error instead of
//! attempting a huge allocation.

pub mod line;
pub mod line_aa;
pub mod polygon;
pub mod triangles;

pub use line::line;
pub use line_aa::line_aa;
pub use polygon::{polygon, FillRule};
pub use triangles::{triangles, TriangleOptions, Triangles};

use crate::error::{FcolError, Result, MAX_PIXELS};

/// Number of pixels of a line from `(r0, c0)` to `(r1, c1)` (one per step
/// along the major axis, both ends included), refused beyond the pixel
/// budget. Works in i128 so that no pair of i64 endpoints can overflow.
pub(crate) fn line_length(r0: i64, c0: i64, r1: i64, c1: i64) -> Result<usize> {
    let dr = (r1 as i128 - r0 as i128).abs();
    let dc = (c1 as i128 - c0 as i128).abs();
    let n = dr.max(dc) + 1;
    if n > MAX_PIXELS as i128 {
        return Err(FcolError::value(
            "r1",
            format!(
                "the line from ({r0}, {c0}) to ({r1}, {c1}) has {n} pixels, beyond the budget of {MAX_PIXELS}; clip it to the image first"
            ),
        ));
    }
    Ok(n as usize)
}
