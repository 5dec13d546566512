//! The binding layer: the only code that touches PyO3 and NumPy. Each
//! submodule converts arguments, releases the GIL around the core call and
//! converts results back.

use pyo3::prelude::*;

mod convert;
mod errors;
mod horizon;
mod parametric;
mod raster;
mod render;
mod run;
pub mod surfaces;
mod view;

#[pymodule]
fn _fcol(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add(
        "build_profile",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
    )?;
    // The instruction sets the extension was compiled for beyond its
    // target's baseline (a build for this machine's processor, see the
    // Makefile, has those it has).
    let features: Vec<&str> = [
        ("sse4.2", cfg!(target_feature = "sse4.2")),
        ("avx2", cfg!(target_feature = "avx2")),
        ("fma", cfg!(target_feature = "fma")),
        ("avx512f", cfg!(target_feature = "avx512f")),
        ("neon", cfg!(target_feature = "neon")),
    ]
    .into_iter()
    .filter_map(|(name, on)| on.then_some(name))
    .collect();
    m.add("build_features", features.join(" "))?;
    errors::register(m)?;
    view::register(m)?;
    raster::register(m)?;
    render::register(m)?;
    surfaces::register(m)?;
    horizon::register(m)?;
    parametric::register(m)?;
    Ok(())
}
