//! The flat tape: a bound expression DAG emitted as a list of instructions
//! over numbered slots (registers), with slots reused once their value is
//! dead, `sin`/`cos` of one argument fused into one `SinCos`, and constant
//! operands of + − × ÷ carried as immediates.
//!
//! Batches are evaluated in structure-of-arrays form: each instruction is a
//! tight loop over a chunk of [`CHUNK`] points, so the dispatch is amortised
//! and the loops vectorise. [`Program::eval_point`] is the one-point path
//! (no allocation for tapes of up to 64 slots).

use super::fastmath as fm;
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

/// The one-point form of an operation: a flat code, so the single-point
/// interpreter dispatches once per instruction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Pt {
    Fill,
    Neg,
    Sin,
    Cos,
    Exp,
    Ln,
    Sqrt,
    Abs,
    OtherUn,
    SinCos,
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
    OtherBin,
    AddK,
    MulK,
    SubKX,
    DivKX,
    DivXK,
    Sqr,
    PowI,
    PowF,
    Select,
}

impl Pt {
    fn of(op: Op, k: f64) -> Pt {
        match op {
            Op::Fill => Pt::Fill,
            Op::Un(u) => match u {
                Un::Neg => Pt::Neg,
                Un::Sin => Pt::Sin,
                Un::Cos => Pt::Cos,
                Un::Exp => Pt::Exp,
                Un::Ln => Pt::Ln,
                Un::Sqrt => Pt::Sqrt,
                Un::Abs => Pt::Abs,
                _ => Pt::OtherUn,
            },
            Op::SinCos => Pt::SinCos,
            Op::Bin(b) => match b {
                Bin::Add => Pt::Add,
                Bin::Sub => Pt::Sub,
                Bin::Mul => Pt::Mul,
                Bin::Div => Pt::Div,
                Bin::Min => Pt::Min,
                Bin::Max => Pt::Max,
                _ => Pt::OtherBin,
            },
            Op::AddK => Pt::AddK,
            Op::MulK => Pt::MulK,
            Op::SubKX => Pt::SubKX,
            Op::DivKX => Pt::DivKX,
            Op::DivXK => Pt::DivXK,
            Op::PowI if k == 2.0 => Pt::Sqr,
            Op::PowI => Pt::PowI,
            Op::PowF => Pt::PowF,
            Op::Select => Pt::Select,
        }
    }
}

#[derive(Debug, Clone, Copy)]
pub struct Instr {
    pub op: Op,
    pub pt: Pt,
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
const MAX_INLINE_OUT: usize = 24;

thread_local! {
    static SCRATCH: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
}

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
                    pt: Pt::Fill,
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
        // Unused operands read slot 0, so the one-point interpreter loads
        // every operand without a test.
        for ins in instrs.iter_mut() {
            ins.pt = Pt::of(ins.op, ins.k);
            for o in [&mut ins.a, &mut ins.b, &mut ins.c, &mut ins.e] {
                if *o == NONE {
                    *o = 0;
                }
            }
            if ins.dst2 == NONE {
                ins.dst2 = ins.dst;
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

    /// Evaluate one chunk of `n <= stride` points already copied into slots
    /// 0 (u) and 1 (v) of `regs` (`nslots * stride` values, slot s at
    /// `s * stride`). On x86-64 with
    /// AVX2 the same code is compiled for 4-wide vectors (no fused
    /// multiply-add is ever used, so results are identical on every path).
    fn run_chunk(&self, regs: &mut [f64], n: usize, stride: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2 (checked above).
                unsafe { self.run_chunk_avx2(regs, n, stride) };
                return;
            }
        }
        self.run_chunk_impl::<0>(regs, n, stride)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn run_chunk_avx2(&self, regs: &mut [f64], n: usize, stride: usize) {
        if stride == 4 {
            self.run_chunk_impl::<4>(regs, n, stride)
        } else {
            self.run_chunk_impl::<0>(regs, n, stride)
        }
    }

    /// One pass of the tape over `n` points in slots `stride` apart. With
    /// `W` > 0 (`stride` == `W`), all `W` lanes are computed whatever `n`:
    /// the loops then have a length known at compile time (no loop set-up
    /// per instruction, which dominates small batches such as the sweeps'
    /// look-ahead), and each lane's arithmetic is the same as in the
    /// general pass (the extra lanes are never read).
    #[inline(always)]
    fn run_chunk_impl<const W: usize>(&self, regs: &mut [f64], n: usize, stride: usize) {
        debug_assert!(regs.len() >= self.nslots * stride && n <= stride);
        debug_assert!(W == 0 || stride == W);
        let n = if W > 0 { W } else { n };
        let base = regs.as_mut_ptr();
        for ins in &self.instrs {
            // SAFETY: slots are disjoint stride-long ranges of `regs`, and
            // the emitter never makes a destination alias an operand.
            let col = |s: u32| -> &[f64] {
                unsafe { std::slice::from_raw_parts(base.add(s as usize * stride), n) }
            };
            let d =
                unsafe { std::slice::from_raw_parts_mut(base.add(ins.dst as usize * stride), n) };
            let k = ins.k;
            match ins.op {
                Op::Fill => d.fill(k),
                Op::Un(op) => kernels::un(op, col(ins.a), d),
                Op::SinCos => {
                    let d2 = unsafe {
                        std::slice::from_raw_parts_mut(base.add(ins.dst2 as usize * stride), n)
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
        if u.is_empty() {
            return;
        }
        // Slots of min(n, CHUNK) points (a multiple of 4), in a per-thread
        // scratch buffer reused across calls (no allocation per batch).
        let stride = u.len().min(CHUNK).next_multiple_of(4);
        SCRATCH.with(|cell| {
            let mut guard = cell.try_borrow_mut();
            let mut own = Vec::new();
            let regs: &mut Vec<f64> = match guard {
                Ok(ref mut g) => g,
                Err(_) => &mut own, // re-entered from a sink: use a fresh buffer
            };
            if regs.len() < self.nslots * stride {
                regs.resize(self.nslots * stride, 0.0);
            }
            let empty: &[f64] = &[];
            let mut start = 0;
            while start < u.len() {
                let n = (u.len() - start).min(stride);
                regs[..n].copy_from_slice(&u[start..start + n]);
                regs[stride..stride + n].copy_from_slice(&v[start..start + n]);
                // Whole vectors (stride is a multiple of 4): the lanes past
                // n repeat the last point, so the loops' scalar remainders
                // never run (and those lanes, never read, need no fix-up
                // that a real lane does not).
                let n4 = n.next_multiple_of(4);
                regs[n..n4].fill(u[start + n - 1]);
                regs[stride + n..stride + n4].fill(v[start + n - 1]);
                self.run_chunk(regs, n4, stride);
                let col = |s: u32| &regs[s as usize * stride..s as usize * stride + n];
                if self.outputs.len() <= MAX_INLINE_OUT {
                    let mut cols = [empty; MAX_INLINE_OUT];
                    for (c, &s) in cols.iter_mut().zip(&self.outputs) {
                        *c = col(s);
                    }
                    sink(start, &cols[..self.outputs.len()]);
                } else {
                    let cols: Vec<&[f64]> = self.outputs.iter().map(|&s| col(s)).collect();
                    sink(start, &cols);
                }
                start += n;
            }
        });
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
        if self.nslots <= 16 {
            let mut r = [0.0f64; 16];
            self.point_with(&mut r, u, v, out);
        } else if self.nslots <= 64 {
            let mut r = [0.0f64; 64];
            self.point_with(&mut r, u, v, out);
        } else {
            let mut r = vec![0.0f64; self.nslots];
            self.point_with(&mut r, u, v, out);
        }
    }

    #[inline]
    fn point_with(&self, r: &mut [f64], u: f64, v: f64, out: &mut [f64]) {
        assert!(r.len() >= self.nslots);
        r[0] = u;
        r[1] = v;
        let rp = r.as_mut_ptr();
        // SAFETY: every slot index of the program is < nslots <= r.len()
        // (the emitter numbers slots from 0 and replaces unused operands
        // by 0), checked by the assertion above.
        let get = |s: u32| unsafe { *rp.add(s as usize) };
        for ins in &self.instrs {
            let a = get(ins.a);
            let b = get(ins.b);
            let k = ins.k;
            let x = match ins.pt {
                Pt::Fill => k,
                Pt::Neg => -a,
                Pt::Sin => fm::sin_cos(a).0,
                Pt::Cos => fm::sin_cos(a).1,
                Pt::Exp => fm::exp(a),
                Pt::Ln => fm::ln(a),
                Pt::Sqrt => a.sqrt(),
                Pt::Abs => a.abs(),
                Pt::OtherUn => match ins.op {
                    Op::Un(op) => kernels::un1(op, a),
                    _ => unreachable!(),
                },
                Pt::SinCos => {
                    let (s, c) = fm::sin_cos(a);
                    unsafe { *rp.add(ins.dst2 as usize) = c };
                    s
                }
                Pt::Add => a + b,
                Pt::Sub => a - b,
                Pt::Mul => a * b,
                Pt::Div => a / b,
                Pt::Min => scalar::min(a, b),
                Pt::Max => scalar::max(a, b),
                Pt::OtherBin => match ins.op {
                    Op::Bin(op) => kernels::bin1(op, a, b),
                    _ => unreachable!(),
                },
                Pt::AddK => a + k,
                Pt::MulK => a * k,
                Pt::SubKX => k - a,
                Pt::DivKX => k / a,
                Pt::DivXK => a / k,
                Pt::Sqr => a * a,
                Pt::PowI => scalar::powi(a, k as i32),
                Pt::PowF => kernels::powf1(a, k),
                Pt::Select => scalar::select(a, b, get(ins.c), get(ins.e)),
            };
            unsafe { *rp.add(ins.dst as usize) = x };
        }
        for (o, &s) in out.iter_mut().zip(&self.outputs) {
            *o = r[s as usize];
        }
    }
}
