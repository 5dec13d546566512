//! The expression DAG: hash-consed nodes (so every common subexpression is a
//! single node), constant folding and algebraic simplification at
//! construction, and forward-mode automatic differentiation by source
//! transformation: the tangent of each node is built from its operands'
//! tangents by the chain rule, as new nodes of the same DAG. Applied twice it
//! gives exact second derivatives. Because derivatives are nodes, `sin(a)`
//! used by a value and `cos(a)` used by its derivative are each computed once.
//!
//! Derivative conventions at kinks (where the function is not
//! differentiable): `abs'(x) = sign(x)` (0 at 0); `min(a, b)` takes the
//! derivative of `a` where `a <= b`, else of `b`; `max(a, b)` of `a` where
//! `a >= b`, else of `b`; `floor`, `ceil` and `sign` have derivative 0
//! everywhere (their jumps are not differentiated).

use std::collections::HashMap;

/// Index of a node in its [`Graph`].
pub type Id = u32;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Un {
    Neg,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
    Exp,
    Ln,
    Log10,
    Sqrt,
    Abs,
    Floor,
    Ceil,
    Sign,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Bin {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Atan2,
    Min,
    Max,
    Hypot,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Node {
    Const(f64),
    /// Input 0 = u, 1 = v.
    Input(u8),
    /// A named parameter (index in the parameter table); bound to a
    /// constant before evaluation.
    Param(u16),
    Un(Un, Id),
    Bin(Bin, Id, Id),
    /// x^n for a small integer n (computed by multiplications).
    PowI(Id, i32),
    /// x^c for a constant non-integer c.
    PowF(Id, f64),
    /// `if a <= b { x } else { y }` (derivatives of min and max).
    Select(Id, Id, Id, Id),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Key {
    Const(u64),
    Input(u8),
    Param(u16),
    Un(Un, Id),
    Bin(Bin, Id, Id),
    PowI(Id, i32),
    PowF(Id, u64),
    Select(Id, Id, Id, Id),
}

fn key(n: &Node) -> Key {
    match *n {
        // Normalise -0.0 and NaN payloads so equal constants share a node.
        Node::Const(c) => Key::Const(if c == 0.0 {
            0
        } else if c.is_nan() {
            f64::NAN.to_bits()
        } else {
            c.to_bits()
        }),
        Node::Input(i) => Key::Input(i),
        Node::Param(i) => Key::Param(i),
        Node::Un(o, a) => Key::Un(o, a),
        Node::Bin(o, a, b) => Key::Bin(o, a, b),
        Node::PowI(a, n) => Key::PowI(a, n),
        Node::PowF(a, c) => Key::PowF(a, c.to_bits()),
        Node::Select(a, b, x, y) => Key::Select(a, b, x, y),
    }
}

/// Scalar semantics of every operation (shared by folding and evaluation).
pub mod scalar {
    #[inline(always)]
    pub fn sign(x: f64) -> f64 {
        if x > 0.0 {
            1.0
        } else if x < 0.0 {
            -1.0
        } else {
            // 0 for ±0, NaN for NaN (as NumPy).
            x * 0.0
        }
    }
    /// NaN-propagating min (as NumPy's `minimum`).
    #[inline(always)]
    pub fn min(a: f64, b: f64) -> f64 {
        if a <= b {
            a
        } else if b < a {
            b
        } else {
            a + b
        }
    }
    #[inline(always)]
    pub fn max(a: f64, b: f64) -> f64 {
        if a >= b {
            a
        } else if b > a {
            b
        } else {
            a + b
        }
    }
    #[inline(always)]
    pub fn powi(x: f64, n: i32) -> f64 {
        // Repeated squaring, exact for n = 2, 3 (x*x, x*x*x).
        let mut e = n.unsigned_abs();
        let mut base = x;
        let mut acc = 1.0;
        let mut first = true;
        while e > 0 {
            if e & 1 == 1 {
                acc = if first { base } else { acc * base };
                first = false;
            }
            e >>= 1;
            if e > 0 {
                base *= base;
            }
        }
        if n < 0 {
            1.0 / acc
        } else {
            acc
        }
    }
    #[inline(always)]
    pub fn select(a: f64, b: f64, x: f64, y: f64) -> f64 {
        if a <= b {
            x
        } else {
            y
        }
    }
}

pub fn eval_un(op: Un, x: f64) -> f64 {
    match op {
        Un::Neg => -x,
        Un::Sin => x.sin(),
        Un::Cos => x.cos(),
        Un::Tan => x.tan(),
        Un::Asin => x.asin(),
        Un::Acos => x.acos(),
        Un::Atan => x.atan(),
        Un::Sinh => x.sinh(),
        Un::Cosh => x.cosh(),
        Un::Tanh => x.tanh(),
        Un::Exp => x.exp(),
        Un::Ln => x.ln(),
        Un::Log10 => x.log10(),
        Un::Sqrt => x.sqrt(),
        Un::Abs => x.abs(),
        Un::Floor => x.floor(),
        Un::Ceil => x.ceil(),
        Un::Sign => scalar::sign(x),
    }
}

pub fn eval_bin(op: Bin, a: f64, b: f64) -> f64 {
    match op {
        Bin::Add => a + b,
        Bin::Sub => a - b,
        Bin::Mul => a * b,
        Bin::Div => a / b,
        Bin::Pow => a.powf(b),
        Bin::Atan2 => a.atan2(b),
        Bin::Min => scalar::min(a, b),
        Bin::Max => scalar::max(a, b),
        Bin::Hypot => a.hypot(b),
    }
}

/// A hash-consed expression DAG. Node ids are topologically ordered
/// (operands before users).
#[derive(Debug, Clone, Default)]
pub struct Graph {
    pub nodes: Vec<Node>,
    index: HashMap<Key, Id>,
}

impl Graph {
    pub fn new() -> Self {
        Graph::default()
    }

    fn intern(&mut self, n: Node) -> Id {
        let k = key(&n);
        if let Some(&id) = self.index.get(&k) {
            return id;
        }
        let id = self.nodes.len() as Id;
        self.nodes.push(n);
        self.index.insert(k, id);
        id
    }

    pub fn konst(&mut self, c: f64) -> Id {
        self.intern(Node::Const(c))
    }
    pub fn input(&mut self, i: u8) -> Id {
        self.intern(Node::Input(i))
    }
    pub fn param(&mut self, i: u16) -> Id {
        self.intern(Node::Param(i))
    }

    pub fn as_const(&self, id: Id) -> Option<f64> {
        match self.nodes[id as usize] {
            Node::Const(c) => Some(c),
            _ => None,
        }
    }

    pub fn un(&mut self, op: Un, a: Id) -> Id {
        if let Some(x) = self.as_const(a) {
            return self.konst(eval_un(op, x));
        }
        if op == Un::Neg {
            if let Node::Un(Un::Neg, inner) = self.nodes[a as usize] {
                return inner;
            }
        }
        self.intern(Node::Un(op, a))
    }

    pub fn neg(&mut self, a: Id) -> Id {
        self.un(Un::Neg, a)
    }

    pub fn bin(&mut self, op: Bin, a: Id, b: Id) -> Id {
        let (ca, cb) = (self.as_const(a), self.as_const(b));
        if let (Some(x), Some(y)) = (ca, cb) {
            return self.konst(eval_bin(op, x, y));
        }
        match op {
            Bin::Add => {
                if ca == Some(0.0) {
                    return b;
                }
                if cb == Some(0.0) {
                    return a;
                }
                if let Node::Un(Un::Neg, nb) = self.nodes[b as usize] {
                    return self.bin(Bin::Sub, a, nb);
                }
                // Canonical order of commutative operands: constants first.
                if cb.is_some() || (ca.is_none() && b < a) {
                    return self.intern(Node::Bin(op, b, a));
                }
            }
            Bin::Sub => {
                if cb == Some(0.0) {
                    return a;
                }
                if ca == Some(0.0) {
                    return self.neg(b);
                }
                if let Node::Un(Un::Neg, nb) = self.nodes[b as usize] {
                    return self.bin(Bin::Add, a, nb);
                }
            }
            Bin::Mul => {
                // Derivative terms multiply by structural zeros; dropping
                // them keeps the tape short (0·x is taken as 0).
                if ca == Some(0.0) || cb == Some(0.0) {
                    return self.konst(0.0);
                }
                if ca == Some(1.0) {
                    return b;
                }
                if cb == Some(1.0) {
                    return a;
                }
                if ca == Some(-1.0) {
                    return self.neg(b);
                }
                if cb == Some(-1.0) {
                    return self.neg(a);
                }
                // Constant times constant times x folds.
                if let (Some(x), Node::Bin(Bin::Mul, p, q)) = (ca, self.nodes[b as usize]) {
                    if let Some(y) = self.as_const(p) {
                        let k = self.konst(x * y);
                        return self.bin(Bin::Mul, k, q);
                    }
                }
                if cb.is_some() || (ca.is_none() && b < a) {
                    return self.bin(Bin::Mul, b, a);
                }
            }
            Bin::Div => {
                if cb == Some(1.0) {
                    return a;
                }
                if ca == Some(0.0) {
                    return self.konst(0.0);
                }
            }
            Bin::Pow => {
                if let Some(c) = cb {
                    return self.powc(a, c);
                }
            }
            _ => {}
        }
        self.intern(Node::Bin(op, a, b))
    }

    /// a^c for a constant exponent.
    pub fn powc(&mut self, a: Id, c: f64) -> Id {
        if let Some(x) = self.as_const(a) {
            return self.konst(x.powf(c));
        }
        if c == 0.0 {
            return self.konst(1.0);
        }
        if c == 1.0 {
            return a;
        }
        if c == 0.5 {
            return self.un(Un::Sqrt, a);
        }
        if c.fract() == 0.0 && c.abs() <= 64.0 {
            return self.intern(Node::PowI(a, c as i32));
        }
        self.intern(Node::PowF(a, c))
    }

    pub fn add(&mut self, a: Id, b: Id) -> Id {
        self.bin(Bin::Add, a, b)
    }
    pub fn sub(&mut self, a: Id, b: Id) -> Id {
        self.bin(Bin::Sub, a, b)
    }
    pub fn mul(&mut self, a: Id, b: Id) -> Id {
        self.bin(Bin::Mul, a, b)
    }
    pub fn div(&mut self, a: Id, b: Id) -> Id {
        self.bin(Bin::Div, a, b)
    }
    pub fn mulc(&mut self, c: f64, a: Id) -> Id {
        let k = self.konst(c);
        self.mul(k, a)
    }

    pub fn select(&mut self, a: Id, b: Id, x: Id, y: Id) -> Id {
        if x == y {
            return x;
        }
        if let (Some(p), Some(q)) = (self.as_const(a), self.as_const(b)) {
            return if p <= q { x } else { y };
        }
        self.intern(Node::Select(a, b, x, y))
    }

    /// Tangent of every node reachable from `roots` along input `wrt`
    /// (0 = u, 1 = v), memoised in `memo` (indexed by node id).
    pub fn derive(&mut self, root: Id, wrt: u8, memo: &mut HashMap<Id, Id>) -> Id {
        if let Some(&d) = memo.get(&root) {
            return d;
        }
        // Iterative post-order so deep expressions cannot overflow the stack.
        let mut stack = vec![(root, false)];
        while let Some((id, ready)) = stack.pop() {
            if memo.contains_key(&id) {
                continue;
            }
            let ops = self.operands(id);
            if !ready {
                stack.push((id, true));
                for o in ops.into_iter().flatten() {
                    if !memo.contains_key(&o) {
                        stack.push((o, false));
                    }
                }
                continue;
            }
            let d = self.tangent(id, wrt, memo);
            memo.insert(id, d);
        }
        memo[&root]
    }

    fn operands(&self, id: Id) -> [Option<Id>; 4] {
        match self.nodes[id as usize] {
            Node::Const(_) | Node::Input(_) | Node::Param(_) => [None; 4],
            Node::Un(_, a) | Node::PowI(a, _) | Node::PowF(a, _) => [Some(a), None, None, None],
            Node::Bin(_, a, b) => [Some(a), Some(b), None, None],
            Node::Select(a, b, x, y) => [Some(a), Some(b), Some(x), Some(y)],
        }
    }

    /// The chain rule for one node, its operands' tangents being in `memo`.
    fn tangent(&mut self, id: Id, wrt: u8, memo: &HashMap<Id, Id>) -> Id {
        let zero = self.konst(0.0);
        let one = self.konst(1.0);
        match self.nodes[id as usize] {
            Node::Const(_) | Node::Param(_) => zero,
            Node::Input(i) => {
                if i == wrt {
                    one
                } else {
                    zero
                }
            }
            Node::Un(op, a) => {
                let da = memo[&a];
                if da == zero {
                    return zero;
                }
                // f'(a) as a node.
                let fp = match op {
                    Un::Neg => return self.neg(da),
                    Un::Sin => self.un(Un::Cos, a),
                    Un::Cos => {
                        let s = self.un(Un::Sin, a);
                        self.neg(s)
                    }
                    Un::Tan => {
                        // 1 + tan²
                        let t2 = self.powc(id, 2.0);
                        self.add(one, t2)
                    }
                    Un::Asin | Un::Acos => {
                        let a2 = self.powc(a, 2.0);
                        let r = self.sub(one, a2);
                        let s = self.un(Un::Sqrt, r);
                        let q = self.div(one, s);
                        if op == Un::Acos {
                            self.neg(q)
                        } else {
                            q
                        }
                    }
                    Un::Atan => {
                        let a2 = self.powc(a, 2.0);
                        let r = self.add(one, a2);
                        return self.div(da, r);
                    }
                    Un::Sinh => self.un(Un::Cosh, a),
                    Un::Cosh => self.un(Un::Sinh, a),
                    Un::Tanh => {
                        let t2 = self.powc(id, 2.0);
                        self.sub(one, t2)
                    }
                    Un::Exp => id,
                    Un::Ln => return self.div(da, a),
                    Un::Log10 => {
                        let k = self.mulc(std::f64::consts::LN_10, a);
                        return self.div(da, k);
                    }
                    Un::Sqrt => {
                        let k = self.mulc(2.0, id);
                        return self.div(da, k);
                    }
                    Un::Abs => self.un(Un::Sign, a),
                    Un::Floor | Un::Ceil | Un::Sign => return zero,
                };
                self.mul(fp, da)
            }
            Node::PowI(a, n) => {
                let da = memo[&a];
                if da == zero {
                    return zero;
                }
                let p = self.powc(a, (n - 1) as f64);
                let k = self.mulc(n as f64, p);
                self.mul(k, da)
            }
            Node::PowF(a, c) => {
                let da = memo[&a];
                if da == zero {
                    return zero;
                }
                let p = self.powc(a, c - 1.0);
                let k = self.mulc(c, p);
                self.mul(k, da)
            }
            Node::Select(a, b, x, y) => {
                let (dx, dy) = (memo[&x], memo[&y]);
                self.select(a, b, dx, dy)
            }
            Node::Bin(op, a, b) => {
                let (da, db) = (memo[&a], memo[&b]);
                if da == zero && db == zero {
                    return zero;
                }
                match op {
                    Bin::Add => self.add(da, db),
                    Bin::Sub => self.sub(da, db),
                    Bin::Mul => {
                        let p = self.mul(da, b);
                        let q = self.mul(a, db);
                        self.add(p, q)
                    }
                    Bin::Div => {
                        // (da − (a/b)·db) / b
                        let q = self.mul(id, db);
                        let n = self.sub(da, q);
                        self.div(n, b)
                    }
                    Bin::Pow => {
                        // d(a^b) = a^b · (db·ln a + b·da/a)
                        let t1 = if db == zero {
                            zero
                        } else {
                            let l = self.un(Un::Ln, a);
                            self.mul(db, l)
                        };
                        let t2 = if da == zero {
                            zero
                        } else {
                            let r = self.div(da, a);
                            self.mul(b, r)
                        };
                        let s = self.add(t1, t2);
                        self.mul(id, s)
                    }
                    Bin::Atan2 => {
                        // atan2(a, b): (b·da − a·db) / (a² + b²)
                        let p = self.mul(b, da);
                        let q = self.mul(a, db);
                        let n = self.sub(p, q);
                        let a2 = self.powc(a, 2.0);
                        let b2 = self.powc(b, 2.0);
                        let d = self.add(a2, b2);
                        self.div(n, d)
                    }
                    Bin::Min => self.select(a, b, da, db),
                    Bin::Max => self.select(b, a, da, db),
                    Bin::Hypot => {
                        let p = self.mul(a, da);
                        let q = self.mul(b, db);
                        let n = self.add(p, q);
                        self.div(n, id)
                    }
                }
            }
        }
    }

    /// Copy the nodes reachable from `roots` into a new graph with every
    /// parameter replaced by its value, folding again. Returns the new graph
    /// and the images of `roots`.
    pub fn bind(&self, values: &[f64], roots: &[Id]) -> (Graph, Vec<Id>) {
        let mut live = vec![false; self.nodes.len()];
        for &r in roots {
            live[r as usize] = true;
        }
        for id in (0..self.nodes.len()).rev() {
            if live[id] {
                for o in self.operands(id as Id).into_iter().flatten() {
                    live[o as usize] = true;
                }
            }
        }
        let mut g = Graph::new();
        let mut map = vec![0 as Id; self.nodes.len()];
        for (id, n) in self.nodes.iter().enumerate() {
            if !live[id] {
                continue;
            }
            let m = |i: Id| map[i as usize];
            map[id] = match *n {
                Node::Const(c) => g.konst(c),
                Node::Input(i) => g.input(i),
                Node::Param(p) => g.konst(values[p as usize]),
                Node::Un(op, a) => g.un(op, m(a)),
                Node::Bin(op, a, b) => g.bin(op, m(a), m(b)),
                Node::PowI(a, k) => g.powc(m(a), k as f64),
                Node::PowF(a, c) => g.powc(m(a), c),
                Node::Select(a, b, x, y) => g.select(m(a), m(b), m(x), m(y)),
            };
        }
        let roots = roots.iter().map(|&r| map[r as usize]).collect();
        (g, roots)
    }
}
