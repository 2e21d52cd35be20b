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
    let bench = judge(&flight_report, &twin_report);
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

/// The flight binary's configuration: `base` (or the defaults) with its
/// devices at the twin's wires, as `twin` (or its defaults) places them.
fn write_flight_config(twin: Option<&Path>, base: Option<&Path>, out: &Path) -> Result<(), Error> {
    let t = match twin {
        Some(p) => crate::twin::settings::TwinSettings::load(p)?,
        None => crate::twin::settings::TwinSettings::defaults(),
    };
    let mut doc: toml::Table = match base {
        Some(p) => std::fs::read_to_string(p)
            .map_err(|e| format!("cannot read {}: {e}", p.display()))?
            .parse()
            .map_err(|e| format!("{}: {e}", p.display()))?,
        None => toml::Table::new(),
    };
    let links = t.table.links()?;
    let port = |s: &crate::twin::serial_end::SerialSetting, link: &str| match s {
        crate::twin::serial_end::SerialSetting::Device { path, .. } => path.clone(),
        crate::twin::serial_end::SerialSetting::Pty { .. } => link.to_string(),
    };
    let devices = doc
        .entry("devices")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let toml::Value::Table(d) = devices else {
        return Err("[devices] is not a table".into());
    };
    let s = |v: &str| toml::Value::String(v.to_string());
    d.insert("lidar_bind".into(), s(&links.lidar_to.to_string()));
    d.insert(
        "lidar_position_bind".into(),
        s(&links
            .lidar_position_to
            .map_or(String::new(), |a| a.to_string())),
    );
    d.insert("lidar_sensor".into(), s(&links.lidar_from.to_string()));
    d.insert("imu_port".into(), s(&port(&links.imu, &t.table.imu_link)));
    d.insert(
        "imu_baud".into(),
        toml::Value::Integer(t.table.imu_baud.into()),
    );
    d.insert("can_transport".into(), s("slcan"));
    d.insert(
        "can_serial_port".into(),
        s(&port(&links.can, &t.table.can_link)),
    );
    d.insert(
        "can_serial_baud".into(),
        toml::Value::Integer(t.table.can_baud.into()),
    );
    let text = toml::to_string(&doc).map_err(|e| e.to_string())?;
    speleo_firmware::config::Config::from_toml(&text)
        .map_err(|e| format!("the flight configuration for the bench: {e}"))?;
    std::fs::write(out, text).map_err(|e| format!("writing {}: {e}", out.display()))?;
    Ok(())
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

/// The bench's verdict figures: the flight binary's final SLAM pose against
/// the twin's truth, in the map frame (level, at the true start, heading as
/// the rover started).
pub fn judge(flight: &Value, twin: &Value) -> Value {
    let f64s = |v: &Value| -> Option<Vec<f64>> {
        v.as_array()?
            .iter()
            .map(Value::as_f64)
            .collect::<Option<Vec<_>>>()
    };
    let start = f64s(&twin["run"]["truth_start"]);
    let end = f64s(&twin["run"]["truth_end"]);
    let believed = f64s(&flight["end"]["slam_position"]);
    let error = match (start, end, believed) {
        (Some(s), Some(e), Some(b)) if s.len() == 4 && e.len() == 4 && b.len() == 3 => {
            let (c, sn) = (s[3].cos(), s[3].sin());
            let (dx, dy, dz) = (e[0] - s[0], e[1] - s[1], e[2] - s[2]);
            let truth = [c * dx + sn * dy, -sn * dx + c * dy, dz];
            let d: f64 = (0..3).map(|i| (truth[i] - b[i]).powi(2)).sum();
            json!({
                "truth_in_map": truth,
                "believed_in_map": b,
                "position_error_m": d.sqrt(),
            })
        }
        _ => json!({ "position_error_m": null }),
    };
    json!({
        "pose": error,
        "truth_distance_m": twin["run"]["truth_distance_m"],
        "odometry_distance_m": flight["end"]["odometry_distance_m"],
        "explored_area_m2": flight["exploration"]["explored_area_m2"],
    })
}

fn print_side_by_side(flight: &Value, twin: &Value, bench: &Value) {
    let n = |v: &Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.2}"));
    println!("{:<34} {:>16} {:>16}", "", "flight (run)", "twin (truth)");
    println!(
        "{:<34} {:>16} {:>16}",
        "seconds",
        n(&flight["sim_time_s"]),
        n(&twin["run"]["seconds"])
    );
    println!(
        "{:<34} {:>16} {:>16}",
        "distance driven, m",
        n(&bench["odometry_distance_m"]),
        n(&bench["truth_distance_m"])
    );
    println!(
        "{:<34} {:>16} {:>16}",
        "position error at the end, m",
        n(&bench["pose"]["position_error_m"]),
        ""
    );
    println!(
        "{:<34} {:>16} {:>16}",
        "explored area, m2",
        n(&bench["explored_area_m2"]),
        ""
    );
    println!(
        "{:<34} {:>16} {:>16}",
        "lidar packets",
        n(&flight["counters"]["lidar_packets"]),
        twin["links"]["lidar_packets_sent"].to_string()
    );
    let rt = &flight["realtime"];
    println!(
        "{:<34} {:>16} {:>16}",
        "frame start lateness p50/p99/max, us",
        format!(
            "{}/{}/{}",
            n(&rt["frame_start_lateness"]["p50_us"]),
            n(&rt["frame_start_lateness"]["p99_us"]),
            n(&rt["frame_start_lateness"]["max_us"])
        ),
        format!("{} slipped", twin["run"]["steps_slipped"])
    );
    for (key, label) in [
        (
            "lidar_to_wheel_command",
            "lidar -> wheel command p50/p99, ms",
        ),
        ("imu_to_odometry", "imu -> odometry p50/p99, ms"),
    ] {
        let ms = |v: &Value| {
            v.as_f64()
                .map_or("-".to_string(), |x| format!("{:.1}", x * 1e-3))
        };
        println!(
            "{:<34} {:>16} {:>16}",
            label,
            format!("{}/{}", ms(&rt[key]["p50_us"]), ms(&rt[key]["p99_us"])),
            ""
        );
    }
    println!(
        "{:<34} {:>16}",
        "real-time setup",
        format!(
            "{}; {}",
            rt["sched_fifo"].as_str().unwrap_or("-"),
            rt["mlockall"].as_str().unwrap_or("-")
        )
    );
}
