//! `render_height`: the native entry of `fcol.render` for function surfaces
//! w = f(u, v) (floating column and floating horizon).

use super::convert::{buffers_to_dict, parse_outputs, take_shading, Options};
use super::run;
use super::view::PyView;
use crate::error::FcolError;
use crate::floating::{self, Corrections, FloatingOptions, ShadingMode};
use crate::surface::{Domain, HeightField, HeightSample};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;
use std::time::Instant;

/// A surface given as a Python object with a `domain` ((u0, u1), (v0, v1))
/// that is called as `obj(u, v) -> (w, f_u, f_v)` on float64 arrays.
struct PyCallableHeight {
    obj: Py<PyAny>,
    domain: Domain,
}

impl HeightField for PyCallableHeight {
    fn domain(&self) -> Domain {
        self.domain
    }
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [HeightSample]) {
        let ok = Python::attach(|py| -> PyResult<()> {
            let ua = PyArray1::from_slice(py, u);
            let va = PyArray1::from_slice(py, v);
            let r = self.obj.bind(py).call1((ua, va))?;
            let (f, fu, fv): (Bound<'_, PyAny>, Bound<'_, PyAny>, Bound<'_, PyAny>) =
                r.extract()?;
            let conv = |a: Bound<'_, PyAny>| -> PyResult<Vec<f64>> {
                let np = py.import("numpy")?;
                let a = np.call_method1("asarray", (a, "float64"))?;
                let a = np.call_method1("broadcast_to", (a, u.len()))?;
                let a = a.cast_into::<PyArray1<f64>>()?;
                Ok(a.to_vec()?)
            };
            let (f, fu, fv) = (conv(f)?, conv(fu)?, conv(fv)?);
            if f.len() != u.len() {
                return Err(
                    FcolError::value("surface", "returned arrays of the wrong length").into(),
                );
            }
            for k in 0..u.len() {
                out[k] = HeightSample {
                    f: f[k],
                    fu: fu[k],
                    fv: fv[k],
                };
            }
            Ok(())
        });
        if ok.is_err() {
            for o in out.iter_mut() {
                *o = HeightSample {
                    f: f64::NAN,
                    fu: f64::NAN,
                    fv: f64::NAN,
                };
            }
        }
    }
    fn cheap_point_eval(&self) -> bool {
        false
    }
}

type Field = Arc<dyn HeightField + Send + Sync>;

fn height_field(obj: &Bound<'_, PyAny>) -> PyResult<Field> {
    let dom = obj.getattr("domain").ok();
    if obj.is_callable() {
        if let Some(d) = dom {
            let ((u0, u1), (v0, v1)): ((f64, f64), (f64, f64)) = d
                .extract()
                .map_err(|_| FcolError::type_("surface", "domain must be ((u0, u1), (v0, v1))"))?;
            let domain = Domain::new(u0, u1, v0, v1)?;
            // Validate one call now, with the GIL held, for a clear error.
            let np = obj.py().import("numpy")?;
            let z = np.call_method1("zeros", (1,))?;
            obj.call1((z.clone(), z)).map_err(|e| {
                pyo3::exceptions::PyTypeError::new_err(format!(
                    "surface: calling surface(u, v) failed: {e}"
                ))
            })?;
            return Ok(Arc::new(PyCallableHeight {
                obj: obj.clone().unbind(),
                domain,
            }));
        }
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "surface: expected a function surface (fcol.Function, fcol.HeightGrid, or an object with a `domain` called as surface(u, v) -> (w, f_u, f_v)), got {}",
        obj.get_type().name()?
    )))
}

fn parse_options(o: &Options<'_>, method: &str) -> PyResult<FloatingOptions> {
    let mut f = FloatingOptions::default();
    if let Some(s) = o.take::<String>("shading")? {
        f.shading = match s.as_str() {
            "normal" => ShadingMode::Normal,
            "intensity" => ShadingMode::Intensity,
            other => {
                return Err(FcolError::value(
                    "shading",
                    format!("must be \"normal\" (Phong) or \"intensity\" (Gouraud), got {other:?}"),
                )
                .into())
            }
        };
    }
    if let Some(v) = o.take("refine")? {
        f.refine = v;
    }
    if let Some(v) = o.take("step")? {
        f.step = v;
    }
    if let Some(v) = o.take("max_step")? {
        f.max_step = v;
    }
    if let Some(v) = o.take("refine_tol")? {
        f.refine_tol = v;
    }
    if let Some(v) = o.take("refine_iters")? {
        f.refine_iters = v;
    }
    let mut c = Corrections::default();
    if let Some(v) = o.take("ridges")? {
        c.ridges = v;
    }
    if let Some(v) = o.take("jumps")? {
        c.jumps = v;
    }
    if let Some(v) = o.take("bumps")? {
        c.bumps = v;
    }
    if let Some(v) = o.take("walls")? {
        c.walls = v;
    }
    if let Some(s) = o.take::<String>("correction")? {
        c.spline = match s.as_str() {
            "spline" => true,
            "supersample" => false,
            other => {
                return Err(FcolError::value(
                    "correction",
                    format!("must be \"supersample\" or \"spline\", got {other:?}"),
                )
                .into())
            }
        };
    }
    if let Some(v) = o.take("rate")? {
        c.rate = v;
    }
    if let Some(v) = o.take("threshold")? {
        c.threshold = v;
    }
    f.corrections = c;
    if let Some(v) = o.take("antialias")? {
        f.antialias = v;
    }
    if method == "floating_horizon" {
        if let Some(v) = o.take("planes")? {
            f.planes = v;
        }
    }
    if let Some(v) = o.take("threads")? {
        f.threads = Some(v);
    }
    Ok(f)
}

/// Render a function surface: `method` is "floating_column" or
/// "floating_horizon"; `options` holds the keyword options of
/// `fcol.render` (unknown ones are a TypeError). Returns the keyword
/// arguments of `fcol.Image`.
#[pyfunction]
#[pyo3(signature = (surface, view, width, height, method, outputs, options = None))]
#[allow(clippy::too_many_arguments)]
fn render_height<'py>(
    py: Python<'py>,
    surface: &Bound<'py, PyAny>,
    view: &Bound<'py, PyAny>,
    width: usize,
    height: usize,
    method: &str,
    outputs: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let view = view
        .cast::<PyView>()
        .map_err(|_| pyo3::exceptions::PyTypeError::new_err("view: expected fcol.View"))?
        .get()
        .view;
    let horizon = match method {
        "floating_column" => false,
        "floating_horizon" => true,
        other => return Err(FcolError::value(
            "method",
            format!(
                "function surfaces take \"floating_column\" or \"floating_horizon\", got {other:?}"
            ),
        )
        .into()),
    };
    let outputs = parse_outputs(outputs)?;
    let o = Options::new(options, py)?;
    let shading = take_shading(&o)?;
    let fopts = parse_options(&o, method)?;
    o.finish(&format!("fcol.render(method={method:?})"))?;
    fopts.validate()?;
    crate::error::check_size(width, height)?;
    let field = height_field(surface)?;
    let t0 = Instant::now();
    let buf = run::cancellable(py, |cancel| {
        let f: &dyn HeightField = &*field;
        if horizon {
            floating::render_floating_horizon(
                f, &view, width, height, &outputs, &shading, &fopts, cancel,
            )
        } else {
            floating::render_floating_column(
                f, &view, width, height, &outputs, &shading, &fopts, cancel,
            )
        }
    })?;
    let elapsed = t0.elapsed().as_secs_f64();
    buffers_to_dict(py, buf, elapsed)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(render_height, m)?)?;
    Ok(())
}
