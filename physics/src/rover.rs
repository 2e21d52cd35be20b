//! The rover in rapier3d: an Asguard-like chassis on four leg-wheels (each a
//! star of legs) on motorised revolute joints, driving on the world mesh.
//!
//! Each drive follows an acceleration-limited velocity profile with a torque
//! limit, as a CiA 402 drive in profile-velocity mode does: the joint motor
//! applies at most `motor_torque_nm`, so a wheel pressed against a boulder
//! stalls instead of spinning through it. Like a real drive's PI velocity
//! loop, it also tracks the integral of the profile (the position), so a
//! wheel held at zero under load stands still instead of creeping.
//! Friction comes from the world's materials (mud is slippery).
//!
//! rapier is built with `enhanced-determinism`: the same world, start and
//! commands give the same motion, bit for bit, on any machine.

use rapier3d::math::{Pose, Rotation, Vector};
use rapier3d::prelude::*;

use crate::body::{BodyState, GRAVITY, WHEELS};
use crate::chassis_contacts::ChassisContacts;
use crate::quat::{self, Quat};
use crate::terrain::{Material, Mesh};

/// The simulated rover's build. Defaults: an Asguard-like rover (DFKI's
/// Asguard series as published: about 1 m long and 0.5 m wide, four
/// five-legged wheels of about 0.2 m driven one motor each), scaled to the
/// V4 with its LiDAR, computer and batteries. These are estimates from the
/// published descriptions and photographs, not measurements of the real
/// rover; every one can be set in `[sim.rover]`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhysicsParams {
    /// Chassis mass including payload, kg.
    pub chassis_mass_kg: f64,
    /// Chassis box: length, width, height, m.
    pub chassis_size_m: [f64; 3],
    /// Front to rear axle, m.
    pub wheelbase_m: f64,
    /// Left to right wheel centre, m.
    pub track_width_m: f64,
    /// Hub to the outer edge of a leg tip, m.
    pub wheel_radius_m: f64,
    /// Legs per wheel (0: a plain round wheel).
    pub legs_per_wheel: u32,
    /// Radius of a leg (its rounded tip), m.
    pub leg_radius_m: f64,
    /// Mass of one leg-wheel, kg.
    pub wheel_mass_kg: f64,
    /// Peak torque of one drive at the wheel (after the gearbox), N m.
    pub motor_torque_nm: f64,
    /// Speed and acceleration limits of the drives' profile, rad/s and rad/s^2.
    pub max_wheel_speed: f64,
    pub max_wheel_accel: f64,
    /// Coulomb friction coefficients of the legs on each surface.
    pub friction_rock: f64,
    pub friction_mud: f64,
    pub friction_concrete: f64,
    /// Velocity-constraint solver iterations per step.
    pub solver_iterations: u32,
}

impl Default for PhysicsParams {
    fn default() -> Self {
        PhysicsParams {
            chassis_mass_kg: 14.0,
            chassis_size_m: [0.62, 0.32, 0.14],
            wheelbase_m: 0.52,
            track_width_m: 0.52,
            wheel_radius_m: 0.19,
            legs_per_wheel: 5,
            leg_radius_m: 0.025,
            wheel_mass_kg: 0.8,
            motor_torque_nm: 15.0,
            max_wheel_speed: 5.0,
            max_wheel_accel: 10.0,
            friction_rock: 0.8,
            friction_mud: 0.35,
            friction_concrete: 0.9,
            solver_iterations: 4,
        }
    }
}

impl PhysicsParams {
    /// Refuse builds the solver cannot simulate sensibly.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("chassis_mass_kg", self.chassis_mass_kg),
            ("wheelbase_m", self.wheelbase_m),
            ("track_width_m", self.track_width_m),
            ("wheel_radius_m", self.wheel_radius_m),
            ("leg_radius_m", self.leg_radius_m),
            ("wheel_mass_kg", self.wheel_mass_kg),
            ("motor_torque_nm", self.motor_torque_nm),
            ("max_wheel_speed", self.max_wheel_speed),
            ("max_wheel_accel", self.max_wheel_accel),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be a positive number, not {v}"));
            }
        }
        if self
            .chassis_size_m
            .iter()
            .any(|v| !(v.is_finite() && *v > 0.0))
        {
            return Err("chassis_size_m must be three positive lengths".into());
        }
        if self.leg_radius_m * 2.0 >= self.wheel_radius_m {
            return Err("leg_radius_m must be under half of wheel_radius_m".into());
        }
        if self.track_width_m <= self.chassis_size_m[1] + 2.0 * self.leg_radius_m {
            return Err("the wheels would cut into the chassis: widen track_width_m".into());
        }
        for (name, f) in [
            ("friction_rock", self.friction_rock),
            ("friction_mud", self.friction_mud),
            ("friction_concrete", self.friction_concrete),
        ] {
            if !(f.is_finite() && (0.0..=3.0).contains(&f)) {
                return Err(format!("{name} must be within 0..3, not {f}"));
            }
        }
        if !(1..=32).contains(&self.solver_iterations) {
            return Err("solver_iterations must be within 1..32".into());
        }
        Ok(())
    }

    fn friction(&self, s: Material) -> f64 {
        match s {
            Material::Rock | Material::Boulder => self.friction_rock,
            Material::Mud => self.friction_mud,
            Material::Concrete => self.friction_concrete,
        }
    }

    /// Hub of wheel `w` in base_link (FL, FR, RL, RR).
    fn hub(&self, w: usize) -> [f64; 3] {
        let x = if w < 2 { 0.5 } else { -0.5 } * self.wheelbase_m;
        let y = if w.is_multiple_of(2) { 0.5 } else { -0.5 } * self.track_width_m;
        [x, y, 0.0]
    }
}

/// The rover and the world's ground in one rapier world.
pub struct PhysicsRover {
    p: PhysicsParams,
    world: PhysicsWorld,
    chassis: RigidBodyHandle,
    wheels: [RigidBodyHandle; WHEELS],
    joints: [ImpulseJointHandle; WHEELS],
    /// The drives' profile speeds, rad/s, and their integrals, rad.
    profile: [f64; WHEELS],
    profile_angle: [f64; WHEELS],
    state: BodyState,
    /// Non-finite states rapier quarantined (the rover would vanish).
    pub quarantined: u64,
    chassis_collider: ColliderHandle,
    /// The chassis touches the world other than from above the ground.
    in_collision: bool,
    /// Times the chassis struck a wall, the ceiling or a boulder's side
    /// (each touch counts once, however long it lasts).
    pub collisions: u64,
    /// The ground's colliders, for taking the world down in slices.
    ground: Vec<ColliderHandle>,
    /// Times the chassis fell: sank faster than [`FALL_SPEED_MPS`] (each
    /// fall counts once), and the worst, as the free-fall height of its
    /// fastest sinking, m.
    pub falls: u64,
    pub worst_fall_m: f64,
    /// The fall under way: its fastest sinking so far, m/s (positive).
    falling: Option<f64>,
    /// A fall from [`WRECK_HEIGHT_M`] or more wrecked the rover: it lies
    /// where it struck, and the world no longer moves it.
    pub wrecked: bool,
}

/// Sinking this fast, m/s, is a fall: about half a metre of free fall. A
/// rover driving down a 0.2 m step sinks at 2 m/s at most.
pub const FALL_SPEED_MPS: f64 = 3.0;
/// A fall from this high, m, wrecks the rover (4.4 m/s at the strike).
/// Why stop the world there: after a roof's 9 m the solver, striking the
/// ground at 13 m/s, flung the rover off the world (hundreds of metres
/// away and falling), and every figure after it was nonsense.
pub const WRECK_HEIGHT_M: f64 = 1.0;

fn v3(a: [f64; 3]) -> Vector {
    Vector::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

fn q_from(r: &Rotation) -> Quat {
    [r.w as f64, r.x as f64, r.y as f64, r.z as f64]
}

fn rot(q: &Quat) -> Rotation {
    Rotation::from_xyzw(q[1] as f32, q[2] as f32, q[3] as f32, q[0] as f32).normalize()
}

/// How far the wheels start above the ground, m.
pub const START_GAP_M: f64 = 0.01;

impl PhysicsRover {
    /// The rover standing on `mesh` at `start` (x, y, ground z, yaw), its
    /// legs just clear of the ground. `dt_s` is the physics step.
    pub fn new(p: &PhysicsParams, mesh: &Mesh, start: [f64; 4], dt_s: f64) -> Result<Self, String> {
        Self::new_tilted(p, mesh, start, [0.0; 2], dt_s)
    }

    /// As [`PhysicsRover::new`], the chassis pitched and rolled by `tilt`
    /// (pitch, roll, rad): to start on a slope as the rover stands on it.
    pub fn new_tilted(
        p: &PhysicsParams,
        mesh: &Mesh,
        start: [f64; 4],
        tilt: [f64; 2],
        dt_s: f64,
    ) -> Result<Self, String> {
        p.validate()?;
        let mut world = PhysicsWorld::new();
        // Same contacts as parry's default, the chassis's far triangles
        // dropped cheaply (see chassis_contacts).
        world.narrow_phase = NarrowPhase::with_query_dispatcher(ChassisContacts);
        world.gravity = Vector::new(0.0, 0.0, -GRAVITY as f32);
        world.integration_parameters.dt = dt_s as f32;
        world.integration_parameters.num_solver_iterations = p.solver_iterations as usize;
        let mut ground = Vec::new();
        add_ground(&mut world, p, mesh, TriMeshFlags::empty(), &mut ground)?;

        let orientation = quat::from_ypr(start[3], tilt[0], tilt[1]);
        let base = [
            start[0],
            start[1],
            start[2] + p.wheel_radius_m + START_GAP_M,
        ];
        let [l, w, h] = p.chassis_size_m;
        let chassis = world.insert_body(
            RigidBodyBuilder::dynamic()
                .pose(Pose::from_parts(v3(base), rot(&orientation)))
                .can_sleep(false),
        );
        let chassis_collider = world.insert_collider(
            ColliderBuilder::cuboid(0.5 * l as f32, 0.5 * w as f32, 0.5 * h as f32)
                .mass(p.chassis_mass_kg as f32)
                .friction(0.5),
            Some(chassis),
        );
        let mut wheels = [chassis; WHEELS];
        let mut joints = Vec::with_capacity(WHEELS);
        for (i, wheel) in wheels.iter_mut().enumerate() {
            let hub = p.hub(i);
            let centre = {
                let r = quat::rotate(&orientation, hub);
                [base[0] + r[0], base[1] + r[1], base[2] + r[2]]
            };
            // Diagonal wheels in phase, the others half a leg apart: the
            // chassis rocks less than with all four legs striking together.
            let phase = if i == 0 || i == 3 { 0.0 } else { 0.5 };
            *wheel = world.insert_body(
                RigidBodyBuilder::dynamic()
                    .pose(Pose::from_parts(v3(centre), rot(&orientation)))
                    .can_sleep(false),
            );
            world.insert_collider(wheel_collider(p, phase)?, Some(*wheel));
            let joint = RevoluteJointBuilder::new(Vector::Y)
                .local_anchor1(v3(hub))
                .local_anchor2(Vector::ZERO)
                .motor_model(MotorModel::ForceBased)
                .motor_velocity(0.0, motor_damping(p))
                .motor_max_force(p.motor_torque_nm as f32)
                .contacts_enabled(false);
            joints.push(world.insert_impulse_joint(chassis, *wheel, joint));
        }
        let joints: [ImpulseJointHandle; WHEELS] = joints
            .try_into()
            .map_err(|_| "four wheel joints".to_string())?;
        let mut rover = PhysicsRover {
            p: p.clone(),
            world,
            chassis,
            wheels,
            joints,
            profile: [0.0; WHEELS],
            profile_angle: [0.0; WHEELS],
            state: BodyState::default(),
            quarantined: 0,
            chassis_collider,
            in_collision: false,
            collisions: 0,
            ground,
            falls: 0,
            worst_fall_m: 0.0,
            falling: None,
            wrecked: false,
        };
        rover.state = rover.read_state(0, None, dt_s);
        Ok(rover)
    }

    /// Add more of the world's surface (the internal simulator builds its
    /// ground a piece at a time).
    pub fn add_ground(&mut self, mesh: &Mesh) -> Result<(), String> {
        add_ground(
            &mut self.world,
            &self.p,
            mesh,
            TriMeshFlags::empty(),
            &mut self.ground,
        )
    }

    /// Remove up to `max` of the ground's colliders (the last added
    /// first); how many are left. Dropping a world of a thousand triangle
    /// meshes at once takes about a millisecond: this spreads it over
    /// bounded steps.
    pub fn remove_ground(&mut self, max: usize) -> usize {
        for _ in 0..max {
            let Some(h) = self.ground.pop() else {
                break;
            };
            self.world.remove_collider(h);
        }
        self.ground.len()
    }

    /// The same for a mesh of many small triangles (a TSDF's): contacts
    /// on the edges between its triangles are corrected, so the legs do not
    /// catch on edges inside a flat floor. A tile whose topology does not
    /// allow it is added as it is.
    pub fn add_ground_smooth(&mut self, mesh: &Mesh) -> Result<(), String> {
        let flags = TriMeshFlags::MERGE_DUPLICATE_VERTICES | TriMeshFlags::FIX_INTERNAL_EDGES;
        let (world, p, ground) = (&mut self.world, &self.p, &mut self.ground);
        add_ground(world, p, mesh, flags, ground)
            .or_else(|_| add_ground(world, p, mesh, TriMeshFlags::empty(), ground))
    }

    pub fn params(&self) -> &PhysicsParams {
        &self.p
    }

    /// The ground the rover drives on, as the physics holds it (every
    /// ground collider's triangles, in world coordinates): what the
    /// internal simulator built, to look at.
    pub fn ground_mesh(&self) -> Mesh {
        let mut out = Mesh::default();
        for &h in &self.ground {
            let Some(c) = self.world.colliders.get(h) else {
                continue;
            };
            let Some(t) = c.shape().as_trimesh() else {
                continue;
            };
            let pose = c.position();
            let base = out.vertices.len() as u32;
            for v in t.vertices() {
                let w = pose * *v;
                out.vertices.push([w.x, w.y, w.z]);
            }
            for tri in t.indices() {
                out.triangles.push(tri.map(|i| i + base));
                out.materials.push(Material::Rock);
            }
        }
        out
    }

    /// How far under each wheel's hub (FL, FR, RL, RR) the ground lies,
    /// straight down, m; `None` where none lies within `max_m`: a wheel
    /// over an edge of the ground built so far.
    pub fn ground_under_hubs(&self, max_m: f64) -> [Option<f64>; WHEELS] {
        let down = Vector::new(0.0, 0.0, -1.0);
        self.wheels.map(|h| {
            let hub = self.world.bodies[h].translation();
            let ray = Ray::new(hub, down);
            self.ground
                .iter()
                .filter_map(|&g| self.world.colliders.get(g))
                .filter_map(|c| c.shape().cast_ray(c.position(), &ray, max_m as f32, true))
                .min_by(f32::total_cmp)
                .map(f64::from)
        })
    }

    /// Where each wheel's hub (FL, FR, RL, RR) stands after the last step.
    pub fn hubs(&self) -> [[f64; 3]; WHEELS] {
        self.wheels.map(|h| {
            let t = self.world.bodies[h].translation();
            [f64::from(t.x), f64::from(t.y), f64::from(t.z)]
        })
    }

    /// The state after the last step.
    pub fn state(&self) -> &BodyState {
        &self.state
    }

    /// Advance one physics step ending at `t_ns` with the drives aiming at
    /// `targets` (rad/s at the wheel). A drive that is not enabled gets 0 and
    /// holds its wheel (it brakes), as CiA 402 drives do in quick stop.
    pub fn step(&mut self, t_ns: u64, targets: &[f64; WHEELS]) {
        let dt = self.world.integration_parameters.dt as f64;
        if self.wrecked {
            self.state.time_ns = t_ns;
            return;
        }
        let max_dv = self.p.max_wheel_accel * dt;
        for (w, target) in targets.iter().enumerate() {
            let target = target.clamp(-self.p.max_wheel_speed, self.p.max_wheel_speed);
            let target = if target.is_finite() { target } else { 0.0 };
            self.profile[w] += (target - self.profile[w]).clamp(-max_dv, max_dv);
            // Position loop around the velocity loop; the following error is
            // bounded, as drives bound it, so a stalled wheel does not wind up.
            let angle = self.state.wheel_angle[w];
            self.profile_angle[w] = (self.profile_angle[w] + self.profile[w] * dt)
                .clamp(angle - MAX_FOLLOWING_ERROR, angle + MAX_FOLLOWING_ERROR);
            let command = self.profile[w] + POSITION_GAIN * (self.profile_angle[w] - angle);
            if let Some(j) = self.world.impulse_joints.get_mut(self.joints[w], true) {
                if let Some(r) = j.data.as_revolute_mut() {
                    r.set_motor_velocity(command as f32, motor_damping(&self.p));
                }
            }
        }
        let before = self.state;
        self.world.step();
        if !self.world.quarantine().is_empty() {
            self.quarantined += 1;
        }
        self.state = self.read_state(t_ns, Some(&before), dt);
        let hit = self.chassis_hits_world();
        if hit && !self.in_collision {
            self.collisions += 1;
        }
        self.in_collision = hit;
        self.watch_for_falls(before.velocity[2]);
    }

    /// Counts falls, and wrecks the rover at the strike that ends a high
    /// one: the first step whose sinking slows.
    fn watch_for_falls(&mut self, vz_before: f64) {
        let sink = -self.state.velocity[2];
        match self.falling {
            None if sink > FALL_SPEED_MPS => {
                self.falls += 1;
                self.falling = Some(sink);
            }
            None => {}
            Some(fastest) if sink >= -vz_before => self.falling = Some(fastest.max(sink)),
            Some(fastest) => {
                let height = fastest * fastest / (2.0 * GRAVITY);
                self.worst_fall_m = self.worst_fall_m.max(height);
                self.falling = None;
                if height >= WRECK_HEIGHT_M {
                    self.wreck();
                }
            }
        }
    }

    /// Stops the world moving the rover: the chassis and wheels become
    /// fixed where they are, at rest.
    fn wreck(&mut self) {
        self.wrecked = true;
        for h in std::iter::once(self.chassis).chain(self.wheels) {
            if let Some(b) = self.world.bodies.get_mut(h) {
                b.set_body_type(RigidBodyType::Fixed, false);
                b.set_linvel(Vector::ZERO, false);
                b.set_angvel(Vector::ZERO, false);
            }
        }
        self.state.velocity = [0.0; 3];
        self.state.angular_velocity = [0.0; 3];
        self.state.specific_force = quat::rotate_inv(&self.state.orientation, [0.0, 0.0, GRAVITY]);
        self.state.wheel_speed = [0.0; WHEELS];
    }

    /// Put parry's own narrow phase in place of [`ChassisContacts`]: the same
    /// contacts, bit for bit, without the chassis's cheap first test. The
    /// reference for benchmarks and tests; call it before the first step.
    pub fn use_parry_narrow_phase(&mut self) {
        self.world.narrow_phase = NarrowPhase::new();
    }

    /// The narrow phase's load after the last step: collider pairs whose
    /// bounding boxes meet, their manifolds (one for each pair of parts,
    /// a leg and a triangle say, whose boxes meet within the prediction
    /// distance: a contact test each) and the contact points in them.
    pub fn contact_load(&self) -> [usize; 3] {
        let mut load = [0; 3];
        for pair in self.world.narrow_phase.contact_pairs() {
            load[0] += 1;
            load[1] += pair.manifolds().len();
            load[2] += pair
                .manifolds()
                .iter()
                .map(|m| m.points.len())
                .sum::<usize>();
        }
        load
    }

    /// Whether the chassis touches the world anywhere but its underside on
    /// the ground (bottoming out on a rock is a scrape, not a collision).
    fn chassis_hits_world(&self) -> bool {
        let c = self.chassis_collider;
        self.world.narrow_phase.contact_pairs_with(c).any(|pair| {
            if !pair.has_any_active_contact() {
                return false;
            }
            pair.manifolds().iter().any(|m| {
                if m.data.num_active_contacts() == 0 {
                    return false;
                }
                // The normal points from collider1 to collider2; turn it to
                // point from the world into the chassis.
                let n = m.data.normal;
                let up = if pair.collider1 == c { -n.z } else { n.z };
                up < 0.7
            })
        })
    }

    fn read_state(&self, t_ns: u64, before: Option<&BodyState>, dt: f64) -> BodyState {
        let body = &self.world.bodies[self.chassis];
        let q = quat::normalise(&q_from(body.rotation()));
        let t = body.translation();
        let v = body.linvel();
        let velocity = [v.x as f64, v.y as f64, v.z as f64];
        let w = body.angvel();
        let w_world = [w.x as f64, w.y as f64, w.z as f64];
        // Acceleration from the velocity change over the step; gravity is
        // subtracted as an accelerometer does.
        let acc = match before {
            Some(b) => [0, 1, 2].map(|k| (velocity[k] - b.velocity[k]) / dt),
            None => [0.0; 3],
        };
        let f_world = [acc[0], acc[1], acc[2] + GRAVITY];
        let axle = quat::rotate(&q, [0.0, 1.0, 0.0]);
        let mut wheel_speed = [0.0; WHEELS];
        let mut wheel_angle = before.map_or([0.0; WHEELS], |b| b.wheel_angle);
        for (i, h) in self.wheels.iter().enumerate() {
            let ww = self.world.bodies[*h].angvel();
            let rel = [
                ww.x as f64 - w_world[0],
                ww.y as f64 - w_world[1],
                ww.z as f64 - w_world[2],
            ];
            wheel_speed[i] = rel[0] * axle[0] + rel[1] * axle[1] + rel[2] * axle[2];
            if before.is_some() {
                wheel_angle[i] += wheel_speed[i] * dt;
            }
        }
        BodyState {
            time_ns: t_ns,
            position: [t.x as f64, t.y as f64, t.z as f64],
            orientation: q,
            velocity,
            angular_velocity: quat::rotate_inv(&q, w_world),
            specific_force: quat::rotate_inv(&q, f_world),
            wheel_speed,
            wheel_angle,
            wheel_torque: self.wheel_torques(),
        }
    }

    /// The torque each wheel's motor applied over the last step, N m: the
    /// motor's impulse of the step's last substep (rapier writes it back)
    /// over that substep's length, signed as the wheel's speed (rapier's
    /// motor impulse has the other sign).
    fn wheel_torques(&self) -> [f64; WHEELS] {
        let ip = &self.world.integration_parameters;
        let substep_s = ip.dt as f64 / ip.num_solver_iterations.max(1) as f64;
        self.joints.map(|j| {
            self.world
                .impulse_joints
                .get(j)
                .and_then(|j| j.data.motor(JointAxis::AngX))
                .map_or(0.0, |m| -(m.impulse as f64) / substep_s)
        })
    }
}

/// Gain of the drives' position loop, 1/s.
const POSITION_GAIN: f64 = 20.0;
/// Largest following error the drives keep, rad.
const MAX_FOLLOWING_ERROR: f64 = 0.3;

/// Damping of the drives' velocity loop: the full torque for an error of
/// 0.2 rad/s, so the loop is stiff but the torque limit still governs.
fn motor_damping(p: &PhysicsParams) -> f32 {
    (p.motor_torque_nm / 0.2) as f32
}

/// One leg-wheel: `legs` capsules from the hub in the wheel's x-z plane
/// (the axle is y), or a round wheel when `legs` is 0.
fn wheel_collider(p: &PhysicsParams, phase: f64) -> Result<ColliderBuilder, String> {
    let r = p.wheel_radius_m;
    let lr = p.leg_radius_m;
    let builder = if p.legs_per_wheel == 0 {
        // Cylinders lie along their local y: the axle.
        ColliderBuilder::cylinder(lr as f32, r as f32)
    } else {
        let n = p.legs_per_wheel;
        let step = 2.0 * core::f64::consts::PI / n as f64;
        let shapes = (0..n)
            .map(|k| {
                let a = (k as f64 + phase) * step;
                let tip = [(r - lr) * libm::cos(a), 0.0, (r - lr) * libm::sin(a)];
                (
                    Pose::identity(),
                    SharedShape::capsule(Vector::ZERO, v3(tip), lr as f32),
                )
            })
            .collect();
        ColliderBuilder::compound(shapes)
    };
    Ok(builder
        .mass(p.wheel_mass_kg as f32)
        .friction(1.0)
        // The ground's coefficient alone decides the grip.
        .friction_combine_rule(CoefficientCombineRule::Min))
}

/// The world's triangles as fixed trimesh colliders, one per surface so each
/// has its friction.
fn add_ground(
    world: &mut PhysicsWorld,
    p: &PhysicsParams,
    mesh: &Mesh,
    flags: TriMeshFlags,
    added: &mut Vec<ColliderHandle>,
) -> Result<(), String> {
    let kinds = [
        Material::Rock,
        Material::Boulder,
        Material::Mud,
        Material::Concrete,
    ];
    for kind in kinds {
        let mut map = vec![u32::MAX; mesh.vertices.len()];
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            if mesh.materials.get(t).copied().unwrap_or_default() != kind {
                continue;
            }
            let mut out = [0u32; 3];
            for (k, &v) in tri.iter().enumerate() {
                let slot = &mut map[v as usize];
                if *slot == u32::MAX {
                    *slot = vertices.len() as u32;
                    let a = mesh.vertices[v as usize];
                    vertices.push(Vector::new(a[0], a[1], a[2]));
                }
                out[k] = *slot;
            }
            triangles.push(out);
        }
        if triangles.is_empty() {
            continue;
        }
        let collider = ColliderBuilder::trimesh_with_flags(vertices, triangles, flags)
            .map_err(|e| format!("the world mesh cannot be driven on: {e:?}"))?
            .friction(p.friction(kind) as f32)
            .friction_combine_rule(CoefficientCombineRule::Min)
            // The ground is fixed: its mass does not matter, and computing
            // it from the triangles (which rapier does for every new
            // collider in the next step) took ~3 ms on a 65k-triangle
            // internal-simulator world.
            .mass_properties(MassProperties::default());
        // No parent body: a static collider, and one body fewer for rapier
        // to take in (the internal simulator adds a thousand tiles).
        added.push(world.insert_collider(collider, None));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ground 3 m square round the origin, of right triangles with legs of
    /// `cell` m (a TSDF mesh's density), at the height `z(x, y)`.
    fn grid(cell: f64, z: impl Fn(f64, f64) -> f64) -> Mesh {
        grid_of(3.0, cell, z)
    }

    /// As [`grid`], `side` m square.
    fn grid_of(side: f64, cell: f64, z: impl Fn(f64, f64) -> f64) -> Mesh {
        let n = (side / cell).round() as u32;
        let mut m = Mesh::default();
        for i in 0..=n {
            for j in 0..=n {
                let (x, y) = (-side / 2.0 + i as f64 * cell, -side / 2.0 + j as f64 * cell);
                m.vertices.push([x as f32, y as f32, z(x, y) as f32]);
            }
        }
        for i in 0..n {
            for j in 0..n {
                let v = i * (n + 1) + j;
                let (a, b, c, d) = (v, v + 1, v + n + 1, v + n + 2);
                m.triangles.push([a, c, d]);
                m.triangles.push([a, d, b]);
                m.materials.extend([Material::Rock; 2]);
            }
        }
        m
    }

    /// The chassis's manifolds with the ground after the last step: with
    /// contact points, and without (triangles near it but clear).
    fn chassis_manifolds(r: &PhysicsRover) -> [usize; 2] {
        let mut n = [0; 2];
        for pair in r.world.narrow_phase.contact_pairs_with(r.chassis_collider) {
            for m in pair.manifolds() {
                n[usize::from(m.points.is_empty())] += 1;
            }
        }
        n
    }

    #[test]
    fn the_chassis_first_test_changes_no_contact_only_the_cost() {
        // A 15-degree slope of 5 cm triangles with a ridge 0.25 m high
        // across it. Dropped onto the ridge yawed 29 degrees, the rover
        // lands on its belly and is driven, wheels turning: the chassis
        // meets the ridge's triangles and is clear of hundreds of the
        // slope's. With parry's default dispatcher in place of
        // ChassisContacts, every step must come out the same.
        let p = PhysicsParams::default();
        let rise = 15f64.to_radians().tan();
        let ground = grid(0.05, |x, y| {
            let ridge = (x - y * 0.2).abs() < 0.12;
            x * rise + if ridge { 0.25 } else { 0.0 }
        });
        let start = [0.0, 0.0, 0.25, 0.5];
        let mut fast = PhysicsRover::new(&p, &ground, start, 0.01).expect("rover");
        let mut plain = PhysicsRover::new(&p, &ground, start, 0.01).expect("rover");
        plain.use_parry_narrow_phase();
        let (mut touching, mut clear) = (0, 0);
        for k in 0..200u64 {
            let targets = [2.0, -1.0, 2.0, -1.0];
            fast.step(k * 10_000_000, &targets);
            plain.step(k * 10_000_000, &targets);
            assert_eq!(fast.state(), plain.state(), "step {k}");
            assert_eq!(fast.contact_load(), plain.contact_load(), "step {k}");
            let [with_points, without] = chassis_manifolds(&fast);
            touching += usize::from(with_points > 0);
            clear += without;
        }
        // The scene tests what it is meant to: the chassis on the ground
        // in most steps, and many triangles near it but clear.
        assert!(touching > 100, "the chassis touched in {touching} steps");
        assert!(clear > 10_000, "{clear} clear triangles tested");
    }
}
