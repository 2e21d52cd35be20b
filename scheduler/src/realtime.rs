//! The real monotonic clock and real-time process setup (Linux, `std`).

use crate::clock::{FrameClock, Platform};

/// Nanoseconds on clock `id`.
#[inline]
fn clock_ns(id: libc::clockid_t) -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the callers pass clocks
    // that always exist on Linux, so the call cannot fail.
    unsafe { libc::clock_gettime(id, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Nanoseconds on `CLOCK_MONOTONIC`.
#[inline]
pub fn monotonic_ns() -> u64 {
    clock_ns(libc::CLOCK_MONOTONIC)
}

/// CPU time of the calling thread, ns (`CLOCK_THREAD_CPUTIME_ID`).
#[inline]
pub fn thread_cpu_ns() -> u64 {
    clock_ns(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// Measures with `CLOCK_MONOTONIC` (and the thread's CPU clock) and
/// reports the running slot to the [`crate::accounting`] allocator.
#[derive(Clone, Copy, Debug, Default)]
pub struct StdPlatform;

impl Platform for StdPlatform {
    #[inline]
    fn now_ns(&self) -> u64 {
        monotonic_ns()
    }
    #[inline]
    fn thread_cpu_ns(&self) -> Option<u64> {
        Some(thread_cpu_ns())
    }
    #[inline]
    fn enter(&self, slot: u16) {
        crate::accounting::set_slot(slot);
    }
    #[inline]
    fn allocated_bytes(&self, slot: u16) -> u64 {
        crate::accounting::bytes(slot as usize)
    }
}

/// Real time: frame `k` starts at the absolute time `t0 + k * minor_frame`, so
/// lateness never accumulates into drift. The thread sleeps with
/// `clock_nanosleep(TIMER_ABSTIME)` until the next frame. A frame whose start
/// has already passed by a whole minor frame or more is skipped (a slip): the
/// frame counter stays tied to time.
#[derive(Clone, Debug)]
pub struct MonotonicClock {
    minor_frame_ns: u64,
    t0: u64,
    /// How late each frame started (wake-up after its deadline).
    lateness: crate::histogram::Histogram,
}

impl MonotonicClock {
    pub fn new(minor_frame_us: u32) -> Self {
        MonotonicClock {
            minor_frame_ns: minor_frame_us as u64 * 1000,
            t0: 0,
            lateness: crate::histogram::Histogram::new(),
        }
    }

    fn sleep_until(abs_ns: u64) {
        let ts = libc::timespec {
            tv_sec: (abs_ns / 1_000_000_000) as libc::time_t,
            tv_nsec: (abs_ns % 1_000_000_000) as libc::c_long,
        };
        loop {
            // SAFETY: `ts` is a valid timespec; a null remainder is allowed with
            // TIMER_ABSTIME.
            let rc = unsafe {
                libc::clock_nanosleep(
                    libc::CLOCK_MONOTONIC,
                    libc::TIMER_ABSTIME,
                    &ts,
                    core::ptr::null_mut(),
                )
            };
            // EINTR: a signal woke us early; the deadline is absolute, so sleep again.
            if rc != libc::EINTR {
                break;
            }
        }
    }
}

impl FrameClock for MonotonicClock {
    fn start(&mut self) {
        self.t0 = monotonic_ns();
    }

    fn wait_frame(&mut self, frame: u64) -> u64 {
        let deadline = self.t0 + frame * self.minor_frame_ns;
        let now = monotonic_ns();
        if now < deadline {
            Self::sleep_until(deadline);
            self.lateness
                .record(monotonic_ns().saturating_sub(deadline));
            return frame;
        }
        // Late by less than one frame: run it now. Later: skip to the frame
        // whose slot we are in.
        let run = frame + (now - deadline) / self.minor_frame_ns;
        self.lateness
            .record(now - (self.t0 + run * self.minor_frame_ns));
        run
    }

    fn start_lateness(&self) -> Option<&crate::histogram::Histogram> {
        Some(&self.lateness)
    }

    fn frame_time_ns(&self, frame: u64) -> u64 {
        frame * self.minor_frame_ns
    }

    fn minor_frame_ns(&self) -> u64 {
        self.minor_frame_ns
    }
}

/// Now as Unix time, ns (0 before 1970): the time base recordings carry.
pub fn unix_now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// What real-time setup achieved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RealtimeReport {
    /// `Ok(priority)` or why SCHED_FIFO was refused.
    pub fifo: Result<i32, String>,
    /// `Ok(())` or why mlockall was refused.
    pub mlock: Result<(), String>,
}

impl core::fmt::Display for RealtimeReport {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match &self.fifo {
            Ok(p) => write!(f, "SCHED_FIFO priority {p}")?,
            Err(e) => write!(f, "SCHED_FIFO not set ({e})")?,
        }
        match &self.mlock {
            Ok(()) => write!(f, ", memory locked"),
            Err(e) => write!(f, ", memory not locked ({e})"),
        }
    }
}

/// Ask for `SCHED_FIFO` at `priority` for the calling thread and lock all
/// current and future pages in memory. Either may be refused (no
/// CAP_SYS_NICE / CAP_IPC_LOCK, container limits); the report says why.
pub fn setup_realtime(priority: i32) -> RealtimeReport {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: plain syscalls with valid arguments.
    let fifo = if unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) } == 0 {
        Ok(priority)
    } else {
        Err(std::io::Error::last_os_error().to_string())
    };
    // SAFETY: as above.
    let mlock = if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error().to_string())
    };
    RealtimeReport { fifo, mlock }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monotonic_clock_paces_frames_without_drift() {
        let mut c = MonotonicClock::new(2_000);
        c.start();
        let start = monotonic_ns();
        let mut frame = 0;
        for _ in 0..10 {
            frame = c.wait_frame(frame) + 1;
        }
        let elapsed = monotonic_ns() - start;
        // Frame 9 starts at 18 ms; it cannot start earlier.
        assert!(elapsed >= 18_000_000, "{elapsed}");
    }

    #[test]
    fn late_frames_are_skipped_not_queued() {
        let mut c = MonotonicClock::new(1_000);
        c.start();
        std::thread::sleep(std::time::Duration::from_millis(5));
        let f = c.wait_frame(0);
        assert!(f >= 4, "ran frame {f}");
    }
}
