//! The arguments of the flight commands (`sim`, `replay`, `run`) and the
//! outputs they share; the command line itself is the `speleo` binary's.

use std::path::PathBuf;

use clap::Args;

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
    /// Serve the recorded channels live over the Foxglove WebSocket
    /// protocol (Foxglove: Open connection, Foxglove WebSocket), on
    /// 127.0.0.1:8765 unless an address is given. A slow viewer loses
    /// messages (counted in the report), never delays a frame.
    #[arg(
        long,
        value_name = "ADDR:PORT",
        num_args = 0..=1,
        default_missing_value = crate::record::live::DEFAULT_ADDRESS
    )]
    pub live: Option<String>,
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
