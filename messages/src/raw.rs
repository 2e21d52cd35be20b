//! The frame's raw device inputs, kept for the drivers and the recorder.

use speleo_hal::{Device, InputSink};

/// Arena sizes: a frame of HDL-32E traffic is ~18 packets of 1206 bytes.
pub const RAW_ARENA_BYTES: usize = 256 * 1024;
/// Raw inputs a frame holds at most.
pub const RAW_ENTRIES: usize = 2048;

/// One raw input of this frame, stored in [`RawFrame`]'s arena.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RawEntry {
    pub device: Device,
    pub receive_time_ns: u64,
    start: u32,
    len: u32,
}

/// The raw inputs received in the current frame: bytes in one arena sized at
/// start-up. Inputs that do not fit are dropped and counted.
#[derive(Debug)]
pub struct RawFrame {
    bytes: Vec<u8>,
    entries: Vec<RawEntry>,
    pub dropped: u64,
}

impl RawFrame {
    pub fn with_capacity(bytes: usize, entries: usize) -> Self {
        RawFrame {
            bytes: Vec::with_capacity(bytes),
            entries: Vec::with_capacity(entries),
            dropped: 0,
        }
    }

    pub fn clear(&mut self) {
        self.bytes.clear();
        self.entries.clear();
    }

    pub fn entries(&self) -> &[RawEntry] {
        &self.entries
    }

    pub fn bytes_of(&self, e: &RawEntry) -> &[u8] {
        &self.bytes[e.start as usize..(e.start + e.len) as usize]
    }

    /// Entries of one device with their bytes, in arrival order.
    pub fn of(&self, device: Device) -> impl Iterator<Item = (&RawEntry, &[u8])> {
        self.entries
            .iter()
            .filter(move |e| e.device == device)
            .map(|e| (e, self.bytes_of(e)))
    }
}

impl InputSink for RawFrame {
    fn input(&mut self, device: Device, receive_time_ns: u64, bytes: &[u8]) {
        // Never grow: the capacities were fixed at start-up.
        if self.entries.len() == self.entries.capacity()
            || self.bytes.len() + bytes.len() > self.bytes.capacity()
        {
            self.dropped += 1;
            return;
        }
        self.entries.push(RawEntry {
            device,
            receive_time_ns,
            start: self.bytes.len() as u32,
            len: bytes.len() as u32,
        });
        self.bytes.extend_from_slice(bytes);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_frame_never_grows() {
        let mut r = RawFrame::with_capacity(10, 2);
        r.input(Device::Imu, 1, &[1, 2, 3]);
        r.input(Device::Can, 2, &[4; 8]); // bytes full
        r.input(Device::Can, 3, &[5; 7]);
        r.input(Device::Can, 4, &[]); // entries full
        assert_eq!(r.entries().len(), 2);
        assert_eq!(r.dropped, 2);
        assert_eq!(
            r.of(Device::Imu).next().map(|(_, b)| b),
            Some(&[1u8, 2, 3][..])
        );
    }
}
