//! `speleo g2o`: optimise a g2o pose graph with the SLAM back end and print
//! both costs (g2o's chi2 and the SE-Sync objective), iterations and time.

use std::path::Path;

use serde::Serialize;
use speleo_slam::batch::{optimize, Init};
use speleo_slam::g2o::{Dim, G2o};

use crate::Error;

/// What `--report` writes.
#[derive(Serialize, Debug)]
pub struct G2oReport {
    pub file: String,
    pub dimension: u8,
    pub vertices: usize,
    pub edges: usize,
    pub skipped_lines: usize,
    pub init: String,
    pub unknowns: usize,
    pub iterations: u32,
    pub initial_chi2: f64,
    pub final_chi2: f64,
    pub initial_sesync_objective: f64,
    pub final_sesync_objective: f64,
    pub init_s: f64,
    pub solve_s: f64,
    pub total_s: f64,
}

pub fn run(
    file: &Path,
    init: &str,
    max_iterations: u32,
    out: Option<&Path>,
) -> Result<G2oReport, Error> {
    let init_kind = Init::parse(init).ok_or_else(|| {
        format!("unknown --init \"{init}\" (expected file, chordal or spanning-tree)")
    })?;
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let g = G2o::parse(&text).map_err(|e| format!("{}: {e}", file.display()))?;
    let r = optimize(&g, init_kind, max_iterations)?;
    if let Some(out) = out {
        let f = std::fs::File::create(out)
            .map_err(|e| format!("cannot create {}: {e}", out.display()))?;
        let mut w = std::io::BufWriter::new(f);
        g.write(&r.poses, &mut w)?;
        std::io::Write::flush(&mut w)?;
    }
    Ok(G2oReport {
        file: file.display().to_string(),
        dimension: if g.dim == Dim::Two { 2 } else { 3 },
        vertices: g.poses.len(),
        edges: g.edges.len(),
        skipped_lines: g.skipped_lines,
        init: init.to_string(),
        unknowns: r.unknowns,
        iterations: r.iterations,
        initial_chi2: r.initial_chi2,
        final_chi2: r.final_chi2,
        initial_sesync_objective: r.initial_objective,
        final_sesync_objective: r.final_objective,
        init_s: r.init_s,
        solve_s: r.solve_s,
        total_s: r.init_s + r.solve_s,
    })
}

impl std::fmt::Display for G2oReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{}: {}D, {} vertices, {} edges ({} unknowns)",
            self.file, self.dimension, self.vertices, self.edges, self.unknowns
        )?;
        writeln!(
            f,
            "chi2             {:.6} -> {:.6}",
            self.initial_chi2, self.final_chi2
        )?;
        writeln!(
            f,
            "SE-Sync objective {:.6} -> {:.6}",
            self.initial_sesync_objective, self.final_sesync_objective
        )?;
        write!(
            f,
            "{} iterations, init ({}) {:.3} s + solve {:.3} s = {:.3} s",
            self.iterations, self.init, self.init_s, self.solve_s, self.total_s
        )
    }
}
