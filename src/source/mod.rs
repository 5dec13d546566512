//! Surface sources: compiled expressions ([`ExprHeight`],
//! [`ExprParametric`]) and height grids ([`HeightGrid`]).

mod expr;

pub use expr::{param_values, ExprHeight, ExprParametric};
