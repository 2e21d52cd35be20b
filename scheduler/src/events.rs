//! Overrun events, rate-limited so that a storm cannot flood the log.

use crate::TaskName;

/// One overrun, as logged.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OverrunEvent {
    pub task: TaskName,
    pub frame: u64,
    pub duration_ns: u64,
    pub budget_ns: u64,
    /// The policy was applied (false when only counted).
    pub enforced: bool,
}

/// Capacity of the pending-event queue.
pub const EVENT_QUEUE: usize = 32;

/// Keeps at most `burst` events per `window_frames` frames; the rest are only
/// counted as suppressed. Counters in the task statistics stay exact.
#[derive(Debug)]
pub struct EventLog {
    queue: heapless::Deque<OverrunEvent, EVENT_QUEUE>,
    window_frames: u64,
    burst: u32,
    window_start: u64,
    in_window: u32,
    suppressed: u64,
}

impl EventLog {
    pub fn new(window_frames: u64, burst: u32) -> Self {
        EventLog {
            queue: heapless::Deque::new(),
            window_frames: window_frames.max(1),
            burst,
            window_start: 0,
            in_window: 0,
            suppressed: 0,
        }
    }

    pub fn push(&mut self, ev: OverrunEvent) {
        if ev.frame >= self.window_start + self.window_frames {
            self.window_start = ev.frame - ev.frame % self.window_frames;
            self.in_window = 0;
        }
        if self.in_window >= self.burst || self.queue.is_full() {
            self.suppressed += 1;
            return;
        }
        self.in_window += 1;
        let _ = self.queue.push_back(ev);
    }

    pub fn pop(&mut self) -> Option<OverrunEvent> {
        self.queue.pop_front()
    }

    /// Events not logged because of the rate limit or a full queue.
    pub fn suppressed(&self) -> u64 {
        self.suppressed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(frame: u64) -> OverrunEvent {
        OverrunEvent {
            task: TaskName::new(),
            frame,
            duration_ns: 2,
            budget_ns: 1,
            enforced: false,
        }
    }

    #[test]
    fn a_storm_is_cut_to_the_burst_per_window() {
        let mut log = EventLog::new(100, 5);
        for f in 0..1000 {
            log.push(ev(f));
            while log.pop().is_some() {}
        }
        // 10 windows of 100 frames, 5 each.
        assert_eq!(log.suppressed(), 1000 - 50);
    }

    #[test]
    fn undrained_queue_never_grows_past_capacity() {
        let mut log = EventLog::new(1, 1000);
        for f in 0..1000 {
            log.push(ev(f));
        }
        let mut n = 0;
        while log.pop().is_some() {
            n += 1;
        }
        assert_eq!(n, EVENT_QUEUE);
        assert_eq!(log.suppressed(), 1000 - EVENT_QUEUE as u64);
    }
}
