//! Twin of the Velodyne HDL-32E.
//!
//! Firing sequences every 46.08 us while the head turns at `rate_hz`: each
//! of the 32 lasers (calibrated elevations, fired 1.152 us apart) casts a
//! ray against the world mesh from the sensor pose at its own firing time,
//! so motion distortion is real. Returns get Gaussian range noise, random
//! dropouts and a maximum range; intensity follows the surface and the
//! incidence angle. Firings go through the driver's packet encoder, so the
//! bytes are exactly what the real sensor sends.

use std::sync::Arc;
use std::time::Duration;

use glam::Vec3A;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::RayHit;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use parry3d::math::Vec3;
use parry3d::query::Ray;
use parry3d::shape::{CompositeShapeRef, TriMesh};

use crate::noise::Noise;
use crate::ray_caster::{Aim, Head, RayCaster};
use speleo_hal::hdl32e::encode::{Firing, PacketEncoder};
use speleo_hal::hdl32e::position::{PositionPacket, POSITION_PERIOD_NS};
use speleo_hal::hdl32e::{
    Calibration, BLOCK_PERIOD_NS, LASERS, LASER_PERIOD_NS, PACKET_LEN, POSITION_PACKET_LEN,
};
use speleo_hal::outbox::Outbox;
use speleo_physics::quat::{self, Quat};
use speleo_physics::terrain::{Material, Mesh};

#[derive(Clone, Debug, PartialEq)]
pub struct LidarParams {
    /// Rotation rate, 5 to 20 Hz.
    pub rate_hz: f64,
    /// Standard deviation of the range noise (HDL-32E: < 2 cm).
    pub range_noise_m: f64,
    pub max_range_m: f64,
    /// Probability that a return is missing.
    pub dropout: f64,
    /// Time from the packet's last firing to its arrival.
    pub latency_ns: u64,
    /// Threads that cast the rays: with 2, a helper thread casts half of
    /// each batch (the same bytes come out either way).
    pub cast_threads: usize,
}

impl Default for LidarParams {
    fn default() -> Self {
        LidarParams {
            rate_hz: 10.0,
            range_noise_m: 0.02,
            max_range_m: 70.0,
            dropout: 0.01,
            latency_ns: 100_000,
            cast_threads: 2,
        }
    }
}

/// The world as the LiDAR sees it: triangles with their materials.
pub struct LidarWorld {
    /// For distances to the surface, and the reference for `bvh`'s rays.
    mesh: TriMesh,
    /// What the rays are cast against: an eight-way compressed BVH
    /// (obvhs), which walks the rays from inside a cave ~1.4x faster than
    /// parry's BVH of the same mesh (`cargo bench -p speleo-twin --bench
    /// lidar_twin`), and the triangles in its leaf order.
    bvh: CwBvh,
    leaf_triangles: Vec<Triangle>,
    materials: Vec<Material>,
    /// Unit normal of each triangle (for the incidence angle).
    normals: Vec<[f32; 3]>,
}

impl LidarWorld {
    pub fn new(m: &Mesh) -> Result<Self, String> {
        let vertices = m
            .vertices
            .iter()
            .map(|v| Vec3::new(v[0], v[1], v[2]))
            .collect();
        let mesh = TriMesh::new(vertices, m.triangles.clone())
            .map_err(|e| format!("the world mesh cannot be used for rays: {e:?}"))?;
        let normals = (0..m.triangles.len())
            .map(|t| m.triangle_geometry(t).1.map(|x| x as f32))
            .collect();
        let corner = |i: u32| {
            let p = m.vertices[i as usize];
            Vec3A::new(p[0], p[1], p[2])
        };
        let triangles: Vec<Triangle> = m
            .triangles
            .iter()
            .map(|t| Triangle {
                v0: corner(t[0]),
                v1: corner(t[1]),
                v2: corner(t[2]),
            })
            .collect();
        let bvh = build_cwbvh_from_tris(
            &triangles,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let leaf_triangles = bvh
            .primitive_indices
            .iter()
            .map(|&i| triangles[i as usize])
            .collect();
        Ok(LidarWorld {
            mesh,
            bvh,
            leaf_triangles,
            materials: m.materials.clone(),
            normals,
        })
    }

    /// Distance from `p` to the nearest surface (for checking clouds against
    /// the ground truth).
    pub fn distance_to_surface(&self, p: [f64; 3]) -> f64 {
        use parry3d::query::PointQuery;
        let q = Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32);
        let proj = self.mesh.project_local_point(q, false);
        (proj.point - q).length() as f64
    }

    /// Distance along the unit direction `dir` to the first surface within
    /// `max`, with the cosine of the incidence angle and the surface.
    pub fn cast(&self, origin: [f64; 3], dir: [f64; 3], max: f64) -> Option<(f64, f64, Material)> {
        let (toi, t) = self.hit(origin, dir, max)?;
        let cos = self.facing(t, dir).abs();
        let surface = self.materials.get(t).copied().unwrap_or_default();
        Some((toi, cos, surface))
    }

    /// Distance to the first surface along `dir` within `max`, and the
    /// cosine between that face's normal and `dir`: positive when the ray
    /// meets the back of the face (it started inside a solid).
    pub fn cast_signed(&self, origin: [f64; 3], dir: [f64; 3], max: f64) -> Option<(f64, f64)> {
        let (toi, t) = self.hit(origin, dir, max)?;
        Some((toi, self.facing(t, dir)))
    }

    fn hit(&self, origin: [f64; 3], dir: [f64; 3], max: f64) -> Option<(f64, usize)> {
        let ray = obvhs::ray::Ray::new(
            Vec3A::new(origin[0] as f32, origin[1] as f32, origin[2] as f32),
            Vec3A::new(dir[0] as f32, dir[1] as f32, dir[2] as f32),
            0.0,
            max as f32,
        );
        let mut hit = RayHit::none();
        let found = self.bvh.ray_traverse(ray, &mut hit, |r, leaf| {
            self.leaf_triangles
                .get(leaf)
                .map_or(f32::INFINITY, |t| t.intersect(r))
        });
        let index = *self.bvh.primitive_indices.get(hit.primitive_id as usize)?;
        found.then_some((hit.t as f64, index as usize % self.normals.len().max(1)))
    }

    /// The same query through parry's BVH of the mesh: distance and
    /// triangle. The reference `cast` is tested and benchmarked against.
    pub fn cast_parry(&self, origin: [f64; 3], dir: [f64; 3], max: f64) -> Option<(f64, usize)> {
        let ray = Ray::new(
            Vec3::new(origin[0] as f32, origin[1] as f32, origin[2] as f32),
            Vec3::new(dir[0] as f32, dir[1] as f32, dir[2] as f32),
        );
        let (tri, toi) = CompositeShapeRef(&self.mesh).cast_local_ray(&ray, max as f32, false)?;
        Some((toi as f64, tri as usize))
    }

    /// What `cast` finds: distance and triangle (for comparing with
    /// `cast_parry`).
    pub fn cast_hit(&self, origin: [f64; 3], dir: [f64; 3], max: f64) -> Option<(f64, usize)> {
        self.hit(origin, dir, max)
    }

    fn facing(&self, t: usize, dir: [f64; 3]) -> f64 {
        let n = self.normals.get(t).copied().unwrap_or([0.0, 0.0, 1.0]);
        n[0] as f64 * dir[0] + n[1] as f64 * dir[1] + n[2] as f64 * dir[2]
    }
}

/// Sensor pose in the world: position and orientation (sensor to world).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorPose {
    pub p: [f64; 3],
    pub q: Quat,
}

impl Default for SensorPose {
    fn default() -> Self {
        SensorPose {
            p: [0.0; 3],
            q: quat::IDENTITY,
        }
    }
}

impl SensorPose {
    /// From a position and yaw, pitch, roll (Z-Y-X).
    pub fn from_ypr(p: [f64; 3], yaw: f64, pitch: f64, roll: f64) -> Self {
        SensorPose {
            p,
            q: quat::from_ypr(yaw, pitch, roll),
        }
    }

    fn lerp(&self, o: &SensorPose, t: f64) -> SensorPose {
        let l = |a: f64, b: f64| a + (b - a) * t;
        SensorPose {
            p: [
                l(self.p[0], o.p[0]),
                l(self.p[1], o.p[1]),
                l(self.p[2], o.p[2]),
            ],
            q: quat::nlerp(&self.q, &o.q, t),
        }
    }

    fn matrix(&self) -> [[f64; 3]; 3] {
        quat::matrix(&self.q)
    }

    /// Rotate a sensor-frame vector into the world.
    pub fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        quat::mat_mul(&self.matrix(), v)
    }
}

fn intensity(s: Material, cos: f64) -> u8 {
    let albedo = match s {
        Material::Rock => 60.0,
        Material::Mud => 25.0,
        Material::Boulder => 90.0,
        Material::Concrete => 110.0,
    };
    (albedo * (0.2 + 0.8 * cos)).round().clamp(1.0, 255.0) as u8
}

/// Firings queued before their rays are cast (a 10 ms frame has 217).
const QUEUED_FIRINGS: usize = 256;

/// A firing whose rays wait in the queue: when, at which azimuth, and
/// each live laser's range noise (standard normal); which lasers fire is
/// in the firing's `Aim`.
#[derive(Clone, Copy, Debug)]
struct QueuedFiring {
    t_ns: u64,
    azimuth: u16,
    noise: [f32; LASERS],
}

pub struct LidarTwin {
    p: LidarParams,
    encoder: PacketEncoder,
    caster: RayCaster,
    /// Firings and where their lasers point, in order, until `flush`.
    firings: Vec<QueuedFiring>,
    aims: Vec<Aim>,
    noise: Noise,
    next_firing_ns: u64,
    /// Azimuth of the next firing, hundredths of a degree (continuous).
    azimuth: f64,
    /// Azimuth advance per firing, hundredths.
    step: f64,
    outbox: Outbox<32, PACKET_LEN>,
    /// Position packets: the sensor's clock, no GPS sentence (none reaches
    /// a cave).
    positions: Outbox<8, POSITION_PACKET_LEN>,
    next_position_ns: u64,
    /// The queued rays are being cast (`launch` without `finish`).
    launched: bool,
    /// Returns beyond the 16-bit distance field.
    pub out_of_range: u64,
}

impl LidarTwin {
    pub fn new(p: LidarParams, cal: Calibration, world: Arc<LidarWorld>, seed: u64) -> Self {
        let elevation = core::array::from_fn(|l| {
            let e = cal.lasers[l].vert_deg.to_radians();
            (libm::cos(e), libm::sin(e))
        });
        let step = p.rate_hz.clamp(5.0, 20.0) * 36000.0 * BLOCK_PERIOD_NS * 1e-9;
        let offset = core::array::from_fn(|l| {
            let d = step
                * (l as f64 * LASER_PERIOD_NS / BLOCK_PERIOD_NS)
                * (core::f64::consts::PI / 18000.0);
            (libm::sin(d), libm::cos(d))
        });
        let head = Head { elevation, offset };
        LidarTwin {
            caster: RayCaster::new(world, head, QUEUED_FIRINGS, p.cast_threads),
            p,
            firings: Vec::with_capacity(QUEUED_FIRINGS),
            aims: Vec::with_capacity(QUEUED_FIRINGS),
            encoder: PacketEncoder::new(cal),
            noise: Noise::new(seed, 0x1_1DA2),
            next_firing_ns: 0,
            azimuth: 0.0,
            step,
            outbox: Outbox::new(),
            positions: Outbox::new(),
            next_position_ns: 0,
            launched: false,
            out_of_range: 0,
        }
    }

    pub(crate) fn outbox(&mut self) -> &mut Outbox<32, PACKET_LEN> {
        // Packets still being cast belong in it first.
        self.finish();
        &mut self.outbox
    }

    pub(crate) fn positions(&mut self) -> &mut Outbox<8, POSITION_PACKET_LEN> {
        &mut self.positions
    }

    pub fn dropped(&self) -> u64 {
        self.outbox.dropped() + self.positions.dropped()
    }

    /// Take the oldest queued packet, whatever its arrival time (benchmarks
    /// and tests that only count). Returns false when none is queued.
    pub fn outbox_len_pop(&mut self) -> bool {
        self.outbox.pop_due(u64::MAX).is_some()
    }

    /// Fire every sequence due in [t0, t1) while the sensor moves from
    /// `pose0` to `pose1`; their packets are queued on return.
    pub fn advance(&mut self, t0: u64, t1: u64, pose0: &SensorPose, pose1: &SensorPose) {
        self.queue(t0, t1, pose0, pose1);
        self.flush();
    }

    /// Aim every firing due in [t0, t1) while the sensor moves from `pose0`
    /// to `pose1`. Each full chunk of firings goes to the helper thread at
    /// once; `flush` casts the rest and queues the packets (once a frame).
    pub fn queue(&mut self, t0: u64, t1: u64, pose0: &SensorPose, pose1: &SensorPose) {
        // The launched rays are still being cast: their packets come first.
        self.finish();
        self.aim_firings(t0, t1, pose0, pose1);
        self.queue_positions(t1);
        // The helper starts on each full chunk while the physics steps on.
        self.caster.publish(&self.aims, self.p.max_range_m, false);
    }

    fn aim_firings(&mut self, t0: u64, t1: u64, pose0: &SensorPose, pose1: &SensorPose) {
        let span = (t1 - t0).max(1) as f64;
        while self.next_firing_ns < t1 {
            if self.firings.len() == QUEUED_FIRINGS {
                self.flush();
            }
            let t = self.next_firing_ns.max(t0);
            let mut firing = QueuedFiring {
                t_ns: t,
                azimuth: (self.azimuth.round() as u32 % 36000) as u16,
                noise: [0.0; LASERS],
            };
            // The head turns 36 us across a firing: one orientation per
            // firing (under 3 mm at 70 m at 1 rad/s), the position per laser.
            let fa = (t - t0) as f64 / span;
            let fb = ((t - t0) as f64 + LASERS as f64 * LASER_PERIOD_NS) / span;
            let mid = pose0.lerp(pose1, 0.5 * (fa + fb));
            let r = mid.matrix();
            let (pa, pb) = (pose0.lerp(pose1, fa).p, pose0.lerp(pose1, fb).p);
            let az0 = self.azimuth * (core::f64::consts::PI / 18000.0);
            let mut live = 0;
            for l in 0..LASERS {
                if self.noise.uniform() < self.p.dropout {
                    continue;
                }
                live |= 1 << l;
                firing.noise[l] = self.noise.gaussian() as f32;
            }
            // The caster aims each live laser from these.
            self.aims.push(Aim {
                live,
                start: pa,
                end: pb,
                rotation: r,
                azimuth: (libm::sin(az0), libm::cos(az0)),
            });
            self.firings.push(firing);
            self.azimuth = (self.azimuth + self.step) % 36000.0;
            self.next_firing_ns += BLOCK_PERIOD_NS as u64;
        }
    }

    /// Queue the position packets due before `t1`.
    fn queue_positions(&mut self, t1: u64) {
        while self.next_position_ns < t1 {
            let t = self.next_position_ns;
            let packet = PositionPacket {
                timestamp_us: ((t / 1000) % 3_600_000_000) as u32,
                nmea: heapless::String::new(),
            };
            self.positions
                .push(t + self.p.latency_ns, &packet.to_bytes());
            self.next_position_ns += POSITION_PERIOD_NS;
        }
    }

    /// Cast the queued firings' rays and queue their packets.
    pub fn flush(&mut self) {
        self.launch();
        self.finish();
    }

    /// Start casting the rest of the queued firings' rays on the helper
    /// thread; the caller is free until `finish`. Firings queued after
    /// this wait for the next launch.
    pub fn launch(&mut self) {
        self.caster.publish(&self.aims, self.p.max_range_m, true);
        self.launched = true;
    }

    /// Finish casting the launched rays and queue their packets.
    pub fn finish(&mut self) {
        if !self.launched {
            return;
        }
        self.launched = false;
        let LidarTwin {
            p,
            encoder,
            caster,
            firings,
            outbox,
            ..
        } = self;
        caster.collect(|k, returns| {
            let Some(q) = firings.get(k) else {
                return;
            };
            let mut firing = Firing {
                azimuth: q.azimuth,
                distance_m: [0.0; LASERS],
                intensity: [0; LASERS],
            };
            for (l, hit) in returns.iter().enumerate() {
                if let Some((d, cos, s)) = *hit {
                    let noisy = d + q.noise[l] as f64 * p.range_noise_m;
                    if noisy > 0.0 {
                        firing.distance_m[l] = noisy as f32;
                        firing.intensity[l] = intensity(s, cos);
                    }
                }
            }
            // Microseconds past the hour of this firing.
            let stamp = ((q.t_ns / 1000) % 3_600_000_000) as u32;
            if let Some(packet) = encoder.push(&firing, stamp) {
                outbox.push(q.t_ns + BLOCK_PERIOD_NS as u64 + p.latency_ns, &packet);
            }
        });
        self.out_of_range = self.encoder.out_of_range;
        self.firings.clear();
        self.aims.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::World;
    use speleo_hal::hdl32e::{DataPacket, Decoder, FrameAssembler};

    fn revolution(world: &World, pose: SensorPose) -> Vec<speleo_hal::hdl32e::Point> {
        let lw = Arc::new(LidarWorld::new(&world.mesh).expect("mesh"));
        let mut l = LidarTwin::new(LidarParams::default(), Calibration::nominal(), lw, 3);
        let mut asm = FrameAssembler::new(Decoder::new(&Calibration::nominal()), 0.0, 200_000);
        let mut frames = Vec::new();
        for k in 0..250u64 {
            l.advance(k * 1_000_000, (k + 1) * 1_000_000, &pose, &pose);
            while let Some((_, b)) = l.outbox().pop_due(u64::MAX) {
                let p = DataPacket::parse(&b).expect("valid packet");
                asm.push(&p, |f| frames.push(f.points.to_vec()));
            }
        }
        // The second complete revolution (the first started mid-turn).
        frames.into_iter().nth(1).expect("two revolutions")
    }

    #[test]
    fn a_decoded_revolution_lies_on_the_flat_ground() {
        let w = World::build("flat", 0).expect("flat");
        let pose = SensorPose::from_ypr([0.0, 0.0, 0.7], 0.0, 0.0, 0.0);
        let pts = revolution(&w, pose);
        // The 16 lasers below -2.5 deg hit the ground inside 70 m.
        assert!(pts.len() > 15_000, "{}", pts.len());
        let mut sum2 = 0.0;
        for p in &pts {
            // Ground at z = 0: the sensor is 0.7 m above it.
            let dz = p.z as f64 + 0.7;
            sum2 += dz * dz;
            // Within 5 sigma of the range noise, projected on z.
            assert!(dz.abs() < 0.1 + 5.0 * 0.02, "{p:?}");
        }
        let rms = (sum2 / pts.len() as f64).sqrt();
        assert!(rms < 0.02, "rms {rms}");
    }

    #[test]
    fn inside_the_lava_tube_every_point_is_on_the_mesh() {
        let w = World::build("lava-tube", 1).expect("tube");
        let lw = LidarWorld::new(&w.mesh).expect("mesh");
        let pose = SensorPose::from_ypr(
            [w.start[0], w.start[1], w.start[2] + 0.7],
            w.start[3],
            0.0,
            0.0,
        );
        let pts = revolution(&w, pose);
        assert!(pts.len() > 60_000, "{}", pts.len());
        // Re-cast each point's ray: the decoded range agrees with the true one.
        let mut worst = 0.0f64;
        let mut sum2 = 0.0;
        for p in pts.iter().step_by(37) {
            let d = (p.x as f64).hypot(p.y as f64).hypot(p.z as f64);
            let dir = pose.rotate([p.x as f64 / d, p.y as f64 / d, p.z as f64 / d]);
            let (truth, _, _) = lw.cast(pose.p, dir, 100.0).expect("the tube is closed");
            let e = d - truth;
            worst = worst.max(e.abs());
            sum2 += e * e;
        }
        let rms = (sum2 / (pts.len() / 37) as f64).sqrt();
        assert!(rms < 0.03, "rms {rms}");
        assert!(worst < 0.2, "worst {worst}");
    }

    /// Rays from points of the world's route (0.2 to 1.5 m above it) in
    /// seeded directions: the CWBVH and parry's BVH find the same surface.
    fn bvh_agrees_with_parry(name: &str) {
        let w = World::build(name, 1).expect("world");
        let lw = LidarWorld::new(&w.mesh).expect("mesh");
        let mut noise = Noise::new(5, 9);
        let (mut rays, mut hits, mut disagree) = (0, 0, 0);
        // Worlds without a route: a 20 m square round the start.
        let square: Vec<[f64; 3]> = (0..100)
            .map(|i| {
                let (x, y) = ((i % 10) as f64 * 2.0 - 10.0, (i / 10) as f64 * 2.0 - 10.0);
                [w.start[0] + x, w.start[1] + y, w.start[2]]
            })
            .collect();
        let origins = if w.route.is_empty() {
            &square
        } else {
            &w.route
        };
        for p in origins.iter().step_by((origins.len() / 200).max(1)) {
            for _ in 0..200 {
                let v = [noise.gaussian(), noise.gaussian(), noise.gaussian()];
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                let d = [v[0] / n, v[1] / n, v[2] / n];
                let o = [p[0], p[1], p[2] + 0.2 + 1.3 * noise.uniform()];
                let ours = lw.cast_hit(o, d, 70.0);
                let parry = lw.cast_parry(o, d, 70.0);
                rays += 1;
                hits += parry.is_some() as usize;
                let same = match (ours, parry) {
                    (Some(g), Some(b)) => (g.0 - b.0).abs() < 1e-3,
                    (None, None) => true,
                    _ => false,
                };
                if !same {
                    disagree += 1;
                    eprintln!("{name}: from {o:?} along {d:?}: ours {ours:?}, parry {parry:?}");
                }
            }
        }
        eprintln!("{name}: {rays} rays, {hits} hits, {disagree} disagree");
        assert!(hits > rays / 10, "{hits} of {rays}");
        assert!(disagree * 10_000 <= rays, "{disagree} of {rays} disagree");
    }

    #[test]
    fn the_bvh_finds_what_parry_finds_in_the_lava_tube() {
        bvh_agrees_with_parry("lava-tube");
    }

    #[test]
    fn the_bvh_finds_what_parry_finds_in_the_garage() {
        bvh_agrees_with_parry("garage");
    }

    #[test]
    fn the_bvh_finds_what_parry_finds_among_the_boulders() {
        bvh_agrees_with_parry("boulders");
    }

    /// The packets do not depend on how the firings are batched for casting
    /// nor on the threads that cast them.
    #[test]
    fn batching_and_threads_leave_the_packets_as_they_were() {
        let w = World::build("lava-tube", 1).expect("tube");
        let lw = Arc::new(LidarWorld::new(&w.mesh).expect("mesh"));
        let pose = |k: u64| {
            let t = k as f64 * 1e-3;
            SensorPose::from_ypr(
                [w.start[0] + 0.4 * t, w.start[1], w.start[2] + 0.7],
                w.start[3] + 0.2 * t,
                0.0,
                0.0,
            )
        };
        let run = |threads: usize, flush_every: u64| {
            let p = LidarParams {
                cast_threads: threads,
                ..LidarParams::default()
            };
            let mut l = LidarTwin::new(p, Calibration::nominal(), lw.clone(), 4);
            let mut packets = Vec::new();
            for k in 0..300u64 {
                l.queue(k * 1_000_000, (k + 1) * 1_000_000, &pose(k), &pose(k + 1));
                if (k + 1) % flush_every == 0 {
                    l.flush();
                    while let Some((t, b)) = l.outbox().pop_due(u64::MAX) {
                        packets.push((t, b.to_vec()));
                    }
                }
            }
            packets
        };
        let reference = run(1, 1);
        assert!(reference.len() > 500, "{}", reference.len());
        assert_eq!(run(1, 10), reference);
        assert_eq!(run(2, 10), reference);
        assert_eq!(run(2, 1), reference);
    }
}
