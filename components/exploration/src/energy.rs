//! The energy the rover has drawn, from what its drives report, and the
//! budget rule that turns it home while it still has enough to get there.
//!
//! Power is counted from the drives' own feedback (velocity actual and
//! torque actual, CiA 402 0x606C and 0x6077) and a constant draw for the
//! computer, the LiDAR, the IMU and the drives' logic:
//!
//! P = base + sum over wheels of (max(tau w, 0) / efficiency + c tau^2)
//!
//! The first wheel term is the mechanical power the motor delivers through
//! its gearbox; braking (tau w < 0) gives nothing back, as drives that
//! burn it in a brake resistor do. The second is the windings' heat, which
//! a stalled wheel pressing on a rock draws with no motion at all. A drive
//! that reports no torque adds nothing but its share of the base draw, and
//! the time it went unmeasured is counted.

/// The rover's electrical draw. Defaults: an Asguard-class rover with an
/// HDL-32E (12 W), an MTi, an embedded computer and four 15 N m drives;
/// estimates, every one settable in `[exploration]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowerModel {
    /// Drawn whatever the wheels do, W.
    pub base_power_w: f64,
    /// Mechanical power at the wheel over electrical power into the drive.
    pub drive_efficiency: f64,
    /// The windings' heat at a wheel torque tau, W per (N m)^2.
    pub winding_loss_w_per_nm2: f64,
}

impl Default for PowerModel {
    fn default() -> Self {
        PowerModel {
            base_power_w: 45.0,
            drive_efficiency: 0.7,
            winding_loss_w_per_nm2: 0.06,
        }
    }
}

impl PowerModel {
    /// The draw, W, with the wheels turning at `speed` (rad/s) under
    /// `torque` (N m; `None` where a drive reports none).
    pub fn power_w<const N: usize>(&self, speed: &[f64; N], torque: &[Option<f64>; N]) -> f64 {
        let mut p = self.base_power_w;
        for (w, t) in speed.iter().zip(torque) {
            if let Some(t) = t {
                p += (t * w).max(0.0) / self.drive_efficiency + self.winding_loss_w_per_nm2 * t * t;
            }
        }
        p
    }
}

/// The energy drawn since the start, integrated frame by frame.
#[derive(Clone, Debug, PartialEq)]
pub struct EnergyMeter {
    model: PowerModel,
    joules: f64,
    /// The draw since the last reading, W, and when that reading was.
    power_w: f64,
    last_ns: Option<u64>,
    /// Time some drive reported no torque, s.
    unmeasured_s: f64,
    unmeasured: bool,
}

impl EnergyMeter {
    pub fn new(model: PowerModel) -> Self {
        EnergyMeter {
            model,
            joules: 0.0,
            power_w: model.base_power_w,
            last_ns: None,
            unmeasured_s: 0.0,
            unmeasured: false,
        }
    }

    /// The drives' feedback at `now_ns`: the draw since the last reading
    /// is counted at that reading's power, and this one's holds from now.
    /// A reading older than the last is ignored.
    pub fn read<const N: usize>(
        &mut self,
        now_ns: u64,
        speed: &[f64; N],
        torque: &[Option<f64>; N],
    ) {
        self.advance(now_ns);
        self.power_w = self.model.power_w(speed, torque);
        self.unmeasured = torque.iter().any(Option::is_none);
    }

    /// Count the draw up to `now_ns` at the last reading's power.
    pub fn advance(&mut self, now_ns: u64) {
        if let Some(last) = self.last_ns {
            if now_ns < last {
                return;
            }
            let dt = (now_ns - last) as f64 * 1e-9;
            self.joules += self.power_w * dt;
            if self.unmeasured {
                self.unmeasured_s += dt;
            }
        }
        self.last_ns = Some(now_ns);
    }

    pub fn used_wh(&self) -> f64 {
        self.joules / 3600.0
    }

    /// The draw of the last reading, W.
    pub fn power_w(&self) -> f64 {
        self.power_w
    }

    /// How long some drive reported no torque, s: its wheel's draw is
    /// missing from [`Self::used_wh`] for that long.
    pub fn unmeasured_s(&self) -> f64 {
        self.unmeasured_s
    }
}

/// What going home from here is expected to cost, Wh: as much a metre as
/// the mission has cost so far (standing, validating and driving alike),
/// over the way home along the track, times `factor`.
pub fn way_home_wh(used_wh: f64, driven_m: f64, home_m: f64, factor: f64) -> f64 {
    used_wh / driven_m.max(1.0) * home_m * factor
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standing_still_draws_the_base_and_a_stall_heats_the_windings() {
        let m = PowerModel::default();
        assert_eq!(m.power_w(&[0.0; 4], &[Some(0.0); 4]), 45.0);
        // 10 N m on one stalled wheel: no motion, 6 W of heat.
        let stalled = m.power_w(&[0.0; 4], &[Some(10.0), Some(0.0), Some(0.0), Some(0.0)]);
        assert!((stalled - 51.0).abs() < 1e-9, "{stalled}");
        // Driving 2 N m at 2 rad/s on every wheel: 16 W at the wheels.
        let rolling = m.power_w(&[2.0; 4], &[Some(2.0); 4]);
        assert!(
            (rolling - (45.0 + 16.0 / 0.7 + 4.0 * 0.24)).abs() < 1e-9,
            "{rolling}"
        );
        // Braking gives nothing back.
        let braking = m.power_w(&[2.0; 4], &[Some(-2.0); 4]);
        assert!((braking - (45.0 + 4.0 * 0.24)).abs() < 1e-9, "{braking}");
    }

    #[test]
    fn the_meter_holds_each_reading_until_the_next() {
        let mut e = EnergyMeter::new(PowerModel::default());
        e.read(0, &[0.0; 4], &[Some(0.0); 4]);
        // One hour at the base, then one at 100 W more.
        let hour = 3_600_000_000_000;
        e.read(hour, &[5.0; 4], &[Some(3.5); 4]);
        assert!((e.used_wh() - 45.0).abs() < 1e-9, "{}", e.used_wh());
        let p = e.power_w();
        e.advance(2 * hour);
        assert!((e.used_wh() - 45.0 - p).abs() < 1e-9, "{}", e.used_wh());
        assert_eq!(e.unmeasured_s(), 0.0);
        // A reading from the past is not counted twice.
        e.advance(hour);
        assert!((e.used_wh() - 45.0 - p).abs() < 1e-9);
    }

    #[test]
    fn a_drive_without_torque_is_counted_as_unmeasured() {
        let mut e = EnergyMeter::new(PowerModel::default());
        e.read(0, &[1.0; 4], &[Some(1.0), None, Some(1.0), Some(1.0)]);
        e.advance(2_000_000_000);
        assert_eq!(e.unmeasured_s(), 2.0);
        e.read(3_000_000_000, &[1.0; 4], &[Some(1.0); 4]);
        e.advance(5_000_000_000);
        assert_eq!(e.unmeasured_s(), 3.0);
    }

    #[test]
    fn the_way_home_costs_what_the_way_out_cost_a_metre() {
        // 100 Wh over 200 m; 50 m home, with half again in hand.
        assert_eq!(way_home_wh(100.0, 200.0, 50.0, 1.5), 37.5);
        // Before the rover has gone a metre, a metre is the divisor.
        assert_eq!(way_home_wh(1.0, 0.0, 0.5, 1.0), 0.5);
    }
}
