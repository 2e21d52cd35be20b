//! Freshness monitoring: every watched source must report within its limit.
//!
//! A source that has never reported is not stale until its start-up grace has
//! passed, so the rover can boot; after that, silence longer than the limit
//! is a fault that the executive answers with the safe schedule.

/// Most sources one monitor watches.
pub const MAX_SOURCES: usize = 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Source {
    pub name: &'static str,
    pub limit_ns: u64,
}

#[derive(Clone, Debug)]
pub struct Freshness {
    sources: [Option<Source>; MAX_SOURCES],
    last_ns: [Option<u64>; MAX_SOURCES],
    grace_ns: u64,
    stale_events: [u64; MAX_SOURCES],
    was_stale: [bool; MAX_SOURCES],
}

/// Index of a registered source.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SourceId(usize);

impl Freshness {
    pub fn new(grace_ns: u64) -> Self {
        Freshness {
            sources: [None; MAX_SOURCES],
            last_ns: [None; MAX_SOURCES],
            grace_ns,
            stale_events: [0; MAX_SOURCES],
            was_stale: [false; MAX_SOURCES],
        }
    }

    /// Register a source; `None` when the table is full.
    pub fn watch(&mut self, source: Source) -> Option<SourceId> {
        let i = self.sources.iter().position(Option::is_none)?;
        self.sources[i] = Some(source);
        Some(SourceId(i))
    }

    pub fn seen(&mut self, id: SourceId, t_ns: u64) {
        let last = &mut self.last_ns[id.0];
        if last.is_none_or(|l| t_ns > l) {
            *last = Some(t_ns);
        }
    }

    pub fn is_stale(&self, id: SourceId, now_ns: u64) -> bool {
        let Some(src) = self.sources[id.0] else {
            return false;
        };
        match self.last_ns[id.0] {
            Some(t) => now_ns.saturating_sub(t) > src.limit_ns,
            None => now_ns > self.grace_ns,
        }
    }

    /// Check every source; returns a bit mask of stale sources (bit = id) and
    /// counts each transition to stale.
    pub fn check(&mut self, now_ns: u64) -> u32 {
        let mut mask = 0;
        for i in 0..MAX_SOURCES {
            if self.sources[i].is_none() {
                continue;
            }
            let stale = self.is_stale(SourceId(i), now_ns);
            if stale {
                mask |= 1 << i;
                if !self.was_stale[i] {
                    self.stale_events[i] += 1;
                }
            }
            self.was_stale[i] = stale;
        }
        mask
    }

    /// Names of the sources in `mask`.
    pub fn names(&self, mask: u32) -> impl Iterator<Item = &'static str> + '_ {
        (0..MAX_SOURCES)
            .filter(move |i| mask & (1 << i) != 0)
            .filter_map(|i| self.sources[i].map(|s| s.name))
    }

    pub fn stale_events(&self, id: SourceId) -> u64 {
        self.stale_events[id.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grace_then_limit() {
        let mut f = Freshness::new(1_000);
        let imu = f
            .watch(Source {
                name: "imu",
                limit_ns: 100,
            })
            .expect("room");
        assert_eq!(f.check(500), 0);
        assert_eq!(f.check(1_001), 1);
        f.seen(imu, 1_050);
        assert_eq!(f.check(1_100), 0);
        assert_eq!(f.check(1_151), 1);
        assert_eq!(f.names(1).collect::<Vec<_>>(), vec!["imu"]);
        assert_eq!(f.stale_events(imu), 2);
    }

    #[test]
    fn old_stamps_do_not_move_time_back() {
        let mut f = Freshness::new(0);
        let s = f
            .watch(Source {
                name: "a",
                limit_ns: 10,
            })
            .expect("room");
        f.seen(s, 100);
        f.seen(s, 50);
        assert!(!f.is_stale(s, 110));
    }
}
