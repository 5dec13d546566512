//! The sampled X scan (Blinn 1978 §4).

use super::trackers::Tracker;
use super::xscan_exact::{XScan, XStats};
use super::Pixel;

#[derive(Debug, Clone, Default)]
pub struct SampledStats {
    pub samples: u64,
    pub refined: u64,
    pub turns: u64,
}

impl SampledStats {
    pub fn add(&mut self, o: &SampledStats) {
        self.samples += o.samples;
        self.refined += o.refined;
        self.turns += o.turns;
    }
}

#[allow(clippy::too_many_arguments)]
pub fn row(
    _xs: &XScan<'_>,
    _trackers: &[Tracker],
    _ys: f64,
    _per_turn: usize,
    _max_error: f64,
    _row: &mut [Option<Pixel>],
    _st: &mut SampledStats,
    _xst: &mut XStats,
) {
}
