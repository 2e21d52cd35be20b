//! How far the ground turned the simulated rover off its commands: the
//! body's turn less the turn the follower commanded, over the last three
//! seconds. A rover whose wheel rides a rock's flank is pivoted on it,
//! against the command; in the simulation it may slip off (the plan
//! "passes"), on the real rover or the true surface it stays pinned (the
//! lava tube's rover, 77 m in, stuck for a quarter of an hour on a plan
//! the simulation passed: 103 degrees off in three seconds, where no
//! other of 61 passed plans of the lava tube and the garage came over 55).

/// Control periods in the window: 3 s at 50 Hz.
pub const WINDOW_PERIODS: usize = 150;

/// The window's body turn less commanded turn, per control period.
pub struct Deflection {
    ring: [f64; WINDOW_PERIODS],
    head: usize,
    last_yaw: Option<f64>,
}

impl Default for Deflection {
    fn default() -> Self {
        Deflection {
            ring: [0.0; WINDOW_PERIODS],
            head: 0,
            last_yaw: None,
        }
    }
}

impl Deflection {
    pub fn clear(&mut self) {
        *self = Deflection::default();
    }

    /// A control period ended at heading `yaw` (rad) with `w` (rad/s)
    /// commanded through it for `period_s`; the window's deflection, rad
    /// (its magnitude).
    pub fn period(&mut self, yaw: f64, w: f64, period_s: f64) -> f64 {
        if let Some(last) = self.last_yaw.replace(yaw) {
            let turned = (yaw - last + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            self.ring[self.head] = turned - w * period_s;
            self.head = (self.head + 1) % WINDOW_PERIODS;
        }
        // Summed afresh: no drift over a long drive.
        self.ring.iter().sum::<f64>().abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: f64 = 0.02;

    #[test]
    fn turning_as_commanded_is_no_deflection_and_a_pivot_against_it_is() {
        let mut d = Deflection::default();
        let mut yaw = 3.0;
        for _ in 0..400 {
            // Commanded 0.8 rad/s left, turning so, across the +-pi wrap.
            yaw = (yaw + 0.8 * P + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            assert!(d.period(yaw, 0.8, P) < 1e-9);
        }
        // Commanded right at 0.4 rad/s, turned left at 0.3 rad/s for 3 s:
        // 0.7 rad/s x 3 s off.
        let mut off = 0.0;
        for _ in 0..WINDOW_PERIODS {
            yaw += 0.3 * P;
            off = d.period(yaw, -0.4, P);
        }
        assert!((off - 2.1).abs() < 1e-9, "{off}");
        // Only the last 3 s count.
        for _ in 0..WINDOW_PERIODS {
            off = d.period(yaw, 0.0, P);
        }
        assert!(off < 1e-9, "{off}");
        d.clear();
        assert_eq!(
            d.period(1.0, 5.0, P),
            0.0,
            "the first period only sets the heading"
        );
    }
}
