//! FcolError → Python exceptions.

use crate::error::FcolError;
use pyo3::exceptions::{PyKeyboardInterrupt, PyTypeError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    fcol,
    ExpressionError,
    PyValueError,
    "An expression failed to parse or compile; the message points at the column."
);

impl From<FcolError> for PyErr {
    fn from(e: FcolError) -> PyErr {
        match &e {
            FcolError::Value { .. } => PyValueError::new_err(e.to_string()),
            FcolError::Type { .. } => PyTypeError::new_err(e.to_string()),
            FcolError::Expression { .. } => ExpressionError::new_err(e.to_string()),
            FcolError::Interrupted => PyKeyboardInterrupt::new_err("render interrupted"),
        }
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ExpressionError", m.py().get_type::<ExpressionError>())?;
    Ok(())
}
