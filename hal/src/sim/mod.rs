//! Simulated hardware: a skid-steer rover on flat ground with twins of its
//! IMU, motor drives and (optionally) HDL-32E that speak the real wire
//! formats.
//!
//! The rover obeys the wheel velocity commands it receives as CiA 402 PDOs;
//! its IMU emits Xbus MTData2 frames at 100 Hz and its drives answer every
//! SYNC with their PDOs. The world is flat ground; the generated caves, the
//! physics rover and the LiDAR twin replace it in later work, behind the same
//! traits. Everything is seeded, and the trigonometry is `libm`'s pure-Rust
//! code, so the byte streams repeat on any machine.

pub mod drives;
pub mod imu;
pub mod lidar;
pub mod noise;
pub mod rover;

use crate::can::CanFrame;
use crate::outbox::Outbox;
use crate::{CanBus, Device, HalError, Hardware, ImuPort, InputSink, LidarSource};

pub use rover::{GroundTruth, RoverParams};

/// Physics step of the flat-ground model.
const STEP_NS: u64 = 1_000_000;

/// Everything configurable about the simulated hardware.
#[derive(Clone, Debug, PartialEq)]
pub struct SimParams {
    pub seed: u64,
    pub rover: RoverParams,
    pub imu: imu::ImuParams,
    pub drives: drives::DriveParams,
    /// The HDL-32E twin (off: no LiDAR data).
    pub lidar: Option<lidar::LidarParams>,
    /// Sensor on base_link: x, y, z (m) and roll, pitch, yaw (rad).
    pub lidar_mount: [f64; 6],
}

impl Default for SimParams {
    fn default() -> Self {
        SimParams {
            seed: 1,
            rover: RoverParams::default(),
            imu: imu::ImuParams::default(),
            drives: drives::DriveParams::default(),
            lidar: None,
            lidar_mount: [0.0, 0.0, 0.5, 0.0, 0.0, 0.0],
        }
    }
}

/// A read-only view of the true pose, updated as the simulation advances.
/// Given to the recorder's ground-truth topic only; on-board tasks never get it.
pub type TruthProbe = std::rc::Rc<std::cell::Cell<GroundTruth>>;

/// The simulated rover and its devices.
pub struct SimHardware {
    t_ns: u64,
    truth: TruthProbe,
    rover: rover::Rover,
    imu: imu::SimImu,
    drives: drives::SimDrives,
    lidar: LidarTwin,
    mount: [f64; 6],
}

/// The LiDAR twin, or none.
enum LidarTwin {
    Off,
    On(Box<lidar::SimLidar>),
}

impl SimHardware {
    pub fn new(p: &SimParams) -> Self {
        let rover = rover::Rover::new(p.rover.clone());
        SimHardware {
            t_ns: 0,
            truth: std::rc::Rc::new(std::cell::Cell::new(rover.truth(0))),
            rover,
            imu: imu::SimImu::new(p.imu.clone(), p.seed),
            drives: drives::SimDrives::new(p.drives.clone()),
            lidar: LidarTwin::Off,
            mount: p.lidar_mount,
        }
    }

    /// Simulated hardware with the LiDAR twin casting rays against `world`
    /// (when `p.lidar` is set).
    pub fn with_world(p: &SimParams, world: &crate::world::World) -> Result<Self, String> {
        let mut hw = Self::new(p);
        if let Some(lp) = &p.lidar {
            let w = std::sync::Arc::new(lidar::LidarWorld::new(&world.mesh)?);
            hw.lidar = LidarTwin::On(Box::new(lidar::SimLidar::new(
                lp.clone(),
                crate::hdl32e::Calibration::nominal(),
                w,
                p.seed,
            )));
        }
        Ok(hw)
    }

    /// Sensor pose for a rover pose on flat ground.
    fn sensor_pose(&self, g: &GroundTruth) -> lidar::SensorPose {
        let [mx, my, mz, roll, pitch, yaw] = self.mount;
        let (s, c) = (libm::sin(g.yaw), libm::cos(g.yaw));
        lidar::SensorPose {
            p: [g.x + c * mx - s * my, g.y + s * mx + c * my, g.z + mz],
            yaw: g.yaw + yaw,
            pitch,
            roll,
        }
    }

    /// The true pose. For the ground-truth recording only: on-board tasks
    /// never see it.
    pub fn ground_truth(&self) -> GroundTruth {
        self.rover.truth(self.t_ns)
    }

    /// A handle that follows the true pose after every `advance_to`.
    pub fn truth_probe(&self) -> TruthProbe {
        self.truth.clone()
    }

    /// The drives, for fault injection.
    pub fn drives_mut(&mut self) -> &mut drives::SimDrives {
        &mut self.drives
    }

    /// Counters of frames the simulated devices could not deliver.
    pub fn dropped(&self) -> u64 {
        let lidar = match &self.lidar {
            LidarTwin::On(l) => l.dropped(),
            LidarTwin::Off => 0,
        };
        self.imu.dropped() + self.drives.dropped() + lidar
    }
}

impl Hardware for SimHardware {
    fn advance_to(&mut self, now_ns: u64) {
        while self.t_ns + STEP_NS <= now_ns {
            self.drives.tick(self.t_ns);
            let targets = self.drives.wheel_targets(self.t_ns);
            let before = self.rover.truth(self.t_ns);
            self.rover.step(STEP_NS, &targets);
            if let LidarTwin::On(_) = self.lidar {
                let after = self.rover.truth(self.t_ns + STEP_NS);
                let (p0, p1) = (self.sensor_pose(&before), self.sensor_pose(&after));
                if let LidarTwin::On(l) = &mut self.lidar {
                    l.advance(self.t_ns, self.t_ns + STEP_NS, &p0, &p1);
                }
            }
            self.t_ns += STEP_NS;
            self.drives.observe(&self.rover);
            self.imu.maybe_sample(self.t_ns, &self.rover);
        }
        self.truth.set(self.rover.truth(self.t_ns));
    }
    fn lidar(&mut self) -> &mut dyn LidarSource {
        &mut self.lidar
    }
    fn imu(&mut self) -> &mut dyn ImuPort {
        &mut self.imu
    }
    fn can(&mut self) -> &mut dyn CanBus {
        &mut self.drives
    }
}

impl LidarSource for LidarTwin {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        if let LidarTwin::On(l) = self {
            deliver(l.outbox(), Device::Lidar, now_ns, sink);
        }
        Ok(())
    }
}

/// Hand the items of `outbox` that have arrived by `now_ns` to `sink`.
fn deliver<const N: usize, const M: usize>(
    outbox: &mut Outbox<N, M>,
    device: Device,
    now_ns: u64,
    sink: &mut dyn InputSink,
) {
    while let Some((t, bytes)) = outbox.pop_due(now_ns) {
        sink.input(device, t, &bytes);
    }
}

impl CanBus for drives::SimDrives {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        deliver(self.outbox(), Device::Can, now_ns, sink);
        Ok(())
    }
    fn send(&mut self, now_ns: u64, frame: &CanFrame) -> Result<(), HalError> {
        self.receive(now_ns, frame);
        Ok(())
    }
}

impl ImuPort for imu::SimImu {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        deliver(self.outbox(), Device::Imu, now_ns, sink);
        Ok(())
    }
    fn write(&mut self, bytes: &[u8]) -> Result<(), HalError> {
        self.receive(bytes);
        Ok(())
    }
}
