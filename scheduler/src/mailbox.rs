//! Fixed-capacity mailboxes: the only way tasks exchange data.
//!
//! Both kinds hold their storage inline, so they are created at start-up and
//! never allocate.

/// A value with the time it is valid for and a publication counter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stamped<T> {
    /// Time of validity of the data, nanoseconds since start.
    pub stamp_ns: u64,
    /// Publication number, 1 for the first; consumers compare it to notice news.
    pub seq: u64,
    pub value: T,
}

/// A latest-value slot: the producer overwrites, consumers read the newest.
///
/// The previous value is kept so that a late output can be withdrawn
/// ([`Latest::retract`], the reuse-last overrun policy).
#[derive(Clone, Debug)]
pub struct Latest<T> {
    current: Option<Stamped<T>>,
    previous: Option<Stamped<T>>,
    published: u64,
}

impl<T> Default for Latest<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T> Latest<T> {
    pub const fn new() -> Self {
        Latest {
            current: None,
            previous: None,
            published: 0,
        }
    }

    pub fn publish(&mut self, stamp_ns: u64, value: T) {
        self.published += 1;
        let new = Stamped {
            stamp_ns,
            seq: self.published,
            value,
        };
        self.previous = self.current.replace(new);
    }

    /// Publish and hand back the value that fell out of the slot (the one
    /// before the previous), so a producer of large values (point clouds)
    /// can reuse its storage instead of allocating.
    pub fn publish_recycle(&mut self, stamp_ns: u64, value: T) -> Option<T> {
        self.published += 1;
        let new = Stamped {
            stamp_ns,
            seq: self.published,
            value,
        };
        let evicted = self.previous.take();
        self.previous = self.current.replace(new);
        evicted.map(|s| s.value)
    }

    /// The newest value, if any was published.
    pub fn get(&self) -> Option<&Stamped<T>> {
        self.current.as_ref()
    }

    /// The newest value if it is newer than publication `seen`.
    pub fn newer_than(&self, seen: u64) -> Option<&Stamped<T>> {
        self.current.as_ref().filter(|s| s.seq > seen)
    }

    /// Withdraw the newest value: the previous one (with its old timestamp and
    /// sequence number) becomes current again. Only one level is kept.
    pub fn retract(&mut self) {
        if self.current.is_some() {
            self.current = self.previous.take();
        }
    }
}

/// A bounded FIFO between one producer and one consumer task. A push into a
/// full queue is refused and counted, never grown.
#[derive(Debug)]
pub struct Fifo<T, const N: usize> {
    items: heapless::Deque<T, N>,
    dropped: u64,
}

impl<T, const N: usize> Default for Fifo<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T, const N: usize> Fifo<T, N> {
    pub const fn new() -> Self {
        Fifo {
            items: heapless::Deque::new(),
            dropped: 0,
        }
    }

    /// Returns false (and counts a drop) when full.
    pub fn push(&mut self, item: T) -> bool {
        match self.items.push_back(item) {
            Ok(()) => true,
            Err(_) => {
                self.dropped += 1;
                false
            }
        }
    }

    pub fn pop(&mut self) -> Option<T> {
        self.items.pop_front()
    }

    pub fn len(&self) -> usize {
        self.items.len()
    }

    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    pub fn iter(&self) -> impl Iterator<Item = &T> {
        self.items.iter()
    }

    pub fn clear(&mut self) {
        self.items.clear();
    }

    /// Items refused because the queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}

/// A broadcast ring: the producer appends, every consumer reads everything
/// published since its own cursor. When a consumer falls more than `N` items
/// behind, the oldest items are overwritten and the consumer is told how many
/// it lost. Storage is inline.
#[derive(Debug)]
pub struct Ring<T, const N: usize> {
    slots: [Option<Stamped<T>>; N],
    published: u64,
}

impl<T, const N: usize> Default for Ring<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T, const N: usize> Ring<T, N> {
    pub const fn new() -> Self {
        Ring {
            slots: [const { None }; N],
            published: 0,
        }
    }

    pub fn publish(&mut self, stamp_ns: u64, value: T) {
        self.published += 1;
        let i = (self.published - 1) as usize % N;
        self.slots[i] = Some(Stamped {
            stamp_ns,
            seq: self.published,
            value,
        });
    }

    /// Items published so far; a consumer that starts now uses this as its cursor.
    pub fn published(&self) -> u64 {
        self.published
    }

    /// Call `f` with every item published after `*cursor`, oldest first, and
    /// advance the cursor. Returns the number of items lost to overwriting.
    pub fn read_since(&self, cursor: &mut u64, mut f: impl FnMut(&Stamped<T>)) -> u64 {
        let oldest = self.published.saturating_sub(N as u64);
        let lost = oldest.saturating_sub(*cursor);
        let mut seq = (*cursor).max(oldest);
        while seq < self.published {
            if let Some(item) = &self.slots[seq as usize % N] {
                f(item);
            }
            seq += 1;
        }
        *cursor = self.published;
        lost
    }

    /// The newest item.
    pub fn latest(&self) -> Option<&Stamped<T>> {
        if self.published == 0 {
            return None;
        }
        self.slots[(self.published - 1) as usize % N].as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_consumers_read_independently_and_count_losses() {
        let mut r: Ring<u32, 4> = Ring::new();
        let (mut a, mut b) = (0u64, 0u64);
        for i in 0..3 {
            r.publish(i as u64, i);
        }
        let mut got = Vec::new();
        assert_eq!(r.read_since(&mut a, |s| got.push(s.value)), 0);
        assert_eq!(got, vec![0, 1, 2]);
        for i in 3..10 {
            r.publish(i as u64, i);
        }
        got.clear();
        assert_eq!(r.read_since(&mut a, |s| got.push(s.value)), 3);
        assert_eq!(got, vec![6, 7, 8, 9]);
        got.clear();
        assert_eq!(r.read_since(&mut b, |s| got.push(s.value)), 6);
        assert_eq!(got, vec![6, 7, 8, 9]);
        assert_eq!(r.latest().map(|s| s.value), Some(9));
    }

    #[test]
    fn latest_keeps_newest_and_can_withdraw_it() {
        let mut m = Latest::new();
        assert!(m.get().is_none());
        m.publish(10, 1.0);
        m.publish(20, 2.0);
        assert_eq!(
            m.get().map(|s| (s.stamp_ns, s.seq, s.value)),
            Some((20, 2, 2.0))
        );
        assert!(m.newer_than(2).is_none());
        assert!(m.newer_than(1).is_some());
        m.retract();
        assert_eq!(
            m.get().map(|s| (s.stamp_ns, s.seq, s.value)),
            Some((10, 1, 1.0))
        );
        m.publish(30, 3.0);
        assert_eq!(m.get().map(|s| s.seq), Some(3));
    }

    #[test]
    fn fifo_refuses_and_counts_when_full() {
        let mut q: Fifo<u32, 4> = Fifo::new();
        for i in 0..6 {
            q.push(i);
        }
        assert_eq!(q.len(), 4);
        assert_eq!(q.dropped(), 2);
        assert_eq!(q.pop(), Some(0));
    }
}
