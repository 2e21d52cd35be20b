//! Decodes HDL-32E data packets into revolutions and position packets into
//! the sensor's GPS time; bad packets are counted by kind, never fatal.

use speleo_hal::hdl32e::calib::CalibError;
use speleo_hal::hdl32e::position::PositionPacket;
use speleo_hal::hdl32e::{DataPacket, Decoder, FrameAssembler, Interpolation, PacketError, Point};
use speleo_hal::Device;
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;
use crate::config::Config;
use crate::params;
use speleo_messages::Cloud;

pub struct LidarDriver {
    assembler: FrameAssembler,
    /// Point buffers not currently in the mailbox (three in all).
    free: heapless::Vec<Vec<Point>, 3>,
    /// Arrival of the last packet the assembler took in.
    last_taken_ns: u64,
}

impl LidarDriver {
    /// `capacity`: most points per revolution; three buffers of that size
    /// are allocated now.
    pub fn new(assembler: FrameAssembler, capacity: usize) -> Self {
        let mut free = heapless::Vec::new();
        for _ in 0..3 {
            // Touch every page now, so the first revolutions do not pay for
            // page faults inside the frame.
            let mut v = vec![Point::default(); capacity];
            v.clear();
            let _ = free.push(v);
        }
        LidarDriver {
            assembler,
            free,
            last_taken_ns: 0,
        }
    }

    /// The driver `[lidar]` describes: its calibration (nominal when none
    /// is given), interpolation, cut angle, nearest range and capacity.
    pub fn from_config(cfg: &Config) -> Result<Self, CalibError> {
        let l = &cfg.lidar;
        let cal = params::lidar_calibration(cfg)?;
        let mode = match l.interpolation.as_str() {
            "veloview" => Interpolation::VeloView,
            "velodyne-decoder" => Interpolation::FixedPairs,
            _ => Interpolation::Continuous,
        };
        let mut decoder = Decoder::new(&cal).with_interpolation(mode);
        decoder.min_distance_m = l.min_range_m;
        let cap = l.max_points_per_frame as usize;
        Ok(LidarDriver::new(
            FrameAssembler::new(decoder, l.cut_angle_deg, cap),
            cap,
        ))
    }
}

impl Task<Bus> for LidarDriver {
    fn run(&mut self, bus: &mut Bus, _cx: &Context) {
        let c = &mut bus.lidar;
        let cloud = &mut bus.cloud;
        let free = &mut self.free;
        for (entry, bytes) in bus.raw.of(Device::Lidar) {
            c.packets += 1;
            let p = match DataPacket::parse(bytes) {
                Ok(p) => p,
                Err(PacketError::WrongLength(_)) => {
                    c.bad_length += 1;
                    continue;
                }
                Err(PacketError::BadFlag { .. }) => {
                    c.bad_flag += 1;
                    continue;
                }
                Err(PacketError::BadAzimuth { .. }) => {
                    c.bad_azimuth += 1;
                    continue;
                }
                Err(PacketError::BadTimestamp(_)) => {
                    c.bad_timestamp += 1;
                    continue;
                }
            };
            let t = entry.receive_time_ns;
            let taken_before = self.assembler.counters.packets;
            let last_taken = self.last_taken_ns;
            self.assembler.push(&p, |f| {
                // A frame flushed by a gap or a resync ended with the packet
                // taken in before this one: stamped with this one's arrival,
                // it would be dated late by the gap.
                let stamp = if f.flushed { last_taken } else { t };
                let Some(mut points) = free.pop() else {
                    c.dropped_frames += 1;
                    return;
                };
                points.clear();
                let n = f.points.len().min(points.capacity());
                points.extend_from_slice(&f.points[..n]);
                let evicted = cloud.publish_recycle(
                    stamp,
                    Cloud {
                        index: f.index,
                        start_us: f.start_us,
                        end_us: f.end_us,
                        points,
                        whole: f.whole,
                    },
                );
                if let Some(old) = evicted {
                    let _ = free.push(old.points);
                }
            });
            if self.assembler.counters.packets > taken_before {
                self.last_taken_ns = t;
            }
        }
        for (_, bytes) in bus.raw.of(Device::LidarPosition) {
            match PositionPacket::parse(bytes) {
                Ok(p) => {
                    c.position_packets += 1;
                    c.position_time_us = p.timestamp_us;
                }
                Err(_) => c.bad_position_packets += 1,
            }
        }
        let a = self.assembler.counters;
        c.lost_packets = a.lost_packets;
        c.out_of_order = a.out_of_order;
        c.resyncs = a.resyncs;
        c.gaps = a.gaps;
        c.dropped_points = a.dropped_points;
        c.frames = a.frames;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_hal::hdl32e::encode::{Firing, PacketEncoder};
    use speleo_hal::hdl32e::{Calibration, Decoder};
    use speleo_hal::InputSink;

    use crate::tasks::test_context as cx;

    #[test]
    fn a_revolution_cut_short_by_a_gap_is_dated_by_its_own_last_packet() {
        let mut bus = Bus::new();
        let cal = Calibration::nominal();
        let mut driver =
            LidarDriver::new(FrameAssembler::new(Decoder::new(&cal), 0.0, 10_000), 10_000);
        let mut enc = PacketEncoder::new(cal);
        // 0.2 deg a block: 60 packets are 40 % of a revolution. Then the
        // sensor falls silent for a second.
        let period_ns = 552_960u64;
        let mut sent = Vec::new();
        let mut k = 0u32;
        while sent.len() < 61 {
            let n = sent.len() as u64;
            let gap = if n == 60 { 1_000_000_000 } else { 0 };
            let t_ns = 1_000_000_000 + n * period_ns + gap;
            let mut f = Firing {
                azimuth: ((20 * k) % 36000) as u16,
                distance_m: [0.0; speleo_hal::hdl32e::LASERS],
                intensity: [0; speleo_hal::hdl32e::LASERS],
            };
            f.distance_m[0] = 5.0;
            if let Some(b) = enc.push(&f, (t_ns / 1000) as u32) {
                // Received 0.2 ms after the last firing.
                bus.raw.input(Device::Lidar, t_ns + period_ns + 200_000, &b);
                sent.push(t_ns + period_ns + 200_000);
            }
            k += 1;
        }
        driver.run(&mut bus, &cx(1));
        let cloud = bus.cloud.get().unwrap_or_else(|| panic!("no cloud"));
        assert_eq!(bus.lidar.gaps, 1);
        assert_eq!(
            cloud.stamp_ns,
            sent[59],
            "dated {} ns late",
            cloud.stamp_ns - sent[59]
        );
    }
}
