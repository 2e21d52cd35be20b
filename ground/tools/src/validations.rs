//! `speleo campaign validations DIR`: every validation a campaign's cases
//! dumped (`speleo campaign run --dump-validations`), replayed three ways:
//! on the map as the mission did, on the map from the start's true
//! attitude, and on the world's true surface from where the rover truly
//! stood. How often each verdict agrees with the truth and how far the
//! most tilt on the map is from the true one are what the internal
//! simulation's margins are set from (docs/margins.md).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use serde::Serialize;
use speleo_campaign::manifest::{Manifest, CONFIG};
use speleo_campaign::matrix::Case;
use speleo_campaign::runner::VALIDATIONS;
use speleo_campaign::stats::quantile;
use speleo_firmware::config::Config;
use speleo_simulator::{Outcome, SimulatorParams, ValidationCase};

use crate::args::CampaignValidationsArgs;
use crate::validate::{crop, drive_on, in_world, read_case, replay, Drive};
use crate::Error;

/// One drive's outcome and most tilt, deg.
#[derive(Clone, Copy, Debug)]
pub struct Drove {
    pub outcome: Outcome,
    pub most_tilt_deg: f64,
}

impl From<&Drive> for Drove {
    fn from(d: &Drive) -> Self {
        Drove {
            outcome: d.verdict.outcome,
            most_tilt_deg: d.max_tilt_deg,
        }
    }
}

/// One validation replayed.
#[derive(Clone, Debug)]
pub struct Row {
    pub case: usize,
    /// The validation's number in its mission (from 1).
    pub validation: u64,
    pub began_s: f64,
    /// On the map, started as the mission started it.
    pub on_board: Drove,
    /// On the map, started at the attitude the rover truly had.
    pub tilted: Drove,
    /// On the map with the candidate configuration (`--config`), started
    /// as it starts the rover.
    pub candidate: Option<Drove>,
    /// On the world's true surface from the true pose and attitude.
    pub truth: Drove,
    /// SLAM's error when it began: x, y, z m, yaw deg (map frame).
    pub slam_error: [f64; 4],
    /// How far the rover truly stood from upright, deg.
    pub true_start_tilt_deg: f64,
    /// It stood tilted past the tip limit: tipped already, its
    /// validations say nothing of the margins and are left out.
    pub started_tipped: bool,
    /// Each plan pose's ground height on the map less the true surface's
    /// under it, m, with its horizontal distance from the start, m.
    pub height_errors: Vec<(f64, f64)>,
}

/// How one way of simulating agrees with the truth, in validations.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Agreement {
    pub both_pass: usize,
    /// Passed on the map, failed on the true surface: a risk taken.
    pub passed_in_error: usize,
    /// Refused on the map, passed on the true surface: ground given up.
    pub refused_in_vain: usize,
    pub both_fail: usize,
}

impl Agreement {
    fn add(&mut self, sim: Outcome, truth: Outcome) {
        let ok = |o| o == Outcome::Reached;
        match (ok(sim), ok(truth)) {
            (true, true) => self.both_pass += 1,
            (true, false) => self.passed_in_error += 1,
            (false, true) => self.refused_in_vain += 1,
            (false, false) => self.both_fail += 1,
        }
    }

    fn agree(&self) -> usize {
        self.both_pass + self.both_fail
    }

    fn total(&self) -> usize {
        self.agree() + self.passed_in_error + self.refused_in_vain
    }
}

/// Quantiles of a figure over the validations that have it.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Quantiles {
    pub n: usize,
    pub p05: f64,
    pub p50: f64,
    pub p90: f64,
    pub p95: f64,
    pub p99: f64,
    pub max: f64,
}

fn quantiles(values: impl Iterator<Item = f64>) -> Quantiles {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return Quantiles::default();
    }
    v.sort_by(f64::total_cmp);
    Quantiles {
        n: v.len(),
        p05: quantile(&v, 0.05),
        p50: quantile(&v, 0.5),
        p90: quantile(&v, 0.9),
        p95: quantile(&v, 0.95),
        p99: quantile(&v, 0.99),
        max: v[v.len() - 1],
    }
}

/// What a campaign's validations show.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Figures {
    pub cases: usize,
    pub validations: usize,
    /// Validations begun tipped past the limit, left out of the figures.
    pub started_tipped: usize,
    /// Validations that could not be replayed, with why.
    pub skipped: Vec<String>,
    pub on_board: Agreement,
    pub tilted: Agreement,
    /// With the candidate configuration, when one was given.
    pub candidate: Option<Agreement>,
    /// Plans whose verdict (reached or not) the candidate changes: to the
    /// truth's, and away from it.
    pub candidate_mends: usize,
    pub candidate_spoils: usize,
    /// Verdict pairs (map as on board -> true surface) that differ, counted.
    pub disagreements: BTreeMap<String, usize>,
    /// The true most tilt less the map's, deg, over the validations that
    /// reached the goal both ways: positive when the map hides tilt.
    pub tilt_error_on_board_deg: Quantiles,
    pub tilt_error_tilted_deg: Quantiles,
    /// SLAM's error at the start of a validation: horizontal and vertical
    /// m, heading deg (absolute values).
    pub slam_xy_m: Quantiles,
    pub slam_z_m: Quantiles,
    pub slam_yaw_deg: Quantiles,
    pub true_start_tilt_deg: Quantiles,
    /// The map's ground height under the plans less the true surface's,
    /// m, by distance from where the rover stood (the range it was seen
    /// from, within a metre or two): each band's upper edge, m, and the
    /// quantiles.
    pub height_error_by_range_m: Vec<(f64, Quantiles)>,
    /// Plan poses with no true surface within a metre under them.
    pub poses_without_truth: usize,
}

/// Upper edges of the distance bands the height errors are sorted into, m.
const RANGE_BANDS_M: [f64; 5] = [2.0, 4.0, 6.0, 8.0, f64::INFINITY];

/// The figures of `rows`.
pub fn figures(all: &[Row], cases: usize, skipped: Vec<String>) -> Figures {
    let rows: Vec<&Row> = all.iter().filter(|r| !r.started_tipped).collect();
    let mut f = Figures {
        cases,
        validations: all.len(),
        started_tipped: all.len() - rows.len(),
        skipped,
        ..Figures::default()
    };
    for r in &rows {
        f.on_board.add(r.on_board.outcome, r.truth.outcome);
        f.tilted.add(r.tilted.outcome, r.truth.outcome);
        if let Some(c) = &r.candidate {
            f.candidate
                .get_or_insert_with(Agreement::default)
                .add(c.outcome, r.truth.outcome);
            let pass = |o: Outcome| o == Outcome::Reached;
            let (was, now, truth) = (
                pass(r.on_board.outcome),
                pass(c.outcome),
                pass(r.truth.outcome),
            );
            if was != now {
                if now == truth {
                    f.candidate_mends += 1;
                } else {
                    f.candidate_spoils += 1;
                }
            }
        }
        if r.on_board.outcome != r.truth.outcome {
            *f.disagreements
                .entry(format!("{:?} -> {:?}", r.on_board.outcome, r.truth.outcome))
                .or_default() += 1;
        }
    }
    // Only drives that both reached the goal went the same way: one that
    // stuck or tipped early saw less of the ground.
    let reached = |d: &Drove| d.outcome == Outcome::Reached;
    let error = |sim: fn(&Row) -> &Drove| {
        quantiles(
            rows.iter()
                .copied()
                .filter(|r| reached(sim(r)) && reached(&r.truth))
                .map(|r| r.truth.most_tilt_deg - sim(r).most_tilt_deg),
        )
    };
    f.tilt_error_on_board_deg = error(|r| &r.on_board);
    f.tilt_error_tilted_deg = error(|r| &r.tilted);
    f.slam_xy_m = quantiles(rows.iter().map(|r| r.slam_error[0].hypot(r.slam_error[1])));
    f.slam_z_m = quantiles(rows.iter().map(|r| r.slam_error[2].abs()));
    f.slam_yaw_deg = quantiles(rows.iter().map(|r| r.slam_error[3].abs()));
    f.true_start_tilt_deg = quantiles(rows.iter().map(|r| r.true_start_tilt_deg));
    let band = |d: f64| RANGE_BANDS_M.iter().position(|&b| d < b);
    f.height_error_by_range_m = RANGE_BANDS_M
        .iter()
        .enumerate()
        .map(|(k, &edge)| {
            let in_band = rows
                .iter()
                .flat_map(|r| &r.height_errors)
                .filter(|(d, _)| band(*d) == Some(k))
                .map(|(_, e)| *e);
            (edge, quantiles(in_band))
        })
        .collect();
    f.poses_without_truth = rows
        .iter()
        .flat_map(|r| &r.height_errors)
        .filter(|(_, e)| e.is_nan())
        .count();
    f
}

/// Each plan pose's ground height less the true surface's under it (NaN
/// where there is none within a metre), with its horizontal distance
/// from `start`.
fn height_errors(
    start: [f64; 3],
    plan: &[[f64; 4]],
    truth: &speleo_twin::lidar::LidarWorld,
) -> Vec<(f64, f64)> {
    // Cast down from half a metre over the pose (a roof is higher): the
    // true surface lies `toi - ABOVE_M` under the map's ground.
    const ABOVE_M: f64 = 0.5;
    plan.iter()
        .map(|&[x, y, z, _]| {
            let d = (x - start[0]).hypot(y - start[1]);
            let under = truth
                .cast_signed([x, y, z + ABOVE_M], [0.0, 0.0, -1.0], ABOVE_M + 1.0)
                .map_or(f64::NAN, |(toi, _)| toi - ABOVE_M);
            (d, under)
        })
        .collect()
}

/// The validation files in `dir`, by number.
fn case_files(dir: &Path) -> Result<Vec<(u64, PathBuf)>, String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut files = Vec::new();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let number = name
            .strip_prefix("validation-")
            .and_then(|n| n.strip_suffix(".case"))
            .and_then(|n| n.parse::<u64>().ok());
        if let Some(n) = number {
            files.push((n, e.path()));
        }
    }
    files.sort();
    Ok(files)
}

/// One validation replayed the three ways.
/// What one case's validations are replayed with.
struct CaseWorld {
    id: usize,
    /// The case's simulator, and the candidate's.
    params: SimulatorParams,
    candidate: Option<SimulatorParams>,
    /// The true track (truth.csv), the world and a ray caster on it.
    truth: String,
    world: speleo_twin::world::World,
    rays: speleo_twin::lidar::LidarWorld,
}

fn row(w: &CaseWorld, number: u64, v: &ValidationCase) -> Result<Row, Error> {
    let params = &w.params;
    let on_board = replay(v, params.clone(), None, None)?;
    let candidate = w
        .candidate
        .as_ref()
        .map(|p| replay(v, p.clone(), None, None).map(|d| Drove::from(&d)))
        .transpose()?;
    // The rover truly stands as it stands: the true drive and the tilted
    // replay start at the attitude (an IMU measures it to a fraction of
    // a degree), whatever the mission's configuration does.
    let upright = SimulatorParams {
        start_tilted: true,
        ..params.clone()
    };
    let (start, plan, slam_error) = in_world(v, &w.truth)?;
    let tilted_case = ValidationCase {
        start: speleo_simulator::Stance {
            pitch: start.pitch,
            roll: start.roll,
            ..v.start
        },
        ..v.clone()
    };
    let tilted = replay(&tilted_case, upright.clone(), None, None)?;
    let ground = crop(&w.world.mesh, start.position, &plan, params.margin_m);
    let t = drive_on(ground, start, v.way_back, &plan, upright, None)?;
    let height_errors = height_errors(start.position, &plan, &w.rays);
    let true_start_tilt_deg = start.up()[2].clamp(-1.0, 1.0).acos().to_degrees();
    Ok(Row {
        case: w.id,
        validation: number,
        began_s: v.began_ns as f64 * 1e-9,
        on_board: Drove::from(&on_board),
        tilted: Drove::from(&tilted),
        candidate,
        truth: Drove::from(&t),
        slam_error,
        true_start_tilt_deg,
        started_tipped: true_start_tilt_deg > params.tip_over_deg,
        height_errors,
    })
}

/// `top`'s keys laid over `base`'s, tables merged key by key.
fn lay_over(base: &mut toml::Table, top: &toml::Table) {
    for (k, v) in top {
        match (base.get_mut(k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(t)) => lay_over(b, t),
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
}

/// The case's configuration with `candidate` laid over it, checked.
fn candidate_config(case_text: &str, candidate: &toml::Table) -> Result<Config, Error> {
    let mut merged: toml::Table = toml::from_str(case_text)?;
    lay_over(&mut merged, candidate);
    let cfg = Config::from_toml(&toml::to_string(&merged)?)?;
    cfg.validate()?;
    Ok(cfg)
}

/// Every validation of one case, replayed; the rows and what was skipped.
fn case_rows(dir: &Path, case: &Case, candidate: Option<&toml::Table>) -> (Vec<Row>, Vec<String>) {
    let cd = Manifest::case_dir(dir, case);
    let vd = cd.join(VALIDATIONS);
    let mut skipped = Vec::new();
    let mut rows = Vec::new();
    let files = match case_files(&vd) {
        Ok(f) => f,
        Err(e) => return (rows, vec![format!("case {}: {e}", case.id)]),
    };
    let setup = || -> Result<_, Error> {
        let config_path = cd.join(CONFIG);
        let text = std::fs::read_to_string(&config_path)
            .map_err(|e| format!("{}: {e}", config_path.display()))?;
        let cfg = Config::from_toml(&text)?;
        cfg.validate()?;
        let candidate = candidate
            .map(|c| candidate_config(&text, c).map(|c| speleo_firmware::params::simulator(&c)))
            .transpose()?;
        let truth_path = vd.join(speleo_firmware::validation_dump::TRUTH_FILE);
        let truth = std::fs::read_to_string(&truth_path)
            .map_err(|e| format!("{}: {e}", truth_path.display()))?;
        let world = speleo_twin::world::World::build(&case.world, case.world_seed)?;
        let rays = speleo_twin::lidar::LidarWorld::new(&world.mesh)?;
        Ok(CaseWorld {
            id: case.id,
            params: speleo_firmware::params::simulator(&cfg),
            candidate,
            truth,
            world,
            rays,
        })
    };
    let w = match setup() {
        Ok(s) => s,
        Err(e) => return (rows, vec![format!("case {}: {e}", case.id)]),
    };
    for (n, path) in files {
        match read_case(&path).and_then(|v| row(&w, n, &v)) {
            Ok(r) => rows.push(r),
            Err(e) => skipped.push(format!("case {} validation {n}: {e}", case.id)),
        }
    }
    (rows, skipped)
}

/// Every case's validations replayed on `jobs` threads, in the cases'
/// order.
pub fn replay_all(
    dir: &Path,
    m: &Manifest,
    jobs: usize,
    candidate: Option<&toml::Table>,
) -> (Vec<Row>, Vec<String>, usize) {
    let cases: Vec<&Case> = m
        .cases
        .iter()
        .filter(|c| Manifest::case_dir(dir, c).join(VALIDATIONS).is_dir())
        .collect();
    let next = AtomicUsize::new(0);
    let done = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..jobs.max(1) {
            s.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(case) = cases.get(k) else { break };
                let r = case_rows(dir, case, candidate);
                done.lock().unwrap_or_else(|p| p.into_inner()).push((k, r));
            });
        }
    });
    let mut done = done.into_inner().unwrap_or_else(|p| p.into_inner());
    done.sort_by_key(|(k, _)| *k);
    let (mut rows, mut skipped) = (Vec::new(), Vec::new());
    for (_, (r, s)) in done {
        rows.extend(r);
        skipped.extend(s);
    }
    (rows, skipped, cases.len())
}

/// Writes one row a validation as CSV.
pub fn write_csv(rows: &[Row], w: &mut dyn std::io::Write) -> Result<(), Error> {
    writeln!(
        w,
        "case,validation,began_s,on_board,on_board_tilt_deg,tilted,tilted_tilt_deg,candidate,candidate_tilt_deg,truth,truth_tilt_deg,slam_dx_m,slam_dy_m,slam_dz_m,slam_dyaw_deg,true_start_tilt_deg"
    )?;
    for r in rows {
        let [dx, dy, dz, dyaw] = r.slam_error;
        writeln!(
            w,
            "{},{},{:.2},{:?},{:.2},{:?},{:.2},{},{},{:?},{:.2},{dx:.3},{dy:.3},{dz:.3},{dyaw:.2},{:.2}",
            r.case,
            r.validation,
            r.began_s,
            r.on_board.outcome,
            r.on_board.most_tilt_deg,
            r.tilted.outcome,
            r.tilted.most_tilt_deg,
            r.candidate.map_or(String::new(), |c| format!("{:?}", c.outcome)),
            r.candidate
                .map_or(String::new(), |c| format!("{:.2}", c.most_tilt_deg)),
            r.truth.outcome,
            r.truth.most_tilt_deg,
            r.true_start_tilt_deg
        )?;
    }
    Ok(())
}

/// The figures as text.
pub fn print(f: &Figures) {
    println!(
        "{} validations replayed ({} cases, {} skipped, {} begun tipped past the limit and left out)",
        f.validations,
        f.cases,
        f.skipped.len(),
        f.started_tipped
    );
    for s in f.skipped.iter().take(10) {
        println!("  skipped: {s}");
    }
    println!("verdicts against the true surface (pass = goal reached):");
    println!("  start            agree  both pass  passed in error  refused in vain  both fail");
    for (name, a) in [
        ("as on board", Some(&f.on_board)),
        ("true attitude", Some(&f.tilted)),
        ("candidate", f.candidate.as_ref()),
    ]
    .into_iter()
    .filter_map(|(n, a)| Some((n, a?)))
    {
        println!(
            "  {name:<15} {:>3}/{:<4} {:>9} {:>16} {:>16} {:>10}",
            a.agree(),
            a.total(),
            a.both_pass,
            a.passed_in_error,
            a.refused_in_vain,
            a.both_fail
        );
    }
    if f.candidate.is_some() {
        println!(
            "  the candidate changes {} verdicts: {} to the truth's, {} away from it",
            f.candidate_mends + f.candidate_spoils,
            f.candidate_mends,
            f.candidate_spoils
        );
    }
    for (pair, n) in &f.disagreements {
        println!("  {n:>4} x {pair}");
    }
    println!("quantiles                    n     p05     p50     p90     p95     p99     max");
    for (name, q) in [
        ("true - map tilt, deg", &f.tilt_error_on_board_deg),
        ("  from true attitude", &f.tilt_error_tilted_deg),
        ("SLAM xy error, m", &f.slam_xy_m),
        ("SLAM z error, m", &f.slam_z_m),
        ("SLAM yaw error, deg", &f.slam_yaw_deg),
        ("true start tilt, deg", &f.true_start_tilt_deg),
    ] {
        println!(
            "  {name:<22} {:>5} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>7.2}",
            q.n, q.p05, q.p50, q.p90, q.p95, q.p99, q.max
        );
    }
    println!(
        "map ground height less the true surface's under the plans, m, by distance from the start ({} poses without a true surface under them):",
        f.poses_without_truth
    );
    let mut from = 0.0;
    for (edge, q) in &f.height_error_by_range_m {
        let band = format!("{from:.0}-{edge:.0} m");
        println!(
            "  {band:<22} {:>5} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3}",
            q.n, q.p05, q.p50, q.p90, q.p95, q.p99, q.max
        );
        from = *edge;
    }
}

pub fn command(a: CampaignValidationsArgs) -> Result<ExitCode, Error> {
    let m = Manifest::load(&a.dir)?;
    let jobs = a
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let candidate: Option<toml::Table> = a
        .config
        .as_ref()
        .map(|p| -> Result<toml::Table, Error> {
            let text = std::fs::read_to_string(p)
                .map_err(|e| format!("cannot read {}: {e}", p.display()))?;
            let t = toml::from_str(&text).map_err(|e| format!("{}: {e}", p.display()))?;
            // Checked alone first: a bad key is named against its file.
            Config::from_toml(&text)
                .and_then(|c| c.validate().map(|()| c))
                .map_err(|e| format!("{}: {e}", p.display()))?;
            Ok(t)
        })
        .transpose()?;
    let (rows, skipped, cases) = replay_all(&a.dir, &m, jobs, candidate.as_ref());
    if cases == 0 {
        return Err(format!(
            "no case of {} has a {VALIDATIONS}/ folder: run the campaign with --dump-validations",
            a.dir.display()
        )
        .into());
    }
    let f = figures(&rows, cases, skipped);
    if let Some(p) = &a.csv {
        let mut w = std::io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("cannot create {}: {e}", p.display()))?,
        );
        write_csv(&rows, &mut w)?;
        std::io::Write::flush(&mut w)?;
    }
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&f)?;
        std::fs::write(p, text).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
    }
    print(&f);
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(on_board: (Outcome, f64), truth: (Outcome, f64)) -> Row {
        let d = |(outcome, most_tilt_deg)| Drove {
            outcome,
            most_tilt_deg,
        };
        Row {
            case: 0,
            validation: 1,
            began_s: 0.0,
            on_board: d(on_board),
            tilted: d(on_board),
            candidate: None,
            truth: d(truth),
            slam_error: [0.3, 0.4, -0.1, -2.0],
            true_start_tilt_deg: 5.0,
            started_tipped: false,
            height_errors: vec![(1.0, 0.02), (3.0, -0.05), (9.0, f64::NAN)],
        }
    }

    #[test]
    fn verdicts_are_sorted_by_how_they_agree_with_the_truth_and_tilt_errors_signed() {
        use Outcome::*;
        let rows = [
            row((Reached, 10.0), (Reached, 12.0)),
            row((Reached, 20.0), (TippedOver, 31.0)),
            row((TippedOver, 31.0), (Reached, 22.0)),
            row((Stuck, 5.0), (Stuck, 5.0)),
            row((NoGround, 0.0), (Reached, 8.0)),
            Row {
                started_tipped: true,
                ..row((Reached, 40.0), (TippedOver, 40.0))
            },
        ];
        let f = figures(&rows, 1, Vec::new());
        assert_eq!((f.validations, f.started_tipped), (6, 1));
        let a = f.on_board;
        assert_eq!(
            (
                a.both_pass,
                a.passed_in_error,
                a.refused_in_vain,
                a.both_fail
            ),
            (1, 1, 2, 1)
        );
        assert_eq!(f.disagreements.get("TippedOver -> Reached"), Some(&1));
        assert_eq!(f.disagreements.get("Reached -> TippedOver"), Some(&1));
        // Only the drives that reached the goal both ways compare.
        let q = f.tilt_error_on_board_deg;
        assert_eq!((q.n, q.p50, q.max), (1, 2.0, 2.0), "{q:?}");
        assert!((f.slam_xy_m.p50 - 0.5).abs() < 1e-12);
        assert_eq!(f.slam_yaw_deg.max, 2.0);
        let bands = &f.height_error_by_range_m;
        assert_eq!((bands[0].1.n, bands[0].1.p50), (5, 0.02));
        assert_eq!((bands[1].1.n, bands[1].1.p50), (5, -0.05));
        assert_eq!(bands[4].1.n, 0, "no truth: not an error");
        assert_eq!(f.poses_without_truth, 5);
    }

    #[test]
    fn a_candidate_is_counted_by_the_verdicts_it_brings_to_the_truth_and_away() {
        use Outcome::*;
        let with = |on_board, candidate, truth| Row {
            candidate: Some(Drove {
                outcome: candidate,
                most_tilt_deg: 10.0,
            }),
            ..row((on_board, 10.0), (truth, 10.0))
        };
        let rows = [
            with(TippedOver, Reached, Reached),
            with(Stuck, Reached, Reached),
            with(Reached, Stuck, Reached),
            with(Reached, TippedOver, TippedOver),
            // A failure for another: no verdict changed.
            with(Stuck, TippedOver, Reached),
        ];
        let f = figures(&rows, 1, Vec::new());
        assert_eq!((f.candidate_mends, f.candidate_spoils), (3, 1));
        let c = f.candidate.expect("a candidate");
        assert_eq!((c.both_pass, c.refused_in_vain, c.both_fail), (2, 2, 1));
    }

    #[test]
    fn a_candidate_configuration_is_laid_over_the_cases_key_by_key() {
        let case = "[sim]\nworld = \"flat\"\nduration_s = 4.0\n[simulator]\ntip_over_deg = 40.0\n";
        let top: toml::Table = toml::from_str("[simulator]\nstart_tilted = true\n").expect("toml");
        let cfg = candidate_config(case, &top).expect("valid");
        assert!(cfg.simulator.params.start_tilted);
        assert_eq!(
            cfg.simulator.params.tip_over_deg, 40.0,
            "the case's own kept"
        );
        assert_eq!(cfg.sim.world, "flat");
        let bad: toml::Table = toml::from_str("[simulator]\ntip_over_deg = 200.0\n").expect("toml");
        assert!(candidate_config(case, &bad).is_err());
    }

    #[test]
    fn a_folder_without_cases_reads_empty_and_numbers_sort_the_files() {
        let dir = std::env::temp_dir().join(format!("speleo-validations-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("made");
        for n in ["validation-0010.case", "validation-0002.case", "truth.csv"] {
            std::fs::write(dir.join(n), b"").expect("written");
        }
        let files = case_files(&dir).expect("read");
        assert_eq!(
            files.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
            vec![2, 10]
        );
        assert!(case_files(&dir.join("absent")).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
