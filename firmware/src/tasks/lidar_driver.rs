//! Decodes HDL-32E data packets into revolutions and position packets into
//! the sensor's GPS time; bad packets are counted by kind, never fatal.

use speleo_hal::hdl32e::position::PositionPacket;
use speleo_hal::hdl32e::{DataPacket, FrameAssembler, PacketError, Point};
use speleo_hal::Device;
use speleo_scheduler::{Context, Task};

use crate::bus::{Bus, Cloud};

pub struct LidarDriver {
    assembler: FrameAssembler,
    /// Point buffers not currently in the mailbox (three in all).
    free: heapless::Vec<Vec<Point>, 3>,
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
        LidarDriver { assembler, free }
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
            self.assembler.push(&p, |f| {
                let Some(mut points) = free.pop() else {
                    c.dropped_frames += 1;
                    return;
                };
                points.clear();
                let n = f.points.len().min(points.capacity());
                points.extend_from_slice(&f.points[..n]);
                let evicted = cloud.publish_recycle(
                    t,
                    Cloud {
                        index: f.index,
                        start_us: f.start_us,
                        end_us: f.end_us,
                        points,
                    },
                );
                if let Some(old) = evicted {
                    let _ = free.push(old.points);
                }
            });
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
