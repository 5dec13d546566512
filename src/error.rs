//! The one error type of the core. The binding layer maps it to Python
//! exceptions (`ValueError`, `TypeError`, `KeyboardInterrupt`); the core never
//! panics on user input.

use std::fmt;

pub type Result<T> = std::result::Result<T, FcolError>;

#[derive(Debug, Clone, PartialEq)]
pub enum FcolError {
    /// A value is out of range or inconsistent; maps to `ValueError`.
    /// `arg` names the argument, `msg` says what is wrong and how to fix it.
    Value { arg: String, msg: String },
    /// A value has the wrong kind; maps to `TypeError`.
    Type { arg: String, msg: String },
    /// An expression did not parse or compile; `col` is the 1-based column.
    Expression {
        expr: String,
        col: usize,
        msg: String,
    },
    /// The call was cancelled (Ctrl-C); maps to `KeyboardInterrupt`.
    Interrupted,
}

impl FcolError {
    pub fn value(arg: impl Into<String>, msg: impl Into<String>) -> Self {
        FcolError::Value {
            arg: arg.into(),
            msg: msg.into(),
        }
    }
    pub fn type_(arg: impl Into<String>, msg: impl Into<String>) -> Self {
        FcolError::Type {
            arg: arg.into(),
            msg: msg.into(),
        }
    }
}

impl fmt::Display for FcolError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FcolError::Value { arg, msg } | FcolError::Type { arg, msg } => {
                write!(f, "{arg}: {msg}")
            }
            FcolError::Expression { expr, col, msg } => {
                let caret = " ".repeat(col.saturating_sub(1));
                write!(f, "{msg} at column {col}\n    {expr}\n    {caret}^")
            }
            FcolError::Interrupted => write!(f, "interrupted"),
        }
    }
}

impl std::error::Error for FcolError {}

/// Check that a float argument is finite.
pub fn finite(arg: &str, x: f64) -> Result<f64> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(FcolError::value(arg, format!("must be finite, got {x}")))
    }
}

/// The largest image any renderer accepts (width × height), to refuse
/// accidental gigapixel requests with a clear message instead of an
/// allocation failure.
pub const MAX_PIXELS: usize = 1 << 27; // 134 million pixels

/// Validate an image size.
pub fn check_size(width: usize, height: usize) -> Result<()> {
    if width == 0 {
        return Err(FcolError::value("width", "must be at least 1"));
    }
    if height == 0 {
        return Err(FcolError::value("height", "must be at least 1"));
    }
    match width.checked_mul(height) {
        Some(n) if n <= MAX_PIXELS => Ok(()),
        _ => Err(FcolError::value(
            "width",
            format!(
                "{width}×{height} exceeds the pixel budget of {MAX_PIXELS} pixels; render a smaller image or tiles"
            ),
        )),
    }
}
