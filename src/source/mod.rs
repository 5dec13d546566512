//! Surface sources: compiled expressions ([`ExprHeight`],
//! [`ExprParametric`]) and height grids ([`HeightGrid`]).

mod expr;
mod grid;

pub use expr::{param_values, ExprHeight, ExprParametric};
pub use grid::{keys, Axis, HeightGrid, Interpolation};
