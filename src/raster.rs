//! Raster primitives (seed 002): lines, anti-aliased lines, polygon fill and
//! z-buffered triangles.
