//! `speleo hil`: a hardware-in-the-loop bench in one command. It starts the
//! twin (`speleo twin`) and, once the twin's wires are up, the flight
//! binary (`speleo run`) pointed at them; after the given time (or when the
//! mission ends by itself) it stops both with SIGINT, as an operator would,
//! and puts their reports side by side: where the rover believed it was
//! against where it truly was, distance, coverage and timing.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crate::Error;
use flight_config::write_flight_config;
use verdict::{judge, print_side_by_side};

mod flight_config;
pub mod track;
pub mod verdict;

/// What `speleo hil` is asked to do.
#[derive(Clone, Debug)]
pub struct HilRequest {
    pub world: Option<String>,
    pub seed: Option<u64>,
    pub duration_s: f64,
    /// The twin's configuration (`examples/twin.toml` form); its defaults
    /// when none.
    pub twin_config: Option<PathBuf>,
    /// The flight binary's; its `[devices]` are set to the twin's wires.
    pub flight_config: Option<PathBuf>,
    /// Where both processes write their recordings and reports.
    pub out_dir: PathBuf,
    pub report: Option<PathBuf>,
    pub unplug_lidar: Vec<String>,
}

/// How long the twin may take to build its world and open its wires.
const TWIN_READY_WITHIN: Duration = Duration::from_secs(120);
/// How long each process may take to finish once asked to stop.
const STOP_WITHIN: Duration = Duration::from_secs(120);

pub fn hil(r: HilRequest) -> Result<ExitCode, Error> {
    std::fs::create_dir_all(&r.out_dir)
        .map_err(|e| format!("--out {}: {e}", r.out_dir.display()))?;
    if let Some(p) = &r.report {
        speleo_firmware::output_paths::check_file(p, "--report")?;
    }
    let out = |name: &str| r.out_dir.join(name);
    let flight_config = out("flight.toml");
    write_flight_config(
        r.twin_config.as_deref(),
        r.flight_config.as_deref(),
        &flight_config,
    )?;
    let exe = std::env::current_exe().map_err(|e| format!("cannot find speleo itself: {e}"))?;
    let mut twin_cmd = Command::new(&exe);
    twin_cmd.args(["--no-progress", "twin"]);
    if let Some(c) = &r.twin_config {
        twin_cmd.arg("--config").arg(c);
    }
    twin_cmd
        .arg("--record")
        .arg(out("twin.mcap"))
        .arg("--report")
        .arg(out("twin.json"));
    if let Some(w) = &r.world {
        twin_cmd.args(["--world", w]);
    }
    if let Some(s) = r.seed {
        twin_cmd.args(["--seed", &s.to_string()]);
    }
    for u in &r.unplug_lidar {
        twin_cmd.args(["--unplug-lidar", u]);
    }
    let mut twin = Guard(
        twin_cmd
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| format!("cannot start the twin: {e}"))?,
    );
    let ready = wait_ready(&mut twin.0)?;
    eprintln!("{ready}");
    let mut flight = Guard(
        Command::new(&exe)
            .args(["--no-progress", "run", "--config"])
            .arg(&flight_config)
            .arg("--record")
            .arg(out("flight.mcap"))
            .arg("--report")
            .arg(out("flight.json"))
            .spawn()
            .map_err(|e| format!("cannot start the flight binary: {e}"))?,
    );
    // The mission ends by itself (home, stranded) or at the bench's time.
    let until = Instant::now() + Duration::from_secs_f64(r.duration_s);
    while Instant::now() < until {
        if flight.0.try_wait()?.is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let flight_status = stop(&mut flight.0, "the flight binary")?;
    let twin_status = stop(&mut twin.0, "the twin")?;
    let flight_report = read_json(&out("flight.json"))?;
    let twin_report = read_json(&out("twin.json"))?;
    let mut bench = judge(&flight_report, &twin_report);
    bench["track"] = compare_tracks(&out("flight.mcap"), &out("twin.mcap"), &twin_report);
    print_side_by_side(&flight_report, &twin_report, &bench);
    if let Some(p) = &r.report {
        let all = json!({
            "flight": flight_report,
            "twin": twin_report,
            "bench": bench,
            "flight_exit": flight_status,
            "twin_exit": twin_status,
        });
        std::fs::write(p, serde_json::to_string_pretty(&all)?)
            .map_err(|e| format!("writing {}: {e}", p.display()))?;
    }
    if flight_status != 0 || twin_status != 0 {
        return Err(format!(
            "the flight binary exited with {flight_status}, the twin with {twin_status}"
        )
        .into());
    }
    Ok(ExitCode::SUCCESS)
}

/// The SLAM track against the truth's, or null (said why) when the
/// recordings cannot give it.
fn compare_tracks(flight: &Path, twin: &Path, twin_report: &Value) -> Value {
    let start: Option<Vec<f64>> = twin_report["run"]["truth_start"]
        .as_array()
        .and_then(|a| a.iter().map(Value::as_f64).collect());
    let Some([x, y, z, yaw]) = start.as_deref().and_then(|s| <[f64; 4]>::try_from(s).ok()) else {
        eprintln!("note: the twin's report has no start pose; the tracks were not compared");
        return Value::Null;
    };
    match track::track_error(flight, twin, [x, y, z, yaw]) {
        Ok(Some(e)) => json!(e),
        Ok(None) => {
            eprintln!(
                "note: no SLAM pose fell within the twin's truth; the tracks were not compared"
            );
            Value::Null
        }
        Err(e) => {
            eprintln!("note: the tracks were not compared: {e}");
            Value::Null
        }
    }
}

/// A child process killed if the bench ends early (an error on the way).
struct Guard(Child);

impl Drop for Guard {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// Read the twin's output until its "twin ready" line; the rest of its
/// output is passed on.
fn wait_ready(twin: &mut Child) -> Result<String, Error> {
    let stdout = twin.stdout.take().ok_or("the twin has no output")?;
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut sent = false;
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if !sent && line.starts_with("twin ready") {
                let _ = tx.send(line);
                sent = true;
            } else {
                println!("{line}");
            }
        }
    });
    rx.recv_timeout(TWIN_READY_WITHIN).map_err(|_| {
        format!(
            "the twin was not ready within {} s",
            TWIN_READY_WITHIN.as_secs()
        )
        .into()
    })
}

/// SIGINT, then wait for the exit status.
fn stop(child: &mut Child, what: &str) -> Result<i32, Error> {
    if child.try_wait()?.is_none() {
        // SAFETY: a plain kill(2) on a child this process started and has
        // not reaped.
        unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    }
    let until = Instant::now() + STOP_WITHIN;
    loop {
        if let Some(s) = child.try_wait()? {
            return Ok(s.code().unwrap_or(-1));
        }
        if Instant::now() > until {
            let _ = child.kill();
            return Err(format!(
                "{what} did not stop within {} s of SIGINT",
                STOP_WITHIN.as_secs()
            )
            .into());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn read_json(p: &Path) -> Result<Value, Error> {
    let text = std::fs::read_to_string(p).map_err(|e| format!("reading {}: {e}", p.display()))?;
    Ok(serde_json::from_str(&text).map_err(|e| format!("{}: {e}", p.display()))?)
}
