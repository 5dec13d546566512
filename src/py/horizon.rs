//! Bindings of the horizon maps (`fcol.horizon_map`, `fcol.horizon_points`)
//! and of their sky light and sun shadows (`fcol.HorizonMap` methods).

use crate::cancel::Cancel;
use crate::error::FcolError;
use crate::horizon::{self, sky, Method, Options, Progress, Terrain};
use numpy::ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray2, PyArray3, PyArrayDescrMethods, PyArrayMethods, PyReadonlyArray1,
    PyReadonlyArray2, PyReadonlyArray3, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// Compute the map with the GIL released, into `out` when given (its
/// length checked by the core), else into a new vector (returned).
fn run_with_progress(
    py: Python<'_>,
    t: &Terrain,
    o: &Options,
    progress: Option<Bound<'_, PyAny>>,
    out: Option<&mut [f32]>,
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
    let out = super::run::cancellable_polled(py, poll, |cancel| match out {
        Some(buf) => horizon::compute_into(t, o, cancel, &prog, buf).map(|()| Vec::new()),
        None => horizon::compute(t, o, cancel, &prog),
    })?;
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

/// `out` as the (k, H, W) output of a horizon map: a writable C-contiguous
/// float32 array of that shape (TypeError for another type or dtype,
/// ValueError for another shape or layout; a read-only array is refused
/// when borrowed for writing).
fn output_array<'py>(
    out: &Bound<'py, PyAny>,
    shape: [usize; 3],
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    use pyo3::exceptions::{PyTypeError, PyValueError};
    let expected = format!(
        "a float32 array of shape {:?}",
        (shape[0], shape[1], shape[2])
    );
    let Ok(any) = out.cast::<PyUntypedArray>() else {
        return Err(PyTypeError::new_err(format!(
            "out: expected {expected}, got {}",
            out.get_type().name()?
        )));
    };
    let Ok(arr) = any.cast::<PyArray3<f32>>() else {
        let dtype = any.dtype();
        if dtype.is_equiv_to(&numpy::dtype::<f32>(out.py())) {
            return Err(PyValueError::new_err(format!(
                "out: expected {expected}, got shape {:?}",
                any.shape()
            )));
        }
        return Err(PyTypeError::new_err(format!(
            "out: expected {expected}, got dtype {dtype}"
        )));
    };
    if arr.shape() != shape {
        return Err(PyValueError::new_err(format!(
            "out: expected {expected}, got shape {:?}",
            arr.shape()
        )));
    }
    // (Checked here: a Fortran-ordered array is contiguous too, and its
    // slice would take the values in the wrong order.)
    if !arr.is_c_contiguous() {
        return Err(PyValueError::new_err("out: must be C-contiguous"));
    }
    Ok(arr.clone())
}

/// Horizon map of a grid z[i, j] at (j·du, i·dv): float32 (k, H, W)
/// radians for the k requested sectors (written into `out` when given, and
/// returned), and the elapsed seconds.
#[pyfunction]
#[pyo3(signature = (z, du, dv, sectors, method, subset=None, max_distance=None, curvature=0.0, near_vertex=false, progress=None, out=None))]
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
    out: Option<Bound<'py, PyAny>>,
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
    if let Some(out) = out {
        let arr = output_array(&out, [k, h, w])?;
        let mut rw = arr.try_readwrite().map_err(|e| {
            FcolError::value(
                "out",
                match e {
                    numpy::BorrowError::NotWriteable => "must be writable (it is read-only)",
                    _ => "is in use by another call",
                },
            )
        })?;
        let buf = rw
            .as_slice_mut()
            .map_err(|_| FcolError::value("out", "must be C-contiguous"))?;
        let t0 = Instant::now();
        run_with_progress(py, &t, &o, progress, Some(buf))?;
        let el = t0.elapsed().as_secs_f64();
        drop(rw);
        return Ok((arr, el));
    }
    let t0 = Instant::now();
    let out = run_with_progress(py, &t, &o, progress, None)?;
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
    let out = run_with_progress(py, &t, &o, progress, None)?;
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
        return Err(FcolError::value("sector", "out of range").into());
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
    m.add_function(wrap_pyfunction!(horizon_sky, m)?)?;
    m.add_function(wrap_pyfunction!(horizon_sun, m)?)?;
    Ok(())
}

// ---------------------------------------------------------------------------
// sky light and sun shadows (Stewart §VI), per point in Rust

/// Horizon elevations as NumPy gave them: float32 (as computed) or float64.
enum ElevArray<'py> {
    F32(PyReadonlyArray3<'py, f32>),
    F64(PyReadonlyArray3<'py, f64>),
}

impl<'py> ElevArray<'py> {
    fn extract(obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        if let Ok(a) = obj.extract::<PyReadonlyArray3<'py, f32>>() {
            return Ok(ElevArray::F32(a));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray3<'py, f64>>() {
            return Ok(ElevArray::F64(a));
        }
        Err(pyo3::exceptions::PyTypeError::new_err(
            "elevation: expected a C-contiguous float32 or float64 array (k, H, W)",
        ))
    }

    fn shape(&self) -> (usize, usize, usize) {
        let s = match self {
            ElevArray::F32(a) => a.shape().to_vec(),
            ElevArray::F64(a) => a.shape().to_vec(),
        };
        (s[0], s[1], s[2])
    }
}

fn contiguous<'a, T: numpy::Element, D: numpy::ndarray::Dimension>(
    a: &'a numpy::PyReadonlyArray<'_, T, D>,
    name: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| crate::error::FcolError::value(name, "must be a C-contiguous array").into())
}

/// Shared arguments of the sky functions, checked and borrowed.
struct SkyArgs<'py> {
    elevation: ElevArray<'py>,
    z: PyReadonlyArray2<'py, f64>,
    normals: Option<PyReadonlyArray3<'py, f64>>,
    indices: Vec<usize>,
    sectors: usize,
    rows: usize,
    cols: usize,
}

impl<'py> SkyArgs<'py> {
    fn new(
        elevation: &Bound<'py, PyAny>,
        sector_indices: Vec<usize>,
        sectors: usize,
        z: PyReadonlyArray2<'py, f64>,
        normals: Option<PyReadonlyArray3<'py, f64>>,
    ) -> PyResult<Self> {
        let elevation = ElevArray::extract(elevation)?;
        let (k, h, w) = elevation.shape();
        if z.shape() != [h, w] {
            return Err(FcolError::value(
                "z",
                format!(
                    "shape {:?} does not match the horizon planes ({h}, {w})",
                    z.shape()
                ),
            )
            .into());
        }
        if k != sector_indices.len() {
            return Err(FcolError::value(
                "sector_indices",
                format!("{} indices for {k} planes", sector_indices.len()),
            )
            .into());
        }
        if let Some(n) = &normals {
            if n.shape() != [h, w, 3] {
                return Err(FcolError::value(
                    "normals",
                    format!("expected shape ({h}, {w}, 3), got {:?}", n.shape()),
                )
                .into());
            }
        }
        Ok(SkyArgs {
            elevation,
            z,
            normals,
            indices: sector_indices,
            sectors,
            rows: h,
            cols: w,
        })
    }

    /// Run `f` on the borrowed planes with the GIL released (Ctrl-C
    /// honoured) and return an (H, W) float64 array.
    fn run<F>(&self, py: Python<'py>, f: F) -> PyResult<Bound<'py, PyArray2<f64>>>
    where
        F: Fn(
                sky::Planes<'_, f32>,
                sky::Planes<'_, f64>,
                bool,
                Option<&[f64]>,
                &Cancel,
            ) -> crate::error::Result<Vec<f64>>
            + Send
            + Sync,
    {
        let z = contiguous(&self.z, "z")?;
        let normals = match &self.normals {
            Some(n) => Some(contiguous(n, "normals")?),
            None => None,
        };
        fn planes<'a, T>(e: &'a [T], a: &'a SkyArgs<'_>, z: &'a [f64]) -> sky::Planes<'a, T> {
            sky::Planes {
                elevation: e,
                sector_indices: &a.indices,
                sectors: a.sectors,
                rows: a.rows,
                cols: a.cols,
                z,
            }
        }
        let (e32, e64): (&[f32], &[f64]) = match &self.elevation {
            ElevArray::F32(a) => (contiguous(a, "elevation")?, &[]),
            ElevArray::F64(a) => (&[], contiguous(a, "elevation")?),
        };
        let is32 = matches!(self.elevation, ElevArray::F32(_));
        let (p32, p64) = (planes(e32, self, z), planes(e64, self, z));
        let out = super::run::cancellable(py, |c| f(p32, p64, is32, normals, c))?;
        let (h, w) = (self.rows, self.cols);
        Ok(Array2::from_shape_vec((h, w), out)
            .expect("shape matches")
            .into_pyarray(py))
    }
}

fn need(normals: Option<&[f64]>) -> crate::error::Result<&[f64]> {
    normals.ok_or_else(|| FcolError::value("normals", "are required"))
}

/// Sky light of every point of a horizon map (Stewart §VI), float64 (H, W):
/// `quantity` "sky_view_factor", "illumination" (needs `table`, the
/// (s, 256) sky radiances over equal-area regions) or "radiosity" (needs
/// `table` and `albedo`). `elevation` (s, H, W) holds every sector in
/// order; `normals` (H, W, 3); `z` (H, W) marks no data (non-finite).
#[pyfunction]
#[pyo3(signature = (elevation, sectors, z, normals, quantity, table=None, albedo=0.5))]
#[allow(clippy::too_many_arguments)]
fn horizon_sky<'py>(
    py: Python<'py>,
    elevation: &Bound<'py, PyAny>,
    sectors: usize,
    z: PyReadonlyArray2<'py, f64>,
    normals: PyReadonlyArray3<'py, f64>,
    quantity: &str,
    table: Option<PyReadonlyArray2<'py, f64>>,
    albedo: f64,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let args = SkyArgs::new(elevation, (0..sectors).collect(), sectors, z, Some(normals))?;
    let table = match &table {
        Some(t) => {
            if t.shape() != [sectors, sky::BANDS] {
                return Err(FcolError::value(
                    "sky",
                    format!(
                        "expected a table of shape ({sectors}, {}), got {:?}",
                        sky::BANDS,
                        t.shape()
                    ),
                )
                .into());
            }
            Some(contiguous(t, "sky")?)
        }
        None => None,
    };
    #[derive(Clone, Copy)]
    enum Q {
        Svf,
        Illum,
        Rad,
    }
    let q = match quantity {
        "sky_view_factor" => Q::Svf,
        "illumination" => Q::Illum,
        "radiosity" => Q::Rad,
        other => {
            return Err(FcolError::value(
                "quantity",
                format!(
                "expected \"sky_view_factor\", \"illumination\" or \"radiosity\", got {other:?}"
            ),
            )
            .into())
        }
    };
    if !matches!(q, Q::Svf) && table.is_none() {
        return Err(FcolError::value("sky", "a table is required").into());
    }
    args.run(py, move |p32, p64, is32, normals, cancel| {
        let n = need(normals)?;
        let t = table.unwrap_or(&[]);
        macro_rules! go {
            ($p:expr) => {
                match q {
                    Q::Svf => sky::sky_view_factor(&$p, n, cancel),
                    Q::Illum => sky::illumination(&$p, n, t, cancel),
                    Q::Rad => sky::radiosity(&$p, n, t, albedo, cancel),
                }
            };
        }
        if is32 {
            go!(p32)
        } else {
            go!(p64)
        }
    })
}

/// Visible fraction of the sun (radians; radius 0: a point) at every point
/// of a horizon map, float64 (H, W), NaN at no data; times max(0, N·s)
/// when `normals` are given. Needs only the sectors the disc covers.
#[pyfunction]
#[pyo3(signature = (elevation, sector_indices, sectors, z, sun_azimuth, sun_elevation, sun_radius, normals=None))]
#[allow(clippy::too_many_arguments)]
fn horizon_sun<'py>(
    py: Python<'py>,
    elevation: &Bound<'py, PyAny>,
    sector_indices: Vec<usize>,
    sectors: usize,
    z: PyReadonlyArray2<'py, f64>,
    sun_azimuth: f64,
    sun_elevation: f64,
    sun_radius: f64,
    normals: Option<PyReadonlyArray3<'py, f64>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let args = SkyArgs::new(elevation, sector_indices, sectors, z, normals)?;
    let s = sky::Sun {
        azimuth: sun_azimuth,
        elevation: sun_elevation,
        radius: sun_radius,
    };
    args.run(py, move |p32, p64, is32, normals, cancel| {
        if is32 {
            sky::sun(&p32, &s, normals, cancel)
        } else {
            sky::sun(&p64, &s, normals, cancel)
        }
    })
}
