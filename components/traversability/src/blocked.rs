//! Why a patch is an obstacle: the tests of its classification that
//! failed, kept for the logs (a level speckled with obstacle patches near
//! a garage ramp's top could not be explained from the classes alone).

use std::fmt;

/// A set of the reasons a node is an obstacle; empty for drivable nodes.
#[derive(Clone, Copy, Default, PartialEq, Eq)]
pub struct Blocked(u8);

impl Blocked {
    pub const NONE: Blocked = Blocked(0);
    /// The support plane is steeper than the slope limit.
    pub const STEEP: Blocked = Blocked(1);
    /// Neighbouring cells of the footprint differ by more than a step.
    pub const STEP: Blocked = Blocked(1 << 1);
    /// Ground too high to be this patch's continuation lies under the body.
    pub const RAISED: Blocked = Blocked(1 << 2);
    /// The footprint hangs over a drop along its rim, or a deep drop lies
    /// within `drop_clearance_m` (looked for only when no test before it
    /// failed).
    pub const DROP: Blocked = Blocked(1 << 3);
    /// Something lies in the body's height band over the plane (looked
    /// for only when no other test failed).
    pub const BODY: Blocked = Blocked(1 << 4);
    /// Marked by [`crate::TravMap::forbid`] (where the rover was stuck).
    pub const FORBIDDEN: Blocked = Blocked(1 << 5);

    const NAMES: [(Blocked, &'static str); 6] = [
        (Blocked::STEEP, "steep"),
        (Blocked::STEP, "step"),
        (Blocked::RAISED, "raised"),
        (Blocked::DROP, "drop"),
        (Blocked::BODY, "body"),
        (Blocked::FORBIDDEN, "forbidden"),
    ];

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    pub fn contains(self, other: Blocked) -> bool {
        self.0 & other.0 == other.0
    }

    /// `self` with `other`'s reasons too, when `on`.
    pub fn with(self, other: Blocked, on: bool) -> Blocked {
        if on {
            Blocked(self.0 | other.0)
        } else {
            self
        }
    }
}

impl fmt::Debug for Blocked {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return f.write_str("-");
        }
        let mut first = true;
        for (b, name) in Blocked::NAMES {
            if self.contains(b) {
                if !first {
                    f.write_str("+")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_its_reasons() {
        let b = Blocked::NONE
            .with(Blocked::STEEP, true)
            .with(Blocked::STEP, false)
            .with(Blocked::DROP, true);
        assert!(b.contains(Blocked::STEEP) && b.contains(Blocked::DROP));
        assert!(!b.contains(Blocked::STEP));
        assert_eq!(format!("{b:?}"), "steep+drop");
        assert_eq!(format!("{:?}", Blocked::NONE), "-");
    }
}
