//! The command line.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// Speleo: on-board autonomy for rovers that explore lava tubes and caves.
///
/// Every mode runs the same deterministic cyclic executive and the same
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
    Sim(SimArgs),
    /// Feed a recording's raw inputs back through the same drivers and tasks
    /// and compare every output with the recording. Prints `identical`, or the
    /// first divergence (topic, frame, field) and exits with status 1.
    Replay(ReplayArgs),
    /// Run on the real rover: monotonic clock, real devices, overrun policies
    /// enforced. Stops on Ctrl-C or after --duration.
    Run(RunArgs),
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

#[derive(Subcommand, Debug)]
pub enum CampaignCommand {
    /// Expand a matrix into numbered cases, each with its configuration,
    /// and write them to DIR with a manifest (`DIR/manifest.toml`).
    Plan(CampaignPlanArgs),
    /// Run the cases not yet finished as `speleo sim` processes, N at a
    /// time; or one case alone (`--case`, as a cluster's array task does).
    /// A case that crashes, hangs past the matrix's `timeout_s` or is
    /// killed is recorded so, and the campaign goes on.
    Run(CampaignRunArgs),
    /// The success rate with its 95 % interval, each part of success, the
    /// failures by cause and place, the figures' spread, and a paired
    /// comparison with a baseline campaign.
    Report(CampaignReportArgs),
}

#[derive(Args, Debug)]
pub struct CampaignPlanArgs {
    #[arg(value_name = "MATRIX.toml")]
    pub matrix: PathBuf,
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

#[derive(Args, Debug)]
pub struct CampaignRunArgs {
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// Cases run side by side (default: the machine's cores).
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,
    /// Run this case alone (0-based).
    #[arg(long, value_name = "K", conflicts_with = "jobs")]
    pub case: Option<usize>,
    /// Run finished cases again (all, or --case K) in a scratch folder and
    /// check each reproduces its output hash; exit status 1 when one does
    /// not.
    #[arg(long)]
    pub verify: bool,
}

#[derive(Args, Debug)]
pub struct CampaignReportArgs {
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// A campaign to compare with, case by case: its folder, or the
    /// summary `report --json` wrote of it (as `campaigns/baseline/` keeps).
    #[arg(long, value_name = "DIR|SUMMARY.json")]
    pub baseline: Option<PathBuf>,
    /// Write the summary as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Write the summary as Markdown too (as printed).
    #[arg(long, value_name = "OUT.md")]
    pub markdown: Option<PathBuf>,
    /// Draw the outcomes as a PNG: each world's floor from above with
    /// where every mission ended, coloured by outcome, and the coverage
    /// histogram.
    #[arg(long, value_name = "OUT.png")]
    pub plot: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct ValidateArgs {
    /// The case (DIR/validation-NNNN.case).
    #[arg(value_name = "CASE")]
    pub case: PathBuf,
    /// The mission's configuration (its `[simulator]`, `[control]` and
    /// rover sections); the defaults when absent.
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// Write the simulated world (ground colliders, the pad and the strip
    /// included) as binary PLY, map frame.
    #[arg(long, value_name = "OUT.ply")]
    pub mesh: Option<PathBuf>,
    /// Write the simulated rover's pose at every physics step as CSV (t,
    /// x, y, z, roll, pitch, yaw, tilt, and the follower's v and w).
    #[arg(long, value_name = "OUT.csv")]
    pub track: Option<PathBuf>,
    /// Write the plan's poses as CSV (x, y, z, yaw; map frame), as the
    /// case holds them.
    #[arg(long, value_name = "OUT.csv")]
    pub plan: Option<PathBuf>,
    /// Also drive the plan on this world's true surface (lava-tube,
    /// short-tube, garage, boulders, flat, or a mesh file), from where the
    /// rover truly stood: the true track (truth.csv) a simulated mission
    /// wrote beside the cases places it.
    #[arg(long, value_name = "NAME|MESH")]
    pub world: Option<String>,
    /// Seed of a generated world.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// With --world: the true drive's track, as --track.
    #[arg(long, value_name = "OUT.csv", requires = "world")]
    pub world_track: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct WcetArgs {
    /// One scenario (route, explore, validate, boulders, garage, replay);
    /// all of them when absent.
    #[arg(long, value_name = "NAME")]
    pub scenario: Option<String>,
    /// Configuration the scenarios start from; values not given keep their
    /// defaults.
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// Write every scenario's verdicts as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub report: Option<PathBuf>,
    /// Write the planner's units per step, phase by phase, sized from the
    /// measured step times (each phase's slowest p99.9 a unit fills 90 % of
    /// the window) as a `[planner.step_units]` configuration, with the
    /// figures it comes from.
    #[arg(long, value_name = "OUT.toml")]
    pub calibrate: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct PrimitivesArgs {
    #[arg(long, value_name = "OUT.mprim")]
    pub out: PathBuf,
    /// Cell size, m.
    #[arg(long, default_value_t = 0.1)]
    pub resolution: f64,
    /// Heading bins.
    #[arg(long, default_value_t = 16)]
    pub angles: u32,
    /// Tightest turn, m.
    #[arg(long, default_value_t = 0.5)]
    pub min_turn_radius: f64,
}

#[derive(Args, Debug)]
pub struct PlanArgs {
    /// SBPL environment (EnvironmentNAVXYTHETALAT .cfg), with --mprim.
    #[arg(
        long,
        value_name = "ENV.cfg",
        required_unless_present = "world",
        conflicts_with = "world"
    )]
    pub sbpl_env: Option<PathBuf>,
    /// Or a world (lava-tube, short-tube, garage, boulders, flat, or a mesh file): the maps are
    /// built from its ground-truth surface.
    #[arg(long, value_name = "NAME|MESH", requires_all = ["start", "goal"])]
    pub world: Option<String>,
    /// Seed of a generated world.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Start and goal in the world: a waypoint (`speleo world waypoints`)
    /// or x,y,z,yaw (m, degrees).
    #[arg(long, value_name = "NAME|x,y,z,yaw")]
    pub start: Option<String>,
    #[arg(long, value_name = "NAME|x,y,z,yaw")]
    pub goal: Option<String>,
    /// Motion primitives (SBPL .mprim); with --world, the rover's own set
    /// when absent.
    #[arg(long, value_name = "FILE.mprim", required_unless_present = "world")]
    pub mprim: Option<PathBuf>,
    /// Inflation of the first search; it falls by --eps-step to 1.
    #[arg(long, default_value_t = 3.0)]
    pub eps: f64,
    #[arg(long, default_value_t = 0.2)]
    pub eps_step: f64,
    /// Expansions per anytime step.
    #[arg(long, default_value_t = 1000)]
    pub quantum: u32,
    /// Write the figures and the path as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub report: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct MeshArgs {
    /// Folder of PLY scans (sensor frame), taken in name order...
    #[arg(
        long,
        value_name = "DIR",
        requires = "poses",
        required_unless_present = "record"
    )]
    pub scans: Option<PathBuf>,
    /// ...with one pose per line, KITTI format: 12 numbers, a row-major
    /// 3x4 sensor -> world.
    #[arg(long, value_name = "POSES.txt")]
    pub poses: Option<PathBuf>,
    /// Or a recording: replayed through the drivers and SLAM, its
    /// keyframes meshed at their final poses.
    #[arg(long, value_name = "LOG.mcap", conflicts_with_all = ["scans", "poses"])]
    pub record: Option<PathBuf>,
    /// Voxel size, m.
    #[arg(long, default_value_t = 0.05)]
    pub voxel: f64,
    /// Truncation distance, in voxels.
    #[arg(long, default_value_t = 3.0)]
    pub trunc: f64,
    /// Voxel blocks (8^3 voxels, 4 KiB each) the TSDF may use.
    #[arg(long, default_value_t = 1 << 16)]
    pub max_blocks: usize,
    #[arg(long, value_name = "MESH.ply")]
    pub out: PathBuf,
    /// Write the figures as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub report: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct RegisterArgs {
    #[arg(value_name = "SOURCE.ply")]
    pub source: PathBuf,
    #[arg(value_name = "TARGET.ply")]
    pub target: PathBuf,
    /// Initial transform: 16 numbers, a row-major 4x4 matrix.
    #[arg(long, value_name = "FILE")]
    pub init: Option<PathBuf>,
    /// Voxel size of the downsampling, m.
    #[arg(long, default_value_t = 0.25)]
    pub voxel: f64,
    /// Write the figures as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub report: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct G2oArgs {
    #[arg(value_name = "FILE.g2o")]
    pub file: PathBuf,
    /// Write the optimised graph here.
    #[arg(long, value_name = "OPT.g2o")]
    pub out: Option<PathBuf>,
    /// First estimate: file, chordal or spanning-tree.
    #[arg(long, default_value = "chordal")]
    pub init: String,
    #[arg(long, default_value_t = 100)]
    pub max_iterations: u32,
    /// Write the figures as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub report: Option<PathBuf>,
}

#[derive(Subcommand, Debug)]
pub enum WorldCommand {
    /// Write a world's ground-truth mesh as binary PLY (with a per-face
    /// `surface` property: 0 rock, 1 mud, 2 boulder, 3 concrete) and print its
    /// size, reachable floor area and start pose.
    Export(WorldExportArgs),
    /// Print a world's named poses (start, entrance, every 10 m along the
    /// route, one per level) for `speleo plan --start/--goal`.
    Waypoints(WorldWaypointsArgs),
}

#[derive(Args, Debug)]
pub struct WorldWaypointsArgs {
    /// lava-tube, short-tube, garage, boulders, flat, or a .ply/.obj/.stl file.
    #[arg(value_name = "NAME|MESH")]
    pub world: String,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(Args, Debug)]
pub struct WorldExportArgs {
    /// lava-tube, short-tube, garage, boulders, flat, or a .ply/.obj/.stl file.
    #[arg(value_name = "NAME|MESH")]
    pub world: String,
    #[arg(value_name = "OUT.ply")]
    pub out: PathBuf,
    /// Seed of the generated world.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(Args, Debug)]
pub struct Pcap2mcapArgs {
    #[arg(value_name = "CAPTURE.pcap")]
    pub capture: PathBuf,
    #[arg(value_name = "OUT.mcap")]
    pub out: PathBuf,
    /// Configuration stored in the recording (replay uses it).
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
}

#[derive(Subcommand, Debug)]
pub enum DecodeCommand {
    /// Velodyne HDL-32E capture: frame count and points per frame.
    Hdl32e(DecodeHdl32eArgs),
    /// Xsens MTi byte stream: every message with its decoded fields, then the
    /// counts of good frames, bad checksums and bytes skipped.
    Xbus(DecodeXbusArgs),
    /// `candump -L` log (or candump's screen format): NMT, SDO, PDO, SYNC,
    /// EMCY and heartbeat events with their CiA 402 meaning.
    Can(DecodeCanArgs),
}

#[derive(Args, Debug)]
pub struct DecodeHdl32eArgs {
    #[arg(value_name = "CAPTURE.pcap")]
    pub capture: PathBuf,
    /// VeloView XML or ROS YAML calibration [default: the nominal table].
    #[arg(long, value_name = "FILE")]
    pub calib: Option<PathBuf>,
    /// Write `frame,x,y,z,intensity,ring,time` (ROS axes: x forward, y left;
    /// time in seconds after the frame's first firing).
    #[arg(long, value_name = "OUT.csv")]
    pub csv: Option<PathBuf>,
    /// With --csv: only this frame.
    #[arg(long, value_name = "N")]
    pub frame: Option<u64>,
    /// Azimuth interpolation within a block: continuous, veloview (reproduces
    /// VeloView) or velodyne-decoder (reproduces that PyPI package).
    #[arg(long, default_value = "continuous")]
    pub interpolation: String,
    /// Azimuth at which frames are split, degrees.
    #[arg(long, default_value_t = 0.0)]
    pub cut_angle: f64,
}

#[derive(Args, Debug)]
pub struct DecodeXbusArgs {
    #[arg(value_name = "FILE.bin")]
    pub file: PathBuf,
    /// One JSON object per line.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct DecodeCanArgs {
    #[arg(value_name = "FILE.log")]
    pub file: PathBuf,
}

#[derive(Args, Debug, Clone, Default)]
pub struct Outputs {
    /// Record every raw input and every output to this MCAP file.
    #[arg(long, value_name = "OUT.mcap")]
    pub record: Option<PathBuf>,
    /// Write the run's figures (frames, output hash, per-task times) as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub report: Option<PathBuf>,
    /// At the end, mesh every keyframe at its final pose (TSDF, marching
    /// cubes) and write it as binary PLY.
    #[arg(long, value_name = "OUT.ply")]
    pub mesh: Option<PathBuf>,
    /// At the end, write every keyframe's cloud (sensor frame) as
    /// DIR/NNNNNN.ply with DIR/poses.txt (KITTI), for `speleo mesh --scans`.
    #[arg(long, value_name = "DIR")]
    pub export_scans: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct SimArgs {
    /// World to simulate: lava-tube, short-tube, garage, boulders, flat, or a PLY/OBJ/STL mesh.
    #[arg(long, value_name = "NAME|MESH")]
    pub world: Option<String>,
    /// Start at one of the world's waypoints (`speleo world waypoints`)
    /// or at x,y,z,yaw (m, degrees; z the floor's) instead of the world's
    /// start; home is there too.
    #[arg(long, value_name = "NAME|x,y,z,yaw")]
    pub start: Option<String>,
    /// Seed of every random source of the simulation, the sensors' noise
    /// too unless --noise-seed is given [default: from config, 1].
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
    /// Seed of the sensors' noise alone, the world and the start keeping
    /// --seed: the same mission with another noise stream [default: from
    /// config, the seed].
    #[arg(long, value_name = "N")]
    pub noise_seed: Option<u64>,
    /// Simulated seconds to run at most [default: from config, 7200]; an
    /// exploration ends earlier, once the rover is home.
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// Configuration file; values not given keep their defaults.
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// Drive the world's scripted route (out and back) instead of
    /// exploring (`exploration.enabled = false`).
    #[arg(long)]
    pub route: bool,
    /// Write the SLAM keyframe poses (world frame, TUM format) here, and
    /// beside it the odometry's poses at the same times as NAME.odom.EXT
    /// and the true poses as NAME.truth.EXT.
    #[arg(long, value_name = "OUT.tum")]
    pub trajectory: Option<PathBuf>,
    /// Draw the explored map with the rover's track, from above and from
    /// the side, as a PNG.
    #[arg(long, value_name = "OUT.png")]
    pub plot: Option<PathBuf>,
    /// Inject a fault, KIND@START[+DURATION][:WHEEL] (seconds; the duration
    /// defaults to 5, the wheel to 1 = front left). Kinds: lidar-dropout,
    /// imu-garbage, imu-dropout, stuck-wheel, wheel-slip, drive-fault,
    /// can-bus-off, overrun-storm, clock-jump. Repeat for more; added to
    /// the configuration's `sim.faults`.
    #[arg(long = "fault", value_name = "SPEC")]
    pub faults: Vec<String>,
    /// Write every internal-simulator validation's inputs and verdict as
    /// DIR/validation-NNNN.case, for `speleo validate`
    /// (`simulator.dump_dir`).
    #[arg(long, value_name = "DIR")]
    pub dump_validations: Option<PathBuf>,
    #[command(flatten)]
    pub out: Outputs,
}

#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The recording to replay (a file cut short by a killed process is
    /// replayed up to its last complete chunk).
    #[arg(value_name = "LOG.mcap")]
    pub log: PathBuf,
    #[command(flatten)]
    pub out: Outputs,
}

#[derive(Args, Debug)]
pub struct RunArgs {
    /// Configuration file with the [devices] table.
    #[arg(long, value_name = "FILE.toml")]
    pub config: PathBuf,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    #[command(flatten)]
    pub out: Outputs,
}
