//! Acceleration limits on the body command: the drives follow a ramped
//! profile anyway, but a ramp planned here keeps the two sides in step, so
//! the curvature holds while the rover speeds up or brakes.

/// Largest changes of the body command per second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelLimits {
    /// m/s^2.
    pub max_accel: f64,
    /// m/s^2 when slowing down (braking may be harder than speeding up).
    pub max_decel: f64,
    /// rad/s^2.
    pub max_yaw_accel: f64,
}

/// Ramps a body command toward its target within [`AccelLimits`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelLimiter {
    limits: AccelLimits,
    v: f64,
    w: f64,
}

impl AccelLimiter {
    pub fn new(limits: AccelLimits) -> Self {
        AccelLimiter {
            limits,
            v: 0.0,
            w: 0.0,
        }
    }

    /// The command after `dt_s` seconds of ramping toward (`v`, `w`).
    /// Speed and yaw rate are scaled by the same fraction of their step, so
    /// the target's curvature is kept while ramping.
    pub fn step(&mut self, v: f64, w: f64, dt_s: f64) -> (f64, f64) {
        let dv = v - self.v;
        let dw = w - self.w;
        let slowing = v.abs() < self.v.abs() || v * self.v < 0.0;
        let a = if slowing {
            self.limits.max_decel
        } else {
            self.limits.max_accel
        };
        let fv = if dv != 0.0 {
            (a * dt_s / dv.abs()).min(1.0)
        } else {
            1.0
        };
        let fw = if dw != 0.0 {
            (self.limits.max_yaw_accel * dt_s / dw.abs()).min(1.0)
        } else {
            1.0
        };
        let f = fv.min(fw);
        self.v += f * dv;
        self.w += f * dw;
        (self.v, self.w)
    }

    /// Stop at once (an emergency stop does not ramp).
    pub fn halt(&mut self) {
        self.v = 0.0;
        self.w = 0.0;
    }

    pub fn current(&self) -> (f64, f64) {
        (self.v, self.w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> AccelLimits {
        AccelLimits {
            max_accel: 0.5,
            max_decel: 1.0,
            max_yaw_accel: 2.0,
        }
    }

    #[test]
    fn speed_ramps_at_the_limit_and_reaches_the_target() {
        let mut l = AccelLimiter::new(limits());
        let (v, _) = l.step(0.4, 0.0, 0.02);
        assert!((v - 0.01).abs() < 1e-12, "{v}");
        for _ in 0..100 {
            l.step(0.4, 0.0, 0.02);
        }
        assert_eq!(l.current(), (0.4, 0.0));
        // Braking uses the harder limit.
        let (v, _) = l.step(0.0, 0.0, 0.02);
        assert!((v - 0.38).abs() < 1e-12, "{v}");
    }

    #[test]
    fn ramping_keeps_the_targets_curvature() {
        let mut l = AccelLimiter::new(limits());
        for _ in 0..10 {
            let (v, w) = l.step(0.4, 0.8, 0.02);
            assert!((w - 2.0 * v).abs() < 1e-12, "{v} {w}");
        }
    }
}
