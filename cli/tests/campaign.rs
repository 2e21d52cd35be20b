//! `speleo campaign` as a user meets it: a tiny matrix of short missions
//! planned, run two at a time, killed halfway and resumed, a crash
//! recorded, a case run through a cluster's index variable, reproduced,
//! and reported.

#![allow(clippy::unwrap_used)] // a broken fixture fails the test where it breaks

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{speleo, text};

fn ok(o: &Output) -> String {
    assert!(
        o.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        o.status,
        text(&o.stdout),
        text(&o.stderr)
    );
    text(&o.stdout)
}

fn outcomes(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir.join("cases"))
        .map(|r| {
            r.filter_map(|e| e.ok())
                .map(|e| e.path().join("outcome.json"))
                .filter(|p| p.exists())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("json")
}

/// Processes whose command line names `needle`.
fn processes_naming(needle: &str) -> usize {
    let Ok(rd) = std::fs::read_dir("/proc") else {
        return 0;
    };
    rd.filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().parse::<u32>().is_ok())
        .filter(|e| {
            std::fs::read(e.path().join("cmdline"))
                .map(|c| String::from_utf8_lossy(&c).contains(needle))
                .unwrap_or(false)
        })
        .count()
}

/// Six flat-ground missions of a few seconds, and one on a mesh world
/// that is deleted once planned (its case must crash).
fn plan(t: &Path) -> PathBuf {
    let mesh = t.join("ground.ply");
    ok(&speleo(&[
        "world",
        "export",
        "flat",
        mesh.to_str().unwrap(),
    ]));
    let matrix = t.join("tiny.toml");
    std::fs::write(
        &matrix,
        r#"name = "tiny"
timeout_s = 600

[[group]]
worlds = ["flat"]
noise_seeds = [1, 2, 3, 4, 5, 6]
duration_s = 4

[[group]]
worlds = ["ground.ply"]
duration_s = 4
"#,
    )
    .unwrap();
    let dir = t.join("campaign");
    let out = ok(&speleo(&[
        "campaign",
        "plan",
        matrix.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]));
    assert!(out.starts_with("7 cases planned"), "{out}");
    assert!(out.contains("--array=0-6"), "{out}");
    let manifest = std::fs::read_to_string(dir.join("manifest.toml")).unwrap();
    assert!(manifest.contains("case_count = 7"), "{manifest}");
    std::fs::remove_file(&mesh).unwrap();
    dir
}

#[test]
fn a_campaign_killed_halfway_resumes_records_its_crash_and_reports() {
    let t = tempfile::tempdir().unwrap();
    let dir = plan(t.path());
    let d = dir.to_str().unwrap();

    // Two at a time, killed once some cases have finished.
    let mut runner = Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args(["campaign", "run", d, "--jobs", "2", "--no-progress"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while outcomes(&dir).len() < 2 {
        assert!(
            started.elapsed() < Duration::from_secs(600),
            "no case finished"
        );
        assert!(
            runner.try_wait().unwrap().is_none(),
            "the runner ended early"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    runner.kill().unwrap();
    runner.wait().unwrap();
    let before = outcomes(&dir).len();
    assert!(before < 7, "killed after every case had run");
    // Its cases die with it.
    let gone = Instant::now();
    while processes_naming(d) > 0 {
        assert!(gone.elapsed() < Duration::from_secs(10), "orphaned cases");
        std::thread::sleep(Duration::from_millis(50));
    }

    // Resumed: what finished is skipped, the rest run.
    let out = ok(&speleo(&["campaign", "run", d, "--jobs", "2"]));
    assert!(
        out.contains(&format!("{} cases run", 7 - before))
            && out.contains(&format!("{before} finished before")),
        "{out}"
    );
    assert_eq!(outcomes(&dir).len(), 7);
    let crash = json(&dir.join("cases/0006/outcome.json"));
    assert_eq!(crash["status"], "crashed");
    let tail = crash["log_tail"].to_string();
    assert!(tail.contains("ground.ply"), "{tail}");
    let ran = json(&dir.join("cases/0000/outcome.json"));
    assert_eq!(ran["status"], "ran");
    let report = json(&dir.join("cases/0000/report.json"));
    assert_eq!(report["success"]["failure"], "out_of_time");

    // Run again: nothing left to do.
    let out = ok(&speleo(&["campaign", "run", d]));
    assert!(
        out.contains("0 cases run") && out.contains("7 finished before"),
        "{out}"
    );

    // Judged.
    let summary = t.path().join("summary.json");
    let out = ok(&speleo(&[
        "campaign",
        "report",
        d,
        "--json",
        summary.to_str().unwrap(),
    ]));
    assert!(
        out.contains("**Success: 0/7 = 0 % (95 % CI 0-35 %)**"),
        "{out}"
    );
    let s = json(&summary);
    assert_eq!(s["missing"], 0);
    let causes: Vec<(String, usize)> = s["failures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            (
                f["cause"].as_str().unwrap().to_string(),
                f["cases"].as_array().unwrap().len(),
            )
        })
        .collect();
    assert_eq!(
        causes,
        vec![("crash".to_string(), 1), ("out_of_time".to_string(), 6)]
    );
}

#[test]
fn one_case_runs_through_the_cluster_index_variable_and_reproduces_its_hash() {
    let t = tempfile::tempdir().unwrap();
    let dir = plan(t.path());
    let d = dir.to_str().unwrap();
    // The shipped Slurm batch file, as an array task runs it.
    let sbatch = Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/slurm/campaign.sbatch");
    let o = Command::new("bash")
        .arg(&sbatch)
        .arg(d)
        .env("SLURM_ARRAY_TASK_ID", "3")
        .env("SPELEO", env!("CARGO_BIN_EXE_speleo"))
        .output()
        .unwrap();
    ok(&o);
    assert_eq!(outcomes(&dir), vec![dir.join("cases/0003/outcome.json")]);
    assert_eq!(json(&dir.join("cases/0003/outcome.json"))["status"], "ran");

    let out = ok(&speleo(&["campaign", "run", d, "--case", "3", "--verify"]));
    assert!(out.contains("reproduced"), "{out}");

    // A partial campaign says how much is missing.
    let out = ok(&speleo(&["campaign", "report", d]));
    assert!(out.contains("Partial: 6 of 7 cases"), "{out}");

    let o = speleo(&["campaign", "run", d, "--case", "7"]);
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("case 7"), "{}", text(&o.stderr));
}

#[test]
fn a_bad_matrix_is_refused_with_the_key_named() {
    let t = tempfile::tempdir().unwrap();
    let m = t.path().join("m.toml");
    let out = t.path().join("c");
    for (body, key) in [
        ("name = \"x\"\n[[group]]\nworlds = [\"flat\"]\nnoise = [1]\n", "noise"),
        ("name = \"x\"\n[[group]]\nworlds = [\"atlantis\"]\n", "atlantis"),
        ("name = \"x\"\n", "group"),
        (
            "name = \"x\"\n[[group]]\nworlds = [\"flat\"]\nvariants = [\"v\"]\n[variants.v]\nplanner = { max_bumpp_m = 1 }\n",
            "max_bumpp_m",
        ),
        (
            "name = \"x\"\n[[group]]\nscenarios = [\"s\"]\n[scenarios.s]\nworld = \"lava-tube\"\nstart = \"m5000\"\nduration_s = 10\nreach_m = 5\n",
            "m5000",
        ),
    ] {
        std::fs::write(&m, body).unwrap();
        let o = speleo(&[
            "campaign",
            "plan",
            m.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(!o.status.success(), "{body}");
        let e = text(&o.stderr);
        assert!(e.contains(key), "{body}: {e}");
        assert!(!out.join("manifest.toml").exists());
    }
}

#[test]
fn two_runners_on_one_folder_run_each_case_once() {
    let t = tempfile::tempdir().unwrap();
    let dir = plan(t.path());
    let d = dir.to_str().unwrap();
    let runner = || {
        Command::new(env!("CARGO_BIN_EXE_speleo"))
            .args(["campaign", "run", d, "--jobs", "1", "--no-progress"])
            .stderr(Stdio::null())
            .output()
            .unwrap()
    };
    let (a, b) = std::thread::scope(|s| {
        let a = s.spawn(runner);
        let b = s.spawn(runner);
        (a.join().unwrap(), b.join().unwrap())
    });
    let ran = |o: &Output| -> usize {
        let out = ok(o);
        out.split(" cases run")
            .next()
            .and_then(|n| n.trim().parse().ok())
            .unwrap_or_else(|| panic!("{out}"))
    };
    assert_eq!(
        ran(&a) + ran(&b),
        7,
        "{} / {}",
        text(&a.stdout),
        text(&b.stdout)
    );
    assert_eq!(outcomes(&dir).len(), 7);
}

/// `matrix` written into `t` and planned into `t/c`.
fn planned(t: &Path, matrix: &str) -> PathBuf {
    let path = t.join("matrix.toml");
    std::fs::write(&path, matrix).unwrap();
    let dir = t.join("c");
    ok(&speleo(&[
        "campaign",
        "plan",
        path.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]));
    dir
}

#[test]
fn a_case_past_its_time_limit_is_killed_and_counted_a_hang() {
    let t = tempfile::tempdir().unwrap();
    // A minute of mission cannot run within a second of wall time.
    let dir = planned(
        t.path(),
        "name = \"slow\"\ntimeout_s = 1\n[[group]]\nworlds = [\"flat\"]\nduration_s = 60\n",
    );
    let d = dir.to_str().unwrap();
    let started = Instant::now();
    let o = speleo(&["campaign", "run", d]);
    ok(&o);
    assert!(started.elapsed() < Duration::from_secs(30));
    assert!(text(&o.stderr).contains("Hung"), "{}", text(&o.stderr));
    let outcome = json(&dir.join("cases/0000/outcome.json"));
    assert_eq!(outcome["status"], "hung");
    assert!(outcome["wall_time_s"].as_f64().unwrap() < 5.0, "{outcome}");
    let out = ok(&speleo(&["campaign", "report", d]));
    assert!(out.contains("| hang | 1 |"), "{out}");
}

/// The repository's matrices plan, and each holds every case of the one
/// before (dev in nightly, nightly in full), so that their cases pair.
#[test]
fn the_shipped_matrices_plan_and_each_holds_the_cases_of_the_one_before() {
    let t = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../campaigns");
    let keys = |name: &str| -> std::collections::BTreeSet<String> {
        let out = t.path().join(name);
        let matrix = root.join(format!("{name}.toml"));
        ok(&speleo(&[
            "campaign",
            "plan",
            matrix.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]));
        let m = speleo_campaign::manifest::Manifest::load(&out).unwrap();
        m.cases.iter().map(|c| c.key()).collect()
    };
    let (dev, nightly, full) = (keys("dev"), keys("nightly"), keys("full"));
    assert!(dev.len() >= 10, "{dev:?}");
    assert!(dev.is_subset(&nightly), "{:?}", dev.difference(&nightly));
    assert!(nightly.is_subset(&full), "{:?}", nightly.difference(&full));
}

/// A campaign run with its validations dumped, then replayed on the true
/// world: on flat ground the map and the truth agree on every verdict.
#[test]
fn a_campaigns_validations_replay_on_the_true_world() {
    let t = tempfile::tempdir().unwrap();
    let dir = planned(
        t.path(),
        "name = \"flat\"\ntimeout_s = 600\n[[group]]\nworlds = [\"flat\"]\nduration_s = 40\n",
    );
    let d = dir.to_str().unwrap();
    let o = speleo(&["campaign", "validations", d]);
    assert!(!o.status.success(), "nothing dumped yet");
    assert!(
        text(&o.stderr).contains("--dump-validations"),
        "{}",
        text(&o.stderr)
    );
    ok(&speleo(&["campaign", "run", d, "--dump-validations"]));
    assert!(dir.join("cases/0000/validations/truth.csv").exists());
    let csv = t.path().join("v.csv");
    let out = ok(&speleo(&[
        "campaign",
        "validations",
        d,
        "--csv",
        csv.to_str().unwrap(),
    ]));
    let rows = std::fs::read_to_string(&csv).unwrap().lines().count() - 1;
    assert!(rows >= 1, "{out}");
    assert!(
        out.starts_with(&format!(
            "{rows} validations replayed (1 cases, 0 skipped, 0 begun"
        )),
        "{out}"
    );
    assert!(
        out.contains(&format!("as on board     {rows:>3}/{rows:<4}")),
        "{out}"
    );
}

#[test]
fn ctrl_c_stops_a_campaign_leaving_the_cases_it_cut_short_to_run_again() {
    let t = tempfile::tempdir().unwrap();
    // Two long missions, one at a time: the first is under way when the
    // signal comes, the second never starts.
    let dir = planned(
        t.path(),
        "name = \"long\"\n[[group]]\nworlds = [\"flat\"]\nnoise_seeds = [1, 2]\nduration_s = 600\n",
    );
    let d = dir.to_str().unwrap();
    let runner = Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args(["campaign", "run", d, "--jobs", "1", "--no-progress"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // A case's lock is taken as it starts.
    let lock = dir.join("cases/0000/lock");
    let started = Instant::now();
    while !lock.exists() {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no case began"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let sent = Command::new("kill")
        .args(["-INT", &runner.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let out = runner.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("interrupted"),
        "{}",
        text(&out.stdout)
    );
    assert!(started.elapsed() < Duration::from_secs(300));
    // Neither case has an outcome: the next run starts both.
    assert!(outcomes(&dir).is_empty(), "{:?}", outcomes(&dir));
    assert_eq!(processes_naming(d), 0, "orphaned cases");
}
