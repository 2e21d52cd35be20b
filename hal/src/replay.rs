//! Replay of recorded raw inputs: each minor frame yields exactly the bytes
//! that were received in the same frame of the recording.

use crate::can::CanFrame;
use crate::{CanBus, Device, HalError, Hardware, ImuPort, InputSink, LidarSource};

/// One recorded raw input.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordedInput {
    pub frame: u64,
    pub device: Device,
    pub receive_time_ns: u64,
    pub bytes: Vec<u8>,
}

/// Inputs of one device, in recorded order, with a read cursor.
#[derive(Default)]
struct Track {
    items: Vec<RecordedInput>,
    next: usize,
    frame: u64,
}

impl Track {
    fn poll(&mut self, sink: &mut dyn InputSink) {
        while let Some(it) = self.items.get(self.next) {
            if it.frame > self.frame {
                break;
            }
            // Inputs of frames already passed (never in a well-formed
            // recording) are delivered late rather than lost.
            sink.input(it.device, it.receive_time_ns, &it.bytes);
            self.next += 1;
        }
    }
}

/// Hardware that plays back a recording. Everything is loaded at start-up,
/// so polling never allocates.
pub struct ReplayHardware {
    minor_frame_ns: u64,
    lidar: Track,
    imu: Track,
    can: Track,
    /// Frames the software sent to the drives; a replay cannot deliver them.
    pub can_sent: u64,
    pub imu_sent: u64,
}

impl ReplayHardware {
    /// `inputs` in recorded order.
    pub fn new(minor_frame_us: u32, inputs: Vec<RecordedInput>) -> Self {
        let mut hw = ReplayHardware {
            minor_frame_ns: minor_frame_us as u64 * 1000,
            lidar: Track::default(),
            imu: Track::default(),
            can: Track::default(),
            can_sent: 0,
            imu_sent: 0,
        };
        for i in inputs {
            match i.device {
                // Data and position packets share the LiDAR source, in order.
                Device::Lidar | Device::LidarPosition => hw.lidar.items.push(i),
                Device::Imu => hw.imu.items.push(i),
                Device::Can => hw.can.items.push(i),
            }
        }
        hw
    }

    /// Recorded inputs not yet delivered.
    pub fn remaining(&self) -> usize {
        [&self.lidar, &self.imu, &self.can]
            .iter()
            .map(|t| t.items.len() - t.next)
            .sum()
    }
}

impl Hardware for ReplayHardware {
    fn advance_to(&mut self, now_ns: u64) {
        let frame = now_ns / self.minor_frame_ns.max(1);
        self.lidar.frame = frame;
        self.imu.frame = frame;
        self.can.frame = frame;
    }
    fn lidar(&mut self) -> &mut dyn LidarSource {
        self
    }
    fn imu(&mut self) -> &mut dyn ImuPort {
        self
    }
    fn can(&mut self) -> &mut dyn CanBus {
        self
    }
}

impl LidarSource for ReplayHardware {
    fn poll(&mut self, _now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        self.lidar.poll(sink);
        Ok(())
    }
}

impl ImuPort for ReplayHardware {
    fn poll(&mut self, _now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        self.imu.poll(sink);
        Ok(())
    }
    fn write(&mut self, _bytes: &[u8]) -> Result<(), HalError> {
        self.imu_sent += 1;
        Ok(())
    }
}

impl CanBus for ReplayHardware {
    fn poll(&mut self, _now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        self.can.poll(sink);
        Ok(())
    }
    fn send(&mut self, _now_ns: u64, _frame: &CanFrame) -> Result<(), HalError> {
        self.can_sent += 1;
        Ok(())
    }
}
