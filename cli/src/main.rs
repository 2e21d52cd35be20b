//! The `speleo` command: the flight commands (`speleo-firmware`) and the
//! ground tools (`speleo-tools`) on one command line. It parses the
//! arguments and runs the flight command or tool they name.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use speleo_firmware::args::{ReplayArgs, RunArgs, SimArgs};
use speleo_firmware::commands as flight;
use speleo_scheduler::accounting::AccountingAllocator;
use speleo_tools::args::*;
use speleo_tools::commands::{decode, info, mesh, solvers, validate, world};

// Every allocation is attributed to the task running on the executive's thread.
#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

/// Speleo: on-board autonomy for rovers that explore lava tubes and caves.
///
/// Every flight command runs the same deterministic cyclic executive and the same
/// drivers: `sim` against simulated hardware on virtual time, `replay`
/// against a recording, `run` against the real rover on the monotonic clock.
#[derive(Parser, Debug)]
#[command(name = "speleo", version, propagate_version = true)]
pub struct Cli {
    /// More log output (-v: debug, -vv: trace). RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
    /// Do not draw a progress bar.
    #[arg(long, global = true)]
    pub no_progress: bool,
    /// Print a backtrace for every allocation of at least this many bytes
    /// a task makes (which allocation made a run ask for more than its
    /// memory budget).
    #[arg(long, global = true, value_name = "BYTES")]
    pub trace_allocations_over: Option<u64>,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run a simulated mission on virtual time: the executive against
    /// simulated hardware that emits the real wire bytes.
    Sim(SimCommand),
    /// Feed a recording's raw inputs back through the same drivers and tasks
    /// and compare every output with the recording. Prints `identical`, or the
    /// first divergence (topic, frame, field) and exits with status 1.
    Replay(ReplayArgs),
    /// Run on the real rover: monotonic clock, real devices, overrun policies
    /// enforced. Stops on Ctrl-C or after --duration.
    Run(RunArgs),
    /// The rover's hardware twin in real time on the real wires, for a
    /// hardware-in-the-loop bench: the world and the physics rover, the
    /// HDL-32E on UDP, the MTi on a serial line (a pseudo-terminal) and the
    /// drives behind an slcan adapter (another), for `speleo run` to drive.
    /// Prints where its ports are, then runs until Ctrl-C or --duration.
    Twin(TwinArgs),
    /// A hardware-in-the-loop bench in one command: starts `speleo twin`,
    /// then `speleo run` wired to it, stops both with Ctrl-C after
    /// --duration (or when the mission ends), and prints their reports side
    /// by side: the rover's pose error against the twin's truth, distance,
    /// coverage and timing. Exits with status 2 unless both exit 0.
    Hil(HilArgs),
    /// What a recording (MCAP) holds, as `ros2 bag info` tells it: its
    /// span, each topic's type, encoding, count and rate, its chunks and
    /// their compression, whether it was finished or cut short, and the
    /// run that wrote it.
    Info(InfoArgs),
    /// Import a LiDAR capture (pcap: datagrams to UDP 2368 and 8308) as a
    /// recording that `speleo replay` runs through the drivers.
    Pcap2mcap(Pcap2mcapArgs),
    /// Decode a device capture or log and print what it holds.
    #[command(subcommand)]
    Decode(DecodeCommand),
    /// Worlds of the simulation.
    #[command(subcommand)]
    World(WorldCommand),
    /// Optimise a g2o pose graph (2D or 3D) with the SLAM back end; prints
    /// g2o's chi2 and the SE-Sync objective before and after.
    G2o(G2oArgs),
    /// Register two point clouds (PLY) with GICP; prints the 4x4 transform
    /// (target <- source), iterations, fitness and time.
    Register(RegisterArgs),
    /// Mesh LiDAR scans through a TSDF (marching cubes): a folder of PLY
    /// scans with KITTI poses, or the keyframes of a recording run through
    /// the drivers and SLAM again. Prints the time, blocks and triangles.
    Mesh(MeshArgs),
    /// Plan with ARA* on an SBPL lattice environment (EnvironmentNAVXYTHETALAT
    /// .cfg and .mprim files, point robot): prints the first solution's and
    /// the optimal solution's times, costs and expansions.
    Plan(PlanArgs),
    /// Write the rover's motion primitives (splines, forward and backward,
    /// no point turns) as an SBPL .mprim file.
    Primitives(PrimitivesArgs),
    /// Run worst-case scenarios through the executive (route, exploration,
    /// the internal simulator, boulders, garage, a replay) and print each
    /// task's max, p99 and p99.9 against its budget, pass or fail (p99.9
    /// within the budget). Exits with status 1 when a task fails.
    Wcet(WcetArgs),
    /// Replay one validation of the internal simulator from the case file a
    /// mission wrote (`speleo sim --dump-validations DIR`): prints its
    /// verdict beside the mission's and where the rover tilted most; writes
    /// the world it built and its track on request. Exits with status 1 when
    /// the verdict differs from the mission's.
    Validate(ValidateArgs),
    /// Campaigns: many simulated missions (worlds x seeds x noise streams
    /// x configurations x scenario starts) run as separate processes,
    /// locally or one case per cluster task, and judged as a success rate.
    #[command(subcommand)]
    Campaign(CampaignCommand),
}

/// `speleo sim`: the mission's arguments and the drawing of its result.
#[derive(Args, Debug)]
pub struct SimCommand {
    #[command(flatten)]
    pub mission: SimArgs,
    /// Draw the explored map with the rover's track, from above and from
    /// the side, with axes in metres, a legend and a title, as a PNG or an
    /// SVG (by the extension).
    #[arg(long, value_name = "OUT.png|OUT.svg")]
    pub plot: Option<PathBuf>,
}

/// `speleo sim`: the mission, then its plot when asked.
fn sim(a: SimCommand, progress: bool) -> Result<ExitCode, speleo_tools::Error> {
    if let Some(p) = &a.plot {
        speleo_firmware::output_paths::check_file(p, "--plot")?;
        let ext = p
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("png" | "svg")) {
            return Err(
                format!("--plot {}: a plot is written as .png or .svg", p.display()).into(),
            );
        }
    }
    let title = flight::mission_title(&flight::sim_config(&a.mission)?);
    let r = flight::sim_mission(a.mission, progress)?;
    if let Some(path) = &a.plot {
        speleo_tools::plot::write_plot(path, &speleo_tools::plot::of_mission(&r, title))?;
    }
    flight::print_summary(&r);
    Ok(flight::finished_status())
}

fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "info",
        1 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose);
    speleo_scheduler::accounting::trace_allocations_over(cli.trace_allocations_over);
    let progress = !cli.no_progress;
    // The commands that run missions end them cleanly on Ctrl-C or SIGTERM.
    if matches!(
        cli.command,
        Command::Sim(_)
            | Command::Replay(_)
            | Command::Run(_)
            | Command::Twin(_)
            | Command::Campaign(_)
    ) {
        if let Err(e) = speleo_firmware::signals::install() {
            eprintln!("error: cannot catch Ctrl-C and SIGTERM: {e}");
            return ExitCode::from(2);
        }
    }
    let result = match cli.command {
        Command::Sim(a) => sim(a, progress),
        Command::Replay(a) => flight::replay(a, progress),
        Command::Run(a) => flight::run(a, progress),
        Command::Twin(a) => speleo_tools::twin::twin(speleo_tools::twin::TwinRequest {
            config: a.config,
            world: a.world,
            seed: a.seed,
            noise_seed: a.noise_seed,
            duration_s: a.duration,
            record: a.record,
            report: a.report,
            unplug_lidar: a.unplug_lidar,
        }),
        Command::Hil(a) => speleo_tools::hil::hil(speleo_tools::hil::HilRequest {
            world: a.world,
            seed: a.seed,
            duration_s: a.duration,
            twin_config: a.twin_config,
            flight_config: a.config,
            out_dir: a.out,
            report: a.report,
            unplug_lidar: a.unplug_lidar,
        }),
        Command::Info(a) => info::info(a),
        Command::Pcap2mcap(a) => decode::pcap2mcap(a),
        Command::Decode(d) => decode::decode(d),
        Command::World(WorldCommand::Export(a)) => world::world_export(a),
        Command::World(WorldCommand::Waypoints(a)) => world::world_waypoints(a),
        Command::G2o(a) => solvers::g2o(a),
        Command::Register(a) => solvers::register(a),
        Command::Plan(a) => solvers::plan(a),
        Command::Primitives(a) => solvers::primitives(a),
        Command::Wcet(a) => speleo_tools::wcet::wcet(
            a.scenario.as_deref(),
            a.recording.as_ref(),
            a.config.as_ref(),
            a.report.as_ref(),
            a.calibrate.as_ref(),
            progress,
        ),
        Command::Mesh(a) => mesh::mesh(a, progress),
        Command::Validate(a) => validate::validate(a),
        Command::Campaign(c) => speleo_tools::campaign::command(c, progress),
    };
    match result {
        Ok(code) => code,
        // The reader went away (`speleo decode ... | head`): not an error.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
