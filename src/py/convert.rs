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

/// Keyword options of a render call, consumed key by key so that a misspelt
/// or unsupported option is an error naming it rather than silently ignored.
pub struct Options<'py> {
    dict: Bound<'py, PyDict>,
}

impl<'py> Options<'py> {
    /// Wrap a copy of `opts` (the caller's dict is never modified).
    pub fn new(opts: Option<&Bound<'py, PyDict>>, py: Python<'py>) -> PyResult<Self> {
        Ok(Options {
            dict: match opts {
                Some(d) => d.copy()?,
                None => PyDict::new(py),
            },
        })
    }

    /// Remove and convert option `key`; `None` when absent or `None`.
    pub fn take<T>(&self, key: &str) -> PyResult<Option<T>>
    where
        T: pyo3::conversion::FromPyObjectOwned<'py>,
    {
        let Some(v) = self.dict.get_item(key)? else {
            return Ok(None);
        };
        self.dict.del_item(key)?;
        if v.is_none() {
            return Ok(None);
        }
        v.extract::<T>().map(Some).map_err(|e| {
            let e: PyErr = e.into();
            pyo3::exceptions::PyTypeError::new_err(format!("{key}: {}", e.value(self.dict.py())))
        })
    }

    /// Error on any option nobody consumed.
    pub fn finish(self, what: &str) -> PyResult<()> {
        if self.dict.is_empty() {
            return Ok(());
        }
        let keys: Vec<String> = self.dict.keys().iter().map(|k| k.to_string()).collect();
        Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{what} got unexpected option(s) {keys:?}"
        )))
    }
}

/// Parse `outputs=` (a string or a sequence of buffer names).
pub fn parse_outputs(obj: &Bound<'_, PyAny>) -> PyResult<crate::image::Outputs> {
    let names: Vec<String> = if let Ok(s) = obj.extract::<String>() {
        vec![s]
    } else {
        obj.extract::<Vec<String>>().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(
                "outputs: expected a buffer name or a sequence of names such as (\"rgb\", \"depth\")",
            )
        })?
    };
    Ok(crate::image::Outputs::from_names(&names)?)
}

/// Consume the shading options shared by every renderer: `light` (None for
/// the headlight, or a direction (u, v, w) towards the light), `ambient`,
/// `diffuse`, `specular`, `shininess`, `upper_color`, `under_color`,
/// `background` (RGB 0–255).
pub fn take_shading(o: &Options<'_>) -> PyResult<crate::shade::Shading> {
    use crate::shade::{Light, Shading};
    let mut s = Shading::default();
    if let Some((x, y, z)) = o.take::<(f64, f64, f64)>("light")? {
        s.light = Light::Directional(glam::DVec3::new(x, y, z));
    }
    if let Some(v) = o.take("ambient")? {
        s.ambient = v;
    }
    if let Some(v) = o.take("diffuse")? {
        s.diffuse = v;
    }
    if let Some(v) = o.take("specular")? {
        s.specular = v;
    }
    if let Some(v) = o.take("shininess")? {
        s.shininess = v;
    }
    let colour = |name: &str, c: (f64, f64, f64)| -> PyResult<[f64; 3]> {
        let c = [c.0, c.1, c.2];
        if c.iter().all(|x| x.is_finite() && (0.0..=255.0).contains(x)) {
            Ok(c)
        } else {
            Err(crate::error::FcolError::value(name, "must be three numbers in 0..255").into())
        }
    };
    if let Some(c) = o.take("upper_color")? {
        s.upper = colour("upper_color", c)?;
    }
    if let Some(c) = o.take("under_color")? {
        s.under = colour("under_color", c)?;
    }
    if let Some(c) = o.take("background")? {
        let c = colour("background", c)?;
        s.background = [c[0] as u8, c[1] as u8, c[2] as u8];
    }
    s.validate()?;
    Ok(s)
}
