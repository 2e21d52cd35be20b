//! The ground tools' arguments (decoding, pose graphs, registration,
//! meshing, planning, validation, budgets, campaigns, worlds).

use std::path::PathBuf;

use clap::{Args, Subcommand};

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
    /// Replay every validation the cases dumped (`run --dump-validations`)
    /// on the map as the mission did, on the map from the start's true
    /// attitude, and on the world's true surface from where the rover
    /// truly stood: how often each verdict agrees with the truth, the
    /// quantiles of the most tilt's error and of SLAM's error at the
    /// start. The margins of the internal simulation are set from these.
    Validations(CampaignValidationsArgs),
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
    /// Each case also writes its internal simulator's validations into
    /// its folder (`validations/`), for `speleo campaign validations`.
    /// About 0.6 MB a validation.
    #[arg(long, conflicts_with = "verify")]
    pub dump_validations: bool,
}

#[derive(Args, Debug)]
pub struct CampaignValidationsArgs {
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// Write one row a validation as CSV.
    #[arg(long, value_name = "OUT.csv")]
    pub csv: Option<PathBuf>,
    /// Write the figures as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Cases replayed side by side (default: the machine's cores).
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,
    /// A candidate configuration, laid over each case's: every plan is
    /// also replayed on the map with its simulator, and the verdicts it
    /// changes are counted toward and away from the truth (a change to
    /// the internal simulation judged on the same plans).
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
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
    #[arg(long, value_name = "NAME", conflicts_with = "recording")]
    pub scenario: Option<String>,
    /// Judge a recording instead (a bench's, the rover's, a simulation's):
    /// replayed through the drivers and tasks, each task's p99.9 against
    /// its budget.
    #[arg(long, value_name = "REC.mcap")]
    pub recording: Option<PathBuf>,
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
pub struct InfoArgs {
    #[arg(value_name = "REC.mcap")]
    pub file: PathBuf,
    /// Print the figures as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Print the configuration the run recorded (TOML) after the figures.
    #[arg(long)]
    pub config: bool,
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

#[derive(Args, Debug)]
pub struct TwinArgs {
    /// The simulated hardware (`[sim]`, `[rover]`, `[lidar]`) and where its
    /// wires go (`[twin]`); the defaults when absent.
    #[arg(long, value_name = "twin.toml")]
    pub config: Option<PathBuf>,
    /// The world (as `sim --world`).
    #[arg(long)]
    pub world: Option<String>,
    /// The world's seed (as `sim --seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// The sensors' noise streams, when they differ from the world's seed.
    #[arg(long)]
    pub noise_seed: Option<u64>,
    /// Stop after this many seconds; otherwise a signal stops it.
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Record the true pose and every byte sent and received (MCAP).
    #[arg(long, value_name = "OUT.mcap")]
    pub record: Option<PathBuf>,
    /// Write the twin's report as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub report: Option<PathBuf>,
    /// Unplug the LiDAR at AT seconds for SECONDS (repeatable): no packets.
    #[arg(long, value_name = "AT:SECONDS")]
    pub unplug_lidar: Vec<String>,
}

#[derive(Args, Debug)]
pub struct HilArgs {
    /// The twin's world (as `sim --world`).
    #[arg(long)]
    pub world: Option<String>,
    /// The twin's world seed (as `sim --seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// How long the bench runs, s of real time (less when the mission ends
    /// by itself).
    #[arg(long, value_name = "SECONDS")]
    pub duration: f64,
    /// The twin's configuration (`examples/twin.toml`); its defaults when absent.
    #[arg(long, value_name = "twin.toml")]
    pub twin_config: Option<PathBuf>,
    /// The flight binary's configuration; its `[devices]` are pointed at
    /// the twin's wires.
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<PathBuf>,
    /// Where both write their recordings, reports and the flight binary's
    /// configuration.
    #[arg(long, value_name = "DIR", default_value = "hil")]
    pub out: PathBuf,
    /// Both reports and the bench's figures in one JSON file.
    #[arg(long, value_name = "OUT.json")]
    pub report: Option<PathBuf>,
    /// Unplug the twin's LiDAR at AT seconds for SECONDS (repeatable).
    #[arg(long, value_name = "AT:SECONDS")]
    pub unplug_lidar: Vec<String>,
}
