//! The flat tape: a bound expression DAG emitted as a list of instructions
//! over numbered slots (registers), with slots reused once their value is
//! dead, `sin`/`cos` of one argument fused into one `SinCos`, and constant
//! operands of + − × ÷ carried as immediates.
//!
//! Batches are evaluated in structure-of-arrays form: each instruction is a
//! tight loop over a chunk of [`CHUNK`] points, so the dispatch is amortised
//! and the loops vectorise. [`Program::eval_point`] is the one-point path
//! (no allocation for tapes of up to 64 slots).

use super::graph::{scalar, Bin, Graph, Id, Node, Un};
use super::kernels;

/// Points per chunk of a batch evaluation.
pub const CHUNK: usize = 256;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    Un(Un),
    /// dst = sin(a), dst2 = cos(a).
    SinCos,
    Bin(Bin),
    /// dst = a + k
    AddK,
    /// dst = a · k
    MulK,
    /// dst = k − a
    SubKX,
    /// dst = k / a
    DivKX,
    /// dst = a / k
    DivXK,
    /// dst = a^n, n = k
    PowI,
    /// dst = a^k
    PowF,
    /// dst = if a <= b { c } else { e }
    Select,
    /// dst = k
    Fill,
}

#[derive(Debug, Clone, Copy)]
pub struct Instr {
    pub op: Op,
    pub dst: u32,
    pub dst2: u32,
    pub a: u32,
    pub b: u32,
    pub c: u32,
    pub e: u32,
    pub k: f64,
}

/// A compiled, parameter-bound evaluation program: inputs u (slot 0) and v
/// (slot 1), outputs in `outputs` slots.
#[derive(Debug, Clone)]
pub struct Program {
    pub instrs: Vec<Instr>,
    pub nslots: usize,
    pub outputs: Vec<u32>,
}

const NONE: u32 = u32::MAX;

impl Program {
    /// Emit a program computing `roots` of the (bound, parameter-free)
    /// graph `g`.
    pub fn emit(g: &Graph, roots: &[Id]) -> Program {
        let n = g.nodes.len();
        // How each node is computed: which operands need a slot.
        #[derive(Clone, Copy, PartialEq)]
        enum How {
            Dead,
            Input(u32),
            Slot, // needs a slot of its own
        }
        let mut how = vec![How::Dead; n];
        let mut slot_uses: Vec<Vec<Id>> = vec![Vec::new(); n]; // operands needing slots
        let mut need = vec![false; n];
        for &r in roots {
            need[r as usize] = true;
        }
        // Immediate form of binary ops with one constant operand.
        let imm = |node: &Node| -> Option<(Op, Id, f64)> {
            if let Node::Bin(op, a, b) = *node {
                let (ca, cb) = (g.as_const(a), g.as_const(b));
                return match (op, ca, cb) {
                    (Bin::Add, Some(k), None) => Some((Op::AddK, b, k)),
                    (Bin::Add, None, Some(k)) => Some((Op::AddK, a, k)),
                    (Bin::Sub, None, Some(k)) => Some((Op::AddK, a, -k)),
                    (Bin::Sub, Some(k), None) => Some((Op::SubKX, b, k)),
                    (Bin::Mul, Some(k), None) => Some((Op::MulK, b, k)),
                    (Bin::Mul, None, Some(k)) => Some((Op::MulK, a, k)),
                    (Bin::Div, Some(k), None) => Some((Op::DivKX, b, k)),
                    (Bin::Div, None, Some(k)) => Some((Op::DivXK, a, k)),
                    _ => None,
                };
            }
            None
        };
        for id in (0..n).rev() {
            if !need[id] {
                continue;
            }
            let node = &g.nodes[id];
            let ops: Vec<Id> = match *node {
                Node::Const(_) => vec![],
                Node::Input(i) => {
                    how[id] = How::Input(i as u32);
                    continue;
                }
                Node::Param(_) => unreachable!("parameters are bound before emission"),
                Node::Un(_, a) | Node::PowI(a, _) | Node::PowF(a, _) => vec![a],
                Node::Bin(_, a, b) => match imm(node) {
                    Some((_, x, _)) => vec![x],
                    None => vec![a, b],
                },
                Node::Select(a, b, x, y) => vec![a, b, x, y],
            };
            how[id] = How::Slot;
            for &o in &ops {
                need[o as usize] = true;
            }
            slot_uses[id] = ops;
        }
        // Fuse sin(a) with cos(a).
        let mut partner = vec![NONE; n]; // sin node -> cos node and back
        {
            let mut sin_of = std::collections::HashMap::new();
            for (id, h) in how.iter().enumerate() {
                if *h == How::Slot {
                    if let Node::Un(Un::Sin, a) = g.nodes[id] {
                        sin_of.insert(a, id);
                    }
                }
            }
            for (id, h) in how.iter().enumerate() {
                if *h == How::Slot {
                    if let Node::Un(Un::Cos, a) = g.nodes[id] {
                        if let Some(&s) = sin_of.get(&a) {
                            partner[s] = id as u32;
                            partner[id] = s as u32;
                        }
                    }
                }
            }
        }
        // Last use (in emission order = id order) of each slot value; the
        // roots live to the end.
        let mut last = vec![0usize; n];
        for (id, uses) in slot_uses.iter().enumerate() {
            for &o in uses {
                last[o as usize] = last[o as usize].max(id);
            }
        }
        for &r in roots {
            last[r as usize] = usize::MAX;
        }
        let mut slot = vec![NONE; n];
        let mut free: Vec<u32> = Vec::new();
        let mut nslots = 2u32;
        let mut alloc = |free: &mut Vec<u32>| -> u32 {
            free.pop().unwrap_or_else(|| {
                nslots += 1;
                nslots - 1
            })
        };
        let mut instrs = Vec::new();
        for id in 0..n {
            match how[id] {
                How::Input(i) => {
                    slot[id] = i;
                    continue;
                }
                How::Slot => {}
                _ => continue,
            }
            if slot[id] != NONE {
                // The cos half of a fused SinCos, already computed.
            } else {
                let s = |x: Id| slot[x as usize];
                let mut ins = Instr {
                    op: Op::Fill,
                    dst: alloc(&mut free),
                    dst2: NONE,
                    a: NONE,
                    b: NONE,
                    c: NONE,
                    e: NONE,
                    k: 0.0,
                };
                let node = g.nodes[id];
                match node {
                    Node::Const(k) => ins.k = k,
                    Node::Un(op, a) => {
                        ins.a = s(a);
                        ins.op = Op::Un(op);
                        if partner[id] != NONE && matches!(op, Un::Sin | Un::Cos) {
                            let other = partner[id] as usize;
                            let d2 = alloc(&mut free);
                            slot[other] = d2;
                            ins.op = Op::SinCos;
                            if op == Un::Cos {
                                // dst must hold the sine.
                                ins.dst2 = ins.dst;
                                ins.dst = d2;
                            } else {
                                ins.dst2 = d2;
                            }
                            slot[id] = if op == Un::Sin { ins.dst } else { ins.dst2 };
                        }
                    }
                    Node::PowI(a, k) => {
                        ins.op = Op::PowI;
                        ins.a = s(a);
                        ins.k = k as f64;
                    }
                    Node::PowF(a, k) => {
                        ins.op = Op::PowF;
                        ins.a = s(a);
                        ins.k = k;
                    }
                    Node::Bin(op, a, b) => match imm(&node) {
                        Some((iop, x, k)) => {
                            ins.op = iop;
                            ins.a = s(x);
                            ins.k = k;
                        }
                        None => {
                            ins.op = Op::Bin(op);
                            ins.a = s(a);
                            ins.b = s(b);
                        }
                    },
                    Node::Select(a, b, x, y) => {
                        ins.op = Op::Select;
                        ins.a = s(a);
                        ins.b = s(b);
                        ins.c = s(x);
                        ins.e = s(y);
                    }
                    Node::Input(_) | Node::Param(_) => unreachable!(),
                }
                if slot[id] == NONE {
                    slot[id] = ins.dst;
                }
                instrs.push(ins);
            }
            // Free operands whose last use is this node (after allocating
            // the destination, so a destination never aliases an operand).
            for &o in &slot_uses[id] {
                let o = o as usize;
                if last[o] == id && o >= 2 && !matches!(how[o], How::Input(_)) {
                    let so = slot[o];
                    if so != NONE && !free.contains(&so) {
                        free.push(so);
                    }
                    last[o] = usize::MAX - 1; // freed once
                }
            }
        }
        let outputs = roots.iter().map(|&r| slot[r as usize]).collect();
        Program {
            instrs,
            nslots: nslots as usize,
            outputs,
        }
    }

    pub fn n_outputs(&self) -> usize {
        self.outputs.len()
    }

    /// Evaluate one chunk of `n <= CHUNK` points already copied into slots
    /// 0 (u) and 1 (v) of `regs` (`nslots * CHUNK` values).
    fn run_chunk(&self, regs: &mut [f64], n: usize) {
        debug_assert!(regs.len() >= self.nslots * CHUNK && n <= CHUNK);
        let base = regs.as_mut_ptr();
        for ins in &self.instrs {
            // SAFETY: slots are disjoint CHUNK-long ranges of `regs`, and
            // the emitter never makes a destination alias an operand.
            let col = |s: u32| -> &[f64] {
                unsafe { std::slice::from_raw_parts(base.add(s as usize * CHUNK), n) }
            };
            let d =
                unsafe { std::slice::from_raw_parts_mut(base.add(ins.dst as usize * CHUNK), n) };
            let k = ins.k;
            match ins.op {
                Op::Fill => d.fill(k),
                Op::Un(op) => kernels::un(op, col(ins.a), d),
                Op::SinCos => {
                    let d2 = unsafe {
                        std::slice::from_raw_parts_mut(base.add(ins.dst2 as usize * CHUNK), n)
                    };
                    kernels::sin_cos(col(ins.a), d, d2)
                }
                Op::Bin(op) => kernels::bin(op, col(ins.a), col(ins.b), d),
                Op::AddK => {
                    for (d, &a) in d.iter_mut().zip(col(ins.a)) {
                        *d = a + k
                    }
                }
                Op::MulK => {
                    for (d, &a) in d.iter_mut().zip(col(ins.a)) {
                        *d = a * k
                    }
                }
                Op::SubKX => {
                    for (d, &a) in d.iter_mut().zip(col(ins.a)) {
                        *d = k - a
                    }
                }
                Op::DivKX => {
                    for (d, &a) in d.iter_mut().zip(col(ins.a)) {
                        *d = k / a
                    }
                }
                Op::DivXK => {
                    for (d, &a) in d.iter_mut().zip(col(ins.a)) {
                        *d = a / k
                    }
                }
                Op::PowI => kernels::powi(col(ins.a), k as i32, d),
                Op::PowF => kernels::powf(col(ins.a), k, d),
                Op::Select => {
                    let (a, b, c, e) = (col(ins.a), col(ins.b), col(ins.c), col(ins.e));
                    for i in 0..n {
                        d[i] = scalar::select(a[i], b[i], c[i], e[i]);
                    }
                }
            }
        }
    }

    /// Evaluate at many points. `sink(start, n, cols)` receives each chunk:
    /// `cols[k][i]` is output k at point `start + i`.
    pub fn eval_chunks(&self, u: &[f64], v: &[f64], mut sink: impl FnMut(usize, &[&[f64]])) {
        assert_eq!(u.len(), v.len());
        let mut regs = vec![0.0f64; self.nslots * CHUNK];
        let mut start = 0;
        while start < u.len() {
            let n = (u.len() - start).min(CHUNK);
            regs[..n].copy_from_slice(&u[start..start + n]);
            regs[CHUNK..CHUNK + n].copy_from_slice(&v[start..start + n]);
            self.run_chunk(&mut regs, n);
            let cols: Vec<&[f64]> = self
                .outputs
                .iter()
                .map(|&s| &regs[s as usize * CHUNK..s as usize * CHUNK + n])
                .collect();
            sink(start, &cols);
            start += n;
        }
    }

    /// Evaluate at many points into structure-of-arrays outputs
    /// (`outs[k].len() == u.len()`).
    pub fn eval_into(&self, u: &[f64], v: &[f64], outs: &mut [&mut [f64]]) {
        assert_eq!(outs.len(), self.outputs.len());
        self.eval_chunks(u, v, |start, cols| {
            for (o, c) in outs.iter_mut().zip(cols) {
                o[start..start + c.len()].copy_from_slice(c);
            }
        });
    }

    /// Evaluate at one point; `out.len() == n_outputs()`.
    #[inline]
    pub fn eval_point(&self, u: f64, v: f64, out: &mut [f64]) {
        if self.nslots <= 64 {
            let mut r = [0.0f64; 64];
            self.point_with(&mut r, u, v, out);
        } else {
            let mut r = vec![0.0f64; self.nslots];
            self.point_with(&mut r, u, v, out);
        }
    }

    #[inline]
    fn point_with(&self, r: &mut [f64], u: f64, v: f64, out: &mut [f64]) {
        r[0] = u;
        r[1] = v;
        for ins in &self.instrs {
            let a = if ins.a != NONE {
                r[ins.a as usize]
            } else {
                0.0
            };
            let k = ins.k;
            let x = match ins.op {
                Op::Fill => k,
                Op::Un(op) => kernels::un1(op, a),
                Op::SinCos => {
                    let (s, c) = kernels::sin_cos1(a);
                    r[ins.dst2 as usize] = c;
                    s
                }
                Op::Bin(op) => kernels::bin1(op, a, r[ins.b as usize]),
                Op::AddK => a + k,
                Op::MulK => a * k,
                Op::SubKX => k - a,
                Op::DivKX => k / a,
                Op::DivXK => a / k,
                Op::PowI => scalar::powi(a, k as i32),
                Op::PowF => kernels::powf1(a, k),
                Op::Select => {
                    scalar::select(a, r[ins.b as usize], r[ins.c as usize], r[ins.e as usize])
                }
            };
            r[ins.dst as usize] = x;
        }
        for (o, &s) in out.iter_mut().zip(&self.outputs) {
            *o = r[s as usize];
        }
    }
}
