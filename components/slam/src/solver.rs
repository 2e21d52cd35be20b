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

use crate::factors::{Factor, Var, VarKind};
use crate::lie::skew;

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SolverError {
    /// Nothing to optimise.
    NoFreeVariables,
    /// A factor names a variable that does not exist.
    BadVariable { factor: usize, var: usize },
    /// The sparse analysis failed (out of memory or index overflow).
    Analysis(String),
    /// A rigid variable's parent is missing, itself rigid, or of another
    /// kind than a full pose.
    BadAttachment { var: usize },
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
            SolverError::BadAttachment { var } => write!(
                f,
                "variable {var} is attached to a parent that is missing, attached itself, or not a full pose"
            ),
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
    /// Column offset of each variable in the system, `usize::MAX` if fixed;
    /// a rigid variable has its parent's.
    offset: Vec<usize>,
    /// The variable whose block each variable's factors go to: itself, or
    /// its parent if it is rigid.
    owner: Vec<usize>,
    /// The rigid variables, moved with their parents.
    rigid: Vec<usize>,
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
    /// The variables moved by the step being evaluated.
    trial: Vec<Var>,
    /// Where the current iteration stands (see [`Solver::advance`]).
    stage: Stage,
    /// Whether the current linearisation carries second-order terms.
    newton_now: bool,
    /// Factorisations tried in the current iteration.
    attempts: u32,
    /// Cost summed so far by the stage in progress.
    partial_cost: f64,
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
        let owner = owners(vars)?;
        let offset = block_order(vars, factors, &owner)?;
        let n: usize = (0..vars.len())
            .filter(|&v| is_free(vars, v))
            .map(|v| vars[v].kind.dim())
            .sum();
        if n == 0 {
            return Err(SolverError::NoFreeVariables);
        }
        // Neighbours of each free variable that come earlier in the system.
        let mut earlier: Vec<Vec<usize>> = vec![Vec::new(); vars.len()];
        for f in factors {
            let (v, nv) = mapped_vars(f, &owner);
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
        let mut in_order: Vec<usize> = (0..vars.len()).filter(|&v| is_free(vars, v)).collect();
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
            let (v, nv) = mapped_vars(f, &owner);
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
                let (v, nv) = mapped_vars(f, &owner);
                // Between two members of one rigid group: a constant.
                let (orig, _) = f.vars();
                let internal = nv == 2 && v[0] == v[1] && orig[0] != orig[1];
                !internal && v[..nv].iter().any(|&x| offset[x] != usize::MAX)
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
        let rigid = (0..vars.len()).filter(|&v| owner[v] != v).collect();
        Ok(Solver {
            params,
            offset,
            owner,
            rigid,
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
            trial: vars.to_vec(),
            stage: Stage::Start,
            newton_now: params.newton,
            attempts: 0,
            partial_cost: 0.0,
            active,
            lambda: params.initial_lambda,
            cost: f64::NAN,
            converged: false,
            iterations: 0,
            factorizations: 0,
        })
    }

    /// The part of an iteration the next [`advance`](Self::advance) does:
    /// "start", "assemble" (linearise), "solve" (factorise) or "evaluate".
    pub fn stage(&self) -> &'static str {
        match self.stage {
            Stage::Start => "start",
            Stage::Assemble(_) => "assemble",
            Stage::Solve => "solve",
            Stage::Evaluate(_) => "evaluate",
        }
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
        self.stage = Stage::Start;
    }

    /// One Levenberg-Marquardt iteration on `vars`, start to end.
    pub fn iterate(&mut self, vars: &mut [Var], factors: &[Factor]) -> Step {
        loop {
            if let Some(step) = self.advance(vars, factors, usize::MAX) {
                return step;
            }
        }
    }

    /// One bounded part of an iteration: linearise or evaluate at most
    /// `quantum` factors, or factorise and solve once. Returns the
    /// iteration's outcome when it ends, `None` while it is under way.
    /// `vars` change only when a step is accepted, so a caller may read
    /// them between parts; it must not change them or `factors` until the
    /// iteration ends (or it builds a new solver).
    pub fn advance(
        &mut self,
        vars: &mut [Var],
        factors: &[Factor],
        quantum: usize,
    ) -> Option<Step> {
        let quantum = quantum.max(1);
        match self.stage {
            Stage::Start => {
                if self.converged {
                    return Some(Step::Converged);
                }
                self.iterations += 1;
                self.attempts = 0;
                follow_parents(vars, &self.rigid);
                // Newton where factors give their curvature; if that step
                // cannot be factorised or does not lower the cost,
                // Gauss-Newton, then damping.
                self.newton_now = self.params.newton;
                self.begin_assembly();
                None
            }
            Stage::Assemble(from) => {
                let to = from.saturating_add(quantum).min(self.active.len());
                self.partial_cost += self.assemble_range(vars, factors, from..to);
                if to == self.active.len() {
                    self.end_assembly();
                    self.cost = self.partial_cost;
                    self.stage = Stage::Solve;
                } else {
                    self.stage = Stage::Assemble(to);
                }
                None
            }
            Stage::Solve => self.solve_stage(vars),
            Stage::Evaluate(from) => {
                let to = from.saturating_add(quantum).min(self.active.len());
                let trial = &self.trial;
                self.partial_cost += self.active[from..to]
                    .iter()
                    .map(|&fi| factors[fi].cost(trial))
                    .sum::<f64>();
                if to < self.active.len() {
                    self.stage = Stage::Evaluate(to);
                    return None;
                }
                self.judge(vars)
            }
        }
    }

    /// Factorise the damped system and solve for a step, or give up on it.
    fn solve_stage(&mut self, vars: &[Var]) -> Option<Step> {
        self.attempts += 1;
        let Some(delta_max) = self.solve_damped() else {
            if self.newton_now {
                self.newton_now = false;
                self.begin_assembly();
                return None;
            }
            self.lambda *= 10.0;
            return self.next_attempt();
        };
        if delta_max < self.params.step_tolerance {
            self.converged = true;
            self.stage = Stage::Start;
            return Some(Step::Converged);
        }
        self.trial.copy_from_slice(vars);
        self.apply_to_trial();
        self.partial_cost = 0.0;
        self.stage = Stage::Evaluate(0);
        None
    }

    /// Keep the evaluated step if it lowered the cost.
    fn judge(&mut self, vars: &mut [Var]) -> Option<Step> {
        let (cost, new_cost) = (self.cost, self.partial_cost);
        let predicted = self.predicted_decrease();
        let rho = (cost - new_cost) / predicted.max(1e-300);
        if new_cost < cost && rho > 0.0 {
            vars.copy_from_slice(&self.trial);
            // Nielsen's update of the damping, allowed to fall faster.
            let t = 2.0 * rho - 1.0;
            self.lambda *= 0.1f64.max(1.0 - t * t * t);
            self.lambda = self.lambda.max(1e-15);
            if (cost - new_cost) <= self.params.relative_tolerance * cost {
                self.converged = true;
            }
            self.cost = new_cost;
            self.stage = Stage::Start;
            return Some(Step::Accepted { cost: new_cost });
        }
        if self.newton_now {
            self.newton_now = false;
            self.begin_assembly();
            return None;
        }
        self.lambda *= 4.0;
        if self.lambda > 1e16 {
            self.converged = true;
            self.stage = Stage::Start;
            return Some(Step::Converged);
        }
        self.next_attempt()
    }

    /// Another factorisation with more damping, if the iteration has one left.
    fn next_attempt(&mut self) -> Option<Step> {
        if self.attempts >= self.params.attempts_per_iteration.max(1) {
            self.stage = Stage::Start;
            return Some(Step::Rejected);
        }
        self.stage = Stage::Solve;
        None
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

    /// Clear the system for a new linearisation.
    fn begin_assembly(&mut self) {
        self.values.iter_mut().for_each(|v| *v = 0.0);
        self.rhs.iter_mut().for_each(|v| *v = 0.0);
        self.partial_cost = 0.0;
        self.stage = Stage::Assemble(0);
    }

    /// Add the active factors `range` to J^T J (upper, in `values`) and
    /// -J^T r (in `rhs`); returns their cost.
    fn assemble_range(
        &mut self,
        vars: &[Var],
        factors: &[Factor],
        range: core::ops::Range<usize>,
    ) -> f64 {
        let curvature = self.newton_now;
        let mut cost = 0.0;
        for i in range {
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
            // A rigid variable's Jacobian, carried to its parent's tangent.
            let own = lin.vars;
            for (a, &v) in own.iter().enumerate().take(lin.nvars) {
                if self.owner[v] != v {
                    lin.j[a] *= rigid_tangent_map(vars, v);
                    lin.vars[a] = self.owner[v];
                }
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
                if curvature && own[a] == va {
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
        cost
    }

    /// Keep the undamped diagonal, which the damping scales.
    fn end_assembly(&mut self) {
        for k in 0..self.n {
            // The diagonal entry is the last of each column (rows ascend).
            self.diag[k] = self.values[self.col_ptr[k + 1] - 1].clamp(1e-9, 1e32);
        }
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

    /// Move `trial` (a copy of the variables) by the solved step.
    fn apply_to_trial(&mut self) {
        for (v, &o) in self.trial.iter_mut().zip(self.offset.iter()) {
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
        follow_parents(&mut self.trial, &self.rigid);
    }
}

/// Whether variable `v` is a state of the system.
fn is_free(vars: &[Var], v: usize) -> bool {
    !vars[v].fixed && vars[v].rigid.is_none()
}

/// Each variable's owner (itself, or its parent if rigid), checked.
fn owners(vars: &[Var]) -> Result<Vec<usize>, SolverError> {
    let mut owner: Vec<usize> = (0..vars.len()).collect();
    for (v, x) in vars.iter().enumerate() {
        if let Some(r) = x.rigid {
            let ok = r.parent != v
                && vars.get(r.parent).is_some_and(|p| {
                    p.rigid.is_none() && p.kind == VarKind::Pose3 && x.kind == VarKind::Pose3
                });
            if !ok {
                return Err(SolverError::BadAttachment { var: v });
            }
            owner[v] = r.parent;
        }
    }
    Ok(owner)
}

/// A factor's variables with rigid ones replaced by their parents.
fn mapped_vars(f: &Factor, owner: &[usize]) -> ([usize; 2], usize) {
    let (v, nv) = f.vars();
    let map = |x: usize| owner.get(x).copied().unwrap_or(x);
    ([map(v[0]), map(v[1])], nv)
}

/// Put rigid variables back at their offsets from their parents.
fn follow_parents(vars: &mut [Var], rigid: &[usize]) {
    for &v in rigid {
        if let Some(r) = vars[v].rigid {
            vars[v].pose = vars[r.parent].pose.compose(&r.offset);
        }
    }
}

/// d(tangent of rigid `v`) / d(tangent of its parent P), for `v = P * O`
/// under the retraction `(t + dt, R Exp(phi))`: phi_v = O.r^T phi and
/// dt_v = dt - P.r [O.t]x phi.
fn rigid_tangent_map(vars: &[Var], v: usize) -> Matrix6<f64> {
    let mut m = Matrix6::identity();
    if let Some(r) = vars[v].rigid {
        let pr = vars[r.parent].pose.r;
        m.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-(pr * skew(&r.offset.t))));
        m.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&r.offset.r.transpose());
    }
    m
}

/// Where an iteration stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// Between iterations.
    Start,
    /// Linearising the active factors from this index on.
    Assemble(usize),
    /// Factorising and solving the damped system.
    Solve,
    /// Costing the trial step, active factors from this index on.
    Evaluate(usize),
}

/// System offsets of the variables (`usize::MAX` if fixed), in an
/// approximate-minimum-degree order of the block graph: ordering blocks
/// rather than scalars is cheaper and keeps each pose's 6 columns together.
fn block_order(
    vars: &[Var],
    factors: &[Factor],
    owner: &[usize],
) -> Result<Vec<usize>, SolverError> {
    let free: Vec<usize> = (0..vars.len()).filter(|&v| is_free(vars, v)).collect();
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
        let (v, _) = mapped_vars(f, owner);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::factors::{Rigid, Robust};
    use crate::lie::{exp_so3, Pose};

    fn pose(phi: [f64; 3], t: [f64; 3]) -> Pose {
        Pose::new(exp_so3(&Vector3::from(phi)), Vector3::from(t))
    }

    fn free(p: Pose) -> Var {
        Var {
            pose: p,
            kind: VarKind::Pose3,
            fixed: false,
            rigid: None,
        }
    }

    /// A factor on a rigid variable, differentiated through its parent,
    /// matches central differences of the residual when the parent moves.
    #[test]
    fn a_rigid_variables_jacobian_carries_to_its_parent() {
        let parent = pose([0.3, -0.2, 1.1], [2.0, -1.0, 0.5]);
        let offset = pose([-0.1, 0.25, 0.4], [0.7, 0.3, -0.2]);
        let mut vars = vec![
            free(parent),
            Var {
                rigid: Some(Rigid { parent: 0, offset }),
                ..free(parent.compose(&offset))
            },
            free(pose([0.05, 0.1, -0.3], [3.0, 0.2, 0.1])),
        ];
        let f = Factor::Between {
            i: 1,
            j: 2,
            z: pose([0.0, 0.1, 0.2], [1.0, 0.0, 0.0]),
            sqrt_info: Matrix6::from_diagonal(&nalgebra::Vector6::new(
                1.0, 2.0, 3.0, 4.0, 5.0, 6.0,
            )),
            robust: Robust::None,
        };
        let lin = f.linearize(&vars);
        let j = lin.j[0] * rigid_tangent_map(&vars, 1);
        let h = 1e-6;
        for k in 0..6 {
            let mut d = [0.0; 6];
            let mut residual = |vars: &mut Vec<Var>, s: f64| {
                d[k] = s;
                vars[0].pose = parent.retract(
                    &Vector3::new(d[0], d[1], d[2]),
                    &Vector3::new(d[3], d[4], d[5]),
                );
                follow_parents(vars, &[1]);
                f.linearize(vars).r
            };
            let plus = residual(&mut vars, h);
            let minus = residual(&mut vars, -h);
            let numeric = (plus - minus) / (2.0 * h);
            for row in 0..lin.rows {
                assert!(
                    (numeric[row] - j[(row, k)]).abs() < 1e-6,
                    "row {row} col {k}: numeric {} analytic {}",
                    numeric[row],
                    j[(row, k)]
                );
            }
        }
    }

    /// A chain whose middle poses ride rigidly on their group's first pose:
    /// with exact measurements the groups fall back into place, and the
    /// measurements between members of one group cost nothing.
    #[test]
    fn rigid_groups_converge_like_the_poses_they_carry() {
        let truth: Vec<Pose> = (0..12)
            .map(|k| {
                pose(
                    [0.0, 0.02 * k as f64, 0.1 * k as f64],
                    [k as f64, 0.3 * k as f64, 0.0],
                )
            })
            .collect();
        let mut vars: Vec<Var> = truth.iter().map(|p| free(*p)).collect();
        let mut factors = vec![Factor::Anchor {
            i: 0,
            position: truth[0].t,
            yaw: truth[0].yaw(),
            sqrt_weight: 1e3,
        }];
        for k in 1..12 {
            for back in 1..=2.min(k) {
                factors.push(Factor::Between {
                    i: k - back,
                    j: k,
                    z: truth[k - back].between(&truth[k]),
                    sqrt_info: Matrix6::identity() * 10.0,
                    robust: Robust::Cauchy(3.0),
                });
            }
        }
        // Roll and pitch of the anchor: a prior on its rotation.
        factors.push(Factor::RotationPrior {
            i: 0,
            r: truth[0].r,
            sqrt_weight: 10.0,
        });
        // Groups of four: 0..4, 4..8, 8..12, members at their true offsets.
        for k in 0..12 {
            if k % 4 != 0 {
                let root = k - k % 4;
                vars[k].rigid = Some(Rigid {
                    parent: root,
                    offset: truth[root].between(&truth[k]),
                });
            }
        }
        // Move the roots away.
        for root in [4, 8] {
            vars[root].pose = vars[root].pose.retract(
                &Vector3::new(0.3, -0.2, 0.1),
                &Vector3::new(0.02, -0.03, 0.05),
            );
        }
        let mut solver = Solver::new(
            &vars,
            &factors,
            LmParams {
                newton: false,
                ..LmParams::default()
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(solver.unknowns(), 18, "three roots of six unknowns");
        let cost = solver.solve(&mut vars, &factors, 20);
        assert!(cost < 1e-16, "cost {cost}");
        assert!(solver.iterations <= 8, "{} iterations", solver.iterations);
        for (k, t) in truth.iter().enumerate() {
            assert!((vars[k].pose.t - t.t).norm() < 1e-7, "pose {k} off");
        }
    }

    #[test]
    fn an_attachment_to_a_rigid_parent_is_refused() {
        let p = pose([0.0; 3], [0.0; 3]);
        let rigid = |parent| Var {
            rigid: Some(Rigid { parent, offset: p }),
            ..free(p)
        };
        let vars = vec![free(p), rigid(0), rigid(1)];
        let err = Solver::new(&vars, &[], LmParams::default()).err();
        assert_eq!(err, Some(SolverError::BadAttachment { var: 2 }));
    }
}
