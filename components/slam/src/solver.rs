//! Levenberg-Marquardt over a pose graph on a sparse Cholesky factorisation
//! (faer). The structure (which variables share factors) is analysed once in
//! [`Solver::new`]: the sparsity pattern, the fill-reducing ordering and the
//! symbolic factorisation, the value and scratch buffers. Each iteration
//! then only assembles numbers into fixed slots, factorises and solves,
//! allocating nothing. Iterations are the anytime steps of the back end.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::{amd, SupernodalThreshold};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side, Spec};
use nalgebra::{Matrix6, Vector3};

use crate::factors::{Factor, Var};

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SolverError {
    /// Nothing to optimise.
    NoFreeVariables,
    /// A factor names a variable that does not exist.
    BadVariable { factor: usize, var: usize },
    /// The sparse analysis failed (out of memory or index overflow).
    Analysis(String),
}

impl std::fmt::Display for SolverError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SolverError::NoFreeVariables => write!(f, "the graph has no free variables"),
            SolverError::BadVariable { factor, var } => {
                write!(
                    f,
                    "factor {factor} refers to variable {var}, which does not exist"
                )
            }
            SolverError::Analysis(e) => write!(f, "sparse analysis failed: {e}"),
        }
    }
}

impl std::error::Error for SolverError {}

/// Settings of the damping and the stopping rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmParams {
    pub initial_lambda: f64,
    /// Stop when the relative cost decrease of an accepted step is below this
    /// (1e-5, the relative tolerance of GTSAM's Levenberg-Marquardt).
    pub relative_tolerance: f64,
    /// Stop when the step's largest component is below this.
    pub step_tolerance: f64,
    /// Iterative-refinement passes after each solve.
    pub refinement_steps: u32,
    /// Add the factors' second-order terms where they provide them
    /// (chordal factors): Newton instead of Gauss-Newton steps.
    pub newton: bool,
    /// Factorisations one [`Solver::iterate`] may try (after a step that
    /// raised the cost, with more damping). 1 bounds an iteration's time:
    /// a rejected step is reported and the next call damps more.
    pub attempts_per_iteration: u32,
}

impl Default for LmParams {
    fn default() -> Self {
        LmParams {
            initial_lambda: 1e-12,
            relative_tolerance: 1e-5,
            step_tolerance: 1e-10,
            refinement_steps: 2,
            newton: true,
            attempts_per_iteration: 10,
        }
    }
}

/// What one iteration did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// The step lowered the cost and was kept.
    Accepted { cost: f64 },
    /// The step did not lower the cost; damping went up.
    Rejected,
    /// Converged: further iterations would change nothing that matters.
    Converged,
}

/// The preallocated solver for one graph structure.
pub struct Solver {
    params: LmParams,
    /// Column offset of each variable in the system, `usize::MAX` if fixed.
    offset: Vec<usize>,
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// Per variable: position of its diagonal block inside each of its columns.
    diag_pre: Vec<usize>,
    /// Per factor: position of the off-diagonal block inside the later
    /// variable's columns (for two-variable factors with both free).
    pair_pre: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    rhs: Vec<f64>,
    delta: Vec<f64>,
    correction: Vec<f64>,
    diag: Vec<f64>,
    backup: Vec<Var>,
    /// Factors touching a free variable: the others add a constant cost and
    /// nothing to the system, so a long frozen past costs nothing.
    active: Vec<usize>,
    lambda: f64,
    cost: f64,
    converged: bool,
    pub iterations: u32,
    /// Numeric factorisations attempted (iterations plus retries).
    pub factorizations: u32,
}

impl Solver {
    /// Analyse the structure of `factors` over `vars` (fixed variables are
    /// held constant).
    pub fn new(vars: &[Var], factors: &[Factor], params: LmParams) -> Result<Self, SolverError> {
        let offset = block_order(vars, factors)?;
        let n: usize = vars.iter().filter(|v| !v.fixed).map(|v| v.kind.dim()).sum();
        if n == 0 {
            return Err(SolverError::NoFreeVariables);
        }
        // Neighbours of each free variable that come earlier in the system.
        let mut earlier: Vec<Vec<usize>> = vec![Vec::new(); vars.len()];
        for f in factors {
            let (v, nv) = f.vars();
            if nv == 2 && offset[v[0]] != usize::MAX && offset[v[1]] != usize::MAX {
                let (a, b) = order(&offset, v[0], v[1]);
                if a != b {
                    earlier[b].push(a);
                }
            }
        }
        for e in earlier.iter_mut() {
            e.sort_unstable_by_key(|&u| offset[u]);
            e.dedup();
        }
        let mut diag_pre = vec![0; vars.len()];
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::new();
        // Columns in system order.
        let mut in_order: Vec<usize> = (0..vars.len()).filter(|&v| !vars[v].fixed).collect();
        in_order.sort_unstable_by_key(|&v| offset[v]);
        for v in in_order {
            let var = &vars[v];
            let pre: usize = earlier[v].iter().map(|&u| vars[u].kind.dim()).sum();
            diag_pre[v] = pre;
            for k in 0..var.kind.dim() {
                for &u in &earlier[v] {
                    row_idx.extend(offset[u]..offset[u] + vars[u].kind.dim());
                }
                row_idx.extend(offset[v]..=offset[v] + k);
                col_ptr.push(row_idx.len());
            }
        }
        let mut pair_pre = vec![usize::MAX; factors.len()];
        for (fi, f) in factors.iter().enumerate() {
            let (v, nv) = f.vars();
            if nv == 2 && offset[v[0]] != usize::MAX && offset[v[1]] != usize::MAX {
                let (a, b) = order(&offset, v[0], v[1]);
                if a != b {
                    let mut pre = 0;
                    for &u in &earlier[b] {
                        if u == a {
                            break;
                        }
                        pre += vars[u].kind.dim();
                    }
                    pair_pre[fi] = pre;
                }
            }
        }
        let active = factors
            .iter()
            .enumerate()
            .filter(|(_, f)| {
                let (v, nv) = f.vars();
                v[..nv].iter().any(|&x| offset[x] != usize::MAX)
            })
            .map(|(i, _)| i)
            .collect();
        let values = vec![0.0; row_idx.len()];
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Upper,
            // Already ordered block-wise by `block_order`.
            SymmetricOrdering::Identity,
            CholeskySymbolicParams {
                // Pose graphs have dense 6x6 blocks: supernodes pay off.
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..CholeskySymbolicParams::default()
            },
        )
        .map_err(|e| SolverError::Analysis(format!("{e:?}")))?;
        let l_values = vec![0.0; symbolic.len_val()];
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Spec::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        Ok(Solver {
            params,
            offset,
            n,
            col_ptr,
            row_idx,
            values,
            diag_pre,
            pair_pre,
            symbolic,
            l_values,
            mem: MemBuffer::new(req),
            rhs: vec![0.0; n],
            delta: vec![0.0; n],
            correction: vec![0.0; n],
            diag: vec![0.0; n],
            backup: vars.to_vec(),
            active,
            lambda: params.initial_lambda,
            cost: f64::NAN,
            converged: false,
            iterations: 0,
            factorizations: 0,
        })
    }

    /// Unknowns in the linear system.
    pub fn unknowns(&self) -> usize {
        self.n
    }

    /// Non-zeros of the upper triangle of the system and of its factor.
    pub fn nonzeros(&self) -> (usize, usize) {
        (self.row_idx.len(), self.l_values.len())
    }

    pub fn converged(&self) -> bool {
        self.converged
    }

    /// Current damping.
    pub fn lambda(&self) -> f64 {
        self.lambda
    }

    /// Let the next iteration start over (after new measurements arrived on
    /// the same structure).
    pub fn reset(&mut self) {
        self.converged = false;
        self.cost = f64::NAN;
        self.lambda = self.params.initial_lambda;
    }

    /// One Levenberg-Marquardt iteration on `vars`.
    pub fn iterate(&mut self, vars: &mut [Var], factors: &[Factor]) -> Step {
        if self.converged {
            return Step::Converged;
        }
        self.iterations += 1;
        // Newton where factors give their curvature; if that step cannot be
        // factorised or does not lower the cost, Gauss-Newton, then damping.
        let mut newton = self.params.newton;
        let cost = self.assemble(vars, factors, newton);
        self.cost = cost;
        for _ in 0..self.params.attempts_per_iteration.max(1) {
            let Some(delta_max) = self.solve_damped() else {
                if newton {
                    newton = false;
                    self.assemble(vars, factors, false);
                } else {
                    self.lambda *= 10.0;
                }
                continue;
            };
            if delta_max < self.params.step_tolerance {
                self.converged = true;
                return Step::Converged;
            }
            self.backup.copy_from_slice(vars);
            self.apply(vars);
            let new_cost = self.active_cost(vars, factors);
            let predicted = self.predicted_decrease();
            let rho = (cost - new_cost) / predicted.max(1e-300);
            if new_cost < cost && rho > 0.0 {
                // Nielsen's update of the damping, allowed to fall faster.
                let t = 2.0 * rho - 1.0;
                self.lambda *= 0.1f64.max(1.0 - t * t * t);
                self.lambda = self.lambda.max(1e-15);
                if (cost - new_cost) <= self.params.relative_tolerance * cost {
                    self.converged = true;
                }
                self.cost = new_cost;
                return Step::Accepted { cost: new_cost };
            }
            vars.copy_from_slice(&self.backup);
            if newton {
                newton = false;
                self.assemble(vars, factors, false);
                continue;
            }
            self.lambda *= 4.0;
            if self.lambda > 1e16 {
                self.converged = true;
                return Step::Converged;
            }
        }
        Step::Rejected
    }

    /// Run until converged or `max_iterations`; returns the final cost.
    pub fn solve(&mut self, vars: &mut [Var], factors: &[Factor], max_iterations: u32) -> f64 {
        for _ in 0..max_iterations {
            if self.iterate(vars, factors) == Step::Converged {
                break;
            }
        }
        factors.iter().map(|f| f.cost(vars)).sum()
    }

    /// Cost of the factors that touch free variables.
    fn active_cost(&self, vars: &[Var], factors: &[Factor]) -> f64 {
        self.active.iter().map(|&fi| factors[fi].cost(vars)).sum()
    }

    /// Build J^T J (upper) into `values` and -J^T r into `rhs`; returns the
    /// cost of the active factors.
    fn assemble(&mut self, vars: &[Var], factors: &[Factor], curvature: bool) -> f64 {
        self.values.iter_mut().for_each(|v| *v = 0.0);
        self.rhs.iter_mut().for_each(|v| *v = 0.0);
        let mut cost = 0.0;
        for i in 0..self.active.len() {
            let fi = self.active[i];
            let f = &factors[fi];
            let mut lin = f.linearize(vars);
            let rows = lin.rows;
            let s = lin.r.rows(0, rows).norm_squared();
            let robust = f.robust();
            cost += robust.rho(s);
            let w = robust.weight(s).sqrt();
            if w != 1.0 {
                lin.r *= w;
                lin.j[0] *= w;
                lin.j[1] *= w;
            }
            for a in 0..lin.nvars {
                let va = lin.vars[a];
                if self.offset[va] == usize::MAX {
                    continue;
                }
                let g = lin.j[a].transpose() * lin.r;
                for (k, &c) in vars[va].kind.columns().iter().enumerate() {
                    self.rhs[self.offset[va] + k] -= g[c];
                }
                if curvature {
                    if let Some(c) = f.curvature(vars) {
                        let mut h = Matrix6::zeros();
                        h.fixed_view_mut::<3, 3>(3, 3).copy_from(&c[a]);
                        self.add_block(vars, fi, va, va, &h);
                    }
                }
                for b in a..lin.nvars {
                    let vb = lin.vars[b];
                    if self.offset[vb] == usize::MAX || (b > a && va == vb) {
                        continue;
                    }
                    let h = lin.j[a].transpose() * lin.j[b];
                    self.add_block(vars, fi, va, vb, &h);
                }
            }
        }
        for k in 0..self.n {
            // The diagonal entry is the last of each column (rows ascend).
            self.diag[k] = self.values[self.col_ptr[k + 1] - 1].clamp(1e-9, 1e32);
        }
        cost
    }

    /// Add `h = J_a^T J_b` (over full tangents) into the system at the
    /// block of the pair; the variable earlier in the system gives the rows.
    fn add_block(&mut self, vars: &[Var], fi: usize, va: usize, vb: usize, h: &Matrix6<f64>) {
        let (rv, cv, h) = if self.offset[va] <= self.offset[vb] {
            (va, vb, *h)
        } else {
            (vb, va, h.transpose())
        };
        let same = rv == cv;
        let pre = if same {
            self.diag_pre[cv]
        } else {
            self.pair_pre[fi]
        };
        let rcols = vars[rv].kind.columns();
        for (k, &cc) in vars[cv].kind.columns().iter().enumerate() {
            let base = self.col_ptr[self.offset[cv] + k] + pre;
            for (i, &rc) in rcols.iter().enumerate() {
                if same && i > k {
                    break;
                }
                self.values[base + i] += h[(rc, cc)];
            }
        }
    }

    /// Solve (H + lambda D) delta = -g into `delta`; returns max |delta|.
    fn solve_damped(&mut self) -> Option<f64> {
        self.factorizations += 1;
        for (k, &d) in self.diag.iter().enumerate() {
            let p = self.col_ptr[k + 1] - 1;
            self.values[p] = d * (1.0 + self.lambda);
        }
        let sym = SymbolicSparseColMatRef::new_checked(
            self.n,
            self.n,
            &self.col_ptr,
            None,
            &self.row_idx,
        );
        let a = SparseColMatRef::new(sym, &self.values);
        let llt = self
            .symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                a,
                Side::Upper,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.mem),
                Spec::default(),
            )
            .ok()?;
        self.delta.copy_from_slice(&self.rhs);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut self.delta, self.n, 1),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        // Pose graphs are badly conditioned (millimetre translations against
        // long chains): refine the solution against the assembled matrix.
        for _ in 0..self.params.refinement_steps {
            damped_residual(
                &self.col_ptr,
                &self.row_idx,
                &self.values,
                &self.rhs,
                &self.delta,
                &mut self.correction,
            );
            llt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut self.correction, self.n, 1),
                Par::Seq,
                MemStack::new(&mut self.mem),
            );
            for (d, c) in self.delta.iter_mut().zip(&self.correction) {
                *d += c;
            }
        }
        let m = self.delta.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        m.is_finite().then_some(m)
    }

    /// Decrease of the linearised cost for the step in `delta`:
    /// `-2 g.d - d^T H d = -g.d + lambda d^T D d` (since H d = -g - lambda D d).
    fn predicted_decrease(&self) -> f64 {
        let mut p = 0.0;
        for k in 0..self.n {
            let d = self.delta[k];
            p += self.rhs[k] * d + self.lambda * self.diag[k] * d * d;
        }
        p
    }

    fn apply(&self, vars: &mut [Var]) {
        for (v, &o) in vars.iter_mut().zip(self.offset.iter()) {
            if o == usize::MAX {
                continue;
            }
            let mut t = [0.0; 6];
            for (k, &c) in v.kind.columns().iter().enumerate() {
                t[c] = self.delta[o + k];
            }
            v.pose = v.pose.retract(
                &Vector3::new(t[0], t[1], t[2]),
                &Vector3::new(t[3], t[4], t[5]),
            );
        }
    }
}

/// System offsets of the variables (`usize::MAX` if fixed), in an
/// approximate-minimum-degree order of the block graph: ordering blocks
/// rather than scalars is cheaper and keeps each pose's 6 columns together.
fn block_order(vars: &[Var], factors: &[Factor]) -> Result<Vec<usize>, SolverError> {
    let free: Vec<usize> = (0..vars.len()).filter(|&v| !vars[v].fixed).collect();
    if free.is_empty() {
        return Err(SolverError::NoFreeVariables);
    }
    let mut block = vec![usize::MAX; vars.len()];
    for (b, &v) in free.iter().enumerate() {
        block[v] = b;
    }
    let m = free.len();
    let mut upper: Vec<Vec<usize>> = (0..m).map(|b| vec![b]).collect();
    for (fi, f) in factors.iter().enumerate() {
        let (v, nv) = f.vars();
        for &x in &v[..nv] {
            if x >= vars.len() {
                return Err(SolverError::BadVariable { factor: fi, var: x });
            }
        }
        if nv == 2 && block[v[0]] != usize::MAX && block[v[1]] != usize::MAX {
            let (a, b) = (block[v[0]].min(block[v[1]]), block[v[0]].max(block[v[1]]));
            upper[b].push(a);
        }
    }
    let mut col_ptr = Vec::with_capacity(m + 1);
    col_ptr.push(0);
    let mut rows = Vec::new();
    for mut u in upper {
        u.sort_unstable();
        u.dedup();
        rows.extend(u);
        col_ptr.push(rows.len());
    }
    let mut perm = vec![0usize; m];
    let mut perm_inv = vec![0usize; m];
    let sym = SymbolicSparseColMatRef::new_checked(m, m, &col_ptr, None, &rows);
    let mut mem = MemBuffer::new(amd::order_scratch::<usize>(m, rows.len()));
    amd::order(
        &mut perm,
        &mut perm_inv,
        sym,
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| SolverError::Analysis(format!("{e:?}")))?;
    let mut offset = vec![usize::MAX; vars.len()];
    let mut next = 0;
    for &b in &perm {
        let v = free[b];
        offset[v] = next;
        next += vars[v].kind.dim();
    }
    Ok(offset)
}

/// `out = rhs - A x` with A symmetric, its upper triangle stored by columns.
fn damped_residual(
    col_ptr: &[usize],
    row_idx: &[usize],
    values: &[f64],
    rhs: &[f64],
    x: &[f64],
    out: &mut [f64],
) {
    out.copy_from_slice(rhs);
    for c in 0..x.len() {
        let xc = x[c];
        let mut acc = 0.0;
        for p in col_ptr[c]..col_ptr[c + 1] {
            let (r, a) = (row_idx[p], values[p]);
            acc += a * x[r];
            if r != c {
                out[r] -= a * xc;
            }
        }
        out[c] -= acc;
    }
}

fn order(offset: &[usize], x: usize, y: usize) -> (usize, usize) {
    if offset[x] <= offset[y] {
        (x, y)
    } else {
        (y, x)
    }
}
