//! `speleo campaign`: the command line over the campaign crate, with this
//! binary's worlds and configuration as its catalog.

use std::path::Path;
use std::process::ExitCode;

use speleo_campaign::manifest::{self, Manifest};
use speleo_campaign::matrix::{Catalog, Matrix};
use speleo_campaign::runner::{self, Program};
use speleo_campaign::summary;

use crate::cli::{CampaignCommand, CampaignPlanArgs, CampaignReportArgs, CampaignRunArgs};
use crate::config::Config;

type Error = Box<dyn std::error::Error>;

/// The worlds and the configuration of this binary.
struct ThisBinary;

impl Catalog for ThisBinary {
    fn waypoints(&self, world: &str, seed: u64) -> Result<Vec<String>, String> {
        let w = speleo_hal::world::World::build(world, seed).map_err(|e| e.to_string())?;
        Ok(crate::tools::plan_world::waypoints(&w)
            .into_iter()
            .map(|(n, _)| n)
            .collect())
    }

    fn check_config(&self, toml_text: &str) -> Result<(), String> {
        Config::from_toml(toml_text)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
}

pub fn command(c: CampaignCommand, progress: bool) -> Result<ExitCode, Error> {
    match c {
        CampaignCommand::Plan(a) => plan(a),
        CampaignCommand::Run(a) => run(a, progress),
        CampaignCommand::Report(a) => report(a),
    }
}

fn plan(a: CampaignPlanArgs) -> Result<ExitCode, Error> {
    let text = std::fs::read_to_string(&a.matrix)
        .map_err(|e| format!("cannot read {}: {e}", a.matrix.display()))?;
    let mut m = Matrix::parse(&text).map_err(|e| format!("{}: {e}", a.matrix.display()))?;
    resolve_mesh_paths(&mut m, a.matrix.parent().unwrap_or(Path::new(".")));
    let cases = m
        .expand(&ThisBinary)
        .map_err(|e| format!("{}: {e}", a.matrix.display()))?;
    manifest::write(&a.out, &text, &m, &cases)?;
    println!(
        "{} cases planned in {} (campaign \"{}\"); run them with `speleo campaign run {}`, or on Slurm with `sbatch --array=0-{} deploy/slurm/campaign.sbatch {}`",
        cases.len(),
        a.out.display(),
        m.name,
        a.out.display(),
        cases.len() - 1,
        a.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// A world given as a mesh file is found from the matrix's folder, and
/// written to the cases as an absolute path.
fn resolve_mesh_paths(m: &mut Matrix, base: &Path) {
    let resolve = |w: &mut String| {
        let p = Path::new(w.as_str());
        let is_mesh = matches!(
            p.extension().and_then(|e| e.to_str()),
            Some("ply" | "obj" | "stl")
        );
        if is_mesh && p.is_relative() {
            if let Ok(abs) = std::fs::canonicalize(base.join(p)) {
                *w = abs.display().to_string();
            }
        }
    };
    for g in &mut m.groups {
        g.worlds.iter_mut().for_each(resolve);
    }
    for s in m.scenarios.values_mut() {
        resolve(&mut s.world);
    }
}

fn run(a: CampaignRunArgs, progress: bool) -> Result<ExitCode, Error> {
    let program = Program::this()?;
    let m = Manifest::load(&a.dir)?;
    if a.verify {
        let ids: Vec<usize> = match a.case {
            Some(k) => vec![k],
            None => (0..m.case_count).collect(),
        };
        let mut differ = 0;
        for id in ids {
            match runner::verify_case(&a.dir, &m, id, &program) {
                Ok((was, again)) if was == again => println!("case {id}: {was} reproduced"),
                Ok((was, again)) => {
                    differ += 1;
                    println!("case {id}: {was} recorded, {again} now: DIFFERENT");
                }
                Err(e) => {
                    differ += 1;
                    println!("case {id}: {e}");
                }
            }
        }
        return Ok(if differ == 0 {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        });
    }
    if let Some(k) = a.case {
        match runner::run_case(&a.dir, &m, k, &program)? {
            None => println!("case {k}: finished before; skipped"),
            Some(o) => println!(
                "case {k} ({}): {:?} in {:.0} s{}",
                m.cases[k].key(),
                o.status,
                o.wall_time_s,
                o.log_tail
                    .last()
                    .map_or(String::new(), |l| format!(": {l}"))
            ),
        }
        return Ok(ExitCode::SUCCESS);
    }
    let jobs = a
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let started = std::time::Instant::now();
    let t = runner::run_all(&a.dir, &program, jobs, progress)?;
    println!(
        "{} cases run ({} did not run to their end), {} finished before; {:.0} s with {jobs} jobs. `speleo campaign report {}` judges them.",
        t.ran,
        t.failed,
        t.skipped,
        started.elapsed().as_secs_f64(),
        a.dir.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn report(a: CampaignReportArgs) -> Result<ExitCode, Error> {
    let s = summary::summarise(&a.dir, a.baseline.as_deref())?;
    let md = summary::markdown(&s);
    print!("{md}");
    if let Some(p) = &a.json {
        crate::report::write_json(p, &s)?;
    }
    if let Some(p) = &a.markdown {
        std::fs::write(p, &md).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}
