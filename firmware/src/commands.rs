//! The three flight commands: sim, replay and run. Each prepares its hardware, clock
//! and recorder, then hands them to [`Session::drive`].

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::thread::JoinHandle;

use indicatif::{ProgressBar, ProgressStyle};
use speleo_hal::replay::ReplayHardware;
use speleo_hal::Hardware;
use speleo_scheduler::realtime::{setup_realtime, MonotonicClock};
use speleo_scheduler::{Enforcement, FrameClock, VirtualClock};
use speleo_twin::{RoverParams, TruthProbe, TwinHardware, TwinParams};

use crate::args::{Outputs, ReplayArgs, RunArgs, SimArgs};
use crate::config::{Config, StartSpec};
use crate::faults::inject::{FaultClock, FaultyHardware};
use crate::mission::{self, Length, MissionInputs, MissionResult};
use crate::record::compare::Comparer;
use crate::record::live::LiveServer;
use crate::record::writer::{self, WriterOptions, WriterStats};
use crate::record::{read, RecorderTap};
use crate::report::{self, ReplayReport};
use crate::schedule_table;

type Error = Box<dyn std::error::Error>;

/// The recorder of one run and, when recording or serving a live view, its
/// writer thread.
struct Session {
    tap: RefCell<RecorderTap>,
    writer: Option<JoinHandle<Result<WriterStats, String>>>,
    live: Option<Arc<LiveServer>>,
    /// A replayed real-time run's slips and overruns.
    replayed_timing: Vec<crate::record::frame_timing::FrameTiming>,
}

impl Session {
    /// `blocking`: on virtual time the recorder waits for the disk; in real
    /// time it drops (and counts) rather than delay a frame. `epoch_ns`:
    /// mission time 0 in Unix ns; without it the mission takes the Unix
    /// time of its first frame.
    fn open(
        out: &Outputs,
        cfg: &Config,
        meta: BTreeMap<String, String>,
        epoch_ns: Option<u64>,
        comparer: Option<Comparer>,
        blocking: bool,
    ) -> Result<Session, Error> {
        let large = mission::cloud_message_capacity(cfg.lidar.max_points_per_frame);
        let tap = RecorderTap::new(comparer, large);
        let live = match &out.live {
            Some(address) => {
                let server = LiveServer::start(address)?;
                tracing::info!(
                    "live view on ws://{} (Foxglove: Open connection, Foxglove WebSocket)",
                    server.address()
                );
                Some(Arc::new(server))
            }
            None => None,
        };
        let (mut tap, writer) = if out.record.is_none() && live.is_none() {
            (tap, None)
        } else {
            let h = writer::spawn(WriterOptions {
                path: out.record.clone(),
                live: live.clone(),
                zstd: cfg.record.compression == "zstd",
                chunk_size: cfg.record.chunk_size_kib as u64 * 1024,
                pool: cfg.record.pool_messages as usize,
                large_pool: 4,
                large_capacity: large,
                run_metadata: meta,
            })?;
            let thread = h.thread.thread().clone();
            let tap = tap.with_writer(h.tx, h.pool, h.large_pool, thread, blocking);
            (tap, Some(h.thread))
        };
        if let Some(e) = epoch_ns {
            tap.begin(e);
        }
        Ok(Session {
            tap: RefCell::new(tap),
            writer,
            live,
            replayed_timing: Vec::new(),
        })
    }

    /// Feed recorded inputs through the drivers and tasks on virtual time,
    /// up to and including frame `last`.
    /// A run in real time (`real_time`) is replayed with its recorded slips
    /// and overruns (`timing`), enforced as they were.
    fn replay(
        &mut self,
        cfg: &Config,
        rec: read::Recording,
        last: u64,
        progress: bool,
    ) -> Result<MissionResult, Error> {
        let real_time = rec.run.get("mode").map(String::as_str) == Some("run");
        let mut recorded = ReplayHardware::new(cfg.executive.minor_frame_us, rec.inputs);
        if real_time {
            self.replayed_timing = rec.timing;
            let slipped: u64 = self
                .replayed_timing
                .iter()
                .filter(|t| t.frame <= last)
                .map(|t| t.slipped)
                .sum();
            let clock = crate::record::frame_timing::SlippingClock::new(
                cfg.executive.minor_frame_us,
                &self.replayed_timing,
            );
            return self.drive(
                cfg,
                Length::Frames(last + 1 - slipped),
                Enforcement::Replay,
                None,
                crate::signals::stop_flag(),
                &mut recorded,
                clock,
                progress,
            );
        }
        // The recorded bytes hold the device faults already; those on the
        // executive (its clock, slow polls) are injected again.
        let faults = crate::faults::parse_all(&cfg.sim.faults)?;
        let mut hw = FaultyHardware::new(&mut recorded, &faults, true);
        let clock = FaultClock::new(VirtualClock::new(cfg.executive.minor_frame_us), &faults);
        let frames = last + 1 - clock.skipped_within(last + 1);
        self.drive(
            cfg,
            Length::Frames(frames),
            virtual_enforcement(cfg),
            None,
            crate::signals::stop_flag(),
            &mut hw,
            clock,
            progress,
        )
    }

    /// Run the mission, then close the recording.
    #[allow(clippy::too_many_arguments)]
    fn drive<C: FrameClock>(
        &mut self,
        cfg: &Config,
        length: Length,
        enforcement: Enforcement,
        truth: Option<TruthProbe>,
        stop: &AtomicBool,
        hw: &mut dyn Hardware,
        clock: C,
        progress: bool,
    ) -> Result<MissionResult, Error> {
        let schedule = schedule_table::build(cfg)?;
        let total = match length {
            Length::Frames(n) => Some(n),
            Length::UntilStopped => None,
        };
        tracing::info!("starting the tasks: drivers, odometry, SLAM, maps, planner, control");
        let frame_s = cfg.executive.minor_frame_us as f64 * 1e-6;
        let bar = progress_bar(progress, total.map(|n| (n as f64 * frame_s).ceil() as u64));
        let on_progress = |p: &mission::Progress| {
            bar.set_position(p.mission_s as u64);
            bar.set_message(format!("{}, {:.0} m driven", p.phase, p.driven_m));
        };
        let result = mission::run(
            MissionInputs {
                cfg,
                schedule,
                length,
                enforcement,
                truth,
                stop,
                progress: Some(&on_progress),
                replayed_timing: &self.replayed_timing,
            },
            hw,
            &self.tap,
            clock,
        )?;
        bar.finish_and_clear();
        self.tap
            .borrow_mut()
            .finish(mission::summary_metadata(&result));
        if let Some(h) = self.writer.take() {
            match h.join() {
                Ok(Ok(stats)) => {
                    tracing::debug!(
                        messages = stats.messages,
                        bytes = stats.bytes,
                        "recording closed"
                    )
                }
                Ok(Err(e)) => return Err(format!("recording failed: {e}").into()),
                Err(_) => return Err("the recording thread panicked".into()),
            }
        }
        let mut result = result;
        // The writer thread has let go of its handle: the server is ours.
        if let Some(server) = self.live.take().and_then(Arc::into_inner) {
            let c = server.stop();
            tracing::info!(
                viewers = c.viewers,
                sent = c.sent,
                dropped = c.dropped,
                "live view closed"
            );
            result.live = Some(c);
        }
        Ok(result)
    }
}

/// A bar in mission seconds with the time left to the mission's limit (a
/// mission home earlier ends sooner), or a counter when it has no limit.
fn progress_bar(enabled: bool, total_s: Option<u64>) -> ProgressBar {
    if !enabled {
        return ProgressBar::hidden();
    }
    let (bar, template) = match total_s {
        Some(n) => (
            ProgressBar::new(n),
            "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} s of mission, {eta} left at most: {msg}",
        ),
        None => (
            ProgressBar::new_spinner(),
            "{spinner} [{elapsed_precise}] {pos} s of mission: {msg}",
        ),
    };
    bar.set_style(
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// The `speleo.run` metadata but its time base (`epoch_ns`, added when the
/// recording begins).
fn run_metadata(cfg: &Config, mode: &str) -> BTreeMap<String, String> {
    let mut m = BTreeMap::new();
    m.insert("config".into(), cfg.to_toml());
    m.insert("mode".into(), mode.into());
    m.insert(
        "minor_frame_us".into(),
        cfg.executive.minor_frame_us.to_string(),
    );
    m.insert("speleo_version".into(), env!("CARGO_PKG_VERSION").into());
    m
}

/// On virtual time, policies act only when the configuration asks (budget tests).
fn virtual_enforcement(cfg: &Config) -> Enforcement {
    if cfg.executive.enforce_policies_in_sim {
        Enforcement::Enforce
    } else {
        Enforcement::CountOnly
    }
}

fn frames_for(cfg: &Config, seconds: f64) -> u64 {
    (seconds * 1e6 / cfg.executive.minor_frame_us as f64).round() as u64
}

/// The mission's figures on standard output.
pub fn print_summary(r: &MissionResult) {
    let speed = if r.wall_time_s > 0.0 {
        r.sim_time_s / r.wall_time_s
    } else {
        0.0
    };
    eprintln!(
        "{} frames, {:.1} s simulated in {:.2} s ({speed:.0}x real time), output hash {:016x}, {} allocations after start-up",
        r.frames, r.sim_time_s, r.wall_time_s, r.output_hash, r.allocations_after_init
    );
    if let Some(m) = &r.maps_figures {
        eprintln!(
            "maps: {} keyframes, MLS {} cells / {} patches{}",
            m.keyframes_mapped,
            m.mls_cells,
            m.mls_patches,
            if m.mesh_triangles > 0 {
                format!(
                    ", mesh {} triangles from {} TSDF blocks",
                    m.mesh_triangles, m.tsdf_blocks
                )
            } else {
                String::new()
            }
        );
    }
    if let Some(e) = &r.exploration {
        let opt =
            |v: Option<f64>, unit: &str| v.map_or("-".to_string(), |v| format!("{v:.2}{unit}"));
        eprintln!(
            "exploration: {}{}, explored {:.0} m2 (coverage {}), {} plans driven of {} goals tried, home error {}, {} driven, {:.1} m up and {:.1} m down, {} collisions{}, {:.0} Wh drawn{}",
            e.state,
            e.return_reason.as_ref().map_or(String::new(), |r| format!(" ({r})")),
            e.explored_area_m2,
            opt(e.coverage_fraction, ""),
            e.plans_executed,
            e.goals_attempted,
            opt(e.home_error_m, " m"),
            opt(e.distance_m, " m"),
            e.climbed_m,
            e.descended_m,
            e.collisions.map_or("-".to_string(), |c| c.to_string()),
            match (e.falls, e.worst_fall_m, e.wrecked) {
                (Some(n), Some(h), Some(w)) if n > 0 => format!(
                    ", {n} fall{} (worst {h:.1} m{})",
                    if n == 1 { "" } else { "s" },
                    if w { ", wrecked" } else { "" }
                ),
                _ => String::new(),
            },
            e.energy_used_wh,
            if e.energy_budget_wh > 0.0 {
                format!(" of {:.0}", e.energy_budget_wh)
            } else {
                String::new()
            },
        );
    }
    if let Some(s) = &r.internal_sim {
        eprintln!(
            "internal simulation: {} plans driven, {} passed, {} refused, prediction RMSE median {} over {} traverses, {} real time",
            s.validations,
            s.validated,
            s.rejected,
            s.prediction_rmse_m_median
                .map_or("-".to_string(), |v| format!("{v:.3} m")),
            s.comparisons,
            s.speed_x_real_time
                .map_or("-".to_string(), |v| format!("{v:.1}x")),
        );
    }
    if let Some(p) = &r.planner {
        let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.0} ms"));
        eprintln!(
            "planner: {} queries, {} solved ({} optimal), first plan median {}, optimum median {}, {} expansions",
            p.calls,
            p.solved,
            p.optimal,
            ms(p.first_solution_ms_median),
            ms(p.optimal_ms_median),
            p.expansions
        );
    }
}

/// The timing of a run in real time: frame start lateness, latencies,
/// deadline misses by task, and what real-time setup was granted.
fn print_timing(r: &MissionResult) {
    let Some(t) = &r.realtime else { return };
    eprintln!("timing ({}; {}):", t.sched_fifo, t.mlockall);
    eprintln!(
        "  {:<28} {:>8} {:>10} {:>10} {:>10}",
        "", "count", "p50 us", "p99 us", "max us"
    );
    for (name, s) in [
        ("frame start lateness", &t.frame_start_lateness),
        ("lidar packet -> wheel cmd", &t.lidar_to_wheel_command),
        ("imu sample -> odometry", &t.imu_to_odometry),
    ] {
        eprintln!(
            "  {name:<28} {:>8} {:>10.0} {:>10.0} {:>10.0}",
            s.count, s.p50_us, s.p99_us, s.max_us
        );
    }
    let missed: Vec<String> = r
        .tasks
        .iter()
        .filter(|f| f.overruns > 0 || f.skipped > 0)
        .map(|f| {
            format!(
                "{} {} over budget, {} skipped",
                f.name, f.overruns, f.skipped
            )
        })
        .collect();
    for e in &r.faults.episodes {
        eprintln!(
            "  health: {} from {:.2} s to {}",
            e.what,
            e.from_s,
            e.until_s
                .map_or("the end".to_string(), |u| format!("{u:.2} s"))
        );
    }
    if missed.is_empty() {
        eprintln!("  deadline misses: none; {} frames slipped", r.slips);
    } else {
        eprintln!(
            "  deadline misses: {}; {} frames slipped",
            missed.join("; "),
            r.slips
        );
    }
}

/// The maps' end-of-run requests (mesh, scans, the report's figures).
fn finish_maps(cfg: &Config, out: &Outputs, r: &mut MissionResult) -> Result<(), Error> {
    let Some(maps) = &r.maps else {
        return Ok(());
    };
    let req = crate::maps_output::MapsRequests {
        figures: out.report.is_some(),
        mesh: out.mesh.as_deref(),
        export_scans: out.export_scans.as_deref(),
    };
    if req.figures || req.mesh.is_some() || req.export_scans.is_some() {
        tracing::info!("finishing the maps: keyframes at their final poses, figures and files");
    }
    r.maps_figures = Some(crate::maps_output::finish(
        maps,
        cfg.maps.tsdf_params(),
        &req,
    )?);
    Ok(())
}

fn write_report(
    path: Option<&Path>,
    mode: &str,
    r: &MissionResult,
    replay: Option<ReplayReport>,
) -> Result<(), Error> {
    if let Some(p) = path {
        report::write(p, &report::build(mode, r, replay))?;
    }
    Ok(())
}

/// `speleo sim`: the mission, its report and trajectory written, its
/// summary printed.
pub fn sim(a: SimArgs, progress: bool) -> Result<ExitCode, Error> {
    print_summary(&sim_mission(a, progress)?);
    Ok(finished_status())
}

/// Success, or [`signals::INTERRUPTED_STATUS`](crate::signals) when a
/// signal cut the run short (its outputs are written all the same).
pub fn finished_status() -> ExitCode {
    if crate::signals::interrupted() {
        ExitCode::from(crate::signals::INTERRUPTED_STATUS)
    } else {
        ExitCode::SUCCESS
    }
}

/// The configuration of the mission `a` describes: its file, then the
/// options given on the command line.
pub fn sim_config(a: &SimArgs) -> Result<Config, Error> {
    let mut cfg = match &a.config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    if let Some(s) = a.seed {
        cfg.sim.seed = s;
    }
    if let Some(s) = a.noise_seed {
        cfg.sim.noise_seed = Some(s);
    }
    if let Some(d) = a.duration {
        cfg.sim.duration_s = d;
    }
    if let Some(w) = &a.world {
        cfg.sim.world = w.clone();
    }
    if let Some(st) = &a.start {
        cfg.sim.start = Some(StartSpec::Waypoint(st.clone()));
    }
    if a.route {
        cfg.exploration.enabled = false;
    }
    cfg.sim.faults.extend(a.faults.iter().cloned());
    if let Some(d) = &a.dump_validations {
        cfg.simulator.dump_dir = Some(d.clone());
    }
    Ok(cfg)
}

/// The mission a configuration describes, for a plot's title: world, seed
/// and noise seed (when it differs).
pub fn mission_title(cfg: &Config) -> String {
    let noise = match cfg.sim.noise_seed {
        Some(n) if n != cfg.sim.seed => format!(", noise seed {n}"),
        _ => String::new(),
    };
    let start = match &cfg.sim.start {
        Some(StartSpec::Waypoint(w)) => format!(", from {w}"),
        Some(StartSpec::Pose(p)) => format!(", from {:.1},{:.1},{:.1}", p[0], p[1], p[2]),
        None => String::new(),
    };
    format!(
        "speleo sim: {}, seed {}{noise}{start}",
        cfg.sim.world, cfg.sim.seed
    )
}

/// A simulated mission from the command's arguments, its report and
/// trajectory written: its result, for drawing or judging.
pub fn sim_mission(a: SimArgs, progress: bool) -> Result<MissionResult, Error> {
    crate::output_paths::check(&a.out)?;
    if let Some(p) = &a.trajectory {
        crate::output_paths::check_file(p, "--trajectory")?;
    }
    if let Some(p) = &a.dump_validations {
        crate::output_paths::check_folder(p, "--dump-validations")?;
    }
    let mut cfg = sim_config(&a)?;
    let result = simulate(&mut cfg, &a.out, progress)?;
    write_report(a.out.report.as_deref(), "sim", &result, None)?;
    if let Some(path) = &a.trajectory {
        let rows = result.slam.as_ref().map_or(&[][..], |s| &s.trajectory);
        crate::slam_figures::write_tum(path, rows)
            .map_err(|e| format!("writing {}: {e}", path.display()))?;
    }
    Ok(result)
}

/// The world `cfg.sim` names, with the rover at its start (`sim.start`
/// when given: then the scripted route, which begins at the world's own
/// start, is dropped).
pub fn world_of(cfg: &Config) -> Result<speleo_twin::world::World, Error> {
    let mut world = speleo_twin::world::World::build(&cfg.sim.world, cfg.sim.seed)?;
    if let Some(spec) = &cfg.sim.start {
        world.start = match spec {
            StartSpec::Pose([x, y, z, yaw_deg]) => [*x, *y, *z, yaw_deg.to_radians()],
            StartSpec::Waypoint(name) => {
                let named = speleo_twin::world::waypoints::waypoints(&world);
                speleo_twin::world::waypoints::pose_of(name, &named)
                    .map_err(|e| format!("sim.start: {e}"))?
            }
        };
        world.route.clear();
    }
    Ok(world)
}

/// A simulated mission as `cfg` describes it (its world, seed and
/// duration), with the outputs `out` asks for; the maps finished and the
/// exploration's ground-truth figures filled in.
pub fn simulate(cfg: &mut Config, out: &Outputs, progress: bool) -> Result<MissionResult, Error> {
    cfg.validate()?;
    tracing::info!(
        "building the world: {}, seed {}",
        cfg.sim.world,
        cfg.sim.seed
    );
    let world = world_of(cfg)?;
    if cfg.sim.follow_route && world.route.len() >= 2 {
        cfg.control.path =
            route_in_odometry_frame(&world, cfg.sim.out_and_back, cfg.sim.route_length_m);
        cfg.control.looped = false;
        cfg.validate()?;
    }
    schedule_table::build(cfg)?;
    if let Some(path) = &out.record {
        warn_of_a_large_recording(cfg, path);
    }
    let mut params = twin_params(cfg);
    // A start away from the world's own stands on the ground there.
    params.start_on_ground = cfg.sim.start.is_some();
    let mut twin = TwinHardware::with_world(&params, &world)?;
    let truth = twin.truth_probe();
    let faults = crate::faults::parse_all(&cfg.sim.faults)?;
    let mut hw = FaultyHardware::new(&mut twin, &faults, false);
    let epoch_ns = cfg.executive.epoch_unix_s * 1_000_000_000;
    let mut meta = run_metadata(cfg, "sim");
    meta.insert("seed".into(), cfg.sim.seed.to_string());
    if let Some(s) = cfg.sim.noise_seed {
        meta.insert("noise_seed".into(), s.to_string());
    }
    meta.insert("world".into(), cfg.sim.world.clone());
    let mut session = Session::open(out, cfg, meta, Some(epoch_ns), None, true)?;
    // A clock jump skips frames of the mission's time.
    let clock = FaultClock::new(VirtualClock::new(cfg.executive.minor_frame_us), &faults);
    let frames = frames_for(cfg, cfg.sim.duration_s);
    let frames = frames - clock.skipped_within(frames);
    let mut result = session.drive(
        cfg,
        Length::Frames(frames),
        virtual_enforcement(cfg),
        Some(truth),
        crate::signals::stop_flag(),
        &mut hw,
        clock,
        progress,
    )?;
    drop(hw);
    if crate::signals::interrupted() {
        tracing::warn!(
            "interrupted at {:.1} s of mission (frame {} of {frames}): finishing the maps, the report and the figures of what was done",
            result.frames as f64 * cfg.executive.minor_frame_us as f64 * 1e-6,
            result.frames
        );
    }
    finish_maps(cfg, out, &mut result)?;
    let strikes = twin.strikes();
    if strikes.wrecked {
        tracing::warn!(
            "the rover fell {:.1} m and was wrecked: the mission ended there",
            strikes.worst_fall_m
        );
    }
    exploration_truth(cfg, &world, &strikes, &mut result)?;
    result.success = result
        .exploration
        .as_ref()
        .map(|e| mission_success(e, result.frames < frames, &cfg.sim.success));
    Ok(result)
}

/// Recordings past this size get a warning before the mission.
const LARGE_RECORDING_BYTES: f64 = 4e9;

/// Bytes a simulated second records, uncompressed: the LiDAR's packets
/// (1,808 a second of 1,206 bytes, with their headers), one decoded
/// revolution in `cloud_every` (about 70,000 points of 20 bytes at 10 Hz),
/// and the rest (IMU, drives, odometry, poses, diagnostics). Measured on
/// the default mission; zstd keeps about 70 % of it.
fn recorded_bytes_per_second(cfg: &Config) -> f64 {
    let packets = if cfg.sim.lidar { 2.25e6 } else { 0.0 };
    let clouds = if cfg.sim.lidar {
        1.4e6 * cfg.sim.lidar_rate_hz / cfg.record.cloud_every.max(1) as f64
    } else {
        0.0
    };
    let rest = 0.15e6;
    let ratio = if cfg.record.compression == "zstd" {
        0.7
    } else {
        1.0
    };
    (packets + clouds + rest) * ratio
}

/// Say how large a long recording will be before it is written.
fn warn_of_a_large_recording(cfg: &Config, path: &Path) {
    let per_s = recorded_bytes_per_second(cfg);
    let bytes = per_s * cfg.sim.duration_s;
    if bytes > LARGE_RECORDING_BYTES {
        tracing::warn!(
            "{} will take up to {:.1} GB ({:.0} s of mission at about {:.1} MB a second; an exploration home earlier writes less); a shorter --duration or a larger [record] cloud_every writes less",
            path.display(),
            bytes / 1e9,
            cfg.sim.duration_s,
            per_s / 1e6
        );
    }
}

/// A simulated exploration judged against its criteria.
fn mission_success(
    e: &crate::exploration_figures::ExplorationFigures,
    ended_before_limit: bool,
    criteria: &speleo_campaign::success::SuccessCriteria,
) -> speleo_campaign::success::Success {
    let facts = speleo_campaign::success::MissionFacts {
        state: e.state.clone(),
        ended_before_limit,
        home_error_m: e.home_error_m,
        coverage: e.coverage_fraction,
        reach_m: e.reach_m,
        collisions: e.collisions.unwrap_or(0),
        falls: e.falls.unwrap_or(0),
        wrecked: e.wrecked.unwrap_or(false),
    };
    speleo_campaign::success::judge(&facts, criteria)
}

/// The exploration's ground-truth figures: the rover's strikes, and the
/// fraction of the world's reachable floor that the explored map covers.
fn exploration_truth(
    cfg: &Config,
    world: &speleo_twin::world::World,
    strikes: &speleo_twin::Strikes,
    r: &mut MissionResult,
) -> Result<(), Error> {
    use crate::exploration_figures as ef;
    let Some(f) = r.exploration.as_mut() else {
        return Ok(());
    };
    f.collisions = Some(strikes.collisions);
    f.falls = Some(strikes.falls);
    f.worst_fall_m = Some(strikes.worst_fall_m);
    f.wrecked = Some(strikes.wrecked);
    // The reachable floor is the world's, whatever the rover saw of it.
    tracing::info!("measuring the coverage: mapping the world's true floor");
    let truth_mls = crate::truth_map::surface_map(world)?;
    // From the start or, where a scanned floor has a hole or a rock right
    // under it, from a ring round it.
    let [x, y, z, _] = world.start;
    let tp = cfg.planner.trav_params();
    let ring: Vec<[f64; 3]> = (0..8)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::FRAC_PI_4;
            [x + 0.3 * a.cos(), y + 0.3 * a.sin(), z]
        })
        .collect();
    let truth = ef::reachable(&truth_mls, &[[x, y, z]], &tp)
        .or_else(|| ef::reachable(&truth_mls, &ring, &tp));
    let Some(truth) = truth else {
        tracing::warn!(
            "no floor of the world's own surface under its start ({x:.2}, {y:.2}, {z:.2}): the reachable floor and the coverage are unknown"
        );
        return Ok(());
    };
    f.reachable_floor_m2 = Some(ef::drivable_area_m2(&truth));
    let (Some(explored), Some((origin, heading))) = (&r.explored, r.world_from_map) else {
        // No ground of the rover's own map is reachable from where it went:
        // it explored nothing of that floor.
        f.coverage_fraction = Some(0.0);
        return Ok(());
    };
    let (s, c) = heading.sin_cos();
    let to_world = |p: [f64; 3]| {
        [
            origin[0] + c * p[0] - s * p[1],
            origin[1] + s * p[0] + c * p[1],
            origin[2] + p[2],
        ]
    };
    f.coverage_fraction = Some(ef::coverage_fraction(&truth, explored, to_world, 0.2));
    Ok(())
}

/// The simulated hardware as the configuration describes it.
pub fn twin_params(cfg: &Config) -> TwinParams {
    let [mr, mp, my] = cfg.sim.imu_misalignment_deg.map(f64::to_radians);
    TwinParams {
        seed: cfg.sim.noise_seed.unwrap_or(cfg.sim.seed),
        rover: RoverParams {
            wheel_radius_m: cfg.rover.wheel_radius_m,
            track_width_m: cfg.rover.track_width_m,
            skid_factor: cfg.rover.skid_factor,
            max_wheel_speed: cfg.rover.max_wheel_speed,
            ..RoverParams::default()
        },
        physics: (cfg.sim.rover_model == "physics").then(|| cfg.sim.rover.clone()),
        imu: speleo_twin::imu::ImuParams {
            misalignment_rpy: [mr, mp, my],
            ..Default::default()
        },
        lidar: cfg.sim.lidar.then(|| speleo_twin::lidar::LidarParams {
            rate_hz: cfg.sim.lidar_rate_hz,
            cast_threads: cfg.sim.lidar_cast_threads,
            ..Default::default()
        }),
        lidar_mount: {
            let [x, y, z] = cfg.lidar.mount_xyz;
            let [r, p, yw] = cfg.lidar.mount_rpy_deg.map(f64::to_radians);
            [x, y, z, r, p, yw]
        },
        ..TwinParams::default()
    }
}

/// The world's route as waypoints of the scripted path: odometry starts at
/// the world's start pose, so the route is expressed relative to it. Out and
/// back, the route is followed by its reverse down to the start. A route
/// longer than the path capacity is shortened from its far end (both ways).
fn route_in_odometry_frame(
    w: &speleo_twin::world::World,
    out_and_back: bool,
    length_m: f64,
) -> Vec<[f64; 2]> {
    let [x0, y0, _, yaw] = w.start;
    let (s, c) = (yaw.sin(), yaw.cos());
    let cap = if out_and_back {
        speleo_control::MAX_WAYPOINTS / 2
    } else {
        speleo_control::MAX_WAYPOINTS
    };
    let mut travelled = 0.0;
    let mut last = [0.0, 0.0];
    let out: Vec<[f64; 2]> = std::iter::once([0.0, 0.0])
        .chain(w.route.iter().map(|p| {
            let (dx, dy) = (p[0] - x0, p[1] - y0);
            [c * dx + s * dy, -s * dx + c * dy]
        }))
        .take_while(|p| {
            travelled += (p[0] - last[0]).hypot(p[1] - last[1]);
            last = *p;
            length_m <= 0.0 || travelled <= length_m
        })
        .take(cap)
        .collect();
    if !out_and_back {
        return out;
    }
    let back = out.iter().rev().skip(1).copied();
    out.iter().copied().chain(back).collect()
}

pub fn replay(a: ReplayArgs, progress: bool) -> Result<ExitCode, Error> {
    crate::output_paths::check(&a.out)?;
    let r = replay_recording(&a.log, &a.out, progress)?;
    write_report(
        a.out.report.as_deref(),
        "replay",
        &r.result,
        Some(ReplayReport {
            identical: r.divergence.is_none(),
            compared_messages: r.compared,
            last_frame_compared: r.last,
            recording_truncated: r.truncated,
            divergence: r.divergence.clone(),
        }),
    )?;
    if r.imported {
        println!(
            "replayed {} frames of an imported capture (it holds no outputs to compare)",
            r.result.frames
        );
        print_summary(&r.result);
        return Ok(ExitCode::SUCCESS);
    }
    if crate::signals::interrupted() {
        println!(
            "interrupted at frame {} of {}: {}",
            r.result.frames,
            r.last + 1,
            r.divergence.as_deref().unwrap_or("identical up to there")
        );
        return Ok(finished_status());
    }
    match r.divergence {
        None => {
            println!("identical");
            tracing::info!(
                frames = r.result.frames,
                compared = r.compared,
                "every output matches the recording"
            );
            Ok(ExitCode::SUCCESS)
        }
        Some(d) => {
            println!("{d}");
            Ok(ExitCode::FAILURE)
        }
    }
}

/// What a replay found.
pub struct Replayed {
    pub result: MissionResult,
    /// The first output that differs from the recording's.
    pub divergence: Option<String>,
    pub compared: u64,
    pub last: u64,
    pub truncated: bool,
    /// An imported capture: raw inputs only, nothing to compare.
    pub imported: bool,
}

/// Feed a recording's raw inputs through the drivers and tasks with the
/// recorded configuration, and compare every output with the recording's.
pub fn replay_recording(
    log: &std::path::Path,
    out: &Outputs,
    progress: bool,
) -> Result<Replayed, Error> {
    let mut rec = read::load(log)?;
    let cfg_text = rec
        .run
        .get("config")
        .ok_or_else(|| format!("{}: the recording holds no configuration", log.display()))?;
    let cfg = Config::from_toml(cfg_text)
        .map_err(|e| format!("{}: recorded configuration: {e}", log.display()))?;
    let Some(last) = rec.last_complete_frame() else {
        return Err(format!("{}: no complete frame to replay", log.display()).into());
    };
    if let Some(why) = &rec.truncated {
        eprintln!(
            "note: {} ends early ({why}); replaying frames 0 to {last}",
            log.display()
        );
    }
    let epoch_ns = rec.epoch_ns();
    let truncated = rec.truncated.is_some();
    let mut meta = run_metadata(&cfg, "replay");
    meta.insert("source".into(), log.display().to_string());
    let imported = rec.run.get("mode").map(String::as_str) == Some("import");
    let comparer = (!imported).then(|| {
        Comparer::new(
            std::mem::take(&mut rec.expected),
            last,
            mission::cloud_message_capacity(cfg.lidar.max_points_per_frame),
        )
    });
    let mut session = Session::open(out, &cfg, meta, Some(epoch_ns), comparer, true)?;
    let mut result = session.replay(&cfg, rec, last, progress)?;
    let (divergence, compared) = {
        let t = session.tap.borrow();
        let c = t.comparer();
        (c.and_then(|c| c.describe()), c.map_or(0, |c| c.compared))
    };
    finish_maps(&cfg, out, &mut result)?;
    Ok(Replayed {
        result,
        divergence,
        compared,
        last,
        truncated,
        imported,
    })
}

pub fn run(a: RunArgs, progress: bool) -> Result<ExitCode, Error> {
    crate::output_paths::check(&a.out)?;
    let cfg = Config::load(&a.config)?;
    schedule_table::build(&cfg)?;
    let mut hw = speleo_hal::real::RealHardware::open(&speleo_hal::real::DeviceSettings {
        lidar_bind: cfg.devices.lidar_bind.clone(),
        lidar_position_bind: cfg.devices.lidar_position_bind.clone(),
        lidar_sensor: cfg.devices.lidar_sensor.clone(),
        imu_port: cfg.devices.imu_port.clone(),
        imu_baud: cfg.devices.imu_baud,
        can: match cfg.devices.can_transport.as_str() {
            "slcan" => speleo_hal::real::CanTransport::Slcan {
                port: cfg.devices.can_serial_port.clone(),
                baud: cfg.devices.can_serial_baud,
                bit_rate: cfg.devices.can_bit_rate,
            },
            _ => speleo_hal::real::CanTransport::SocketCan(cfg.devices.can_interface.clone()),
        },
    })?;
    let rt = setup_realtime(cfg.executive.realtime_priority);
    tracing::info!("real-time setup: {rt}");
    // Mission time 0 is the first frame's start, in Unix time: the tap
    // begins there (after the tasks' start-up, which takes a second).
    let meta = run_metadata(&cfg, "run");
    let mut session = Session::open(&a.out, &cfg, meta, None, None, false)?;
    // Without a duration a signal is how a run ends; with one, a signal
    // cuts it short.
    crate::signals::install()?;
    let length = match a.duration {
        Some(d) => Length::Frames(frames_for(&cfg, d)),
        None => Length::UntilStopped,
    };
    let mut result = session.drive(
        &cfg,
        length,
        Enforcement::Enforce,
        None,
        crate::signals::stop_flag(),
        &mut hw,
        MonotonicClock::new(cfg.executive.minor_frame_us),
        progress,
    )?;
    if let Some(t) = &mut result.realtime {
        t.sched_fifo = match &rt.fifo {
            Ok(p) => format!("SCHED_FIFO priority {p}"),
            Err(e) => format!("SCHED_FIFO refused: {e}"),
        };
        t.mlockall = match &rt.mlock {
            Ok(()) => "memory locked".into(),
            Err(e) => format!("mlockall refused: {e}"),
        };
    }
    finish_maps(&cfg, &a.out, &mut result)?;
    write_report(a.out.report.as_deref(), "run", &result, None)?;
    print_summary(&result);
    print_timing(&result);
    Ok(if a.duration.is_some() {
        finished_status()
    } else {
        ExitCode::SUCCESS
    })
}

/// A recording run through the drivers, SLAM and the maps (as `replay`
/// does, without comparing), for meshing its keyframes.
pub fn replay_for_maps(log: &Path, progress: bool) -> Result<MissionResult, Error> {
    let rec = read::load(log)?;
    let cfg_text = rec
        .run
        .get("config")
        .ok_or_else(|| format!("{}: the recording holds no configuration", log.display()))?;
    let mut cfg = Config::from_toml(cfg_text)
        .map_err(|e| format!("{}: recorded configuration: {e}", log.display()))?;
    cfg.maps.enabled = true;
    let Some(last) = rec.last_complete_frame() else {
        return Err(format!("{}: no complete frame to replay", log.display()).into());
    };
    let epoch_ns = rec.epoch_ns();
    let meta = run_metadata(&cfg, "mesh");
    let outputs = Outputs::default();
    let mut session = Session::open(&outputs, &cfg, meta, Some(epoch_ns), None, true)?;
    session.replay(&cfg, rec, last, progress)
}
