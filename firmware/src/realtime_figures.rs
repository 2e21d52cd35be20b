//! Timing of a run in real time (`speleo run`): how late frames started,
//! and how long inputs took to reach the outputs made from them. Measured
//! between frames on the executive's thread, into fixed histograms.

use serde::Serialize;
use speleo_scheduler::histogram::Histogram;

use crate::bus::Bus;

/// p50, p99 and the maximum of a set of durations, in microseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Spread {
    pub count: u64,
    pub p50_us: f64,
    pub p99_us: f64,
    pub max_us: f64,
}

impl Spread {
    pub fn of(h: &Histogram) -> Spread {
        let us = |ns: u64| ns as f64 * 1e-3;
        Spread {
            count: h.count(),
            p50_us: us(h.quantile_ns(0.5)),
            p99_us: us(h.quantile_ns(0.99)),
            max_us: us(h.max_ns()),
        }
    }
}

/// The report's `realtime` section.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RealtimeFigures {
    /// How late each frame started after its scheduled time.
    pub frame_start_lateness: Spread,
    /// From the arrival of the LiDAR packet that completed a revolution to
    /// the end of the frame that computed the first wheel command after
    /// SLAM had used that revolution.
    pub lidar_to_wheel_command: Spread,
    /// From the arrival of an IMU sample to the end of the frame whose
    /// odometry used it (the newest sample of each odometry step).
    pub imu_to_odometry: Spread,
    /// What real-time setup was granted: SCHED_FIFO and its priority, and
    /// whether memory is locked; each with the reason when refused.
    pub sched_fifo: String,
    pub mlockall: String,
}

/// Follows inputs to the outputs made from them, frame by frame.
#[derive(Clone, Debug, Default)]
pub struct LatencyProbe {
    slam_seq: u64,
    cloud_used_seq: u64,
    command_seq: u64,
    odom_seq: u64,
    newest_imu_used_ns: u64,
    /// Arrival of the revolution SLAM used, until a wheel command follows.
    pending_scan_ns: Option<u64>,
    lidar_to_command: Histogram,
    imu_to_odometry: Histogram,
}

impl LatencyProbe {
    pub fn new() -> Self {
        Self::default()
    }

    /// After a frame: `now_ns` in the receive times' base.
    pub fn observe(&mut self, bus: &Bus, now_ns: u64) {
        if let Some(s) = bus.slam.newer_than(self.slam_seq) {
            self.slam_seq = s.seq;
            // SLAM takes the newest revolution when it runs.
            if let Some(c) = bus.cloud.newer_than(self.cloud_used_seq) {
                self.cloud_used_seq = c.seq;
                self.pending_scan_ns = Some(c.stamp_ns);
            }
        }
        if let Some(c) = bus.command.newer_than(self.command_seq) {
            self.command_seq = c.seq;
            if let Some(t) = self.pending_scan_ns.take() {
                self.lidar_to_command.record(now_ns.saturating_sub(t));
            }
        }
        if let Some(o) = bus.odom.newer_than(self.odom_seq) {
            self.odom_seq = o.seq;
            if let Some(i) = bus.imu.latest() {
                if i.stamp_ns > self.newest_imu_used_ns {
                    self.newest_imu_used_ns = i.stamp_ns;
                    self.imu_to_odometry
                        .record(now_ns.saturating_sub(i.stamp_ns));
                }
            }
        }
    }

    /// The figures, with the frames' start lateness.
    pub fn figures(&self, lateness: Option<&Histogram>) -> RealtimeFigures {
        RealtimeFigures {
            frame_start_lateness: lateness.map(Spread::of).unwrap_or_default(),
            lidar_to_wheel_command: Spread::of(&self.lidar_to_command),
            imu_to_odometry: Spread::of(&self.imu_to_odometry),
            sched_fifo: String::new(),
            mlockall: String::new(),
        }
    }
}
