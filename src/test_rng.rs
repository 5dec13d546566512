//! A small deterministic generator for the unit tests (no dependency): the
//! same sequence on every machine.

/// Uniform numbers in [0, 1) from Knuth's 64-bit LCG seeded with `seed`
/// (the top 53 bits of each state).
pub(crate) fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}
