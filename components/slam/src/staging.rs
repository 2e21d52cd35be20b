//! Keyframe staging: the revolution that should become a keyframe, copied
//! when it arrives, then a part per unit of work moved into the base frame,
//! deskewed with the odometry's motion and offered to the graph SLAM. The
//! returns within the map range also go, evenly thinned, to the maps'
//! keyframe store.

use nalgebra::{Isometry3, Vector3};
use speleo_messages::Cloud;

use crate::deskew::deskew;
use crate::graph_slam::GraphSlam;
use crate::lie::Pose;

/// Points within this span of firing times share one deskewing pose.
const DESKEW_SLICE_S: f64 = 100e-6;

/// Returns closer than this hit the rover itself.
const MIN_RANGE_M: f32 = 0.6;

/// Where a keyframe's map points go (the maps' keyframe store).
pub trait MapSink {
    /// A keyframe's cloud begins; false when there is no room.
    fn begin(&mut self) -> bool;
    /// A point of it, base frame, m, and the intensity of its return.
    fn push(&mut self, p: [f64; 3], intensity: u8);
    /// The cloud is complete.
    fn commit(&mut self);
}

/// The odometry's pose at a time, ns: where the rover was at each firing.
pub type OdometryAt<'a> = &'a dyn Fn(u64) -> Option<Isometry3<f64>>;

pub struct Stager {
    /// LiDAR mount: base <- sensor.
    mount: Pose,
    /// Points one unit moves into the base frame and deskews.
    points_per_step: usize,
    /// The revolution taken for a keyframe: sensor-frame points and their
    /// times, copied as they came...
    raw: Vec<[f32; 3]>,
    times: Vec<f32>,
    /// Range of each staged point from the sensor.
    ranges: Vec<f32>,
    /// Intensity of each staged point's return.
    intensities: Vec<u8>,
    /// ...and, a part per unit, in the base frame at the first firing.
    points: Vec<[f64; 3]>,
    /// When and where the staged revolution began.
    staged: Option<(u64, Pose)>,
    /// Returns within this range go to the map sink (`None`: no maps),
    /// thinned to this many points...
    map_range_m: Option<f32>,
    map_points: usize,
    /// ...from this many in range in the staged revolution.
    staged_in_map_range: usize,
    /// Points of the staged revolution seen so far within the map range.
    map_seen: usize,
    /// Revolutions that could not be placed in the odometry history.
    pub scans_without_odometry: u64,
    pub points_not_deskewed: u64,
}

impl Stager {
    /// Room for revolutions of `max_cloud_points`, moved `points_per_step`
    /// a unit, seen through `mount`.
    pub fn new(mount: Pose, points_per_step: usize, max_cloud_points: usize) -> Self {
        Stager {
            mount,
            points_per_step: points_per_step.max(1),
            raw: Vec::with_capacity(max_cloud_points),
            times: Vec::with_capacity(max_cloud_points),
            ranges: Vec::with_capacity(max_cloud_points),
            intensities: Vec::with_capacity(max_cloud_points),
            points: Vec::with_capacity(max_cloud_points),
            staged: None,
            map_range_m: None,
            map_points: 0,
            staged_in_map_range: 0,
            map_seen: 0,
            scans_without_odometry: 0,
            points_not_deskewed: 0,
        }
    }

    /// Also hand each keyframe's returns within `range_m` (at most
    /// `points`, thinned evenly) to the map sink.
    pub fn with_maps(mut self, range_m: f64, points: usize) -> Self {
        self.map_range_m = Some(range_m as f32);
        self.map_points = points;
        self
    }

    /// Whether the maps get the keyframes' points.
    pub fn maps(&self) -> bool {
        self.map_range_m.is_some()
    }

    /// A revolution is staged and not yet offered.
    pub fn is_staged(&self) -> bool {
        self.staged.is_some()
    }

    /// Stage `cloud`, stamped `stamp_ns`, when it should become a keyframe:
    /// only a copy here, the work is spread over the units.
    pub fn take(
        &mut self,
        slam: &GraphSlam,
        cloud: &Cloud,
        stamp_ns: u64,
        odometry: OdometryAt,
        sink: &mut dyn MapSink,
    ) {
        if !slam.is_idle() || self.staged.is_some() {
            return;
        }
        // The cloud is stamped when the packet that completed it arrived,
        // which the sensor's clock puts `end_us - start_us` after the first
        // firing (the network's latency, a fraction of a millisecond, is
        // not known here).
        let span_ns = ((cloud.end_us - cloud.start_us).max(0.0) * 1e3) as u64;
        let t0 = stamp_ns.saturating_sub(span_ns);
        let Some(odom0) = odometry(t0) else {
            self.scans_without_odometry += 1;
            return;
        };
        let odom0 = Pose::from_isometry(&odom0);
        if !slam.wants_keyframe(&odom0) {
            return;
        }
        self.raw.clear();
        self.times.clear();
        self.ranges.clear();
        self.intensities.clear();
        self.points.clear();
        let slam_range = slam.params().max_range_m as f32;
        let range = self.map_range_m.map_or(slam_range, |m| m.max(slam_range));
        self.staged_in_map_range = 0;
        self.map_seen = 0;
        for p in &cloud.points {
            if p.distance < MIN_RANGE_M
                || p.distance > range
                || self.raw.len() == self.raw.capacity()
            {
                continue;
            }
            if self.map_range_m.is_some_and(|m| p.distance <= m) {
                self.staged_in_map_range += 1;
            }
            self.raw.push([p.x, p.y, p.z]);
            self.times.push(p.time);
            self.ranges.push(p.distance);
            self.intensities.push(p.intensity);
        }
        if self.map_range_m.is_some() {
            sink.begin();
        }
        self.staged = Some((t0, odom0));
    }

    /// Move the next part of the staged revolution into the base frame and
    /// deskew it; when all of it is done, offer it to `slam` as a keyframe.
    pub fn deskew_part(
        &mut self,
        slam: &mut GraphSlam,
        odometry: OdometryAt,
        sink: &mut dyn MapSink,
    ) {
        let Some((t0, odom0)) = self.staged else {
            return;
        };
        let from = self.points.len();
        let to = (from + self.points_per_step).min(self.raw.len());
        for r in &self.raw[from..to] {
            let v = self
                .mount
                .transform(&Vector3::new(r[0] as f64, r[1] as f64, r[2] as f64));
            self.points.push([v.x, v.y, v.z]);
        }
        let graph = &*slam;
        // The odometry's motion since the first firing, at the distance
        // scale the registrations have measured.
        self.points_not_deskewed += deskew(
            &mut self.points[from..to],
            &self.times[from..to],
            DESKEW_SLICE_S,
            |dt| {
                odometry(t0 + (dt * 1e9) as u64).map(|iso: Isometry3<f64>| {
                    odom0.compose(&graph.scale_odometry(&odom0.between(&Pose::from_isometry(&iso))))
                })
            },
        ) as u64;
        if let Some(m) = self.map_range_m {
            // Even thinning: the j-th point in range is kept when it moves
            // floor(j * kept / in_range) on.
            let (n, keep) = (self.staged_in_map_range, self.map_points);
            let returns = self.ranges[from..to]
                .iter()
                .zip(&self.intensities[from..to]);
            for (p, (&r, &i)) in self.points[from..to].iter().zip(returns) {
                if r > m {
                    continue;
                }
                let j = self.map_seen;
                self.map_seen += 1;
                if n <= keep || (j + 1) * keep / n > j * keep / n {
                    sink.push(*p, i);
                }
            }
        }
        if to < self.raw.len() {
            return;
        }
        self.staged = None;
        // Gravity in the base frame at the revolution's first firing. The
        // MTi's last sample is up to a revolution late, and a legged rover
        // rocks by degrees within that time; the odometry's attitude is the
        // MTi's roll and pitch carried to any instant by the gyro.
        let up = odom0.r.transpose() * Vector3::z();
        let slam_range = slam.params().max_range_m as f32;
        let (points, ranges) = (&self.points, &self.ranges);
        let scan = points
            .iter()
            .zip(ranges)
            .filter(move |(_, &r)| r <= slam_range)
            .map(|(p, _)| *p);
        let taken = slam.offer_scan(t0, odom0, up, scan);
        if taken && self.map_range_m.is_some() {
            sink.commit();
        }
    }
}
