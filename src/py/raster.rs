//! Bindings of the raster primitives (`fcol.raster`). The public, documented
//! wrappers are in `python/fcol/raster.py`, which also normalises dtypes;
//! these functions check shapes again and copy their (small) inputs before
//! releasing the GIL.

use super::run;
use crate::error::FcolError;
use crate::raster::{self, FillRule, TriangleOptions};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

type Ints<'py> = Bound<'py, PyArray1<i64>>;

/// Pixels of an integer midpoint line: `(rows, cols)`.
#[pyfunction]
fn raster_line<'py>(
    py: Python<'py>,
    r0: i64,
    c0: i64,
    r1: i64,
    c1: i64,
) -> PyResult<(Ints<'py>, Ints<'py>)> {
    let (r, c) = run::detached(py, || raster::line(r0, c0, r1, c1))?;
    Ok((r.into_pyarray(py), c.into_pyarray(py)))
}

/// Pixels and coverage of an anti-aliased line: `(rows, cols, values)`.
#[pyfunction]
#[allow(clippy::type_complexity)]
fn raster_line_aa<'py>(
    py: Python<'py>,
    r0: i64,
    c0: i64,
    r1: i64,
    c1: i64,
) -> PyResult<(Ints<'py>, Ints<'py>, Bound<'py, PyArray1<f64>>)> {
    let (r, c, v) = run::detached(py, || raster::line_aa(r0, c0, r1, c1))?;
    Ok((r.into_pyarray(py), c.into_pyarray(py), v.into_pyarray(py)))
}

/// Pixels inside a polygon: `(rows, cols)`.
#[pyfunction]
#[pyo3(signature = (rows, cols, shape = None, rule = "evenodd"))]
fn raster_polygon<'py>(
    py: Python<'py>,
    rows: PyReadonlyArray1<'py, f64>,
    cols: PyReadonlyArray1<'py, f64>,
    shape: Option<(usize, usize)>,
    rule: &str,
) -> PyResult<(Ints<'py>, Ints<'py>)> {
    let rule = FillRule::parse(rule)?;
    let rows: Vec<f64> = rows.as_array().iter().copied().collect();
    let cols: Vec<f64> = cols.as_array().iter().copied().collect();
    let (r, c) = run::detached(py, || raster::polygon(&rows, &cols, shape, rule))?;
    Ok((r.into_pyarray(py), c.into_pyarray(py)))
}

/// Z-buffered Gouraud triangles: `(depth, values or None, face)`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, values, height, width, cull_backfaces = false, perspective_correct = false))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn raster_triangles<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    values: Option<PyReadonlyArray2<'py, f64>>,
    height: usize,
    width: usize,
    cull_backfaces: bool,
    perspective_correct: bool,
) -> PyResult<(
    Bound<'py, PyAny>,
    Option<Bound<'py, PyAny>>,
    Bound<'py, PyAny>,
)> {
    let va = vertices.as_array();
    if va.ncols() != 3 {
        return Err(FcolError::value(
            "vertices",
            format!(
                "expected shape (N, 3) of (row, col, depth), got {:?}",
                va.shape()
            ),
        )
        .into());
    }
    let fa = faces.as_array();
    if fa.ncols() != 3 {
        return Err(FcolError::value(
            "faces",
            format!(
                "expected shape (M, 3) of vertex indices, got {:?}",
                fa.shape()
            ),
        )
        .into());
    }
    let verts: Vec<[f64; 3]> = va.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let mut fs: Vec<[usize; 3]> = Vec::with_capacity(fa.nrows());
    for (k, r) in fa.rows().into_iter().enumerate() {
        if let Some(&i) = r.iter().find(|&&i| i < 0) {
            return Err(FcolError::value(
                "faces",
                format!("face {k} has the negative vertex index {i}"),
            )
            .into());
        }
        fs.push([r[0] as usize, r[1] as usize, r[2] as usize]);
    }
    let vals: Option<(Vec<f64>, usize)> = values.map(|v| {
        let a = v.as_array();
        (a.iter().copied().collect(), a.ncols())
    });
    if let Some((v, k)) = &vals {
        let nv = if *k > 0 { v.len() / k } else { 0 };
        if *k == 0 || nv != verts.len() {
            return Err(FcolError::value(
                "values",
                format!("expected one row per vertex ({}), got {nv}", verts.len()),
            )
            .into());
        }
    }
    let opt = TriangleOptions {
        cull_backfaces,
        perspective_correct,
    };
    let t = run::cancellable(py, |cancel| {
        raster::triangles(
            &verts,
            &fs,
            vals.as_ref().map(|(v, k)| (v.as_slice(), *k)),
            height,
            width,
            &opt,
            cancel,
        )
    })?;
    let (h, w) = (t.height, t.width);
    let depth = Array2::from_shape_vec((h, w), t.depth)
        .expect("depth buffer matches its shape")
        .into_pyarray(py)
        .into_any();
    let face = Array2::from_shape_vec((h, w), t.face)
        .expect("face buffer matches its shape")
        .into_pyarray(py)
        .into_any();
    let values = t.values.map(|v| {
        Array3::from_shape_vec((h, w, t.channels), v)
            .expect("value buffer matches its shape")
            .into_pyarray(py)
            .into_any()
    });
    Ok((depth, values, face))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(raster_line, m)?)?;
    m.add_function(wrap_pyfunction!(raster_line_aa, m)?)?;
    m.add_function(wrap_pyfunction!(raster_polygon, m)?)?;
    m.add_function(wrap_pyfunction!(raster_triangles, m)?)?;
    Ok(())
}
