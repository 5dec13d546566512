//! Bindings of the horizon maps (`fcol.horizon_map`, `fcol.horizon_points`).

use crate::horizon::{self, Method, Options, Progress, Terrain};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use std::sync::atomic::Ordering;
use std::time::Instant;

fn run_with_progress(
    py: Python<'_>,
    t: &Terrain,
    o: &Options,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<Vec<f32>> {
    horizon::validate(t, o)?;
    let prog = Progress::default();
    let mut last = usize::MAX;
    let poll = |_py: Python<'_>| -> PyResult<()> {
        if let Some(cb) = &progress {
            let d = prog.done.load(Ordering::Relaxed);
            let tot = prog.total.load(Ordering::Relaxed);
            if d != last {
                last = d;
                cb.call1((d.min(tot), tot))?;
            }
        }
        Ok(())
    };
    let out =
        super::run::cancellable_polled(py, poll, |cancel| horizon::compute(t, o, cancel, &prog))?;
    if let Some(cb) = &progress {
        let tot = prog.total.load(Ordering::Relaxed);
        cb.call1((tot, tot))?;
    }
    Ok(out)
}

fn options(
    sectors: usize,
    method: &str,
    subset: Option<Vec<usize>>,
    max_distance: Option<f64>,
    curvature: f64,
    near_vertex: bool,
) -> PyResult<Options> {
    let mut o = Options::new(sectors, Method::parse(method)?);
    o.subset = subset;
    o.max_distance = max_distance;
    o.curvature = curvature;
    o.near_vertex = near_vertex;
    Ok(o)
}

/// Horizon map of a grid z[i, j] at (j·du, i·dv): float32 (k, H, W)
/// radians for the k requested sectors, and the elapsed seconds.
#[pyfunction]
#[pyo3(signature = (z, du, dv, sectors, method, subset=None, max_distance=None, curvature=0.0, near_vertex=false, progress=None))]
#[allow(clippy::too_many_arguments)]
fn horizon_grid<'py>(
    py: Python<'py>,
    z: PyReadonlyArray2<'py, f64>,
    du: f64,
    dv: f64,
    sectors: usize,
    method: &str,
    subset: Option<Vec<usize>>,
    max_distance: Option<f64>,
    curvature: f64,
    near_vertex: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyArray3<f32>>, f64)> {
    let a = z.as_array();
    let (h, w) = (a.shape()[0], a.shape()[1]);
    let zv: Vec<f64> = a.iter().copied().collect();
    let t = Terrain::from_grid(zv, h, w, du, dv)?;
    let o = options(
        sectors,
        method,
        subset,
        max_distance,
        curvature,
        near_vertex,
    )?;
    let k = o.sector_list().len();
    let t0 = Instant::now();
    let out = run_with_progress(py, &t, &o, progress)?;
    let el = t0.elapsed().as_secs_f64();
    let arr = Array3::from_shape_vec((k, h, w), out).expect("shape matches");
    Ok((arr.into_pyarray(py), el))
}

/// Horizons of scattered points (x, y, z): float32 (k, n) radians.
#[pyfunction]
#[pyo3(signature = (x, y, z, sectors, method, subset=None, max_distance=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn horizon_points<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    y: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
    sectors: usize,
    method: &str,
    subset: Option<Vec<usize>>,
    max_distance: Option<f64>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyArray2<f32>>, f64)> {
    let v = |a: &PyReadonlyArray1<'py, f64>| a.as_array().iter().copied().collect::<Vec<f64>>();
    let t = Terrain::from_points(v(&x), v(&y), v(&z))?;
    let o = options(sectors, method, subset, max_distance, 0.0, false)?;
    let k = o.sector_list().len();
    let n = t.len();
    let t0 = Instant::now();
    let out = run_with_progress(py, &t, &o, progress)?;
    let el = t0.elapsed().as_secs_f64();
    let arr = Array2::from_shape_vec((k, n), out).expect("shape matches");
    Ok((arr.into_pyarray(py), el))
}

/// (mean, max) points per hull of Stewart's tree in one sector of a grid.
#[pyfunction]
#[pyo3(signature = (z, du, dv, sectors, sector))]
fn horizon_hull_stats(
    py: Python<'_>,
    z: PyReadonlyArray2<'_, f64>,
    du: f64,
    dv: f64,
    sectors: usize,
    sector: usize,
) -> PyResult<(f64, usize)> {
    let a = z.as_array();
    let (h, w) = (a.shape()[0], a.shape()[1]);
    let t = Terrain::from_grid(a.iter().copied().collect(), h, w, du, dv)?;
    let o = Options::new(sectors, Method::Stewart);
    horizon::validate(&t, &o)?;
    if sector >= sectors {
        return Err(crate::error::FcolError::value("sector", "out of range").into());
    }
    super::run::detached(py, || {
        Ok(horizon::stewart::hull_stats(
            &t,
            &horizon::Frame::new(sector, sectors),
            &o,
        ))
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(horizon_grid, m)?)?;
    m.add_function(wrap_pyfunction!(horizon_points, m)?)?;
    m.add_function(wrap_pyfunction!(horizon_hull_stats, m)?)?;
    Ok(())
}
