//! Assembling packets into frames (revolutions).
//!
//! A new frame starts at the first block whose azimuth, measured from the cut
//! angle, is more than half a turn smaller than the previous block's: the
//! scan crossed the cut angle (a small step back is jitter, not a new turn).
//! A gap in the timestamps longer than a revolution also ends the frame.
//! Point times are made relative to the first firing of the frame.
//! Zero-range returns are dropped by the decoder.
//!
//! Timestamps count microseconds past the hour. A packet whose timestamp is
//! not after the previous one is a duplicate or late and is dropped (counted);
//! after [`RESYNC_AFTER`] such packets in a row the assembler follows the
//! sensor's clock again (it jumped, or one earlier packet was bogus). Short
//! gaps count as lost packets.

use super::decode::{Decoder, Point};
use super::packet::DataPacket;
use super::{BLOCKS, BLOCK_PERIOD_NS};

/// Nominal time between two data packets.
pub const PACKET_PERIOD_US: f64 = BLOCKS as f64 * BLOCK_PERIOD_NS / 1000.0;
const HOUR_US: i64 = 3_600_000_000;
/// Out-of-order packets in a row after which the sensor's clock is followed.
pub const RESYNC_AFTER: u32 = 16;
/// A gap longer than one revolution at the slowest rate (5 Hz) ends a frame.
pub const MAX_GAP_US: i64 = 200_000;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameCounters {
    pub packets: u64,
    pub frames: u64,
    pub points: u64,
    /// Points that did not fit in the frame buffer.
    pub dropped_points: u64,
    /// Packets missing according to the timestamps.
    pub lost_packets: u64,
    /// Packets not newer than the previous one (dropped).
    pub out_of_order: u64,
    /// Times the assembler followed a jump of the sensor's clock.
    pub resyncs: u64,
    /// Gaps longer than a revolution (the frame in progress was ended).
    pub gaps: u64,
}

/// A completed frame.
#[derive(Debug)]
pub struct Frame<'a> {
    pub index: u64,
    /// Time of the frame's first firing, microseconds past the hour.
    pub start_us: f64,
    /// When the packet that completed the frame had fired its last block,
    /// same clock: the frame is known from then on, so a receiver can tell
    /// the first firing's time in its own clock from the delivering
    /// packet's arrival, less only the network's latency.
    pub end_us: f64,
    pub points: &'a [Point],
    /// Emitted by [`FrameAssembler::flush`] (a gap, a resync, the end of a
    /// capture): its last packet is the one taken in before the packet
    /// being pushed, which arrived later by the gap.
    pub flushed: bool,
    /// A whole turn from the cut angle: not the turn in progress when the
    /// packets began (start-up, after a gap or a resync), nor one a gap
    /// cut short.
    pub whole: bool,
}

/// A frame whose first block is this close past the cut (centidegrees,
/// about a packet's sweep at 20 Hz) began at the cut.
const AT_CUT_CENTIDEG: u32 = 500;

pub struct FrameAssembler {
    decoder: Decoder,
    cut: u16,
    points: Vec<Point>,
    /// Relative azimuth of the previous block, if any.
    last_rel: Option<u32>,
    last_ts: Option<u32>,
    start_us: Option<f64>,
    /// The frame in progress began at the cut angle.
    began_at_cut: bool,
    /// End (`Frame::end_us`) of the last packet taken in.
    end_us: f64,
    /// Hours added to timestamps after wraps, so time keeps increasing.
    hours: i64,
    /// Out-of-order packets in a row.
    behind: u32,
    index: u64,
    pub counters: FrameCounters,
}

impl FrameAssembler {
    /// `cut_deg`: azimuth at which frames are split; `capacity`: most points
    /// per frame (allocated now, never grown).
    pub fn new(decoder: Decoder, cut_deg: f64, capacity: usize) -> Self {
        let cut = ((cut_deg.rem_euclid(360.0)) * 100.0).round() as u32 % 36000;
        // Touched now, so no page faults while assembling.
        let mut points = vec![Point::default(); capacity];
        points.clear();
        FrameAssembler {
            decoder,
            cut: cut as u16,
            points,
            last_rel: None,
            last_ts: None,
            start_us: None,
            began_at_cut: false,
            end_us: 0.0,
            hours: 0,
            behind: 0,
            index: 0,
            counters: FrameCounters::default(),
        }
    }

    /// Add a packet; `on_frame` is called for each frame it completes.
    pub fn push(&mut self, p: &DataPacket, mut on_frame: impl FnMut(&Frame<'_>)) {
        let mut restart = false;
        if let Some(last) = self.last_ts {
            // Time since the previous packet, taking the hourly wrap into
            // account in both directions.
            let mut dt = p.timestamp_us as i64 - last as i64;
            let mut wrapped = 0;
            if dt <= -HOUR_US / 2 {
                dt += HOUR_US;
                wrapped = 1;
            } else if dt > HOUR_US / 2 {
                dt -= HOUR_US;
                wrapped = -1;
            }
            if dt <= 0 {
                self.counters.out_of_order += 1;
                self.behind += 1;
                if self.behind < RESYNC_AFTER {
                    return;
                }
                // The sensor's clock jumped back (or a packet before was
                // bogus): follow it, in a new frame.
                self.counters.resyncs += 1;
                restart = true;
            } else if dt > MAX_GAP_US {
                self.counters.gaps += 1;
                self.hours += wrapped.max(0);
                restart = true;
            } else {
                self.hours += wrapped.max(0);
                let missing = (dt as f64 / PACKET_PERIOD_US).round() as i64 - 1;
                if missing > 0 {
                    self.counters.lost_packets += missing as u64;
                }
            }
        }
        self.behind = 0;
        if restart {
            self.flush(&mut on_frame);
            self.last_rel = None;
            self.start_us = None;
        }
        self.last_ts = Some(p.timestamp_us);
        self.counters.packets += 1;
        let packet_us = p.timestamp_us as f64 + (self.hours * HOUR_US) as f64;

        // Blocks of this packet that begin a new frame.
        let mut first_block_of_new = None;
        for (b, blk) in p.blocks.iter().enumerate() {
            let rel = super::decode::azimuth_step(self.cut, blk.azimuth);
            if self.start_us.is_none() && b == 0 {
                self.began_at_cut = rel < AT_CUT_CENTIDEG;
            }
            if self.last_rel.is_some_and(|l| l > rel + 18_000) && first_block_of_new.is_none() {
                first_block_of_new = Some(b);
            }
            self.last_rel = Some(rel);
        }
        let split = first_block_of_new.unwrap_or(BLOCKS);
        let block_us = |b: u8| packet_us + b as f64 * BLOCK_PERIOD_NS / 1000.0;
        if self.start_us.is_none() {
            self.start_us = Some(packet_us);
        }
        let mut lost = 0u64;
        let mut emitted = false;
        let decoder = &self.decoder;
        let points = &mut self.points;
        let mut start = self.start_us.unwrap_or(packet_us);
        let end_us = packet_us + PACKET_PERIOD_US;
        let whole = self.began_at_cut;
        decoder.decode_with(p, |mut pt| {
            if pt.block as usize >= split && !emitted {
                emitted = true;
                self.index += 1;
                self.counters.frames += 1;
                self.counters.points += points.len() as u64;
                on_frame(&Frame {
                    index: self.index - 1,
                    start_us: start,
                    end_us,
                    points,
                    flushed: false,
                    whole,
                });
                points.clear();
                start = block_us(split as u8);
            }
            pt.time += ((block_us(0) - start) * 1e-6) as f32;
            if points.len() < points.capacity() {
                points.push(pt);
            } else {
                lost += 1;
            }
        });
        if split < BLOCKS && !emitted {
            // The frame ended at a block with no returns at all.
            self.index += 1;
            self.counters.frames += 1;
            self.counters.points += self.points.len() as u64;
            on_frame(&Frame {
                index: self.index - 1,
                start_us: start,
                end_us,
                points: &self.points,
                flushed: false,
                whole,
            });
            self.points.clear();
            start = block_us(split as u8);
        }
        if split < BLOCKS {
            self.began_at_cut = true;
        }
        self.start_us = Some(start);
        self.end_us = end_us;
        self.counters.dropped_points += lost;
    }

    /// Emit the partial frame in progress (end of a capture, or a gap).
    pub fn flush(&mut self, mut on_frame: impl FnMut(&Frame<'_>)) {
        if self.points.is_empty() {
            return;
        }
        self.counters.frames += 1;
        self.counters.points += self.points.len() as u64;
        on_frame(&Frame {
            index: self.index,
            start_us: self.start_us.unwrap_or(0.0),
            end_us: self.end_us,
            points: &self.points,
            flushed: true,
            whole: false,
        });
        self.index += 1;
        self.points.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::super::encode::{Firing, PacketEncoder};
    use super::super::{Calibration, LASERS};
    use super::*;

    /// Packets of a sensor turning 0.2 deg per block from `az0`, one return
    /// per block, timestamps 552.96 us apart from `t0`.
    fn packets(n: usize, az0: u32, t0: u32) -> Vec<DataPacket> {
        let mut enc = PacketEncoder::new(Calibration::nominal());
        let mut out = Vec::new();
        let mut k = 0u32;
        while out.len() < n {
            let mut f = Firing {
                azimuth: ((az0 + 20 * k) % 36000) as u16,
                distance_m: [0.0; LASERS],
                intensity: [0; LASERS],
            };
            f.distance_m[0] = 5.0;
            let t = t0.wrapping_add((out.len() as f64 * PACKET_PERIOD_US) as u32) % 3_600_000_000;
            if let Some(b) = enc.push(&f, t) {
                out.push(DataPacket::parse(&b).expect("valid"));
            }
            k += 1;
        }
        out
    }

    fn assembler() -> FrameAssembler {
        FrameAssembler::new(Decoder::new(&Calibration::nominal()), 0.0, 10_000)
    }

    #[test]
    fn a_revolution_is_one_frame_split_at_the_cut_angle() {
        // 36000 / 20 = 1800 blocks = 150 packets a revolution.
        let mut a = assembler();
        let mut sizes = Vec::new();
        for p in packets(400, 0, 0) {
            a.push(&p, |f| sizes.push(f.points.len()));
        }
        assert_eq!(sizes, vec![1800, 1800]);
        assert_eq!(a.counters.lost_packets + a.counters.out_of_order, 0);
    }

    #[test]
    fn only_turns_from_the_cut_are_whole() {
        // Started at the cut: whole from the first.
        let mut a = assembler();
        let mut whole = Vec::new();
        for p in packets(301, 0, 0) {
            a.push(&p, |f| whole.push(f.whole));
        }
        assert_eq!(whole, [true, true]);
        // Started a quarter turn in: the first frame is the rest of a turn.
        let mut a = assembler();
        let mut frames = Vec::new();
        let ps = packets(400, 9000, 0);
        for p in &ps {
            a.push(p, |f| frames.push((f.whole, f.points.len())));
        }
        assert_eq!(frames, [(false, 1350), (true, 1800)]);
        // After a gap the turn in progress is neither.
        let later = packets(200, 9000, ps[399].timestamp_us + 500_000);
        let mut after = Vec::new();
        for p in &later {
            a.push(p, |f| after.push((f.whole, f.flushed)));
        }
        assert_eq!(after, [(false, true), (false, false)]);
    }

    #[test]
    fn a_frame_ends_when_the_packet_completing_it_has_fired() {
        // The first revolution's 1800 blocks fill packets 0..150; packet 150
        // holds the first blocks of the next and completes it.
        let mut a = assembler();
        let mut spans = Vec::new();
        let ps = packets(301, 0, 1_000);
        for p in &ps {
            a.push(p, |f| spans.push((f.start_us, f.end_us)));
        }
        let t = |i: usize| ps[i].timestamp_us as f64;
        assert_eq!(spans.len(), 2);
        assert_eq!(spans[0], (t(0), t(150) + PACKET_PERIOD_US));
        assert_eq!(spans[1], (t(150), t(300) + PACKET_PERIOD_US));
        // A flushed frame ends with the last packet taken in.
        a.flush(|f| spans.push((f.start_us, f.end_us)));
        assert_eq!(spans[2], (t(300), t(300) + PACKET_PERIOD_US));
    }

    #[test]
    fn gaps_count_as_lost_and_going_back_as_out_of_order() {
        let mut a = assembler();
        let ps = packets(10, 0, 1000);
        for (i, p) in ps.iter().enumerate() {
            if i != 3 && i != 4 {
                a.push(p, |_| {});
            }
        }
        assert_eq!(a.counters.lost_packets, 2);
        a.push(&ps[2], |_| {});
        assert_eq!(a.counters.out_of_order, 1);
        assert_eq!(a.counters.packets, 8);
    }

    #[test]
    fn a_clock_jump_is_followed_after_a_few_packets() {
        let mut a = assembler();
        let ps = packets(40, 0, 1_000_000);
        for p in &ps[..5] {
            a.push(p, |_| {});
        }
        // One bogus packet ten minutes ahead...
        let mut bogus = ps[5];
        bogus.timestamp_us += 600_000_000;
        a.push(&bogus, |_| {});
        assert_eq!(a.counters.gaps, 1);
        // ...then the real ones look old; after RESYNC_AFTER they are followed.
        for p in &ps[6..] {
            a.push(p, |_| {});
        }
        assert_eq!(a.counters.out_of_order, RESYNC_AFTER as u64);
        assert_eq!(a.counters.resyncs, 1);
        assert_eq!(a.counters.packets, 6 + 1 + (40 - 6 - RESYNC_AFTER as u64));
    }

    #[test]
    fn duplicates_are_dropped_and_jitter_does_not_split() {
        let mut a = assembler();
        let ps = packets(20, 100, 0);
        let mut frames = 0;
        for p in &ps {
            a.push(p, |_| frames += 1);
            a.push(p, |_| frames += 1);
        }
        assert_eq!(a.counters.out_of_order, 20);
        // A block one hundredth behind its predecessor is not a new turn.
        let mut j = ps[19];
        j.timestamp_us += 600;
        j.blocks[0].azimuth -= 1;
        a.push(&j, |_| frames += 1);
        assert_eq!(frames, 0);
    }

    #[test]
    fn the_hourly_timestamp_wrap_is_not_a_loss() {
        let mut a = assembler();
        for p in packets(10, 0, 3_600_000_000 - 2000) {
            a.push(&p, |_| {});
        }
        assert_eq!(a.counters.lost_packets, 0);
        assert_eq!(a.counters.out_of_order, 0);
        assert_eq!(a.counters.packets, 10);
    }

    #[test]
    fn a_full_buffer_drops_and_counts() {
        let mut a = FrameAssembler::new(Decoder::new(&Calibration::nominal()), 0.0, 100);
        for p in packets(20, 0, 0) {
            a.push(&p, |_| {});
        }
        assert_eq!(a.counters.dropped_points, 20 * 12 - 100);
    }
}
