//! `fcol.Function`, `fcol.HeightGrid`, `fcol.Parametric`: surface sources
//! for the renderers, and their conversion to the core traits
//! ([`height_field_from_py`], [`parametric_from_py`]).
//!
//! Python callables are called in batches: the trait implementations
//! acquire the GIL once per batch (`Python::attach`), so they work from the
//! renderers' worker threads while the calling thread waits with the GIL
//! released. An exception raised by a callable during a render turns that
//! batch into holes (NaN) and is kept; [`check_surface_errors`] re-raises it.

use crate::error::FcolError;
use crate::source::{ExprHeight, ExprParametric, HeightGrid, Interpolation};
use crate::surface::{Domain, HeightField, HeightSample, ParamSample, ParametricSurface};
use glam::DVec3;
use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use super::run;

type DynHeight = Arc<dyn HeightField + Send + Sync>;
type DynParam = Arc<dyn ParametricSurface + Send + Sync>;

// ---------------------------------------------------------------------------
// argument helpers

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// `n` numbers from any sequence (tuple, list, NumPy array), else a
/// TypeError naming `name` with the expected form `what`.
fn numbers(obj: &Bound<'_, PyAny>, n: usize, name: &str, what: &str) -> PyResult<Vec<f64>> {
    let bad = || {
        PyTypeError::new_err(format!(
            "{name}: expected {what}, got {}",
            obj.repr().map(|r| r.to_string()).unwrap_or_default()
        ))
    };
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(bad());
    }
    let v: Vec<f64> = obj.extract().map_err(|_| bad())?;
    if v.len() != n {
        return Err(bad());
    }
    Ok(v)
}

/// `((u0, u1), (v0, v1))`.
pub(crate) fn extract_domain(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Domain> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Err(
            FcolError::value("domain", "required: pass domain=((u0, u1), (v0, v1))").into(),
        );
    };
    let what = "((u0, u1), (v0, v1)) of numbers";
    let bad = || {
        PyTypeError::new_err(format!(
            "domain: expected {what}, got {}",
            obj.repr().map(|r| r.to_string()).unwrap_or_default()
        ))
    };
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(bad());
    }
    let pairs: Vec<Bound<'_, PyAny>> = obj
        .try_iter()
        .map_err(|_| bad())?
        .collect::<PyResult<_>>()
        .map_err(|_| bad())?;
    if pairs.len() != 2 {
        return Err(bad());
    }
    let a = numbers(&pairs[0], 2, "domain", what).map_err(|_| bad())?;
    let b = numbers(&pairs[1], 2, "domain", what).map_err(|_| bad())?;
    let (u0, u1, v0, v1) = (a[0], a[1], b[0], b[1]);
    Ok(Domain::new(u0, u1, v0, v1)?)
}

/// `{name: value}`.
fn extract_params(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<(String, f64)>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(Vec::new());
    };
    let d = obj.cast::<PyDict>().map_err(|_| {
        PyTypeError::new_err(format!(
            "params: expected a dict {{name: value}}, got {}",
            type_name(obj)
        ))
    })?;
    let mut out = Vec::new();
    for (k, v) in d.iter() {
        let name: String = k.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "params: names must be strings, got {}",
                type_name(&k)
            ))
        })?;
        let x: f64 = v.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "params: the value of {name:?} must be a real number, got {}",
                type_name(&v)
            ))
        })?;
        out.push((name, x));
    }
    Ok(out)
}

fn kwargs_params(kw: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, f64)>> {
    match kw {
        None => Ok(Vec::new()),
        Some(d) => extract_params(Some(d.as_any())),
    }
}

/// `obj` as a float64 NumPy array, refusing complex, object and other
/// non-real dtypes with a TypeError naming `name`.
pub(crate) fn real_array<'py>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let np = py.import("numpy")?;
    let a = np.call_method1("asarray", (obj,)).map_err(|e| {
        PyTypeError::new_err(format!(
            "{name}: expected an array of real numbers ({})",
            e.value(py)
        ))
    })?;
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "b" | "i" | "u" | "f") {
        let dt = a.getattr("dtype")?.str()?.to_string();
        return Err(PyTypeError::new_err(format!(
            "{name}: expected real numbers, got dtype {dt}"
        )));
    }
    a.call_method1("astype", ("float64",))
}

/// Broadcast `u` and `v` (any array-likes of real numbers) together:
/// (shape, u values, v values) in C order.
fn broadcast_uv(
    py: Python<'_>,
    u: &Bound<'_, PyAny>,
    v: &Bound<'_, PyAny>,
) -> PyResult<(Vec<usize>, Vec<f64>, Vec<f64>)> {
    let np = py.import("numpy")?;
    let ua = real_array(py, u, "u")?;
    let va = real_array(py, v, "v")?;
    let b = np.call_method1("broadcast_arrays", (ua, va)).map_err(|e| {
        PyValueError::new_err(format!(
            "u, v: shapes do not broadcast together ({})",
            e.value(py)
        ))
    })?;
    let take = |x: Bound<'_, PyAny>| -> PyResult<(Vec<usize>, Vec<f64>)> {
        let a: PyReadonlyArrayDyn<'_, f64> = x.extract()?;
        let shape = a.shape().to_vec();
        Ok((shape, a.as_array().iter().copied().collect()))
    };
    let (shape, uu) = take(b.get_item(0)?)?;
    let (_, vv) = take(b.get_item(1)?)?;
    Ok((shape, uu, vv))
}

/// A result array of the given shape (a float for 0-d).
fn shaped<'py>(py: Python<'py>, shape: &[usize], data: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
    if shape.is_empty() {
        return Ok(data[0].into_pyobject(py)?.into_any());
    }
    let a = ArrayD::from_shape_vec(IxDyn(shape), data).expect("length matches shape");
    Ok(a.into_pyarray(py).into_any())
}

/// (..., 3) array from DVec3s.
fn shaped3<'py>(py: Python<'py>, shape: &[usize], data: &[DVec3]) -> PyResult<Bound<'py, PyAny>> {
    let mut s = shape.to_vec();
    s.push(3);
    let flat: Vec<f64> = data.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let a = ArrayD::from_shape_vec(IxDyn(&s), flat).expect("length matches shape");
    Ok(a.into_pyarray(py).into_any())
}

// ---------------------------------------------------------------------------
// Python callables

/// cbrt(machine epsilon): the central-difference step relative to scale.
const CBRT_EPS: f64 = 6.055_454_452_393_343e-6;
/// eps^(1/4): the step of second differences relative to scale.
const QRT_EPS: f64 = 1.220_703_125e-4;

/// The central-difference step at x for a domain of width `width`:
/// h = max(c · width, 64 · eps · |x|), c = cbrt(eps) for first and
/// eps^(1/4) for second derivatives, then rounded so that x ± h are
/// exactly representable (h = (x + h) − x).
#[inline]
fn fd_step(x: f64, width: f64, c: f64) -> f64 {
    let h = (c * width).max(64.0 * f64::EPSILON * x.abs());
    (x + h) - x
}

/// The state shared by callable sources: the Python objects, time and
/// keyword parameters, the number of calls, and the first error raised
/// during a render.
struct PyCallables {
    funcs: Vec<Py<PyAny>>,
    t: Option<f64>,
    params: Vec<(String, f64)>,
    calls: AtomicUsize,
    error: Mutex<Option<PyErr>>,
    failed: AtomicBool,
}

impl PyCallables {
    /// Fresh state for `funcs` (no calls yet); `t` must be finite.
    fn new(funcs: Vec<Py<PyAny>>, t: Option<f64>, params: Vec<(String, f64)>) -> PyResult<Self> {
        if let Some(t) = t {
            crate::error::finite("t", t)?;
        }
        Ok(PyCallables {
            funcs,
            t,
            params,
            calls: AtomicUsize::new(0),
            error: Mutex::new(None),
            failed: AtomicBool::new(false),
        })
    }

    fn clone_with(&self, py: Python<'_>, t: Option<f64>, params: Vec<(String, f64)>) -> Self {
        PyCallables {
            funcs: self.funcs.iter().map(|f| f.clone_ref(py)).collect(),
            t,
            params,
            calls: AtomicUsize::new(0),
            error: Mutex::new(None),
            failed: AtomicBool::new(false),
        }
    }

    /// Call function `k` on (u, v[, t], **params).
    fn call<'py>(
        &self,
        py: Python<'py>,
        k: usize,
        u: Vec<f64>,
        v: Vec<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let ua = PyArray1::from_vec(py, u);
        let va = PyArray1::from_vec(py, v);
        let args = match self.t {
            Some(t) => PyTuple::new(
                py,
                [
                    ua.into_any(),
                    va.into_any(),
                    t.into_pyobject(py)?.into_any(),
                ],
            )?,
            None => PyTuple::new(py, [ua.into_any(), va.into_any()])?,
        };
        let kw = PyDict::new(py);
        for (n, x) in &self.params {
            kw.set_item(n, x)?;
        }
        self.calls.fetch_add(1, Ordering::Relaxed);
        self.funcs[k]
            .bind(py)
            .call(args, if kw.is_empty() { None } else { Some(&kw) })
    }

    fn record(&self, e: PyErr) {
        let mut g = self.error.lock().unwrap_or_else(|p| p.into_inner());
        if g.is_none() {
            *g = Some(e);
        }
        self.failed.store(true, Ordering::Relaxed);
    }

    /// Whether a batch already failed in this render: later batches are
    /// holes without calling Python again (a render interrupted by Ctrl-C
    /// inside the callable, or a broken callable, then ends quickly).
    fn failed(&self) -> bool {
        self.failed.load(Ordering::Relaxed)
    }

    /// Stop calling Python for the rest of this render (Ctrl-C): later
    /// batches are holes, and no error is recorded.
    fn abort(&self) {
        self.failed.store(true, Ordering::Relaxed);
    }

    fn take_error(&self) -> Option<PyErr> {
        self.failed.store(false, Ordering::Relaxed);
        self.error.lock().unwrap_or_else(|p| p.into_inner()).take()
    }
}

/// A callable's result as n float64 values (broadcast, real only).
fn values_of(py: Python<'_>, r: &Bound<'_, PyAny>, n: usize, what: &str) -> PyResult<Vec<f64>> {
    let np = py.import("numpy")?;
    let a = real_array(py, r, what)?;
    let b = np
        .call_method1("broadcast_to", (a.clone(), (n,)))
        .map_err(|_| {
            let shape = a
                .getattr("shape")
                .and_then(|s| s.repr())
                .map(|s| s.to_string())
                .unwrap_or_default();
            PyValueError::new_err(format!(
                "{what}: called on arrays of shape ({n},) it must return the same shape (or a scalar), got shape {shape}"
            ))
        })?;
    let a: PyReadonlyArrayDyn<'_, f64> = b.extract()?;
    Ok(a.as_array().iter().copied().collect())
}

/// A pair (a, b) returned by a gradient or Jacobian callable.
fn pair<'py>(
    r: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let bad = || {
        PyTypeError::new_err(format!(
            "{what}: must return a pair (d/du, d/dv), got {}",
            type_name(r)
        ))
    };
    if r.len().map_err(|_| bad())? != 2 {
        return Err(bad());
    }
    Ok((r.get_item(0)?, r.get_item(1)?))
}

fn concat(parts: &[&[f64]]) -> Vec<f64> {
    parts.concat()
}

/// w = f(u, v) from a vectorised Python callable, with an optional
/// gradient callable; otherwise central differences (step [`fd_step`]).
pub struct CallableHeight {
    c: PyCallables,
    has_grad: bool,
    domain: Domain,
}

impl CallableHeight {
    fn eval_py(
        &self,
        py: Python<'_>,
        u: &[f64],
        v: &[f64],
        out: &mut [HeightSample],
    ) -> PyResult<()> {
        let n = u.len();
        if self.has_grad {
            let f = values_of(py, &self.c.call(py, 0, u.to_vec(), v.to_vec())?, n, "f")?;
            let g = self.c.call(py, 1, u.to_vec(), v.to_vec())?;
            let (gu, gv) = pair(&g, "grad")?;
            let gu = values_of(py, &gu, n, "grad")?;
            let gv = values_of(py, &gv, n, "grad")?;
            for i in 0..n {
                out[i] = HeightSample {
                    f: f[i],
                    fu: gu[i],
                    fv: gv[i],
                };
            }
            return Ok(());
        }
        let d = self.domain;
        let hu: Vec<f64> = u
            .iter()
            .map(|&x| fd_step(x, d.u1 - d.u0, CBRT_EPS))
            .collect();
        let hv: Vec<f64> = v
            .iter()
            .map(|&x| fd_step(x, d.v1 - d.v0, CBRT_EPS))
            .collect();
        let up: Vec<f64> = u.iter().zip(&hu).map(|(x, h)| x + h).collect();
        let um: Vec<f64> = u.iter().zip(&hu).map(|(x, h)| x - h).collect();
        let vp: Vec<f64> = v.iter().zip(&hv).map(|(x, h)| x + h).collect();
        let vm: Vec<f64> = v.iter().zip(&hv).map(|(x, h)| x - h).collect();
        // One call for the value and the four neighbours.
        let uu = concat(&[u, &up, &um, u, u]);
        let vv = concat(&[v, v, v, &vp, &vm]);
        let f = values_of(py, &self.c.call(py, 0, uu, vv)?, 5 * n, "f")?;
        for i in 0..n {
            out[i] = HeightSample {
                f: f[i],
                fu: (f[n + i] - f[2 * n + i]) / (up[i] - um[i]),
                fv: (f[3 * n + i] - f[4 * n + i]) / (vp[i] - vm[i]),
            };
        }
        Ok(())
    }

    fn values_py(&self, py: Python<'_>, u: &[f64], v: &[f64]) -> PyResult<Vec<f64>> {
        values_of(
            py,
            &self.c.call(py, 0, u.to_vec(), v.to_vec())?,
            u.len(),
            "f",
        )
    }
}

impl HeightField for CallableHeight {
    fn domain(&self) -> Domain {
        self.domain
    }
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [HeightSample]) {
        let nan = HeightSample {
            f: f64::NAN,
            fu: f64::NAN,
            fv: f64::NAN,
        };
        if u.is_empty() {
            return;
        }
        if self.c.failed() {
            out.iter_mut().for_each(|o| *o = nan);
            return;
        }
        Python::attach(|py| {
            if let Err(e) = self.eval_py(py, u, v, out) {
                out.iter_mut().for_each(|o| *o = nan);
                self.c.record(e);
            }
        })
    }
    fn eval_value_batch(&self, u: &[f64], v: &[f64], out: &mut [f64]) {
        if u.is_empty() {
            return;
        }
        if self.c.failed() {
            out.fill(f64::NAN);
            return;
        }
        Python::attach(|py| match self.values_py(py, u, v) {
            Ok(f) => out.copy_from_slice(&f),
            Err(e) => {
                out.fill(f64::NAN);
                self.c.record(e);
            }
        })
    }
    fn cheap_point_eval(&self) -> bool {
        false
    }
}

/// (X, Y, Z)(u, v) from three vectorised Python callables, with an
/// optional Jacobian callable `jac(u, v) -> (Pu, Pv)` (each (n, 3)).
/// Without `jac`, first derivatives are central differences with step
/// h = cbrt(eps)·width; second derivatives are central second differences
/// (of `jac` when given, else of the values) with step h = eps^(1/4)·width.
pub struct CallableParametric {
    c: PyCallables,
    has_jac: bool,
    domain: Domain,
}

fn xyz(py: Python<'_>, c: &PyCallables, u: &[f64], v: &[f64]) -> PyResult<Vec<DVec3>> {
    let n = u.len();
    let mut cols = Vec::with_capacity(3);
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        cols.push(values_of(
            py,
            &c.call(py, k, u.to_vec(), v.to_vec())?,
            n,
            name,
        )?);
    }
    Ok((0..n)
        .map(|i| DVec3::new(cols[0][i], cols[1][i], cols[2][i]))
        .collect())
}

/// A (n, 3) array-like as DVec3s.
fn vec3s(py: Python<'_>, r: &Bound<'_, PyAny>, n: usize, what: &str) -> PyResult<Vec<DVec3>> {
    let np = py.import("numpy")?;
    let a = real_array(py, r, what)?;
    let b = np.call_method1("broadcast_to", (a, (n, 3))).map_err(|_| {
        PyValueError::new_err(format!("{what}: each part must have shape ({n}, 3)"))
    })?;
    let a: PyReadonlyArrayDyn<'_, f64> = b.extract()?;
    let flat: Vec<f64> = a.as_array().iter().copied().collect();
    Ok(flat
        .chunks_exact(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect())
}

impl CallableParametric {
    fn jac_py(&self, py: Python<'_>, u: &[f64], v: &[f64]) -> PyResult<(Vec<DVec3>, Vec<DVec3>)> {
        let n = u.len();
        let r = self.c.call(py, 3, u.to_vec(), v.to_vec())?;
        let (a, b) = pair(&r, "jac")?;
        Ok((vec3s(py, &a, n, "jac")?, vec3s(py, &b, n, "jac")?))
    }

    fn eval_py(
        &self,
        py: Python<'_>,
        u: &[f64],
        v: &[f64],
        out: &mut [ParamSample],
        second: bool,
    ) -> PyResult<()> {
        let n = u.len();
        let d = self.domain;
        let (wu, wv) = (d.u1 - d.u0, d.v1 - d.v0);
        let shift = |x: &[f64], h: &[f64], s: f64| -> Vec<f64> {
            x.iter().zip(h).map(|(x, h)| x + s * h).collect()
        };
        let p = xyz(py, &self.c, u, v)?;
        for i in 0..n {
            out[i].p = p[i];
        }
        let h1u: Vec<f64> = u.iter().map(|&x| fd_step(x, wu, CBRT_EPS)).collect();
        let h1v: Vec<f64> = v.iter().map(|&x| fd_step(x, wv, CBRT_EPS)).collect();
        let h2u: Vec<f64> = u.iter().map(|&x| fd_step(x, wu, QRT_EPS)).collect();
        let h2v: Vec<f64> = v.iter().map(|&x| fd_step(x, wv, QRT_EPS)).collect();
        if self.has_jac {
            let (pu, pv) = self.jac_py(py, u, v)?;
            for i in 0..n {
                out[i].pu = pu[i];
                out[i].pv = pv[i];
            }
            if second {
                // Differences of the Jacobian: Puu, Pvv, and Puv as the mean
                // of d(Pu)/dv and d(Pv)/du.
                let uu = concat(&[&shift(u, &h2u, 1.0), &shift(u, &h2u, -1.0), u, u]);
                let vv = concat(&[v, v, &shift(v, &h2v, 1.0), &shift(v, &h2v, -1.0)]);
                let (ju, jv) = self.jac_py(py, &uu, &vv)?;
                for i in 0..n {
                    let du = 2.0 * h2u[i];
                    let dv = 2.0 * h2v[i];
                    out[i].puu = (ju[i] - ju[n + i]) / du;
                    out[i].pvv = (jv[2 * n + i] - jv[3 * n + i]) / dv;
                    out[i].puv =
                        0.5 * ((jv[i] - jv[n + i]) / du + (ju[2 * n + i] - ju[3 * n + i]) / dv);
                }
            }
            return Ok(());
        }
        // Neighbours: (u±h1, v), (u, v±h1) for the first derivatives; with
        // `second`, (u±h2, v), (u, v±h2) and the four corners (u±h2, v±h2).
        let mut uu = vec![
            shift(u, &h1u, 1.0),
            shift(u, &h1u, -1.0),
            u.to_vec(),
            u.to_vec(),
        ];
        let mut vv = vec![
            v.to_vec(),
            v.to_vec(),
            shift(v, &h1v, 1.0),
            shift(v, &h1v, -1.0),
        ];
        if second {
            let (up, um) = (shift(u, &h2u, 1.0), shift(u, &h2u, -1.0));
            let (vp, vm) = (shift(v, &h2v, 1.0), shift(v, &h2v, -1.0));
            uu.extend([up.clone(), um.clone(), u.to_vec(), u.to_vec()]);
            vv.extend([v.to_vec(), v.to_vec(), vp.clone(), vm.clone()]);
            uu.extend([up.clone(), up, um.clone(), um]);
            vv.extend([vp.clone(), vm.clone(), vp, vm]);
        }
        let uu: Vec<f64> = uu.concat();
        let vv: Vec<f64> = vv.concat();
        let q = xyz(py, &self.c, &uu, &vv)?;
        let at = |k: usize, i: usize| q[k * n + i];
        for i in 0..n {
            let o = &mut out[i];
            o.pu = (at(0, i) - at(1, i)) / (2.0 * h1u[i]);
            o.pv = (at(2, i) - at(3, i)) / (2.0 * h1v[i]);
            if second {
                let (hu, hv) = (h2u[i], h2v[i]);
                o.puu = (at(4, i) - 2.0 * p[i] + at(5, i)) / (hu * hu);
                o.pvv = (at(6, i) - 2.0 * p[i] + at(7, i)) / (hv * hv);
                o.puv = (at(8, i) - at(9, i) - at(10, i) + at(11, i)) / (4.0 * hu * hv);
            }
        }
        Ok(())
    }

    fn run(&self, u: &[f64], v: &[f64], out: &mut [ParamSample], second: bool) {
        let nan = DVec3::splat(f64::NAN);
        let hole = ParamSample {
            p: nan,
            pu: nan,
            pv: nan,
            puu: nan,
            puv: nan,
            pvv: nan,
        };
        if u.is_empty() {
            return;
        }
        if self.c.failed() {
            out.iter_mut().for_each(|o| *o = hole);
            return;
        }
        Python::attach(|py| {
            if let Err(e) = self.eval_py(py, u, v, out, second) {
                out.iter_mut().for_each(|o| *o = hole);
                self.c.record(e);
            }
        })
    }
}

impl ParametricSurface for CallableParametric {
    fn domain(&self) -> Domain {
        self.domain
    }
    fn eval_batch(&self, u: &[f64], v: &[f64], out: &mut [ParamSample]) {
        self.run(u, v, out, true)
    }
    fn eval_first_batch(&self, u: &[f64], v: &[f64], out: &mut [ParamSample]) {
        self.run(u, v, out, false)
    }
    fn eval_point_batch(&self, u: &[f64], v: &[f64], out: &mut [DVec3]) {
        if u.is_empty() {
            return;
        }
        if self.c.failed() {
            out.fill(DVec3::splat(f64::NAN));
            return;
        }
        Python::attach(|py| match xyz(py, &self.c, u, v) {
            Ok(p) => out.copy_from_slice(&p),
            Err(e) => {
                out.fill(DVec3::splat(f64::NAN));
                self.c.record(e);
            }
        })
    }
    fn cheap_point_eval(&self) -> bool {
        false
    }
}

fn check_callable(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<()> {
    if obj.is_callable() {
        Ok(())
    } else {
        Err(PyTypeError::new_err(format!(
            "{name}: expected an expression string or a callable, got {}",
            type_name(obj)
        )))
    }
}

/// Probe points: the corners and the centre of the domain.
fn probe_points(d: &Domain) -> (Vec<f64>, Vec<f64>) {
    let (um, vm) = (0.5 * (d.u0 + d.u1), 0.5 * (d.v0 + d.v1));
    (
        vec![d.u0, d.u1, um, d.u0, d.u1],
        vec![d.v0, d.v0, vm, d.v1, d.v1],
    )
}

// ---------------------------------------------------------------------------
// what fcol.Function and fcol.Parametric share

/// An expression source bound to parameter values.
trait ExprSource: Sized {
    /// (name, value) of every parameter, `t` first.
    fn named_values(&self) -> Vec<(String, f64)>;
    /// The same compiled expression(s) with some values changed.
    fn rebound(&self, changes: &[(String, f64)]) -> crate::error::Result<Self>;
}

impl ExprSource for ExprHeight {
    fn named_values(&self) -> Vec<(String, f64)> {
        self.params()
    }
    fn rebound(&self, changes: &[(String, f64)]) -> crate::error::Result<Self> {
        self.with_values(changes)
    }
}

impl ExprSource for ExprParametric {
    fn named_values(&self) -> Vec<(String, f64)> {
        self.params()
    }
    fn rebound(&self, changes: &[(String, f64)]) -> crate::error::Result<Self> {
        self.with_values(changes)
    }
}

/// A source calling Python: its callables, and the same source around
/// other ones.
trait CallSource {
    fn callables(&self) -> &PyCallables;
    fn with_callables(&self, c: PyCallables) -> Self;
}

impl CallSource for CallableHeight {
    fn callables(&self) -> &PyCallables {
        &self.c
    }
    fn with_callables(&self, c: PyCallables) -> Self {
        CallableHeight {
            c,
            has_grad: self.has_grad,
            domain: self.domain,
        }
    }
}

impl CallSource for CallableParametric {
    fn callables(&self) -> &PyCallables {
        &self.c
    }
    fn with_callables(&self, c: PyCallables) -> Self {
        CallableParametric {
            c,
            has_jac: self.has_jac,
            domain: self.domain,
        }
    }
}

/// A surface from expressions or from Python callables.
enum Kind<E, C> {
    Expr(Arc<E>),
    Call(Arc<C>),
}

impl<E: ExprSource, C: CallSource> Kind<E, C> {
    /// The Python callables, None for expressions.
    fn callables(&self) -> Option<&PyCallables> {
        match self {
            Kind::Expr(_) => None,
            Kind::Call(c) => Some(c.callables()),
        }
    }

    /// `with_params(**kwargs)`: expressions are rebound without re-parsing.
    fn with_params(&self, py: Python<'_>, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let changes = kwargs_params(kwargs)?;
        Ok(match self {
            Kind::Expr(e) => Kind::Expr(Arc::new(e.rebound(&changes)?)),
            Kind::Call(s) => {
                let c = s.callables();
                let (t, params) = changed_callable(c, changes)?;
                Kind::Call(Arc::new(s.with_callables(c.clone_with(py, t, params))))
            }
        })
    }

    /// The `params` property: named parameters and values, without `t`.
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let list = match self {
            Kind::Expr(e) => e.named_values()[1..].to_vec(),
            Kind::Call(s) => s.callables().params.clone(),
        };
        for (n, x) in list {
            d.set_item(n, x)?;
        }
        Ok(d)
    }

    /// The `t` property.
    fn t(&self) -> Option<f64> {
        match self {
            Kind::Expr(e) => Some(e.named_values()[0].1),
            Kind::Call(s) => s.callables().t,
        }
    }

    /// The `calls` property (0 for expressions).
    fn calls(&self) -> usize {
        self.callables()
            .map_or(0, |c| c.calls.load(Ordering::Relaxed))
    }
}

/// The `domain` property: ((u0, u1), (v0, v1)).
fn domain_pair(d: Domain) -> ((f64, f64), (f64, f64)) {
    ((d.u0, d.u1), (d.v0, d.v1))
}

/// `domain=((u0, u1), (v0, v1))` in a repr.
fn domain_repr(d: Domain) -> String {
    format!("domain=(({}, {}), ({}, {}))", d.u0, d.u1, d.v0, d.v1)
}

// ---------------------------------------------------------------------------
// fcol.Function

type FnKind = Kind<ExprHeight, CallableHeight>;

/// A function surface w = f(u, v) over `domain=((u0, u1), (v0, v1))`.
///
/// ``f`` is an expression string in u, v, t and the names of ``params``,
/// compiled once with exact derivatives, or a NumPy-vectorised callable
/// ``f(u, v[, t], **params)`` called on whole batches, with an optional
/// ``grad(u, v[, t], **params) -> (f_u, f_v)`` (central differences with
/// step h = max(cbrt(eps)·(u1 − u0), 64·eps·|u|) otherwise, likewise in v;
/// the value and the four neighbours in one call). A callable is probed
/// once at construction, on the domain's corners and centre, so that a
/// wrong signature or result shape fails there rather than mid-render.
/// ``with_params`` rebinds parameters (and ``t``) without re-parsing. Calling
/// the Function (``f(u, v)``, ``f.gradient(u, v)``) evaluates anywhere; the
/// domain bounds the surface the renderers draw. Derivatives at kinks:
/// ``abs'(x) = sign(x)``, ``min``/``max`` follow the selected argument (the
/// first on ties), ``floor``/``ceil``/``sign`` have derivative 0. NaN and
/// ±inf are returned as they are; renderers draw them as holes.
///
/// >>> import fcol, numpy as np
/// >>> f = fcol.Function("a*sin(u)*v", domain=((0, 3), (0, 1)), params={"a": 2.0})
/// >>> float(f(np.pi / 2, 0.5))
/// 1.0
/// >>> [float(x) for x in f.gradient(0.0, 0.5)]
/// [1.0, 0.0]
/// >>> float(f.with_params(a=4.0)(np.pi / 2, 0.5))
/// 2.0
#[pyclass(name = "Function", module = "fcol._fcol", frozen)]
pub struct PyFunction {
    kind: FnKind,
}

impl PyFunction {
    fn dyn_field(&self) -> DynHeight {
        match &self.kind {
            FnKind::Expr(h) => h.clone(),
            FnKind::Call(h) => h.clone(),
        }
    }
}

#[pymethods]
impl PyFunction {
    #[new]
    #[pyo3(signature = (f, grad = None, domain = None, params = None, *, t = None))]
    fn new(
        py: Python<'_>,
        f: &Bound<'_, PyAny>,
        grad: Option<&Bound<'_, PyAny>>,
        domain: Option<&Bound<'_, PyAny>>,
        params: Option<&Bound<'_, PyAny>>,
        t: Option<f64>,
    ) -> PyResult<Self> {
        let domain = extract_domain(domain)?;
        let params = extract_params(params)?;
        let grad = grad.filter(|g| !g.is_none());
        if let Ok(src) = f.extract::<String>() {
            if grad.is_some() {
                return Err(FcolError::value(
                    "grad",
                    "an expression is differentiated exactly; grad is only for callables",
                )
                .into());
            }
            let h = ExprHeight::new(&src, &params, t.unwrap_or(0.0), domain)?;
            return Ok(PyFunction {
                kind: FnKind::Expr(Arc::new(h)),
            });
        }
        check_callable(f, "f")?;
        let mut funcs = vec![f.clone().unbind()];
        if let Some(g) = grad {
            if !g.is_callable() {
                return Err(PyTypeError::new_err(format!(
                    "grad: expected a callable returning (f_u, f_v), got {}",
                    type_name(g)
                )));
            }
            funcs.push(g.clone().unbind());
        }
        let h = CallableHeight {
            c: PyCallables::new(funcs, t, params)?,
            has_grad: grad.is_some(),
            domain,
        };
        // Probe once so that a wrong signature or shape fails here, not in
        // the middle of a render.
        let (pu, pv) = probe_points(&domain);
        let mut tmp = vec![HeightSample::default(); pu.len()];
        h.eval_py(py, &pu, &pv, &mut tmp)?;
        h.c.calls.store(0, Ordering::Relaxed);
        Ok(PyFunction {
            kind: FnKind::Call(Arc::new(h)),
        })
    }

    /// f(u, v) on arrays (broadcast together), as float64.
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (shape, u, v) = broadcast_uv(py, u, v)?;
        let w = match &self.kind {
            FnKind::Expr(h) => run::detached(py, || {
                let mut w = vec![0.0; u.len()];
                h.eval_value_batch(&u, &v, &mut w);
                Ok(w)
            })?,
            FnKind::Call(h) => {
                if u.is_empty() {
                    Vec::new()
                } else {
                    h.values_py(py, &u, &v)?
                }
            }
        };
        shaped(py, &shape, w)
    }

    /// (f_u, f_v) on arrays (broadcast together), as float64.
    fn gradient<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (shape, u, v) = broadcast_uv(py, u, v)?;
        let mut s = vec![HeightSample::default(); u.len()];
        match &self.kind {
            FnKind::Expr(h) => run::detached(py, || {
                h.eval_batch(&u, &v, &mut s);
                Ok(())
            })?,
            FnKind::Call(h) => {
                if !u.is_empty() {
                    h.eval_py(py, &u, &v, &mut s)?
                }
            }
        }
        let fu = s.iter().map(|x| x.fu).collect();
        let fv = s.iter().map(|x| x.fv).collect();
        Ok((shaped(py, &shape, fu)?, shaped(py, &shape, fv)?))
    }

    /// A new Function with some parameters (or ``t``) changed, sharing the
    /// compiled expression (no re-parsing). Unknown names are ValueErrors.
    #[pyo3(signature = (**kwargs))]
    fn with_params(&self, py: Python<'_>, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        Ok(PyFunction {
            kind: self.kind.with_params(py, kwargs)?,
        })
    }

    /// ((u0, u1), (v0, v1)).
    #[getter]
    fn domain(&self) -> ((f64, f64), (f64, f64)) {
        domain_pair(self.dyn_field().domain())
    }

    /// (lo, hi) bounding every finite value of f over the domain, by
    /// interval arithmetic on the expression (possibly loose, never too
    /// narrow); None for a callable or where no finite bound follows.
    ///
    /// >>> import fcol
    /// >>> lo, hi = fcol.Function("3*sin(u*cos(v))", domain=((-5, 5), (-5, 5))).height_bound
    /// >>> round(lo, 9), round(hi, 9)
    /// (-3.0, 3.0)
    #[getter]
    fn height_bound(&self) -> Option<(f64, f64)> {
        self.dyn_field().height_bound()
    }

    /// The expression string, or None for a callable.
    #[getter]
    fn expr(&self) -> Option<String> {
        match &self.kind {
            FnKind::Expr(h) => Some(h.expr().to_string()),
            FnKind::Call(_) => None,
        }
    }

    /// The named parameters and their values (without ``t``).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.kind.params(py)
    }

    /// The time t (None for a callable not given t).
    #[getter]
    fn t(&self) -> Option<f64> {
        self.kind.t()
    }

    /// Number of Python calls made so far (0 for an expression).
    #[getter]
    fn calls(&self) -> usize {
        self.kind.calls()
    }

    fn __repr__(&self) -> String {
        let d = self.dyn_field().domain();
        match &self.kind {
            FnKind::Expr(h) => {
                let ps: Vec<String> = h.params()[1..]
                    .iter()
                    .map(|(n, x)| format!("{n:?}: {x}"))
                    .collect();
                format!(
                    "Function({:?}, {}, params={{{}}})",
                    h.expr(),
                    domain_repr(d),
                    ps.join(", ")
                )
            }
            FnKind::Call(_) => format!("Function(<callable>, {})", domain_repr(d)),
        }
    }
}

/// New (t, params) of a callable source after `changes`; names must be
/// among its parameters or `t` (only when it was given `t`).
type TimeAndParams = (Option<f64>, Vec<(String, f64)>);

fn changed_callable(c: &PyCallables, changes: Vec<(String, f64)>) -> PyResult<TimeAndParams> {
    let mut t = c.t;
    let mut params = c.params.clone();
    for (name, x) in changes {
        crate::error::finite(&name, x)?;
        if name == "t" && t.is_some() {
            t = Some(x);
        } else if let Some(p) = params.iter_mut().find(|(n, _)| *n == name) {
            p.1 = x;
        } else {
            let known: Vec<&String> = c.params.iter().map(|(n, _)| n).collect();
            return Err(FcolError::value(
                "params",
                format!(
                    "unknown parameter {name:?} (the parameters are {known:?}{})",
                    if c.t.is_some() { " and t" } else { "" }
                ),
            )
            .into());
        }
    }
    Ok((t, params))
}

// ---------------------------------------------------------------------------
// fcol.HeightGrid

/// A height grid: ``z[i, j]`` is the height at ``(u0 + j·du, v0 + i·dv)``
/// (rows along v, row 0 at v0; SPEC §1), interpolated ``"bilinear"`` or
/// ``"bicubic"`` (Keys' cubic convolution, a = −0.5, i.e. Catmull-Rom), with
/// derivatives of the interpolant itself.
///
/// Place it with ``extent=(u0, u1, v0, v1)`` (the first and last sample
/// positions; ``v0 > v1`` for a north-up raster whose row 0 is north) or
/// with ``spacing=(du, dv)`` and ``origin=(u0, v0)`` (default (0, 0); a
/// negative spacing flips the axis). ``z`` may have any integer or float
/// dtype and any strides; NaN (or ±inf) is no data: a bilinear cell touching
/// one is a hole, and a bicubic cell is a hole when any of the 16 samples
/// of its kernel is. A single row or column is constant across its extent
/// (or one spacing). Outside the grid the surface does not exist (NaN).
///
/// >>> import fcol, numpy as np
/// >>> g = fcol.HeightGrid(np.array([[0, 1], [2, 3]], np.int16), extent=(0, 1, 0, 1))
/// >>> float(g(0.5, 0.5)), [float(x) for x in g.gradient(0.25, 0.5)]
/// (1.5, [1.0, 2.0])
#[pyclass(name = "HeightGrid", module = "fcol._fcol", frozen)]
pub struct PyHeightGrid {
    grid: Arc<HeightGrid>,
}

#[pymethods]
impl PyHeightGrid {
    #[new]
    #[pyo3(signature = (z, extent = None, *, spacing = None, origin = None, interpolation = "bilinear"))]
    fn new(
        py: Python<'_>,
        z: &Bound<'_, PyAny>,
        extent: Option<&Bound<'_, PyAny>>,
        spacing: Option<&Bound<'_, PyAny>>,
        origin: Option<&Bound<'_, PyAny>>,
        interpolation: &str,
    ) -> PyResult<Self> {
        let interp = Interpolation::parse(interpolation)?;
        let np = py.import("numpy")?;
        let a = np.call_method1("asarray", (z,)).map_err(|e| {
            PyTypeError::new_err(format!(
                "z: expected a 2-D array of real numbers ({})",
                e.value(py)
            ))
        })?;
        let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
        if !matches!(kind.as_str(), "i" | "u" | "f") {
            let dt = a.getattr("dtype")?.str()?.to_string();
            return Err(PyTypeError::new_err(format!(
                "z: expected real heights (an integer or float dtype), got dtype {dt}"
            )));
        }
        let ndim: usize = a.getattr("ndim")?.extract()?;
        if ndim != 2 {
            let shape = a.getattr("shape")?.repr()?.to_string();
            return Err(FcolError::value(
                "z",
                format!("must be 2-D (rows along v, columns along u), got shape {shape}"),
            )
            .into());
        }
        let a = a.call_method1("astype", ("float64",))?;
        let arr: PyReadonlyArrayDyn<'_, f64> = a.extract()?;
        let (ny, nx) = (arr.shape()[0], arr.shape()[1]);
        if nx == 0 || ny == 0 {
            return Err(FcolError::value(
                "z",
                format!("must have at least one row and one column, got shape ({ny}, {nx})"),
            )
            .into());
        }
        let data: Vec<f64> = arr.as_array().iter().copied().collect();
        let pair = |o: &Bound<'_, PyAny>, name: &str| -> PyResult<(f64, f64)> {
            let v = numbers(o, 2, name, "two numbers")?;
            Ok((v[0], v[1]))
        };
        let extent = extent.filter(|e| !e.is_none());
        let spacing = spacing.filter(|e| !e.is_none());
        let origin = origin.filter(|e| !e.is_none());
        let (u0, du, v0, dv) = match (extent, spacing) {
            (Some(e), None) => {
                if origin.is_some() {
                    return Err(FcolError::value(
                        "origin",
                        "origin goes with spacing=; extent= already places the grid",
                    )
                    .into());
                }
                let x = numbers(e, 4, "extent", "(u0, u1, v0, v1)")?;
                let (u0, u1, v0, v1) = (x[0], x[1], x[2], x[3]);
                for (n, x) in [("u0", u0), ("u1", u1), ("v0", v0), ("v1", v1)] {
                    if !x.is_finite() {
                        return Err(FcolError::value("extent", format!("{n} must be finite, got {x}")).into());
                    }
                }
                if u0 == u1 || v0 == v1 {
                    return Err(FcolError::value(
                        "extent",
                        format!("u0 != u1 and v0 != v1 required, got ({u0}, {u1}, {v0}, {v1})"),
                    )
                    .into());
                }
                let step = |a: f64, b: f64, n: usize| if n > 1 { (b - a) / (n - 1) as f64 } else { b - a };
                (u0, step(u0, u1, nx), v0, step(v0, v1, ny))
            }
            (None, Some(s)) => {
                let (du, dv) = pair(s, "spacing")?;
                let (u0, v0) = match origin {
                    Some(o) => pair(o, "origin")?,
                    None => (0.0, 0.0),
                };
                (u0, du, v0, dv)
            }
            (Some(_), Some(_)) => {
                return Err(FcolError::value("extent", "give extent= or spacing=, not both").into())
            }
            (None, None) => {
                return Err(FcolError::value(
                    "extent",
                    "place the grid with extent=(u0, u1, v0, v1) or spacing=(du, dv) [+ origin=(u0, v0)]",
                )
                .into())
            }
        };
        let grid = HeightGrid::new(data, ny, nx, u0, du, v0, dv, interp)?;
        Ok(PyHeightGrid {
            grid: Arc::new(grid),
        })
    }

    /// Interpolated heights at (u, v) (broadcast together), NaN in holes and
    /// outside the grid.
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (shape, u, v) = broadcast_uv(py, u, v)?;
        let g = &self.grid;
        let w = run::detached(py, || {
            let mut w = vec![0.0; u.len()];
            g.eval_value_batch(&u, &v, &mut w);
            Ok(w)
        })?;
        shaped(py, &shape, w)
    }

    /// (f_u, f_v) of the interpolant at (u, v).
    fn gradient<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (shape, u, v) = broadcast_uv(py, u, v)?;
        let g = &self.grid;
        let s = run::detached(py, || {
            let mut s = vec![HeightSample::default(); u.len()];
            g.eval_batch(&u, &v, &mut s);
            Ok(s)
        })?;
        let fu = s.iter().map(|x| x.fu).collect();
        let fv = s.iter().map(|x| x.fv).collect();
        Ok((shaped(py, &shape, fu)?, shaped(py, &shape, fv)?))
    }

    /// The shape of z (rows, columns).
    #[getter]
    fn shape(&self) -> (usize, usize) {
        self.grid.shape()
    }

    /// (u0, u1, v0, v1): the positions of the first and last samples (for
    /// a single row or column, the span it covers).
    #[getter]
    fn extent(&self) -> (f64, f64, f64, f64) {
        let (u0, du, v0, dv) = self.grid.geometry();
        let (ny, nx) = self.grid.shape();
        let last = |n: usize| n.max(2) as f64 - 1.0;
        (u0, u0 + last(nx) * du, v0, v0 + last(ny) * dv)
    }

    /// (du, dv), signed.
    #[getter]
    fn spacing(&self) -> (f64, f64) {
        let (_, du, _, dv) = self.grid.geometry();
        (du, dv)
    }

    #[getter]
    fn interpolation(&self) -> &'static str {
        self.grid.interpolation().name()
    }

    /// ((u_min, u_max), (v_min, v_max)).
    #[getter]
    fn domain(&self) -> ((f64, f64), (f64, f64)) {
        let d = self.grid.domain();
        ((d.u0, d.u1), (d.v0, d.v1))
    }

    /// (lo, hi) bounding the interpolant: the finite samples' range
    /// (bilinear), widened for bicubic's overshoot (Keys' weights: by up to
    /// 0.28 of the range on each side); None when no sample is finite.
    #[getter]
    fn height_bound(&self) -> Option<(f64, f64)> {
        self.grid.height_bound()
    }

    fn __repr__(&self) -> String {
        let (ny, nx) = self.grid.shape();
        let (u0, u1, v0, v1) = self.extent();
        format!(
            "HeightGrid(<{ny}×{nx}>, extent=({u0}, {u1}, {v0}, {v1}), interpolation={:?})",
            self.grid.interpolation().name()
        )
    }
}

// ---------------------------------------------------------------------------
// fcol.Parametric

type ParKind = Kind<ExprParametric, CallableParametric>;

/// A parametric surface (X, Y, Z)(u, v) over ``domain=((u0, u1), (v0, v1))``.
///
/// ``x``, ``y``, ``z`` are three expression strings sharing ``params``
/// (exact first and second derivatives), or three vectorised callables
/// ``f(u, v[, t], **params)`` with an optional ``jac(u, v) -> (Pu, Pv)``
/// (each (n, 3)); derivatives are then central differences (first:
/// step cbrt(eps)·width; second: step eps^(1/4)·width, of ``jac`` when
/// given).
///
/// >>> import fcol
/// >>> s = fcol.Parametric("cos(u)*cos(v)", "sin(u)*cos(v)", "sin(v)",
/// ...                     domain=((0, 6.283185307179586), (-1.5, 1.5)))
/// >>> [round(float(c), 12) for c in s(0.0, 0.0)]
/// [1.0, 0.0, 0.0]
/// >>> pu, pv = s.jacobian(0.0, 0.0)
/// >>> (pu + 0.0).tolist(), (pv + 0.0).tolist()  # + 0.0 folds -0.0 into 0.0
/// ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
#[pyclass(name = "Parametric", module = "fcol._fcol", frozen)]
pub struct PyParametric {
    kind: ParKind,
}

impl PyParametric {
    fn dyn_surface(&self) -> DynParam {
        match &self.kind {
            ParKind::Expr(s) => s.clone(),
            ParKind::Call(s) => s.clone(),
        }
    }

    fn samples(
        &self,
        py: Python<'_>,
        u: &[f64],
        v: &[f64],
        second: bool,
    ) -> PyResult<Vec<ParamSample>> {
        let mut out = vec![ParamSample::default(); u.len()];
        match &self.kind {
            ParKind::Expr(s) => run::detached(py, || {
                if second {
                    s.eval_batch(u, v, &mut out)
                } else {
                    s.eval_first_batch(u, v, &mut out)
                }
                Ok(())
            })?,
            ParKind::Call(s) => {
                if !u.is_empty() {
                    s.eval_py(py, u, v, &mut out, second)?
                }
            }
        }
        Ok(out)
    }
}

#[pymethods]
impl PyParametric {
    #[new]
    #[pyo3(signature = (x, y, z, domain = None, params = None, *, jac = None, t = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        x: &Bound<'_, PyAny>,
        y: &Bound<'_, PyAny>,
        z: &Bound<'_, PyAny>,
        domain: Option<&Bound<'_, PyAny>>,
        params: Option<&Bound<'_, PyAny>>,
        jac: Option<&Bound<'_, PyAny>>,
        t: Option<f64>,
    ) -> PyResult<Self> {
        let domain = extract_domain(domain)?;
        let params = extract_params(params)?;
        let jac = jac.filter(|j| !j.is_none());
        let strs: Vec<Option<String>> = [x, y, z].iter().map(|o| o.extract().ok()).collect();
        if strs.iter().all(|s| s.is_some()) {
            if jac.is_some() {
                return Err(FcolError::value(
                    "jac",
                    "expressions are differentiated exactly; jac is only for callables",
                )
                .into());
            }
            let s: Vec<String> = strs.into_iter().flatten().collect();
            let p = ExprParametric::new(
                [s[0].as_str(), s[1].as_str(), s[2].as_str()],
                &params,
                t.unwrap_or(0.0),
                domain,
            )
            .map_err(|e| match e {
                FcolError::Expression { expr, col, msg } => {
                    let which = ["x", "y", "z"][s.iter().position(|q| *q == expr).unwrap_or(0)];
                    FcolError::Expression {
                        expr,
                        col,
                        msg: format!("{which}: {msg}"),
                    }
                }
                e => e,
            })?;
            return Ok(PyParametric {
                kind: ParKind::Expr(Arc::new(p)),
            });
        }
        for (o, name) in [(x, "x"), (y, "y"), (z, "z")] {
            if strs.iter().any(|s| s.is_some()) && o.extract::<String>().is_err() {
                return Err(PyTypeError::new_err(format!(
                    "{name}: x, y and z must be all expression strings or all callables, got {}",
                    type_name(o)
                )));
            }
            check_callable(o, name)?;
        }
        let mut funcs = vec![x.clone().unbind(), y.clone().unbind(), z.clone().unbind()];
        if let Some(j) = jac {
            if !j.is_callable() {
                return Err(PyTypeError::new_err(format!(
                    "jac: expected a callable returning (Pu, Pv), got {}",
                    type_name(j)
                )));
            }
            funcs.push(j.clone().unbind());
        }
        let s = CallableParametric {
            c: PyCallables::new(funcs, t, params)?,
            has_jac: jac.is_some(),
            domain,
        };
        let (pu, pv) = probe_points(&domain);
        let mut tmp = vec![ParamSample::default(); pu.len()];
        s.eval_py(py, &pu, &pv, &mut tmp, false)?;
        s.c.calls.store(0, Ordering::Relaxed);
        Ok(PyParametric {
            kind: ParKind::Call(Arc::new(s)),
        })
    }

    /// (X, Y, Z) on arrays (broadcast together), as float64.
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (shape, u, v) = broadcast_uv(py, u, v)?;
        let mut p = vec![DVec3::ZERO; u.len()];
        match &self.kind {
            ParKind::Expr(s) => run::detached(py, || {
                s.eval_point_batch(&u, &v, &mut p);
                Ok(())
            })?,
            ParKind::Call(s) => {
                if !u.is_empty() {
                    p = xyz(py, &s.c, &u, &v)?
                }
            }
        }
        let comp = |k: usize| p.iter().map(|q| q[k]).collect::<Vec<f64>>();
        Ok((
            shaped(py, &shape, comp(0))?,
            shaped(py, &shape, comp(1))?,
            shaped(py, &shape, comp(2))?,
        ))
    }

    /// (Pu, Pv), each of shape (..., 3).
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (shape, u, v) = broadcast_uv(py, u, v)?;
        let s = self.samples(py, &u, &v, false)?;
        let pu: Vec<DVec3> = s.iter().map(|x| x.pu).collect();
        let pv: Vec<DVec3> = s.iter().map(|x| x.pv).collect();
        Ok((shaped3(py, &shape, &pu)?, shaped3(py, &shape, &pv)?))
    }

    /// (Puu, Puv, Pvv), each of shape (..., 3).
    fn hessian<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (shape, u, v) = broadcast_uv(py, u, v)?;
        let s = self.samples(py, &u, &v, true)?;
        let g = |f: fn(&ParamSample) -> DVec3| s.iter().map(f).collect::<Vec<DVec3>>();
        Ok((
            shaped3(py, &shape, &g(|x| x.puu))?,
            shaped3(py, &shape, &g(|x| x.puv))?,
            shaped3(py, &shape, &g(|x| x.pvv))?,
        ))
    }

    /// A new Parametric with some parameters (or ``t``) changed, sharing
    /// the compiled expressions.
    #[pyo3(signature = (**kwargs))]
    fn with_params(&self, py: Python<'_>, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        Ok(PyParametric {
            kind: self.kind.with_params(py, kwargs)?,
        })
    }

    #[getter]
    fn domain(&self) -> ((f64, f64), (f64, f64)) {
        domain_pair(self.dyn_surface().domain())
    }

    /// The three expression strings, or None for callables.
    #[getter]
    fn exprs(&self) -> Option<(String, String, String)> {
        match &self.kind {
            ParKind::Expr(s) => {
                let e = s.exprs();
                Some((e[0].clone(), e[1].clone(), e[2].clone()))
            }
            ParKind::Call(_) => None,
        }
    }

    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.kind.params(py)
    }

    /// The time t (None for callables not given t).
    #[getter]
    fn t(&self) -> Option<f64> {
        self.kind.t()
    }

    /// Number of Python calls made so far (0 for expressions).
    #[getter]
    fn calls(&self) -> usize {
        self.kind.calls()
    }

    fn __repr__(&self) -> String {
        let d = self.dyn_surface().domain();
        let dom = domain_repr(d);
        match &self.kind {
            ParKind::Expr(s) => {
                let e = s.exprs();
                format!("Parametric({:?}, {:?}, {:?}, {dom})", e[0], e[1], e[2])
            }
            ParKind::Call(_) => format!("Parametric(<callables>, {dom})"),
        }
    }
}

// ---------------------------------------------------------------------------
// conversions for the renderers

/// The height field behind `surface` (`fcol.Function` or `fcol.HeightGrid`).
pub fn height_field_from_py(obj: &Bound<'_, PyAny>) -> PyResult<DynHeight> {
    if let Ok(f) = obj.cast::<PyFunction>() {
        return Ok(f.get().dyn_field());
    }
    if let Ok(g) = obj.cast::<PyHeightGrid>() {
        return Ok(g.get().grid.clone());
    }
    Err(PyTypeError::new_err(format!(
        "surface: expected fcol.Function or fcol.HeightGrid, got {}",
        type_name(obj)
    )))
}

/// The parametric surface behind `surface` (`fcol.Parametric`).
#[allow(dead_code)] // used by the renderers' bindings
pub fn parametric_from_py(obj: &Bound<'_, PyAny>) -> PyResult<DynParam> {
    if let Ok(p) = obj.cast::<PyParametric>() {
        return Ok(p.get().dyn_surface());
    }
    Err(PyTypeError::new_err(format!(
        "surface: expected fcol.Parametric, got {}",
        type_name(obj)
    )))
}

/// The Python callables behind `surface`, if it is a callable
/// `fcol.Function` or `fcol.Parametric`.
fn callables_of<'a>(obj: &'a Bound<'_, PyAny>) -> Option<&'a PyCallables> {
    if let Ok(f) = obj.cast::<PyFunction>() {
        f.get().kind.callables()
    } else if let Ok(p) = obj.cast::<PyParametric>() {
        p.get().kind.callables()
    } else {
        None
    }
}

/// Make the Python callables behind `surface` (if any) stop calling back
/// into Python until the render ends: called on Ctrl-C, so that a slow
/// callable does not delay the core's next cancellation check.
/// [`check_surface_errors`] clears it.
pub fn abort_callables(obj: &Bound<'_, PyAny>) {
    if let Some(c) = callables_of(obj) {
        c.abort();
    }
}

/// Re-raise the first exception a Python callable behind `surface` raised
/// during a render (the render turned those batches into holes). A no-op
/// for expressions and grids. Renderers call it after the core returns.
pub fn check_surface_errors(obj: &Bound<'_, PyAny>) -> PyResult<()> {
    match callables_of(obj).and_then(PyCallables::take_error) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Test hook: evaluate any height surface through the renderers' path —
/// [`height_field_from_py`], then `eval_batch` in chunks of `chunk` points
/// on rayon worker threads with the GIL released — returning (f, f_u, f_v)
/// as 1-D arrays, and re-raising a callable's error as a render would.
#[pyfunction]
#[pyo3(signature = (surface, u, v, chunk = 256))]
fn _eval_height<'py>(
    py: Python<'py>,
    surface: &Bound<'py, PyAny>,
    u: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
    chunk: usize,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    use rayon::prelude::*;
    let h = height_field_from_py(surface)?;
    let (_, u, v) = broadcast_uv(py, u, v)?;
    let chunk = chunk.max(1);
    let s = run::cancellable(py, |cancel| {
        let mut s = vec![HeightSample::default(); u.len()];
        s.par_chunks_mut(chunk)
            .zip(u.par_chunks(chunk).zip(v.par_chunks(chunk)))
            .for_each(|(o, (u, v))| {
                if !cancel.is_cancelled() {
                    h.eval_batch(u, v, o)
                }
            });
        cancel.check()?;
        Ok(s)
    })?;
    check_surface_errors(surface)?;
    let n = [s.len()];
    Ok((
        shaped(py, &n, s.iter().map(|x| x.f).collect())?,
        shaped(py, &n, s.iter().map(|x| x.fu).collect())?,
        shaped(py, &n, s.iter().map(|x| x.fv).collect())?,
    ))
}

/// Median nanoseconds per point (of `n`) of `run` over `repeat` timed runs
/// after one warm-up run.
fn median_ns_per_point(repeat: usize, n: usize, mut run: impl FnMut()) -> f64 {
    let mut times = Vec::new();
    for _ in 0..repeat.max(1) + 1 {
        let t0 = std::time::Instant::now();
        run();
        times.push(t0.elapsed().as_secs_f64() * 1e9 / n.max(1) as f64);
    }
    times.remove(0); // warm-up
    times.sort_by(|a, b| a.total_cmp(b));
    times[times.len() / 2]
}

/// Benchmark hook: median nanoseconds per point of evaluating a height
/// surface on one thread with the GIL released. `mode`: "batch" (f, f_u,
/// f_v by `eval_batch`), "point" (the same, one `eval` per point), "value"
/// (f alone, batched).
#[pyfunction]
#[pyo3(signature = (surface, u, v, mode = "batch", repeat = 7))]
fn _time_height(
    py: Python<'_>,
    surface: &Bound<'_, PyAny>,
    u: &Bound<'_, PyAny>,
    v: &Bound<'_, PyAny>,
    mode: &str,
    repeat: usize,
) -> PyResult<f64> {
    let h = height_field_from_py(surface)?;
    let (_, u, v) = broadcast_uv(py, u, v)?;
    if !matches!(mode, "batch" | "point" | "value") {
        return Err(FcolError::value("mode", "must be \"batch\", \"point\" or \"value\"").into());
    }
    run::detached(py, || {
        let mut s = vec![HeightSample::default(); u.len()];
        let mut w = vec![0.0; u.len()];
        Ok(median_ns_per_point(repeat, u.len(), || {
            match mode {
                "batch" => h.eval_batch(&u, &v, &mut s),
                "value" => h.eval_value_batch(&u, &v, &mut w),
                _ => {
                    for i in 0..u.len() {
                        s[i] = h.eval(u[i], v[i]);
                    }
                }
            }
            std::hint::black_box(&s);
            std::hint::black_box(&w);
        }))
    })
}

/// Benchmark hook: median nanoseconds per point of evaluating a parametric
/// surface on one thread with the GIL released. `mode`: "second" (P and
/// its first and second derivatives, batched), "first" (P, Pu, Pv,
/// batched), "point" (second order, one `eval` per point).
#[pyfunction]
#[pyo3(signature = (surface, u, v, mode = "second", repeat = 7))]
fn _time_parametric(
    py: Python<'_>,
    surface: &Bound<'_, PyAny>,
    u: &Bound<'_, PyAny>,
    v: &Bound<'_, PyAny>,
    mode: &str,
    repeat: usize,
) -> PyResult<f64> {
    let p = parametric_from_py(surface)?;
    let (_, u, v) = broadcast_uv(py, u, v)?;
    if !matches!(mode, "second" | "first" | "point") {
        return Err(FcolError::value("mode", "must be \"second\", \"first\" or \"point\"").into());
    }
    run::detached(py, || {
        let mut s = vec![ParamSample::default(); u.len()];
        Ok(median_ns_per_point(repeat, u.len(), || {
            match mode {
                "second" => p.eval_batch(&u, &v, &mut s),
                "first" => p.eval_first_batch(&u, &v, &mut s),
                _ => {
                    for i in 0..u.len() {
                        s[i] = p.eval(u[i], v[i]);
                    }
                }
            }
            std::hint::black_box(&s);
        }))
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_time_parametric, m)?)?;
    m.add_function(wrap_pyfunction!(_eval_height, m)?)?;
    m.add_function(wrap_pyfunction!(_time_height, m)?)?;
    m.add_class::<PyFunction>()?;
    m.add_class::<PyParametric>()?;
    m.add_class::<PyHeightGrid>()?;
    Ok(())
}
