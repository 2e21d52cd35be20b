//! Time-stamped byte messages waiting to be "received", with fixed capacity.

/// Up to `N` messages of up to `M` bytes each, in time order.
#[derive(Debug, Default)]
pub struct Outbox<const N: usize, const M: usize> {
    items: heapless::Deque<(u64, heapless::Vec<u8, M>), N>,
    dropped: u64,
}

impl<const N: usize, const M: usize> Outbox<N, M> {
    pub const fn new() -> Self {
        Outbox {
            items: heapless::Deque::new(),
            dropped: 0,
        }
    }

    /// Queue `bytes` to arrive at `t_ns`. Messages that do not fit (queue full
    /// or longer than `M`) are dropped and counted, like a real device's
    /// overflowing buffer.
    pub fn push(&mut self, t_ns: u64, bytes: &[u8]) {
        let Ok(v) = heapless::Vec::from_slice(bytes) else {
            self.dropped += 1;
            return;
        };
        if self.items.push_back((t_ns, v)).is_err() {
            self.dropped += 1;
        }
    }

    /// The oldest message if it has arrived by `now_ns`.
    pub fn pop_due(&mut self, now_ns: u64) -> Option<(u64, heapless::Vec<u8, M>)> {
        match self.items.front() {
            Some((t, _)) if *t <= now_ns => self.items.pop_front(),
            _ => None,
        }
    }

    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}
