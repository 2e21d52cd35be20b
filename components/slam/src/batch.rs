//! Batch optimisation of a whole g2o graph (the `speleo g2o` tool): an
//! initial estimate, then Levenberg-Marquardt on the SE-Sync (chordal)
//! cost, whose optimum is the published reference figure.

use std::time::Instant;

use crate::factors::{Factor, Var, VarKind};
use crate::g2o::{Dim, G2o};
use crate::initialize;
use crate::lie::Pose;
use crate::solver::{LmParams, Solver, SolverError};

/// Where the first estimate comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Init {
    /// The vertices in the file.
    File,
    Chordal,
    SpanningTree,
}

impl Init {
    pub fn parse(s: &str) -> Option<Init> {
        Some(match s {
            "file" => Init::File,
            "chordal" => Init::Chordal,
            "spanning-tree" => Init::SpanningTree,
            _ => return None,
        })
    }
}

#[derive(Clone, Debug)]
pub struct BatchResult {
    pub poses: Vec<Pose>,
    pub iterations: u32,
    pub initial_chi2: f64,
    pub final_chi2: f64,
    pub initial_objective: f64,
    pub final_objective: f64,
    pub unknowns: usize,
    pub init_s: f64,
    pub solve_s: f64,
}

#[derive(Debug)]
pub enum BatchError {
    /// `--init file` on a file without vertices.
    NoVertices,
    /// Nothing to optimise.
    NoEdges,
    /// Vertex `id` is joined by no chain of edges to the anchor `anchor`
    /// (or, but for the chordal start, to a fixed vertex).
    Unjoined {
        id: u64,
        anchor: u64,
    },
    Init(String),
    Solver(SolverError),
}

impl std::fmt::Display for BatchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BatchError::NoVertices => {
                write!(
                    f,
                    "the file has no vertices to start from: use --init chordal or spanning-tree"
                )
            }
            BatchError::NoEdges => write!(f, "the graph has no edges: there is nothing to optimise"),
            BatchError::Unjoined { id, anchor } => write!(
                f,
                "vertex {id} is joined by no chain of edges to the held vertex {anchor}: its pose is undetermined (join it or remove it)"
            ),
            BatchError::Init(e) => write!(f, "initialisation failed: {e}"),
            BatchError::Solver(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for BatchError {}

/// Initialise and optimise `g`; the anchor (first `FIX`ed vertex, else the
/// first vertex) and every `FIX`ed vertex are held.
pub fn optimize(g: &G2o, init: Init, max_iterations: u32) -> Result<BatchResult, BatchError> {
    if g.edges.is_empty() {
        return Err(BatchError::NoEdges);
    }
    let anchor = initialize::anchor(g);
    // The chordal start holds the anchor only; the solver holds every
    // FIX vertex too.
    let mut roots = vec![anchor];
    if !matches!(init, Init::Chordal) {
        roots.extend((0..g.fixed.len()).filter(|&k| g.fixed[k]));
    }
    if let Some(k) = g.first_unjoined(&roots) {
        return Err(BatchError::Unjoined {
            id: g.ids[k],
            anchor: g.ids[anchor],
        });
    }
    let t0 = Instant::now();
    let poses = match init {
        Init::File if !g.given.iter().any(|v| *v) => return Err(BatchError::NoVertices),
        Init::File => g.poses.clone(),
        Init::Chordal => initialize::chordal(g).map_err(BatchError::Init)?,
        Init::SpanningTree => initialize::spanning_tree(g),
    };
    let init_s = t0.elapsed().as_secs_f64();
    let initial_chi2 = g.chi2(&poses);
    let initial_objective = g.sesync_objective(&poses);
    let t1 = Instant::now();
    let kind = match g.dim {
        Dim::Two => VarKind::Pose2,
        Dim::Three => VarKind::Pose3,
    };
    let mut vars: Vec<Var> = poses
        .iter()
        .enumerate()
        .map(|(k, p)| Var {
            pose: *p,
            kind,
            fixed: k == anchor || g.fixed[k],
            rigid: None,
        })
        .collect();
    let factors: Vec<Factor> = g
        .edges
        .iter()
        .map(|e| {
            let (kappa, tau) = g.sesync_weights(e);
            Factor::Chordal {
                i: e.i,
                j: e.j,
                z: e.z,
                kappa,
                tau,
            }
        })
        .collect();
    let mut solver =
        Solver::new(&vars, &factors, LmParams::default()).map_err(BatchError::Solver)?;
    solver.solve(&mut vars, &factors, max_iterations);
    let solve_s = t1.elapsed().as_secs_f64();
    let poses: Vec<Pose> = vars.iter().map(|v| v.pose).collect();
    Ok(BatchResult {
        iterations: solver.iterations,
        initial_chi2,
        final_chi2: g.chi2(&poses),
        initial_objective,
        final_objective: g.sesync_objective(&poses),
        unknowns: solver.unknowns(),
        poses,
        init_s,
        solve_s,
    })
}
