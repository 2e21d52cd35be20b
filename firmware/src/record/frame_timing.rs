//! The executive's timing decisions of a run in real time, recorded on
//! `/executive/timing` and taken again by replay: which frames the clock
//! slipped past and which tasks overran. Overrun policies and slips change
//! what runs, so a replay that measured its own would not reproduce the run.

use std::io::Write;

use speleo_scheduler::FrameClock;

use super::cdr::{CdrReader, CdrWriter};

/// One frame in which the clock slipped or a task overran.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameTiming {
    /// The frame run.
    pub frame: u64,
    /// Frames skipped before it.
    pub slipped: u64,
    /// Bit `i`: task `i` of the schedule overran.
    pub overran: u64,
}

impl FrameTiming {
    /// The frame that was due when this one ran instead.
    pub fn due(&self) -> u64 {
        self.frame - self.slipped
    }
}

/// The CDR of `speleo_msgs/msg/FrameTiming`.
pub fn write<W: Write>(w: W, sec: u64, nsec: u32, t: &FrameTiming) -> std::io::Result<()> {
    let mut c = CdrWriter::new(w)?;
    c.time(sec, nsec)?;
    c.u32(t.slipped.min(u32::MAX as u64) as u32)?;
    c.u64(t.overran)
}

/// A `speleo_msgs/msg/FrameTiming` of frame `frame`.
pub fn read(frame: u64, b: &[u8]) -> Result<FrameTiming, String> {
    let mut r = CdrReader::new(b).map_err(|e| e.to_string())?;
    let _sec = r.i32().map_err(|e| e.to_string())?;
    let _nsec = r.u32().map_err(|e| e.to_string())?;
    let slipped = r.u32().map_err(|e| e.to_string())? as u64;
    let overran = r.u64().map_err(|e| e.to_string())?;
    if slipped > frame {
        return Err(format!("frame {frame} slipped past {slipped} frames"));
    }
    Ok(FrameTiming {
        frame,
        slipped,
        overran,
    })
}

/// Walks the recorded frames as the replay reaches them.
pub struct Cursor<'a> {
    timing: &'a [FrameTiming],
    next: usize,
}

impl<'a> Cursor<'a> {
    pub fn new(timing: &'a [FrameTiming]) -> Self {
        Cursor { timing, next: 0 }
    }

    /// The tasks that overran in the frame run when frame `due` was due.
    pub fn overruns_due(&mut self, due: u64) -> u64 {
        while let Some(t) = self.timing.get(self.next) {
            if t.due() > due {
                break;
            }
            self.next += 1;
            if t.due() == due {
                return t.overran;
            }
        }
        0
    }
}

/// Virtual time that slips where the recorded run slipped: frame `k`
/// starts at `k` minor frames, and the frames the run skipped are skipped.
#[derive(Clone, Debug)]
pub struct SlippingClock {
    minor_frame_ns: u64,
    /// (due, run) of each slip, in order.
    slips: Vec<(u64, u64)>,
    next: usize,
}

impl SlippingClock {
    pub fn new(minor_frame_us: u32, timing: &[FrameTiming]) -> Self {
        SlippingClock {
            minor_frame_ns: minor_frame_us as u64 * 1000,
            slips: timing
                .iter()
                .filter(|t| t.slipped > 0)
                .map(|t| (t.due(), t.frame))
                .collect(),
            next: 0,
        }
    }
}

impl FrameClock for SlippingClock {
    fn wait_frame(&mut self, frame: u64) -> u64 {
        while let Some(&(due, run)) = self.slips.get(self.next) {
            if due > frame {
                break;
            }
            self.next += 1;
            if due == frame {
                return run;
            }
        }
        frame
    }
    fn frame_time_ns(&self, frame: u64) -> u64 {
        frame * self.minor_frame_ns
    }
    fn minor_frame_ns(&self) -> u64 {
        self.minor_frame_ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_timing_record_round_trips_in_cdr() {
        let t = FrameTiming {
            frame: 120,
            slipped: 2,
            overran: 0b1001,
        };
        let mut b = Vec::new();
        write(&mut b, 5, 7, &t).expect("write");
        assert_eq!(read(120, &b), Ok(t));
        assert!(read(1, &b).is_err(), "a slip past frame 0");
        assert!(read(120, &b[..b.len() - 1]).is_err(), "cut short");
    }

    #[test]
    fn the_clock_skips_the_frames_the_run_skipped() {
        let slip = |frame, slipped| FrameTiming {
            frame,
            slipped,
            overran: 0,
        };
        let mut c = SlippingClock::new(10_000, &[slip(5, 2), slip(9, 0), slip(12, 1)]);
        let mut run = Vec::new();
        let mut next = 0;
        while next < 14 {
            let f = c.wait_frame(next);
            run.push(f);
            next = f + 1;
        }
        assert_eq!(run, [0, 1, 2, 5, 6, 7, 8, 9, 10, 12, 13]);
        assert_eq!(c.frame_time_ns(5), 50_000_000);
    }
}
