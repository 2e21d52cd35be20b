//! The rover's hardware twin: a skid-steer rover in a world (a generated
//! lava tube, a garage, a boulder field, flat ground or a mesh file) with
//! twins of its IMU, motor drives and HDL-32E that speak the real wire
//! formats, behind `speleo-hal`'s `Hardware` traits.
//!
//! The rover obeys the wheel velocity commands it receives as CiA 402 PDOs;
//! its IMU emits Xbus MTData2 frames at 100 Hz, its drives answer every SYNC
//! with their PDOs and the LiDAR streams UDP payloads, all encoded by
//! `speleo-hal`'s codecs. The rover is either the rapier3d physics model of
//! `speleo-physics` (the default) or flat-ground kinematics ([`rover`]:
//! fast, for tests of the software around it). Everything is seeded, physics
//! is built with enhanced determinism and the twins' trigonometry is
//! `libm`'s pure-Rust code, so the byte streams repeat on any machine.

pub mod drives;
pub mod imu;
pub mod lidar;
pub mod noise;
pub mod put_down;
pub mod ray_caster;
pub mod rover;
pub mod world;

use speleo_hal::can::CanFrame;
use speleo_hal::outbox::Outbox;
use speleo_hal::{CanBus, Device, HalError, Hardware, ImuPort, InputSink, LidarSource};
use speleo_physics::rover::{PhysicsRover, START_GAP_M};
use speleo_physics::{body, quat};

pub use rover::RoverParams;
pub use speleo_physics::{BodyState, PhysicsParams};
/// The true state, as recorded on the ground-truth topic.
pub type GroundTruth = BodyState;

/// Step of the simulation: physics, drives and sensor twins.
const STEP_NS: u64 = 1_000_000;

/// Everything configurable about the simulated hardware.
#[derive(Clone, Debug, PartialEq)]
pub struct TwinParams {
    pub seed: u64,
    /// The flat-ground kinematic model (used when `physics` is none).
    pub rover: RoverParams,
    /// The rapier3d rover.
    pub physics: Option<PhysicsParams>,
    pub imu: imu::ImuParams,
    pub drives: drives::DriveParams,
    /// The HDL-32E twin (off: no LiDAR data).
    pub lidar: Option<lidar::LidarParams>,
    /// Sensor on base_link (the chassis frame at axle height): x, y, z (m)
    /// and roll, pitch, yaw (rad).
    pub lidar_mount: [f64; 6],
    /// Put the physics rover down on the ground under its wheels, pitched
    /// and rolled as it slopes (a start anywhere in a world), rather than
    /// level at the start's height (a world's own start, chosen level).
    pub start_on_ground: bool,
}

impl Default for TwinParams {
    fn default() -> Self {
        TwinParams {
            seed: 1,
            rover: RoverParams::default(),
            physics: Some(PhysicsParams::default()),
            imu: imu::ImuParams::default(),
            drives: drives::DriveParams::default(),
            lidar: None,
            lidar_mount: [0.0, 0.0, 0.35, 0.0, 0.0, 0.0],
            start_on_ground: false,
        }
    }
}

/// A read-only view of the true pose, updated as the simulation advances.
/// Given to the recorder's ground-truth topic only; on-board tasks never get it.
pub type TruthProbe = std::rc::Rc<std::cell::Cell<GroundTruth>>;

/// What the world's physics saw the rover strike over a mission.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Strikes {
    /// Times the chassis struck a wall, the ceiling or a boulder's side.
    pub collisions: u64,
    /// Times it fell (sank faster than [`speleo_physics::rover::FALL_SPEED_MPS`]).
    pub falls: u64,
    /// The worst fall's height, m.
    pub worst_fall_m: f64,
    /// Whether a fall wrecked it (one from [`speleo_physics::rover::WRECK_HEIGHT_M`] or
    /// more).
    pub wrecked: bool,
}

/// The simulated rover and its devices.
pub struct TwinHardware {
    t_ns: u64,
    truth: TruthProbe,
    motion: Motion,
    imu: imu::ImuTwin,
    drives: drives::DrivesTwin,
    lidar: LidarTwin,
    mount: lidar::SensorPose,
}

/// How the rover moves.
enum Motion {
    Kinematic(rover::Rover),
    Physics(Box<PhysicsRover>),
}

impl Motion {
    fn state(&self, t_ns: u64) -> BodyState {
        match self {
            Motion::Kinematic(r) => r.state(t_ns),
            Motion::Physics(r) => *r.state(),
        }
    }

    fn step(&mut self, t_end_ns: u64, targets: &[f64; body::WHEELS]) {
        match self {
            Motion::Kinematic(r) => r.step(STEP_NS, targets),
            Motion::Physics(r) => r.step(t_end_ns, targets),
        }
    }
}

/// The LiDAR twin, or none.
enum LidarTwin {
    Off,
    On(Box<lidar::LidarTwin>),
}

impl TwinHardware {
    /// Simulated hardware on flat ground.
    pub fn new(p: &TwinParams) -> Result<Self, String> {
        let flat = crate::world::World::build("flat", p.seed).map_err(|e| e.to_string())?;
        Self::with_world(p, &flat)
    }

    /// Simulated hardware in `world`: the rover at the world's start, the
    /// LiDAR twin (when `p.lidar` is set) casting rays against its mesh.
    pub fn with_world(p: &TwinParams, world: &crate::world::World) -> Result<Self, String> {
        let motion = match &p.physics {
            Some(pp) => {
                let (start, tilt) = if p.start_on_ground {
                    put_down::standing(
                        &world.mesh,
                        world.start,
                        pp.wheelbase_m,
                        pp.track_width_m,
                        pp.wheel_radius_m + START_GAP_M,
                    )
                } else {
                    (world.start, [0.0; 2])
                };
                Motion::Physics(Box::new(PhysicsRover::new_tilted(
                    pp,
                    &world.mesh,
                    start,
                    tilt,
                    STEP_NS as f64 * 1e-9,
                )?))
            }
            None => {
                // base_link is at axle height on the kinematic rover too.
                let [x, y, z, yaw] = world.start;
                let lift = p.rover.wheel_radius_m;
                Motion::Kinematic(rover::Rover::at(p.rover.clone(), [x, y, z + lift, yaw]))
            }
        };
        let lidar = match &p.lidar {
            Some(lp) => {
                let w = std::sync::Arc::new(lidar::LidarWorld::new(&world.mesh)?);
                LidarTwin::On(Box::new(lidar::LidarTwin::new(
                    lp.clone(),
                    speleo_hal::hdl32e::Calibration::nominal(),
                    w,
                    p.seed,
                )))
            }
            None => LidarTwin::Off,
        };
        let [mx, my, mz, roll, pitch, yaw] = p.lidar_mount;
        let first = motion.state(0);
        Ok(TwinHardware {
            t_ns: 0,
            truth: std::rc::Rc::new(std::cell::Cell::new(first)),
            motion,
            imu: imu::ImuTwin::new(p.imu.clone(), p.seed),
            drives: drives::DrivesTwin::new(p.drives.clone()),
            lidar,
            mount: lidar::SensorPose {
                p: [mx, my, mz],
                q: quat::from_ypr(yaw, pitch, roll),
            },
        })
    }

    /// The sensor's pose in the world for a rover state.
    fn sensor_pose(&self, g: &BodyState) -> lidar::SensorPose {
        lidar::SensorPose {
            p: g.to_world(self.mount.p),
            q: quat::mul(&g.orientation, &self.mount.q),
        }
    }

    /// The true state. For the ground-truth recording only: on-board tasks
    /// never see it.
    pub fn ground_truth(&self) -> GroundTruth {
        // The probe's state: the frame's start, even when the world has
        // looked ahead.
        self.truth.get()
    }

    /// What the world's physics saw the rover strike: walls and ceiling,
    /// and the ground after a fall; nothing for the kinematic rover.
    pub fn strikes(&self) -> Strikes {
        match &self.motion {
            Motion::Kinematic(_) => Strikes::default(),
            Motion::Physics(r) => Strikes {
                collisions: r.collisions,
                falls: r.falls,
                worst_fall_m: r.worst_fall_m,
                wrecked: r.wrecked,
            },
        }
    }

    /// A handle that follows the true pose after every `advance_to`.
    pub fn truth_probe(&self) -> TruthProbe {
        self.truth.clone()
    }

    /// The drives, for fault injection.
    pub fn drives_mut(&mut self) -> &mut drives::DrivesTwin {
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

impl TwinHardware {
    /// Step the rover and its devices through every physics step that ends
    /// by `until_ns`, aiming the LiDAR's firings on the way.
    fn step_to(&mut self, until_ns: u64) {
        while self.t_ns + STEP_NS <= until_ns {
            self.drives.tick(self.t_ns);
            let targets = self.drives.wheel_targets(self.t_ns);
            let before = self.motion.state(self.t_ns);
            self.motion.step(self.t_ns + STEP_NS, &targets);
            let after = self.motion.state(self.t_ns + STEP_NS);
            if let LidarTwin::On(_) = self.lidar {
                let (p0, p1) = (self.sensor_pose(&before), self.sensor_pose(&after));
                if let LidarTwin::On(l) = &mut self.lidar {
                    l.queue(self.t_ns, self.t_ns + STEP_NS, &p0, &p1);
                }
            }
            self.t_ns += STEP_NS;
            self.drives.observe(&after);
            self.imu.observe(&after);
            self.imu.maybe_sample(self.t_ns, &after);
        }
    }
}

impl Hardware for TwinHardware {
    fn advance_to(&mut self, now_ns: u64) {
        self.step_to(now_ns);
        // The frame's rays in one batch, on two cores; those launched by
        // `look_ahead` have been cast meanwhile.
        if let LidarTwin::On(l) = &mut self.lidar {
            l.flush();
        }
        self.truth.set(self.motion.state(self.t_ns));
    }
    fn look_ahead(&mut self, next_ns: u64) {
        // The truth probe keeps the frame's start: it moves on at
        // `advance_to`, with everything the rover's software can see.
        self.step_to(next_ns);
        if let LidarTwin::On(l) = &mut self.lidar {
            l.launch();
        }
    }
    fn world_over(&self) -> bool {
        self.strikes().wrecked
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
            deliver(l.positions(), Device::LidarPosition, now_ns, sink);
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

impl CanBus for drives::DrivesTwin {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        deliver(self.outbox(), Device::Can, now_ns, sink);
        Ok(())
    }
    fn send(&mut self, now_ns: u64, frame: &CanFrame) -> Result<(), HalError> {
        self.receive(now_ns, frame);
        Ok(())
    }
}

impl ImuPort for imu::ImuTwin {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        deliver(self.outbox(), Device::Imu, now_ns, sink);
        Ok(())
    }
    fn write(&mut self, bytes: &[u8]) -> Result<(), HalError> {
        self.receive(bytes);
        Ok(())
    }
}
