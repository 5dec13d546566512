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
    errors::register(m)?;
    view::register(m)?;
    raster::register(m)?;
    render::register(m)?;
    surfaces::register(m)?;
    horizon::register(m)?;
    parametric::register(m)?;
    Ok(())
}
