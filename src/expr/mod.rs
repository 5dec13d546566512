//! The expression engine: `3*sin(u*cos(v))` parsed once, differentiated
//! exactly (forward-mode automatic differentiation, applied to the DAG at
//! compile time), bound to parameter values without re-parsing, and
//! evaluated from a flat tape over batches or at single points.
//!
//! Language: numbers (`2`, `.5`, `1e-3`), the variables `u`, `v`, `t`,
//! named parameters, `+ - * / **` (`**` right-associative and tighter than
//! unary minus, as in Python), parentheses, the functions
//! `sin cos tan asin acos atan atan2 sinh cosh tanh exp log log10 sqrt abs
//! min max floor ceil sign hypot` (`log` is the natural logarithm,
//! `atan2(y, x)` as NumPy's `arctan2`), and the constants `pi`, `e`.
//! NaN and ±inf from the arithmetic are returned as they are (the renderers
//! treat them as holes).

mod fastmath;
mod graph;
mod interval;
mod kernels;
mod parser;
mod tape;

pub use graph::{Bin, Graph, Id, Node, Un};
pub use interval::Iv;
pub use parser::{parse, Ast};
pub use tape::{Program, CHUNK};

use crate::error::{FcolError, Result};
use std::collections::HashMap;

/// Names no parameter may take.
pub const RESERVED: &[&str] = &[
    "u", "v", "t", "pi", "e", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh",
    "tanh", "exp", "log", "log10", "sqrt", "abs", "min", "max", "floor", "ceil", "sign", "hypot",
];

fn function(name: &str) -> Option<(usize, std::result::Result<Un, Bin>)> {
    let un = |o| Some((1, Ok(o)));
    let bin = |o| Some((2, Err(o)));
    match name {
        "sin" => un(Un::Sin),
        "cos" => un(Un::Cos),
        "tan" => un(Un::Tan),
        "asin" => un(Un::Asin),
        "acos" => un(Un::Acos),
        "atan" => un(Un::Atan),
        "sinh" => un(Un::Sinh),
        "cosh" => un(Un::Cosh),
        "tanh" => un(Un::Tanh),
        "exp" => un(Un::Exp),
        "log" => un(Un::Ln),
        "log10" => un(Un::Log10),
        "sqrt" => un(Un::Sqrt),
        "abs" => un(Un::Abs),
        "floor" => un(Un::Floor),
        "ceil" => un(Un::Ceil),
        "sign" => un(Un::Sign),
        "atan2" => bin(Bin::Atan2),
        "min" => bin(Bin::Min),
        "max" => bin(Bin::Max),
        "hypot" => bin(Bin::Hypot),
        _ => None,
    }
}

/// Check a parameter name (a Python-style identifier, not reserved).
pub fn check_param_name(name: &str) -> Result<()> {
    let mut chars = name.chars();
    let ok = match chars.next() {
        Some(c) if c.is_alphabetic() || c == '_' => chars.all(|c| c.is_alphanumeric() || c == '_'),
        _ => false,
    };
    if !ok {
        return Err(FcolError::value(
            "params",
            format!("{name:?} is not a valid parameter name (letters, digits and _, not starting with a digit)"),
        ));
    }
    if name == "t" {
        return Err(FcolError::value(
            "params",
            "\"t\" is the time variable: pass t=... rather than params={\"t\": ...}",
        ));
    }
    if RESERVED.contains(&name) {
        return Err(FcolError::value(
            "params",
            format!("{name:?} is a reserved name (a variable, constant or function of the expression language)"),
        ));
    }
    Ok(())
}

struct Lower<'a> {
    g: &'a mut Graph,
    src: &'a str,
    params: &'a HashMap<String, u16>,
    used: &'a mut Vec<bool>,
}

impl Lower<'_> {
    fn err(&self, col: usize, msg: String) -> FcolError {
        FcolError::Expression {
            expr: self.src.to_string(),
            col,
            msg,
        }
    }
    fn lower(&mut self, ast: &Ast) -> Result<Id> {
        Ok(match ast {
            Ast::Num(x) => self.g.konst(*x),
            Ast::Name(name, col) => match name.as_str() {
                "u" => self.g.input(0),
                "v" => self.g.input(1),
                "pi" => self.g.konst(std::f64::consts::PI),
                "e" => self.g.konst(std::f64::consts::E),
                _ => match self.params.get(name) {
                    Some(&i) => {
                        self.used[i as usize] = true;
                        self.g.param(i)
                    }
                    None => {
                        let msg = if function(name).is_some() {
                            format!("{name} is a function: call it as {name}(...)")
                        } else {
                            format!(
                                "unknown name {name:?} (the variables are u, v, t; pass other names in params={{...}})"
                            )
                        };
                        return Err(self.err(*col, msg));
                    }
                },
            },
            Ast::Neg(a) => {
                let a = self.lower(a)?;
                self.g.neg(a)
            }
            Ast::Bin(op, a, b) => {
                let (a, b) = (self.lower(a)?, self.lower(b)?);
                let op = match op {
                    parser::BinOp::Add => Bin::Add,
                    parser::BinOp::Sub => Bin::Sub,
                    parser::BinOp::Mul => Bin::Mul,
                    parser::BinOp::Div => Bin::Div,
                    parser::BinOp::Pow => Bin::Pow,
                };
                self.g.bin(op, a, b)
            }
            Ast::Call(name, args, col) => {
                let Some((arity, op)) = function(name) else {
                    return Err(self.err(*col, format!("unknown function {name:?}")));
                };
                if args.len() != arity {
                    return Err(self.err(
                        *col,
                        format!(
                            "{name} takes {arity} argument{}, got {}",
                            if arity == 1 { "" } else { "s" },
                            args.len()
                        ),
                    ));
                }
                let a = self.lower(&args[0])?;
                match op {
                    Ok(un) => self.g.un(un, a),
                    Err(bin) => {
                        let b = self.lower(&args[1])?;
                        self.g.bin(bin, a, b)
                    }
                }
            }
        })
    }
}

/// Expressions compiled together (sharing one DAG and one parameter table)
/// with their derivatives up to `order` (0, 1 or 2), ready to be bound to
/// parameter values. Parameter 0 is always `t`.
#[derive(Debug, Clone)]
pub struct Compiled {
    graph: Graph,
    params: Vec<String>,
    used: Vec<bool>,
    order: u8,
    /// Per expression: value, then d/du, d/dv (order ≥ 1), then d²/du²,
    /// d²/dudv, d²/dv² (order 2).
    roots: Vec<Vec<Id>>,
    sources: Vec<String>,
}

/// An expression's value DAG with its parameters bound, for interval
/// bounds over boxes ([`Compiled::value_bounder`]).
#[derive(Debug)]
pub struct ValueBound {
    g: Graph,
    root: Id,
}

impl ValueBound {
    /// Bounds of the value over the box `u` × `v`: every non-NaN value
    /// the evaluation returns there lies inside (empty: NaN everywhere
    /// there).
    pub fn over(&self, u: (f64, f64), v: (f64, f64)) -> Iv {
        interval::bound(&self.g, self.root, u, v)
    }
}

impl Compiled {
    /// Parse and differentiate `exprs`, with the named parameters `params`
    /// (besides `t`). Errors point at the column of the offending expression.
    pub fn new(exprs: &[&str], params: &[&str], order: u8) -> Result<Compiled> {
        let mut table: HashMap<String, u16> = HashMap::new();
        let mut names = vec!["t".to_string()];
        table.insert("t".into(), 0);
        for &p in params {
            check_param_name(p)?;
            if table.contains_key(p) {
                return Err(FcolError::value("params", format!("{p:?} given twice")));
            }
            table.insert(p.to_string(), names.len() as u16);
            names.push(p.to_string());
        }
        let mut used = vec![false; names.len()];
        let mut g = Graph::new();
        let mut values = Vec::new();
        for &src in exprs {
            let ast = parse(src)?;
            let mut l = Lower {
                g: &mut g,
                src,
                params: &table,
                used: &mut used,
            };
            values.push(l.lower(&ast)?);
        }
        let mut roots: Vec<Vec<Id>> = values.iter().map(|&v| vec![v]).collect();
        if order >= 1 {
            let (mut mu, mut mv) = (HashMap::new(), HashMap::new());
            for r in roots.iter_mut() {
                let du = g.derive(r[0], 0, &mut mu);
                let dv = g.derive(r[0], 1, &mut mv);
                r.extend([du, dv]);
            }
            if order >= 2 {
                let (mut muu, mut mvv) = (mu.clone(), mv.clone());
                for r in roots.iter_mut() {
                    let duu = g.derive(r[1], 0, &mut muu);
                    let duv = g.derive(r[1], 1, &mut mvv);
                    let dvv = g.derive(r[2], 1, &mut mvv);
                    r.extend([duu, duv, dvv]);
                }
            }
        }
        Ok(Compiled {
            graph: g,
            params: names,
            used,
            order,
            roots,
            sources: exprs.iter().map(|s| s.to_string()).collect(),
        })
    }

    /// Parameter names, `t` first.
    pub fn params(&self) -> &[String] {
        &self.params
    }

    /// Whether parameter `name` appears in any expression.
    pub fn uses(&self, name: &str) -> bool {
        self.params
            .iter()
            .position(|p| p == name)
            .is_some_and(|i| self.used[i])
    }

    pub fn sources(&self) -> &[String] {
        &self.sources
    }

    pub fn order(&self) -> u8 {
        self.order
    }

    /// Size of the differentiated DAG (nodes).
    pub fn graph_len(&self) -> usize {
        self.graph.nodes.len()
    }

    /// Bounds of expression `which`'s value over the box `u` × `v` with the
    /// parameters bound to `values` (see [`interval`]): every non-NaN
    /// value the evaluation returns there lies inside. Empty: NaN
    /// everywhere there.
    pub fn value_bound(&self, values: &[f64], which: usize, u: (f64, f64), v: (f64, f64)) -> Iv {
        self.value_bounder(values, which).over(u, v)
    }

    /// Expression `which`'s value with the parameters bound to `values`,
    /// kept for bounds over many boxes ([`ValueBound::over`]).
    pub fn value_bounder(&self, values: &[f64], which: usize) -> ValueBound {
        assert_eq!(values.len(), self.params.len());
        let (g, roots) = self.graph.bind(values, &[self.roots[which][0]]);
        ValueBound { g, root: roots[0] }
    }

    /// A program computing, for each expression in turn, its value and then
    /// its derivatives up to `order` (≤ the compiled order), with the
    /// parameters bound to `values` (`values.len() == params().len()`).
    /// Parameters are folded in as constants, so binding re-folds the
    /// (small) DAG but never re-parses.
    pub fn program(&self, values: &[f64], order: u8) -> Program {
        assert_eq!(values.len(), self.params.len());
        assert!(order <= self.order);
        let per = [1usize, 3, 6][order as usize];
        let roots: Vec<Id> = self
            .roots
            .iter()
            .flat_map(|r| r[..per].iter().copied())
            .collect();
        let (g, roots) = self.graph.bind(values, &roots);
        Program::emit(&g, &roots)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prog(src: &str, order: u8) -> Program {
        Compiled::new(&[src], &[], order)
            .unwrap()
            .program(&[0.0], order)
    }

    fn eval(src: &str, u: f64, v: f64) -> Vec<f64> {
        let p = prog(src, 1);
        let mut out = vec![0.0; 3];
        p.eval_point(u, v, &mut out);
        // The batch path must agree bit for bit.
        let mut b = vec![vec![0.0; 1]; 3];
        let mut refs: Vec<&mut [f64]> = b.iter_mut().map(|x| x.as_mut_slice()).collect();
        p.eval_into(&[u], &[v], &mut refs);
        for k in 0..3 {
            assert!(
                out[k].to_bits() == b[k][0].to_bits() || (out[k].is_nan() && b[k][0].is_nan()),
                "{src}: point {} vs batch {}",
                out[k],
                b[k][0]
            );
        }
        out
    }

    #[test]
    fn values_and_gradients() {
        let r = eval("3*sin(u*cos(v))", 0.7, -1.3);
        let (u, v) = (0.7f64, -1.3f64);
        let w = u * v.cos();
        assert!((r[0] - 3.0 * w.sin()).abs() < 1e-15);
        assert!((r[1] - 3.0 * w.cos() * v.cos()).abs() < 1e-14);
        assert!((r[2] + 3.0 * w.cos() * u * v.sin()).abs() < 1e-14);
        assert_eq!(eval("-u**2", 3.0, 0.0)[0], -9.0);
        assert_eq!(eval("2**3**2", 0.0, 0.0)[0], 512.0);
        assert_eq!(eval("u", 2.0, 5.0), vec![2.0, 1.0, 0.0]);
        assert_eq!(eval("7", 2.0, 5.0), vec![7.0, 0.0, 0.0]);
        assert_eq!(eval("abs(u)", 0.0, 0.0)[1], 0.0);
        assert!(eval("log(u)", -1.0, 0.0)[0].is_nan());
    }

    #[test]
    fn long_batches_match_points() {
        let p = prog(
            "hypot(u, v) * atan2(v, u) + min(u, v)**3 / (1 + exp(-u))",
            2,
        );
        let n = 1000;
        let u: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin() * 3.0).collect();
        let v: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos() * 2.0).collect();
        let mut cols = vec![vec![0.0; n]; 6];
        let mut refs: Vec<&mut [f64]> = cols.iter_mut().map(|x| x.as_mut_slice()).collect();
        p.eval_into(&u, &v, &mut refs);
        let mut out = [0.0; 6];
        for i in 0..n {
            p.eval_point(u[i], v[i], &mut out);
            for k in 0..6 {
                assert_eq!(out[k].to_bits(), cols[k][i].to_bits());
            }
        }
    }

    #[test]
    fn small_batches_match_points() {
        let p = prog("exp(-(u*u + v*v)/4)*cos(3*u) - sqrt(abs(u*v)) + u**-2.5", 2);
        for n in [1usize, 2, 3, 5, 255, 256, 257, 600] {
            let u: Vec<f64> = (0..n).map(|i| 0.1 + i as f64 * 0.013).collect();
            let v: Vec<f64> = (0..n).map(|i| 2.0 - i as f64 * 0.007).collect();
            let mut cols = vec![vec![0.0; n]; 6];
            let mut refs: Vec<&mut [f64]> = cols.iter_mut().map(|x| x.as_mut_slice()).collect();
            p.eval_into(&u, &v, &mut refs);
            let mut out = [0.0; 6];
            for i in 0..n {
                p.eval_point(u[i], v[i], &mut out);
                for k in 0..6 {
                    assert_eq!(out[k].to_bits(), cols[k][i].to_bits(), "n={n} i={i} k={k}");
                }
            }
        }
    }

    #[test]
    fn errors_name_columns() {
        let col = |s: &str, params: &[&str]| match Compiled::new(&[s], params, 1) {
            Err(FcolError::Expression { col, .. }) => col,
            other => panic!("{other:?}"),
        };
        assert_eq!(col("u + foo", &[]), 5);
        assert_eq!(col("u + bar(v)", &[]), 5);
        assert_eq!(col("u + sin(u, v)", &[]), 5);
        assert_eq!(col("a*u + b", &["a"]), 7);
    }

    #[test]
    fn sin_cos_are_shared() {
        // value and both derivatives of sin(u*cos(v)): sin(v), cos(v),
        // sin(w), cos(w) — two fused SinCos instructions.
        let p = prog("3*sin(u*cos(v))", 1);
        let n_sincos = p.instrs.iter().filter(|i| i.op == tape::Op::SinCos).count();
        assert_eq!(n_sincos, 2, "{:?}", p.instrs);
    }
}
