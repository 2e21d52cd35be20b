//! Time: the frame clock that paces frames, and the platform that measures.

/// Measures execution time and tells the allocator who is running.
///
/// Execution times are always taken from a monotonic clock, whatever the frame
/// clock is. `enter` is called with the slot of the code about to run
/// (0 = executive, `1 + i` = task `i`) so an accounting allocator can attribute
/// allocations.
pub trait Platform {
    fn now_ns(&self) -> u64;
    /// CPU time the calling thread has had, ns; None where the platform
    /// cannot tell. A run's CPU time leaves out the time the thread was
    /// preempted, which its wall time (`now_ns`) includes.
    fn thread_cpu_ns(&self) -> Option<u64> {
        None
    }
    fn enter(&self, _slot: u16) {}
    /// Heap bytes requested so far by the code of `slot` (0 where nothing
    /// counts them).
    fn allocated_bytes(&self, _slot: u16) -> u64 {
        0
    }
}

/// Slot number of the executive itself for [`Platform::enter`].
pub const EXECUTIVE_SLOT: u16 = 0;

/// Paces minor frames.
pub trait FrameClock {
    /// Called once before the first frame.
    fn start(&mut self) {}
    /// Wait until minor frame `frame` may start and return the frame to run:
    /// `frame` itself, or a later one when the clock has slipped past it.
    fn wait_frame(&mut self, frame: u64) -> u64;
    /// Start time of `frame` in nanoseconds since start.
    fn frame_time_ns(&self, frame: u64) -> u64;
    fn minor_frame_ns(&self) -> u64;
    /// How late each frame started against its scheduled time, on a clock
    /// that runs in real time; none on virtual time, where frames start on
    /// time by definition.
    fn start_lateness(&self) -> Option<&crate::histogram::Histogram> {
        None
    }
}

/// Simulated time: exactly one minor frame per frame, however long the work
/// took. Used by sim and replay; never slips.
#[derive(Clone, Debug)]
pub struct VirtualClock {
    minor_frame_ns: u64,
}

impl VirtualClock {
    pub fn new(minor_frame_us: u32) -> Self {
        VirtualClock {
            minor_frame_ns: minor_frame_us as u64 * 1000,
        }
    }
}

impl FrameClock for VirtualClock {
    fn wait_frame(&mut self, frame: u64) -> u64 {
        frame
    }
    fn frame_time_ns(&self, frame: u64) -> u64 {
        frame * self.minor_frame_ns
    }
    fn minor_frame_ns(&self) -> u64 {
        self.minor_frame_ns
    }
}
