//! One run of the executive against some hardware: wire the tasks to the
//! bus, run frames, record, and collect the figures for the report.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serde::Serialize;
use speleo_hal::Hardware;
use speleo_scheduler::accounting;
use speleo_scheduler::executive::ExecutiveError;
use speleo_scheduler::realtime::StdPlatform;
use speleo_scheduler::{Enforcement, Executive, FrameClock, Mode, Schedule};
use speleo_twin::TruthProbe;

use crate::bus::Bus;
use crate::config::Config;
use crate::record::cdr::CdrWriter;
use crate::record::messages::mode_name;
use crate::record::ros2::{header, pose_stamped, tf_message, Transform};
use crate::record::tap::TapCounters;
use crate::record::{RecorderTap, Topic};
use crate::simulator_host::SimulatorWorker;
use crate::slam_figures::{SlamFigures, TruthTrack};
use crate::tasks::{BuildError, Tasks};

/// How long the mission runs.
#[derive(Clone, Copy, Debug)]
pub enum Length {
    Frames(u64),
    /// Until the stop flag is raised.
    UntilStopped,
}

pub struct MissionInputs<'a> {
    pub cfg: &'a Config,
    pub schedule: Schedule,
    pub length: Length,
    pub enforcement: Enforcement,
    pub truth: Option<TruthProbe>,
    pub stop: &'a AtomicBool,
    /// Called between frames (once a mission second) for the progress
    /// display.
    pub progress: Option<&'a dyn Fn(&Progress)>,
    /// In replay of a run in real time ([`Enforcement::Replay`]): its
    /// recorded slips and overruns, in order.
    pub replayed_timing: &'a [crate::record::frame_timing::FrameTiming],
}

#[derive(Clone, Debug, Serialize)]
pub struct TaskFigures {
    pub name: String,
    pub period_us: u64,
    pub budget_us: u32,
    pub policy: String,
    pub runs: u64,
    pub max_us: f64,
    pub p50_us: f64,
    pub p99_us: f64,
    pub p999_us: f64,
    /// The same runs on the thread's CPU clock: without the time the
    /// thread was preempted (by the simulated world's threads or anything
    /// else on the machine). None where it was not measured.
    pub cpu_p99_us: Option<f64>,
    pub cpu_p999_us: Option<f64>,
    pub cpu_max_us: Option<f64>,
    pub overruns: u64,
    pub skipped: u64,
    pub allocations: u64,
    /// Most heap bytes requested within one run.
    pub alloc_bytes_max_run: u64,
    /// The per-run memory budget of a task that may allocate.
    pub memory_budget_kib: Option<u32>,
}

/// The heap across the run (every thread of the process), when the
/// accounting allocator is installed.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct MemoryFigures {
    /// The high-water mark over the first half of the frames.
    pub heap_peak_first_half_bytes: u64,
    /// The high-water mark over the whole run.
    pub heap_peak_bytes: u64,
    /// How much the second half raised it.
    pub heap_peak_growth_bytes: u64,
    pub heap_live_end_bytes: u64,
}

pub struct MissionResult {
    /// A simulated mission's verdict against `[sim.success]`.
    pub success: Option<speleo_campaign::success::Success>,
    /// The exploration's figures (when exploring), and the graph of the
    /// ground it mapped (map frame) with the map frame's origin and
    /// heading in the world (simulation), for the coverage figures.
    pub exploration: Option<crate::exploration_figures::ExplorationFigures>,
    pub internal_sim: Option<crate::exploration_figures::InternalSimFigures>,
    pub explored: Option<speleo_traversability::TravMap>,
    /// Where the exploration started (map frame).
    pub exploration_home: Option<[f64; 3]>,
    pub world_from_map: Option<([f64; 3], f64)>,
    pub frames: u64,
    pub sim_time_s: f64,
    pub wall_time_s: f64,
    pub output_hash: u64,
    /// Hash of the raw device byte streams the run received.
    pub input_hash: u64,
    pub minor_frame_us: u32,
    pub slips: u64,
    pub allocations_after_init: u64,
    /// Allocations of the tasks that run within a memory budget.
    pub budgeted_allocations: u64,
    pub housekeeping_allocations: u64,
    pub tasks: Vec<TaskFigures>,
    pub mode: Mode,
    pub safe_mode_cause: Option<String>,
    pub suppressed_events: u64,
    pub recorder: TapCounters,
    pub counters: speleo_messages::Counters,
    /// What the LiDAR driver counted (data and position packets, frames).
    pub lidar: speleo_messages::LidarCounters,
    pub slam: Option<SlamFigures>,
    /// The maps at the end of the run, when kept.
    pub maps: Option<crate::maps_output::MapsResult>,
    /// The report's `maps` section, once the run's requests are done.
    pub maps_figures: Option<crate::maps_output::MapsFigures>,
    pub planner: Option<crate::planner_figures::PlannerFigures>,
    /// What became of the injected faults, and the false alarms.
    pub faults: crate::faults::log::FaultFigures,
    /// None without the accounting allocator.
    pub memory: Option<MemoryFigures>,
    /// What the live view sent and dropped (filled in once it has closed).
    pub live: Option<crate::record::live::LiveCounters>,
    /// Frame start lateness and input-to-output latencies, in real time.
    pub realtime: Option<crate::realtime_figures::RealtimeFigures>,
    /// Where the rover believed it was at the end: the last SLAM pose (map
    /// frame) and the odometry's distance driven.
    pub end: Option<EndPose>,
}

/// The report's `end` section.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct EndPose {
    pub slam_position: [f64; 3],
    /// w, x, y, z.
    pub slam_orientation: [f64; 4],
    pub odometry_distance_m: f64,
}

/// Where a mission stands, for the progress display.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub mission_s: f64,
    /// The mission's time limit, when it has one.
    pub total_s: Option<f64>,
    /// exploring, returning, home, stranded, or following the route.
    pub phase: &'static str,
    /// Odometry's distance driven.
    pub driven_m: f64,
}

/// The exploration phase as the progress display names it.
pub fn phase_name(p: speleo_messages::ExplorationPhase) -> &'static str {
    use speleo_messages::ExplorationPhase::*;
    match p {
        Off => "following the route",
        Exploring => "exploring",
        Returning => "returning home",
        Finished => "home",
        Stranded => "stranded",
    }
}

#[derive(Debug, thiserror::Error)]
pub enum MissionError {
    #[error("{0}")]
    Executive(#[from] ExecutiveError),
    #[error(transparent)]
    Build(#[from] BuildError),
    #[error("sim.faults: {0}")]
    Faults(String),
}

/// Bytes of one recorded point-cloud message for `max_points` points
/// (20-byte points, plus the CDR header and field table).
pub fn cloud_message_capacity(max_points: u32) -> usize {
    max_points as usize * 20 + 1024
}

/// The simulator's worker as a task of its own core: a batch a frame at
/// most, within [`crate::simulator_host::SIM_WORKER_BUDGET_US`].
fn worker_figures(w: &SimulatorWorker, minor_frame_us: u32) -> TaskFigures {
    let (h, cpu) = (&w.batch_times, &w.batch_cpu_times);
    let us = |ns: u64| ns as f64 * 1e-3;
    let budget = crate::simulator_host::SIM_WORKER_BUDGET_US;
    TaskFigures {
        name: "simulator_worker".into(),
        period_us: minor_frame_us as u64,
        budget_us: budget,
        policy: "wait".into(),
        runs: h.count(),
        max_us: us(h.max_ns()),
        p50_us: us(h.quantile_ns(0.5)),
        p99_us: us(h.quantile_ns(0.99)),
        p999_us: us(h.quantile_ns(0.999)),
        cpu_p99_us: Some(us(cpu.quantile_ns(0.99))),
        cpu_p999_us: Some(us(cpu.quantile_ns(0.999))),
        cpu_max_us: Some(us(cpu.max_ns())),
        overruns: w.counters.overruns,
        skipped: 0,
        // Charged to the planner, whose runs take its batches back.
        allocations: 0,
        alloc_bytes_max_run: 0,
        memory_budget_kib: None,
    }
}

/// Park this thread once so that everything the standard library creates
/// lazily for parking exists before the first frame.
fn warm_up_blocking() {
    std::thread::park_timeout(Duration::from_micros(1));
}

/// Run the mission. The tap is created by the caller (with or without a
/// writer, with or without a comparer) and is returned inside `tap` after
/// the run, for finishing.
pub fn run<C: FrameClock>(
    m: MissionInputs<'_>,
    hw: &mut dyn Hardware,
    tap: &RefCell<RecorderTap>,
    clock: C,
) -> Result<MissionResult, MissionError> {
    let cfg = m.cfg;
    let mut bus = Bus::new();
    let hw = RefCell::new(hw);
    let faults = crate::faults::parse_all(&cfg.sim.faults).map_err(MissionError::Faults)?;
    let mut fault_log = crate::faults::log::FaultLog::new(&faults);
    let mut built = Tasks::build(cfg, &mut bus, &hw, tap)?;
    let maps_on = cfg.maps.enabled && cfg.slam.enabled;
    let planner_on = maps_on && cfg.planner.enabled;
    let worker_sync = built.planner.host.worker.as_ref().map(|w| w.sync());
    let minor_frame_us = m.schedule.minor_frame_us();
    let m_names: Vec<String> = m
        .schedule
        .tasks()
        .iter()
        .map(|t| t.name.to_string())
        .collect();
    let ntasks = m.schedule.tasks().len();
    let mut exec = Executive::new(
        m.schedule,
        built.in_order(),
        StdPlatform,
        clock,
        m.enforcement,
    )?;
    let io_task = exec.schedule().tasks().iter().position(|t| t.name == "io");

    let total = match m.length {
        Length::Frames(n) => Some(n),
        Length::UntilStopped => None,
    };
    let telemetry_every = cfg.record.telemetry_every_frames as u64;
    // Odometry starts at the rover's first pose, heading as it heads.
    let mut odom_origin: Option<([f64; 3], [f64; 4])> = None;
    // Ground truth for the SLAM error figures, sized for the whole run.
    let mut track = TruthTrack::with_capacity(match (&m.truth, total) {
        (Some(_), Some(n)) => n as usize,
        _ => 0,
    });
    // On hardware whose time passes on its own, inputs are followed to the
    // outputs made from them.
    let mut latency = hw
        .borrow()
        .receive_clock_ns()
        .map(|_| crate::realtime_figures::LatencyProbe::new());
    let mut replayed = crate::record::frame_timing::Cursor::new(m.replayed_timing);
    warm_up_blocking();
    // The executive's clock starts with the first frame, just after this;
    // a recording without a time base yet takes the Unix time of it.
    hw.borrow_mut().start_receive_clock();
    if !tap.borrow().has_begun() {
        tap.borrow_mut()
            .begin(speleo_scheduler::realtime::unix_now_ns());
    }
    let started = Instant::now();
    accounting::reset();
    accounting::reset_heap_peak();
    let mut first_half_peak = None;
    accounting::set_slot(speleo_scheduler::clock::EXECUTIVE_SLOT);
    loop {
        // An exploration that is home, or cannot move any more, ends the
        // mission; so does a simulated rover wrecked in a fall.
        let finished = matches!(
            bus.exploration.phase,
            speleo_messages::ExplorationPhase::Finished
                | speleo_messages::ExplorationPhase::Stranded
        ) || hw.borrow().world_over();
        if total.is_some_and(|n| exec.frames_run() >= n)
            || m.stop.load(Ordering::Relaxed)
            || finished
        {
            break;
        }
        // The outside world moves on to the next frame's start before the
        // frame runs, on its own allocation account.
        accounting::set_slot(accounting::WORLD);
        let next = exec.clock().frame_time_ns(exec.next_frame());
        hw.borrow_mut().advance_to(next);
        accounting::set_slot(speleo_scheduler::clock::EXECUTIVE_SLOT);
        // The simulator's batch on its own core ends within the frame
        // before; the virtual clock's frames come back to back, so this
        // is where a real-time executive would sleep.
        if let Some(s) = &worker_sync {
            s.wait_idle();
        }
        // Once the io task has sent the commands and collected the inputs,
        // nothing on board can change the world before the next frame: a
        // simulated world computes that stretch beside the tasks (the
        // LiDAR's rays on the second core).
        if m.enforcement == Enforcement::Replay {
            exec.replay_overruns(replayed.overruns_due(exec.next_frame()));
        }
        let after = exec.clock().frame_time_ns(exec.next_frame() + 1);
        let f = exec.run_frame_with(&mut bus, &mut |i| {
            if Some(i) == io_task {
                accounting::set_slot(accounting::WORLD);
                hw.borrow_mut().look_ahead(after);
                accounting::set_slot(speleo_scheduler::clock::EXECUTIVE_SLOT);
            }
        });
        if bus.safe_mode_request && exec.mode() == Mode::Nominal {
            exec.enter_safe_mode();
        } else if bus.recovery_ready && exec.mode() == Mode::Safe {
            exec.leave_safe_mode();
            bus.recovery_ready = false;
        }
        if let (Some(p), Some(now)) = (&mut latency, hw.borrow().receive_clock_ns()) {
            p.observe(&bus, now);
        }
        bus.timing.overruns += f.overruns as u64;
        bus.timing.slipped_frames += f.slipped;
        bus.timing.enforcing = m.enforcement.enforces();
        // What replay must take again: decisions made by measured time.
        if m.enforcement == Enforcement::Enforce && (f.slipped > 0 || f.overran != 0) {
            record_frame_timing(&mut tap.borrow_mut(), &f);
        }
        fault_log.observe(
            f.time_ns,
            bus.health.get().map_or(0, |h| h.value.findings),
            exec.mode(),
        );
        if let Some(truth) = &m.truth {
            record_truth(
                &mut tap.borrow_mut(),
                f.frame,
                f.time_ns,
                truth,
                &mut odom_origin,
            );
            let g = truth.get();
            track.samples.push((f.time_ns, g.position, g.orientation));
        }
        if (f.frame + 1) % telemetry_every == 0 {
            record_telemetry(&mut tap.borrow_mut(), &exec, f.frame, f.time_ns);
        }
        // Logging and progress display allocate; they are housekeeping
        // between frames, accounted apart from the periodic work.
        accounting::set_slot(accounting::HOUSEKEEPING);
        while let Some(ev) = exec.pop_event() {
            tracing::debug!(
                task = ev.task.as_str(),
                frame = ev.frame,
                took_us = ev.duration_ns as f64 / 1e3,
                budget_us = ev.budget_ns as f64 / 1e3,
                enforced = ev.enforced,
                "overrun"
            );
        }
        if total.is_some_and(|n| exec.frames_run() * 2 >= n) && first_half_peak.is_none() {
            first_half_peak = Some(accounting::heap_peak_bytes());
        }
        if let Some(p) = m.progress {
            if f.frame % 100 == 0 {
                let frame_s = m.cfg.executive.minor_frame_us as f64 * 1e-6;
                p(&Progress {
                    mission_s: exec.frames_run() as f64 * frame_s,
                    total_s: total.map(|n| n as f64 * frame_s),
                    phase: phase_name(bus.exploration.phase),
                    driven_m: bus.odom.get().map_or(0.0, |o| o.value.distance_m),
                });
            }
        }
        accounting::set_slot(speleo_scheduler::clock::EXECUTIVE_SLOT);
    }
    accounting::untrack();
    let wall = started.elapsed().as_secs_f64();
    // Before the results are gathered (they copy maps and clouds).
    let peak = accounting::heap_peak_bytes();
    let memory = (peak > 0).then(|| {
        let half = first_half_peak.unwrap_or(peak);
        MemoryFigures {
            heap_peak_first_half_bytes: half,
            heap_peak_bytes: peak,
            heap_peak_growth_bytes: peak.saturating_sub(half),
            heap_live_end_bytes: accounting::heap_live_bytes(),
        }
    });
    // Tasks that call allocating crates (sparse factorisation) are counted
    // apart: they run within a memory budget instead.
    let budgeted = |slot: usize| {
        slot > 0
            && crate::schedule_table::allocating_tasks(cfg)
                .contains(&m_names.get(slot - 1).map_or("", String::as_str))
    };
    let allocations_after_init: u64 = (0..=ntasks)
        .filter(|s| !budgeted(*s))
        .map(accounting::allocations)
        .sum();
    let budgeted_allocations: u64 = (0..=ntasks)
        .filter(|s| budgeted(*s))
        .map(accounting::allocations)
        .sum();
    let housekeeping_allocations = accounting::allocations(accounting::HOUSEKEEPING as usize);

    if let Some(c) = tap.borrow_mut().comparer_mut() {
        c.finish();
    }
    let mut tasks: Vec<TaskFigures> = exec
        .schedule()
        .tasks()
        .iter()
        .zip(exec.stats())
        .enumerate()
        .map(|(i, (spec, st))| TaskFigures {
            cpu_p99_us: st.cpu_us().map(|c| c.p99_us),
            cpu_p999_us: st.cpu_us().map(|c| c.p999_us),
            cpu_max_us: st.cpu_us().map(|c| c.max_us),
            name: spec.name.to_string(),
            period_us: spec.rate.period_us(minor_frame_us),
            budget_us: spec.run_budget_us(),
            policy: spec.policy.to_string(),
            runs: st.runs,
            max_us: st.max_us(),
            p50_us: st.p50_us(),
            p99_us: st.p99_us(),
            p999_us: st.p999_us(),
            overruns: st.overruns,
            skipped: st.skipped,
            allocations: accounting::allocations(i + 1),
            alloc_bytes_max_run: st.alloc_bytes_max_run,
            memory_budget_kib: crate::schedule_table::memory_budget_kib(cfg, &spec.name),
        })
        .collect();
    let realtime = latency.map(|p| p.figures(exec.clock().start_lateness()));
    let end = bus.slam.get().map(|p| EndPose {
        slam_position: p.value.position,
        slam_orientation: p.value.orientation,
        odometry_distance_m: bus.odom.get().map_or(0.0, |o| o.value.distance_m),
    });
    let frames = exec.frames_run();
    let slips = exec.slips();
    let mode = exec.mode();
    let safe_mode_cause = exec.safe_mode_cause().map(str::to_string);
    let suppressed_events = exec.suppressed_events();
    // The executive borrows the tasks; release them to read SLAM's result.
    drop(exec);
    if let Some(w) = &built.planner.host.worker {
        tasks.push(worker_figures(w, minor_frame_us));
    }
    track.odom_origin = odom_origin.map(|(p, q)| (p, 2.0 * q[3].atan2(q[0])));
    if let (Some(dir), false) = (&cfg.simulator.dump_dir, track.samples.is_empty()) {
        if let Err(e) = crate::validation_dump::write_truth(dir, &track.samples) {
            tracing::warn!("the true track not written to {}: {e}", dir.display());
        }
    }
    let slam = (built.slam.slam().stats().keyframes > 0).then(|| {
        crate::slam_figures::figures(
            built.slam.slam(),
            m.truth.as_ref().map(|_| &track),
            m.truth.as_ref().map(|_| cfg.sim.imu_misalignment_deg),
        )
    });
    let maps = maps_on.then(|| crate::maps_output::MapsResult {
        mls: bus.surface.stats(),
        memory_bytes: bus.surface.memory_bytes() + bus.keyframe_clouds.memory_bytes(),
        counters: built.maps.builder.counters,
        keyframes: std::mem::replace(
            &mut bus.keyframe_clouds,
            speleo_mapping::KeyframeClouds::new(0, 0),
        ),
        mount: crate::params::mount_pose(cfg),
    });
    let planner = planner_on
        .then(|| crate::planner_figures::figures(&built.planner, cfg.planner.nav.trav.max_nodes));
    let mut explored = None;
    let exploration = built.planner.nav.exploration().map(|e| {
        use crate::exploration_figures as ef;
        let mut f = ef::onboard(e, &built.control.counters());
        // The ground under home, every keyframe and the rover now. A full
        // map drops what lies farthest from the rover, so a mission that
        // ended far from home (stranded on the garage's roof) may hold no
        // ground there any more, nor under the rover if it stands on an
        // edge; what the rest of its track reaches is still explored.
        let below = |p: [f64; 3]| [p[0], p[1], p[2] - crate::params::base_height_m(cfg)];
        let graph = built.slam.slam();
        let mut starts = vec![below(e.explorer.home())];
        starts.extend((0..graph.keyframes().len()).map(|k| {
            let at = graph.keyframe_pose(k).t;
            below([at[0], at[1], at[2]])
        }));
        starts.extend(bus.slam.get().map(|p| below(p.value.position)));
        let (mls, tp) = (bus.surface.serving(), cfg.planner.trav_params());
        explored = ef::reachable(mls, &starts, &tp);
        f.explored_area_m2 = explored.as_ref().map_or(0.0, ef::drivable_area_m2);
        if m.truth.is_some() {
            let s = &track.samples;
            f.distance_m = Some(
                s.windows(2)
                    .map(|w| {
                        let (a, b) = (w[0].1, w[1].1);
                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                            .sqrt()
                    })
                    .sum(),
            );
            // In 3D: a garage rover that ended over home on a deck is not
            // home.
            f.reach_m = s.first().map(|a| {
                s.iter()
                    .map(|b| {
                        ((a.1[0] - b.1[0]).powi(2)
                            + (a.1[1] - b.1[1]).powi(2)
                            + (a.1[2] - b.1[2]).powi(2))
                        .sqrt()
                    })
                    .fold(0.0, f64::max)
            });
            f.end_position = s.last().map(|b| b.1);
            if let (Some(a), Some(b)) = (s.first(), s.last()) {
                f.home_error_m = Some(
                    ((a.1[0] - b.1[0]).powi(2)
                        + (a.1[1] - b.1[1]).powi(2)
                        + (a.1[2] - b.1[2]).powi(2))
                    .sqrt(),
                );
            }
        }
        f
    });
    let t = tap.borrow();
    Ok(MissionResult {
        success: None,
        memory,
        live: None,
        realtime,
        end,
        faults: fault_log.figures(),
        exploration,
        explored,
        exploration_home: built.planner.nav.exploration().map(|e| e.explorer.home()),
        internal_sim: built.planner.nav.exploration().and_then(|e| {
            crate::exploration_figures::internal_sim(
                e,
                built.planner.host.worker.as_ref(),
                minor_frame_us,
            )
        }),
        world_from_map: track.odom_origin,
        frames,
        sim_time_s: frames as f64 * minor_frame_us as f64 * 1e-6,
        wall_time_s: wall,
        output_hash: t.output_hash(),
        input_hash: t.input_hash(),
        minor_frame_us,
        slips,
        allocations_after_init,
        budgeted_allocations,
        housekeeping_allocations,
        tasks,
        mode,
        safe_mode_cause,
        suppressed_events,
        slam,
        maps,
        maps_figures: None,
        planner,
        recorder: t.counters,
        counters: bus.counters,
        lidar: bus.lidar,
    })
}

fn record_truth(
    tap: &mut RecorderTap,
    frame: u64,
    now: u64,
    truth: &TruthProbe,
    map_origin: &mut Option<([f64; 3], [f64; 4])>,
) {
    let g = truth.get();
    let (at, rotation) = *map_origin.get_or_insert_with(|| {
        // The map (and odometry) frame: level, at the first true pose,
        // heading as the rover heads. This ties the two trees together in a
        // viewer.
        let half = 0.5 * g.yaw();
        (g.position, [half.cos(), 0.0, 0.0, half.sin()])
    });
    if frame.is_multiple_of(crate::tasks::recorder::PLAN_EVERY_FRAMES) {
        let tf = Transform {
            stamp: tap.time(now),
            parent: "world",
            child: "map",
            translation: at,
            rotation,
        };
        tap.emit(Topic::SimTf, frame, now, now, |w| tf_message(w, &[tf]));
    }
    let stamp = tap.time(g.time_ns);
    tap.emit(Topic::GroundTruth, frame, now, g.time_ns, |w| {
        pose_stamped(w, stamp, "world", g.position, g.orientation)
    });
}

fn record_frame_timing(tap: &mut RecorderTap, f: &speleo_scheduler::FrameReport) {
    let stamp = tap.time(f.time_ns);
    let t = crate::record::frame_timing::FrameTiming {
        frame: f.frame,
        slipped: f.slipped,
        overran: f.overran,
    };
    tap.emit(Topic::FrameTiming, f.frame, f.time_ns, f.time_ns, |w| {
        crate::record::frame_timing::write(w, stamp.sec, stamp.nsec, &t)
    });
}

fn record_telemetry<P, C>(
    tap: &mut RecorderTap,
    exec: &Executive<'_, Bus, P, C>,
    frame: u64,
    now: u64,
) where
    P: speleo_scheduler::Platform,
    C: FrameClock,
{
    let stamp = tap.time(now);
    tap.emit(Topic::Scheduler, frame, now, now, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, "")?;
        c.u64(exec.frames_run())?;
        c.u64(exec.slips())?;
        c.string(mode_name(exec.mode()))?;
        let tasks = exec.schedule().tasks();
        c.sequence_len(tasks.len())?;
        for (spec, st) in tasks.iter().zip(exec.stats()) {
            c.string(spec.name.as_str())?;
            c.u64(st.runs)?;
            c.u64(st.overruns)?;
            c.u64(st.skipped)?;
            c.f64(st.max_us())?;
            c.f64(st.p50_us())?;
            c.f64(st.p99_us())?;
            c.f64(st.p999_us())?;
        }
        Ok(())
    });
}

/// The summary record written at the end of a recording.
pub fn summary_metadata(r: &MissionResult) -> BTreeMap<String, String> {
    let mut m = BTreeMap::new();
    m.insert("frames".into(), r.frames.to_string());
    m.insert("output_hash".into(), format!("{:016x}", r.output_hash));
    m.insert("mode_at_end".into(), mode_name(r.mode).into());
    m
}
