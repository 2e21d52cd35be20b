//! `speleo campaign`: the command line over the campaign crate, with this
//! binary's worlds and configuration as its catalog.

use std::path::Path;
use std::process::ExitCode;

use speleo_campaign::manifest::{self, Manifest};
use speleo_campaign::matrix::{Catalog, Matrix};
use speleo_campaign::runner::{self, Program};
use speleo_campaign::summary;

use crate::args::{CampaignCommand, CampaignPlanArgs, CampaignReportArgs, CampaignRunArgs};
use speleo_firmware::config::Config;

type Error = Box<dyn std::error::Error>;

/// The worlds and the configuration of this binary.
struct ThisBinary;

impl Catalog for ThisBinary {
    fn waypoints(&self, world: &str, seed: u64) -> Result<Vec<String>, String> {
        let w = speleo_twin::world::World::build(world, seed).map_err(|e| e.to_string())?;
        Ok(speleo_twin::world::waypoints::waypoints(&w)
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
        CampaignCommand::Validations(a) => crate::validations::command(a),
    }
}

fn plan(a: CampaignPlanArgs) -> Result<ExitCode, Error> {
    let text = std::fs::read_to_string(&a.matrix)
        .map_err(|e| format!("cannot read {}: {e}", a.matrix.display()))?;
    let mut m = Matrix::parse(&text).map_err(|e| format!("{}: {e}", a.matrix.display()))?;
    let base = a.matrix.parent().unwrap_or(Path::new("."));
    let text = add_scenario_files(&mut m, base, text)?;
    resolve_mesh_paths(&mut m, base);
    let cases = m
        .expand(&ThisBinary)
        .map_err(|e| format!("{}: {e}", a.matrix.display()))?;
    manifest::write(&a.out, &text, &m, &cases)?;
    // A Slurm task must outlast its case's own limit, or Slurm kills it
    // before the case can be recorded as a hang.
    let minutes = ((m.timeout_s + 600.0) / 60.0).ceil() as u64;
    println!(
        "{} cases planned in {} (campaign \"{}\"); run them with `speleo campaign run {}`, or on Slurm with `sbatch --array=0-{} --time={minutes} deploy/slurm/campaign.sbatch {}`",
        cases.len(),
        a.out.display(),
        m.name,
        a.out.display(),
        cases.len() - 1,
        a.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Reads the matrix's scenario files (from its folder) into it. Returns
/// the matrix's text with their scenarios appended, so that the copy a
/// campaign keeps says everything its cases were planned from.
fn add_scenario_files(m: &mut Matrix, base: &Path, text: String) -> Result<String, Error> {
    let mut copy = text;
    for f in m.scenario_files.clone() {
        let path = base.join(&f);
        let t = std::fs::read_to_string(&path)
            .map_err(|e| format!("scenario_files: cannot read {}: {e}", path.display()))?;
        m.add_scenarios(&path.display().to_string(), &t)?;
        copy.push_str(&format!("\n# ---- scenario file {f} ----\n{t}"));
    }
    Ok(copy)
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
    let program = Program {
        dump_validations: a.dump_validations,
        stop: speleo_firmware::signals::stop_flag(),
        ..Program::this()?
    };
    let m = Manifest::load(&a.dir)?;
    if a.verify {
        // Every case that ran its mission, or the one asked for.
        let ids: Vec<usize> = match a.case {
            Some(k) => vec![k],
            None => m
                .cases
                .iter()
                .filter(|c| {
                    matches!(
                        speleo_campaign::outcome::Outcome::load(&Manifest::case_dir(&a.dir, c)),
                        Some(Ok(o)) if o.status == speleo_campaign::outcome::Status::Ran
                    )
                })
                .map(|c| c.id)
                .collect(),
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
            None => println!("case {k}: finished before, or another runner holds it; skipped"),
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
    if speleo_firmware::signals::interrupted() {
        println!(
            "interrupted: the cases cut short have no outcome; `speleo campaign run {}` runs them and the rest",
            a.dir.display()
        );
    }
    Ok(speleo_firmware::commands::finished_status())
}

fn report(a: CampaignReportArgs) -> Result<ExitCode, Error> {
    let s = summary::summarise(&a.dir, a.baseline.as_deref())?;
    let md = summary::markdown(&s);
    print!("{md}");
    if let Some(p) = &a.json {
        speleo_firmware::report::write_json(p, &s)?;
    }
    if let Some(p) = &a.markdown {
        std::fs::write(p, &md).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
    }
    if let Some(p) = &a.plot {
        let mut maps = Vec::new();
        for ((world, seed), cases) in speleo_campaign::plot::cases_by_world(&s) {
            let w = speleo_twin::world::World::build(&world, seed)
                .map_err(|e| format!("the plot's map of {world}: {e}"))?;
            let name = Path::new(&world)
                .file_name()
                .map_or(world.clone(), |n| n.to_string_lossy().into_owned());
            let (floor, floor_cell_m) = floor_from_above(&w.mesh);
            maps.push(speleo_campaign::plot::FloorMap {
                title: format!("{name} (seed {seed})"),
                floor,
                floor_cell_m,
                cases,
            });
        }
        speleo_campaign::plot::write_plot(p, &s, &maps)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The floor seen from above: the centre of every cell under some face
/// within 20 degrees of level, facing up, with its size, m (a plot's
/// pixel or two: 0.25 m, coarser for a large world).
fn floor_from_above(m: &speleo_physics::Mesh) -> (Vec<[f64; 2]>, f64) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for v in &m.vertices {
        for k in 0..2 {
            lo[k] = lo[k].min(f64::from(v[k]));
            hi[k] = hi[k].max(f64::from(v[k]));
        }
    }
    let cell = ((hi[0] - lo[0]).max(hi[1] - lo[1]) / 600.0).max(0.25);
    let mut cells = std::collections::BTreeSet::new();
    let cos_max = 20f64.to_radians().cos();
    for t in 0..m.triangles.len() {
        let (_, n) = m.triangle_geometry(t);
        if n[2] < cos_max {
            continue;
        }
        let v = m.triangles[t].map(|i| m.vertices[i as usize].map(f64::from));
        let longest = (0..3)
            .map(|k| {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
            })
            .fold(0.0, f64::max);
        let n_steps = ((longest / (0.5 * cell)).ceil() as usize).clamp(1, 4000);
        for i in 0..=n_steps {
            for j in 0..=(n_steps - i) {
                let (a, b) = (i as f64 / n_steps as f64, j as f64 / n_steps as f64);
                let c = 1.0 - a - b;
                let x = a * v[0][0] + b * v[1][0] + c * v[2][0];
                let y = a * v[0][1] + b * v[1][1] + c * v[2][1];
                cells.insert(((x / cell).floor() as i64, (y / cell).floor() as i64));
            }
        }
    }
    let centres = cells
        .into_iter()
        .map(|(i, j)| [(i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell])
        .collect();
    (centres, cell)
}
