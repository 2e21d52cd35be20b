//! A campaign judged: success rates with their intervals, each criterion,
//! the failures by cause and place, the figures' spread, and a paired
//! comparison with a baseline campaign.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::manifest::{Manifest, REPORT};
use crate::matrix::Case;
use crate::outcome::{Outcome, Status};
use crate::stats::{spread, wilson, Rate, Spread};
use crate::success::FailureCause;

/// One case as the summary sees it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CaseRow {
    pub id: usize,
    pub key: String,
    pub world: String,
    pub world_seed: u64,
    pub scenario: Option<String>,
    pub variant: String,
    /// `None`: not run to its end yet.
    pub status: Option<Status>,
    pub passed: bool,
    pub failure: Option<FailureCause>,
    /// The parts of success each met (empty when the mission did not run).
    pub criteria: BTreeMap<String, bool>,
    pub output_hash: Option<String>,
    pub coverage: Option<f64>,
    pub home_error_m: Option<f64>,
    pub distance_m: Option<f64>,
    pub energy_wh: Option<f64>,
    pub mission_time_s: Option<f64>,
    pub wall_time_s: Option<f64>,
    /// Where the rover ended, world frame (simulation truth).
    pub end_position: Option<[f64; 3]>,
    pub log_tail: Vec<String>,
}

/// A failure cause and the cases it ended.
#[derive(Clone, Debug, Serialize)]
pub struct FailureGroup {
    pub cause: FailureCause,
    pub cases: Vec<usize>,
}

/// A case that changed between the baseline and this campaign.
#[derive(Clone, Debug, Serialize)]
pub struct Flip {
    pub key: String,
    pub id: usize,
    pub baseline_id: usize,
    pub baseline_failure: Option<FailureCause>,
    pub failure: Option<FailureCause>,
}

/// The paired comparison with a baseline campaign, over the cases both
/// ran to their end.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub baseline_name: String,
    pub paired: usize,
    pub baseline_rate: Rate,
    pub rate: Rate,
    /// Failed in the baseline, passed here; and the other way.
    pub fixed: Vec<Flip>,
    pub broken: Vec<Flip>,
    /// Paired cases whose output hash differs (the course changed).
    pub hash_changed: usize,
    /// Cases of one campaign with no twin in the other.
    pub unpaired: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub name: String,
    pub cases: usize,
    /// Cases not run to their end yet: the campaign is partial.
    pub missing: usize,
    pub overall: Rate,
    pub by_world: BTreeMap<String, Rate>,
    /// Whole-world missions under [`WHOLE_WORLD`]; each scenario by name.
    pub by_scenario: BTreeMap<String, Rate>,
    pub by_variant: BTreeMap<String, Rate>,
    /// Cases meeting each part of success, of those whose mission ran.
    pub criteria: BTreeMap<String, Rate>,
    pub failures: Vec<FailureGroup>,
    pub coverage: Option<Spread>,
    pub home_error_m: Option<Spread>,
    pub distance_m: Option<Spread>,
    pub energy_wh: Option<Spread>,
    pub mission_time_s: Option<Spread>,
    pub case_wall_time_s: Option<Spread>,
    /// Wall time of every case added up, s (the campaign's own wall time
    /// is this over the jobs that ran side by side).
    pub total_case_wall_time_s: f64,
    pub rows: Vec<CaseRow>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baseline: Option<Comparison>,
}

/// The group of the missions that explore a whole world, beside the
/// scenarios.
pub const WHOLE_WORLD: &str = "whole world";

/// The output hash a report holds.
pub fn output_hash(report: &Path) -> Option<String> {
    let v = read_json(report).ok()?;
    v.get("output_hash")?.as_str().map(str::to_string)
}

fn read_json(path: &Path) -> Result<serde_json::Value, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// One case's row, from its outcome and report.
fn row(dir: &Path, c: &Case) -> Result<CaseRow, String> {
    let cd = Manifest::case_dir(dir, c);
    let outcome = Outcome::load(&cd).transpose()?;
    let mut r = CaseRow {
        id: c.id,
        key: c.key(),
        world: c.world.clone(),
        world_seed: c.world_seed,
        scenario: c.scenario.clone(),
        variant: c.variant.clone(),
        status: outcome.as_ref().map(|o| o.status),
        passed: false,
        failure: None,
        criteria: BTreeMap::new(),
        output_hash: None,
        coverage: None,
        home_error_m: None,
        distance_m: None,
        energy_wh: None,
        mission_time_s: None,
        wall_time_s: outcome.as_ref().map(|o| o.wall_time_s),
        end_position: None,
        log_tail: outcome.as_ref().map_or(Vec::new(), |o| o.log_tail.clone()),
    };
    let Some(o) = outcome else {
        return Ok(r);
    };
    match o.status {
        Status::Ran => {}
        Status::Hung => {
            r.failure = Some(FailureCause::Hang);
            return Ok(r);
        }
        Status::Crashed | Status::Killed => {
            r.failure = Some(FailureCause::Crash);
            return Ok(r);
        }
    }
    match judged(&cd, &mut r) {
        Ok(()) => Ok(r),
        // The mission's process said it ran, but its report cannot be
        // judged: counted as a crash, with why.
        Err(e) => {
            r.failure = Some(FailureCause::Crash);
            r.log_tail.push(e);
            Ok(r)
        }
    }
}

/// Fills a row from the case's report.
fn judged(cd: &Path, r: &mut CaseRow) -> Result<(), String> {
    let v = read_json(&cd.join(REPORT))?;
    let f64_at = |path: &[&str]| {
        let mut x = &v;
        for k in path {
            x = x.get(*k)?;
        }
        x.as_f64()
    };
    r.output_hash = v
        .get("output_hash")
        .and_then(|h| h.as_str())
        .map(str::to_string);
    r.coverage = f64_at(&["exploration", "coverage_fraction"]);
    r.home_error_m = f64_at(&["exploration", "home_error_m"]);
    r.distance_m = f64_at(&["exploration", "distance_m"]);
    r.energy_wh = f64_at(&["exploration", "energy_used_wh"]);
    r.mission_time_s = f64_at(&["sim_time_s"]);
    r.end_position = v
        .pointer("/exploration/end_position")
        .and_then(|p| serde_json::from_value::<[f64; 3]>(p.clone()).ok());
    let Some(s) = v.get("success") else {
        return Err(format!(
            "{}: no `success` section (a report from before campaigns, or a mission without exploration)",
            cd.join(REPORT).display()
        ));
    };
    let s: crate::success::Success = serde_json::from_value(s.clone())
        .map_err(|e| format!("{}: success: {e}", cd.join(REPORT).display()))?;
    r.passed = s.passed;
    r.failure = s.failure;
    r.criteria = s
        .criteria
        .parts()
        .iter()
        .map(|(k, ok)| (k.to_string(), *ok))
        .collect();
    Ok(())
}

/// Judges the campaign in `dir`, against `baseline` when given.
pub fn summarise(dir: &Path, baseline: Option<&Path>) -> Result<Summary, String> {
    let m = Manifest::load(dir)?;
    let rows: Vec<CaseRow> = m
        .cases
        .iter()
        .map(|c| row(dir, c))
        .collect::<Result<_, _>>()?;
    let mut s = aggregate(&m.name, rows);
    if let Some(b) = baseline {
        let base = if b.is_dir() {
            let base = summarise(b, None)?;
            SavedSummary {
                name: base.name,
                rows: base.rows,
            }
        } else {
            let text = std::fs::read_to_string(b).map_err(|e| format!("{}: {e}", b.display()))?;
            serde_json::from_str(&text).map_err(|e| {
                format!(
                    "{}: neither a campaign folder nor a summary written by `campaign report --json` ({e})",
                    b.display()
                )
            })?
        };
        s.baseline = Some(compare(&base, &s));
    }
    Ok(s)
}

/// What a baseline needs of a campaign: its name and its cases, from the
/// campaign's folder or from the summary `report --json` wrote (so that a
/// baseline can be kept in a repository without its cases' folders).
#[derive(Deserialize)]
struct SavedSummary {
    name: String,
    rows: Vec<CaseRow>,
}

fn aggregate(name: &str, rows: Vec<CaseRow>) -> Summary {
    let done: Vec<&CaseRow> = rows.iter().filter(|r| r.status.is_some()).collect();
    let rate_of = |f: &dyn Fn(&CaseRow) -> bool| {
        let sel: Vec<&&CaseRow> = done.iter().filter(|r| f(r)).collect();
        wilson(sel.iter().filter(|r| r.passed).count(), sel.len())
    };
    let mut by_world = BTreeMap::new();
    let mut by_scenario = BTreeMap::new();
    let mut by_variant = BTreeMap::new();
    for r in &done {
        by_world
            .entry(r.world.clone())
            .or_insert_with(|| rate_of(&|x| x.world == r.world));
        let sc = r.scenario.clone().unwrap_or_else(|| WHOLE_WORLD.into());
        by_scenario.entry(sc.clone()).or_insert_with(|| {
            rate_of(&|x| x.scenario.clone().unwrap_or_else(|| WHOLE_WORLD.into()) == sc)
        });
        by_variant
            .entry(r.variant.clone())
            .or_insert_with(|| rate_of(&|x| x.variant == r.variant));
    }
    let mut criteria = BTreeMap::new();
    let ran: Vec<&&CaseRow> = done.iter().filter(|r| !r.criteria.is_empty()).collect();
    if let Some(first) = ran.first() {
        for k in first.criteria.keys() {
            let met = ran
                .iter()
                .filter(|r| r.criteria.get(k) == Some(&true))
                .count();
            criteria.insert(k.clone(), wilson(met, ran.len()));
        }
    }
    let failures = FailureCause::ALL
        .iter()
        .filter_map(|&cause| {
            let cases: Vec<usize> = done
                .iter()
                .filter(|r| r.failure == Some(cause))
                .map(|r| r.id)
                .collect();
            (!cases.is_empty()).then_some(FailureGroup { cause, cases })
        })
        .collect();
    let pick = |f: &dyn Fn(&CaseRow) -> Option<f64>| {
        spread(&done.iter().filter_map(|r| f(r)).collect::<Vec<_>>())
    };
    Summary {
        name: name.to_string(),
        cases: rows.len(),
        missing: rows.len() - done.len(),
        overall: rate_of(&|_| true),
        by_world,
        by_scenario,
        by_variant,
        criteria,
        failures,
        coverage: pick(&|r| r.coverage),
        home_error_m: pick(&|r| r.home_error_m),
        distance_m: pick(&|r| r.distance_m),
        energy_wh: pick(&|r| r.energy_wh),
        mission_time_s: pick(&|r| r.mission_time_s),
        case_wall_time_s: pick(&|r| r.wall_time_s),
        total_case_wall_time_s: done.iter().filter_map(|r| r.wall_time_s).sum(),
        rows,
        baseline: None,
    }
}

/// Pairs the cases of two campaigns by what they are (world, seeds,
/// variant, scenario), not by number.
fn compare(base: &SavedSummary, now: &Summary) -> Comparison {
    let done = |rows: &[CaseRow]| -> BTreeMap<String, CaseRow> {
        rows.iter()
            .filter(|r| r.status.is_some())
            .map(|r| (r.key.clone(), r.clone()))
            .collect()
    };
    let (b, n) = (done(&base.rows), done(&now.rows));
    let mut fixed = Vec::new();
    let mut broken = Vec::new();
    let (mut paired, mut b_pass, mut n_pass, mut hash_changed) = (0, 0, 0, 0);
    for (key, nr) in &n {
        let Some(br) = b.get(key) else { continue };
        paired += 1;
        b_pass += usize::from(br.passed);
        n_pass += usize::from(nr.passed);
        if br.output_hash != nr.output_hash {
            hash_changed += 1;
        }
        let flip = || Flip {
            key: key.clone(),
            id: nr.id,
            baseline_id: br.id,
            baseline_failure: br.failure,
            failure: nr.failure,
        };
        match (br.passed, nr.passed) {
            (false, true) => fixed.push(flip()),
            (true, false) => broken.push(flip()),
            _ => {}
        }
    }
    Comparison {
        baseline_name: base.name.clone(),
        paired,
        baseline_rate: wilson(b_pass, paired),
        rate: wilson(n_pass, paired),
        fixed,
        broken,
        hash_changed,
        unpaired: b.len() + n.len() - 2 * paired,
    }
}

fn pct(r: &Rate) -> String {
    format!(
        "{}/{} = {:.0} % (95 % CI {:.0}-{:.0} %)",
        r.passed,
        r.n,
        100.0 * r.rate,
        100.0 * r.low,
        100.0 * r.high
    )
}

fn spread_cell(s: &Option<Spread>, digits: usize) -> String {
    s.map_or("- | - | - | 0".into(), |s| {
        format!(
            "{:.d$} | {:.d$} | {:.d$} | {}",
            s.median,
            s.p10,
            s.p90,
            s.n,
            d = digits
        )
    })
}

/// The summary as Markdown, for a person and for `REPORT.md`.
pub fn markdown(s: &Summary) -> String {
    use std::fmt::Write;
    let mut o = String::new();
    let _ = writeln!(o, "# Campaign `{}`\n", s.name);
    if s.missing > 0 {
        let _ = writeln!(
            o,
            "**Partial: {} of {} cases have not run to their end**; the figures below are over the other {}.\n",
            s.missing,
            s.cases,
            s.cases - s.missing
        );
    }
    let _ = writeln!(o, "**Success: {}**\n", pct(&s.overall));
    let _ = writeln!(o, "| by | group | success |\n|---|---|---|");
    for (by, map) in [
        ("world", &s.by_world),
        ("scenario", &s.by_scenario),
        ("variant", &s.by_variant),
    ] {
        for (k, r) in map {
            let _ = writeln!(o, "| {by} | {k} | {} |", pct(r));
        }
    }
    if !s.criteria.is_empty() {
        let _ = writeln!(o, "\n## Each part of success\n\n| part | met |\n|---|---|");
        // In the order success is judged, not the alphabet's.
        let order = crate::success::Criteria::NAMES;
        for k in order.iter().filter(|k| s.criteria.contains_key(**k)) {
            let r = &s.criteria[*k];
            let _ = writeln!(o, "| {k} | {}/{} |", r.passed, r.n);
        }
    }
    let _ = writeln!(o, "\n## Failures\n");
    if s.failures.is_empty() {
        let _ = writeln!(o, "None.");
    } else {
        let _ = writeln!(
            o,
            "| cause | cases | where (case: world x, y, z) |\n|---|---|---|"
        );
        for f in &s.failures {
            let places: Vec<String> = f
                .cases
                .iter()
                .map(|&id| {
                    let r = &s.rows[id];
                    match r.end_position {
                        Some([x, y, z]) => format!("{id}: {x:.1}, {y:.1}, {z:.1}"),
                        None => format!("{id}"),
                    }
                })
                .collect();
            let _ = writeln!(
                o,
                "| {} | {} | {} |",
                f.cause.name(),
                f.cases.len(),
                places.join("; ")
            );
        }
    }
    let _ = writeln!(
        o,
        "\n## Figures\n\n| figure | median | p10 | p90 | cases |\n|---|---|---|---|---|"
    );
    for (name, sp, d) in [
        ("coverage", &s.coverage, 2),
        ("home error, m", &s.home_error_m, 2),
        ("distance, m", &s.distance_m, 0),
        ("energy, Wh", &s.energy_wh, 1),
        ("mission time, s", &s.mission_time_s, 0),
        ("wall time a case, s", &s.case_wall_time_s, 0),
    ] {
        let _ = writeln!(o, "| {name} | {} |", spread_cell(sp, d));
    }
    let _ = writeln!(
        o,
        "\nWall time of all cases added up: {:.0} s.",
        s.total_case_wall_time_s
    );
    if let Some(c) = &s.baseline {
        let _ = writeln!(
            o,
            "\n## Against `{}`\n\n{} cases paired: baseline {}, now {}; {} fixed, {} broken; {} with another output hash; {} without a twin.\n",
            c.baseline_name,
            c.paired,
            pct(&c.baseline_rate),
            pct(&c.rate),
            c.fixed.len(),
            c.broken.len(),
            c.hash_changed,
            c.unpaired
        );
        for (what, flips) in [("fixed", &c.fixed), ("broken", &c.broken)] {
            for f in flips {
                let name = |x: Option<FailureCause>| x.map_or("passed", FailureCause::name);
                let _ = writeln!(
                    o,
                    "- {what}: case {} ({}): {} -> {}",
                    f.id,
                    f.key,
                    name(f.baseline_failure),
                    name(f.failure)
                );
            }
        }
    }
    let _ = writeln!(
        o,
        "\n## Cases\n\n| case | mission | result | coverage | home error, m | output hash |\n|---|---|---|---|---|---|"
    );
    for r in &s.rows {
        let result = match (r.status, r.failure) {
            (None, _) => "not run".to_string(),
            (_, None) => "passed".to_string(),
            (_, Some(f)) => f.name().to_string(),
        };
        let _ = writeln!(
            o,
            "| {} | {} | {} | {} | {} | {} |",
            r.id,
            r.key,
            result,
            r.coverage.map_or("-".into(), |v| format!("{v:.2}")),
            r.home_error_m.map_or("-".into(), |v| format!("{v:.2}")),
            r.output_hash.as_deref().unwrap_or("-")
        );
    }
    o
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a broken fixture fails the test where it breaks
mod tests {
    use super::*;
    use crate::matrix::BASELINE;
    use crate::success::{judge, MissionFacts, SuccessCriteria};

    /// What one case did, for a campaign written by hand.
    #[derive(Clone, Copy)]
    enum Did {
        /// A mission that ran: its coverage, home error and output hash.
        Ran(f64, f64, u64),
        Stranded(f64),
        Crashed,
    }

    fn campaign(dir: &Path, name: &str, cases: &[(u64, Option<Did>)]) {
        let list: Vec<Case> = cases
            .iter()
            .enumerate()
            .map(|(id, (noise, _))| Case {
                id,
                world: "tube".into(),
                world_seed: 1,
                noise_seed: Some(*noise),
                variant: BASELINE.into(),
                scenario: None,
                start: None,
                duration_s: 100.0,
                explore_s: None,
                success: SuccessCriteria::default(),
            })
            .collect();
        let m = Manifest {
            name: name.into(),
            case_count: list.len(),
            timeout_s: 10.0,
            cases: list.clone(),
        };
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(
            dir.join(crate::manifest::MANIFEST),
            toml::to_string(&m).unwrap(),
        )
        .unwrap();
        for (c, (_, did)) in list.iter().zip(cases) {
            let cd = Manifest::case_dir(dir, c);
            std::fs::create_dir_all(&cd).unwrap();
            let Some(did) = did else { continue };
            let status = if matches!(did, Did::Crashed) {
                Status::Crashed
            } else {
                Status::Ran
            };
            Outcome {
                status,
                exit_code: Some(if status == Status::Ran { 0 } else { 1 }),
                signal: None,
                wall_time_s: 10.0 + c.id as f64,
                host: "h".into(),
                log_tail: vec!["error: it broke".into()],
            }
            .save(&cd)
            .unwrap();
            let (state, cov, home, hash) = match *did {
                Did::Ran(cov, home, hash) => ("finished", cov, home, hash),
                Did::Stranded(cov) => ("stranded", cov, 40.0, 7),
                Did::Crashed => continue,
            };
            let facts = MissionFacts {
                state: state.into(),
                ended_before_limit: true,
                home_error_m: Some(home),
                coverage: Some(cov),
                reach_m: Some(50.0),
                ..Default::default()
            };
            let report = serde_json::json!({
                "output_hash": format!("{hash:016x}"),
                "sim_time_s": 50.0,
                "exploration": {
                    "coverage_fraction": cov,
                    "home_error_m": home,
                    "distance_m": 100.0,
                    "energy_used_wh": 5.0,
                    "end_position": [1.0, 2.0, 3.0],
                },
                "success": judge(&facts, &SuccessCriteria::default()),
            });
            std::fs::write(cd.join(REPORT), report.to_string()).unwrap();
        }
    }

    #[test]
    fn a_campaign_is_judged_case_by_case_with_its_interval() {
        let t = tempfile::tempdir().unwrap();
        campaign(
            t.path(),
            "now",
            &[
                (1, Some(Did::Ran(0.95, 0.2, 1))),
                (2, Some(Did::Ran(0.5, 0.3, 2))),
                (3, Some(Did::Stranded(0.7))),
                (4, Some(Did::Crashed)),
                (5, None),
            ],
        );
        let s = summarise(t.path(), None).unwrap();
        assert_eq!((s.cases, s.missing), (5, 1));
        assert_eq!((s.overall.passed, s.overall.n), (1, 4));
        // Wilson, 1 of 4: centre (0.25 + 0.4802) / 1.9604 = 0.3725, half
        // 1.96 sqrt(0.046875 + 0.060024) / 1.9604 = 0.3268.
        assert!((s.overall.low - 0.0456).abs() < 5e-4, "{:?}", s.overall);
        assert!((s.overall.high - 0.6994).abs() < 5e-4, "{:?}", s.overall);
        let causes: Vec<(FailureCause, Vec<usize>)> = s
            .failures
            .iter()
            .map(|f| (f.cause, f.cases.clone()))
            .collect();
        assert_eq!(
            causes,
            vec![
                (FailureCause::Crash, vec![3]),
                (FailureCause::Stranded, vec![2]),
                (FailureCause::GaveUpEarly, vec![1]),
            ]
        );
        assert_eq!(s.criteria["home"].passed, 2);
        assert_eq!(s.criteria["home"].n, 3);
        let cov = s.coverage.unwrap();
        assert_eq!((cov.n, cov.median), (3, 0.7));
        let md = markdown(&s);
        assert!(md.contains("Partial: 1 of 5"), "{md}");
        assert!(md.contains("1/4 = 25 %"), "{md}");
        assert!(md.contains("2: 1.0, 2.0, 3.0"), "{md}");
    }

    #[test]
    fn a_baseline_comparison_pairs_cases_by_what_they_are_and_finds_flips() {
        let t = tempfile::tempdir().unwrap();
        let (base, now) = (t.path().join("base"), t.path().join("now"));
        campaign(
            &base,
            "base",
            &[
                (1, Some(Did::Ran(0.95, 0.2, 1))),
                (2, Some(Did::Stranded(0.4))),
                (3, Some(Did::Ran(0.95, 0.2, 3))),
            ],
        );
        // The same missions listed in another order, one more, one flipped
        // each way.
        campaign(
            &now,
            "now",
            &[
                (3, Some(Did::Ran(0.95, 0.2, 3))),
                (2, Some(Did::Ran(0.92, 0.1, 9))),
                (1, Some(Did::Crashed)),
                (6, Some(Did::Ran(0.95, 0.2, 6))),
            ],
        );
        let s = summarise(&now, Some(&base)).unwrap();
        let c = s.baseline.as_ref().unwrap();
        assert_eq!(c.paired, 3);
        assert_eq!(c.unpaired, 1);
        assert_eq!((c.baseline_rate.passed, c.rate.passed), (2, 2));
        assert_eq!(c.fixed.len(), 1);
        assert_eq!((c.fixed[0].id, c.fixed[0].baseline_id), (1, 1));
        assert_eq!(c.fixed[0].baseline_failure, Some(FailureCause::Stranded));
        assert_eq!(c.broken.len(), 1);
        assert_eq!((c.broken[0].id, c.broken[0].baseline_id), (2, 0));
        assert_eq!(c.broken[0].failure, Some(FailureCause::Crash));
        assert_eq!(c.hash_changed, 2);
        let md = markdown(&s);
        assert!(
            md.contains("- fixed: case 1 (tube seed 1 noise 2 baseline): stranded -> passed"),
            "{md}"
        );
        assert!(md.contains("- broken: case 2"), "{md}");
        // The same baseline from the summary `report --json` keeps.
        let saved = t.path().join("base.json");
        let json = serde_json::to_string(&summarise(&base, None).unwrap()).unwrap();
        std::fs::write(&saved, json).unwrap();
        let c2 = summarise(&now, Some(&saved)).unwrap().baseline.unwrap();
        let figures = |c: &Comparison| (c.paired, c.fixed.len(), c.broken.len(), c.hash_changed);
        assert_eq!(figures(&c2), figures(c));
        std::fs::write(&saved, "{}").unwrap();
        let e = summarise(&now, Some(&saved)).unwrap_err();
        assert!(e.contains("base.json") && e.contains("neither"), "{e}");
    }
}
