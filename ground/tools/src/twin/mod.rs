//! `speleo twin`: the rover's hardware twin as a process of its own, in real
//! time, on the real wires: the world and the physics rover with the
//! HDL-32E, MTi and drive twins, speaking UDP, the MTi's serial line and an
//! slcan adapter's serial line to an unmodified flight binary (`speleo run`).

pub mod links;
pub mod pump;
pub mod serial_end;
pub mod settings;
pub mod tape;

use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use speleo_firmware::commands::{twin_params, world_of};
use speleo_twin::TwinHardware;

use crate::Error;
use links::{LinkCounters, Links};
use pump::{PumpFigures, Unplug};
use settings::TwinSettings;

/// What `speleo twin` is asked to do.
#[derive(Clone, Debug, Default)]
pub struct TwinRequest {
    pub config: Option<PathBuf>,
    pub world: Option<String>,
    pub seed: Option<u64>,
    pub noise_seed: Option<u64>,
    pub duration_s: Option<f64>,
    pub record: Option<PathBuf>,
    pub report: Option<PathBuf>,
    pub unplug_lidar: Vec<String>,
}

/// The twin's report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TwinReport {
    pub world: String,
    pub seed: u64,
    pub noise_seed: Option<u64>,
    pub run: PumpFigures,
    pub links: LinkCounters,
    pub lidar_unplugged: Vec<Unplug>,
    /// Messages the recording dropped (its queue full).
    pub recording_dropped: u64,
    pub recording_messages: u64,
}

/// Run the twin until a signal (or the duration) ends it.
pub fn twin(r: TwinRequest) -> Result<ExitCode, Error> {
    for (p, what) in [(&r.record, "--record"), (&r.report, "--report")] {
        if let Some(p) = p {
            speleo_firmware::output_paths::check_file(p, what)?;
        }
    }
    let mut s = match &r.config {
        Some(p) => TwinSettings::load(p)?,
        None => TwinSettings::defaults(),
    };
    let cfg = &mut s.config;
    if let Some(w) = &r.world {
        cfg.sim.world = w.clone();
    }
    if let Some(v) = r.seed {
        cfg.sim.seed = v;
    }
    if r.noise_seed.is_some() {
        cfg.sim.noise_seed = r.noise_seed;
    }
    cfg.validate()?;
    let unplug = r
        .unplug_lidar
        .iter()
        .map(|u| Unplug::parse(u))
        .collect::<Result<Vec<_>, _>>()?;
    tracing::info!(
        "building the world: {}, seed {}",
        cfg.sim.world,
        cfg.sim.seed
    );
    let world = world_of(cfg)?;
    let mut params = twin_params(cfg);
    params.start_on_ground = cfg.sim.start.is_some();
    let mut hw = TwinHardware::with_world(&params, &world)?;
    let mut links = Links::open(&s.table.links()?)?;
    if let Some(p) = &r.record {
        let mut meta = BTreeMap::new();
        meta.insert("world".into(), cfg.sim.world.clone());
        meta.insert("seed".into(), cfg.sim.seed.to_string());
        if let Some(n) = cfg.sim.noise_seed {
            meta.insert("noise_seed".into(), n.to_string());
        }
        meta.insert("config".into(), s.text.clone());
        links.tape = Some(tape::Tape::create(p, meta)?);
    }
    let (imu, can) = links.port_paths();
    // One line for whoever wires the flight binary to the twin (`speleo hil`
    // reads it), then the same in words.
    println!(
        "twin ready: lidar {} -> {}, imu {imu}, can (slcan) {can}",
        s.table.lidar_from, s.table.lidar_to
    );
    let _ = std::io::stdout().flush();
    let run = pump::run(
        &mut hw,
        &mut links,
        r.duration_s.map(Duration::from_secs_f64),
        speleo_firmware::signals::stop_flag(),
        &unplug,
    )?;
    let (recording_dropped, recording_messages) = match links.tape.take() {
        Some(t) => {
            let dropped = t.dropped;
            (dropped, t.finish()?)
        }
        None => (0, 0),
    };
    let report = TwinReport {
        world: cfg.sim.world.clone(),
        seed: cfg.sim.seed,
        noise_seed: cfg.sim.noise_seed,
        run,
        links: links.counters,
        lidar_unplugged: unplug,
        recording_dropped,
        recording_messages,
    };
    print_report(&report);
    if report.run.wrecked {
        tracing::warn!("the rover was wrecked in a fall: the twin stopped there");
    }
    if let Some(p) = &r.report {
        let json = serde_json::to_string_pretty(&report)?;
        std::fs::write(p, json).map_err(|e| format!("writing {}: {e}", p.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn print_report(r: &TwinReport) {
    let f = &r.run;
    let [x0, y0, z0, _] = f.truth_start;
    let [x, y, z, yaw] = f.truth_end;
    println!(
        "twin: {:.1} s of {} (seed {}), {} steps, {} slipped",
        f.seconds, r.world, r.seed, f.steps, f.steps_slipped
    );
    println!(
        "  truth: drove {:.2} m, from ({x0:.2}, {y0:.2}, {z0:.2}) to ({x:.2}, {y:.2}, {z:.2}) heading {:.1} deg",
        f.truth_distance_m,
        yaw.to_degrees()
    );
    let l = &r.links;
    println!(
        "  lidar: {} packets sent, {} unplugged, {} send errors; position packets {}",
        l.lidar_packets_sent,
        l.lidar_packets_unplugged,
        l.lidar_send_errors,
        l.lidar_position_packets_sent
    );
    println!(
        "  imu: {} bytes sent, {} dropped, {} received",
        l.imu_bytes_sent, l.imu_bytes_dropped, l.imu_bytes_received
    );
    println!(
        "  can: {} frames to the host, {} from it, {} while closed, {} lines refused, {} bytes dropped",
        l.can_frames_to_host,
        l.can_frames_from_host,
        l.can_frames_while_closed,
        l.can_lines_refused,
        l.can_bytes_dropped
    );
    if r.recording_messages > 0 || r.recording_dropped > 0 {
        println!(
            "  recorded {} messages, {} dropped",
            r.recording_messages, r.recording_dropped
        );
    }
}
