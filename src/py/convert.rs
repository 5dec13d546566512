//! Core buffers → NumPy arrays (moved, not copied) and common argument
//! conversions.

use crate::image::Buffers;
use numpy::ndarray::{Array2, Array3};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn a2<T: numpy::Element>(py: Python<'_>, h: usize, w: usize, v: Vec<T>) -> Bound<'_, PyAny> {
    Array2::from_shape_vec((h, w), v)
        .expect("buffer length matches its shape")
        .into_pyarray(py)
        .into_any()
}

fn a3<T: numpy::Element>(
    py: Python<'_>,
    h: usize,
    w: usize,
    c: usize,
    v: Vec<T>,
) -> Bound<'_, PyAny> {
    Array3::from_shape_vec((h, w, c), v)
        .expect("buffer length matches its shape")
        .into_pyarray(py)
        .into_any()
}

/// The keyword arguments of `fcol.Image(...)`: one C-contiguous array per
/// requested buffer, plus `samples`, `elapsed` and `stats`.
pub fn buffers_to_dict<'py>(
    py: Python<'py>,
    b: Buffers,
    elapsed: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let (h, w) = (b.height, b.width);
    let d = PyDict::new(py);
    d.set_item("width", w)?;
    d.set_item("height", h)?;
    if let Some(v) = b.rgb {
        d.set_item("rgb", a3(py, h, w, 3, v))?;
    }
    if let Some(v) = b.intensity {
        d.set_item("intensity", a2(py, h, w, v))?;
    }
    if let Some(v) = b.depth {
        d.set_item("depth", a2(py, h, w, v))?;
    }
    if let Some(v) = b.normal {
        d.set_item("normal", a3(py, h, w, 3, v))?;
    }
    if let Some(v) = b.uv {
        d.set_item("uv", a3(py, h, w, 2, v))?;
    }
    if let Some(v) = b.side {
        d.set_item("side", a2(py, h, w, v))?;
    }
    if let Some(v) = b.mask {
        d.set_item("mask", a2(py, h, w, v))?;
    }
    if let Some(v) = b.lines {
        d.set_item("lines", a2(py, h, w, v))?;
    }
    d.set_item("samples", b.samples)?;
    d.set_item("elapsed", elapsed)?;
    let stats = PyDict::new(py);
    for (k, v) in b.stats {
        stats.set_item(k, v)?;
    }
    d.set_item("stats", stats)?;
    Ok(d)
}
