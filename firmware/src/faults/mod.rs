//! Fault injection for simulated and replayed missions: what can go wrong,
//! when, for how long, and which of the health task's findings shows it.
//!
//! A fault is written `KIND@START[+DURATION][:WHEEL]`, times in seconds of
//! mission time, e.g. `lidar-dropout@20+5` or `stuck-wheel@30+4:3`. The
//! duration defaults to 5 s (for `clock-jump` it is the size of the jump),
//! the wheel to 1 (front left; 2 front right, 3 rear left, 4 rear right).

pub mod inject;
pub mod log;

use speleo_health::finding;

/// Everything that can be injected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaultKind {
    /// The HDL-32E's packets stop arriving.
    LidarDropout,
    /// The IMU's serial line delivers noise instead of Xbus messages.
    ImuGarbage,
    /// The IMU's serial line goes quiet.
    ImuDropout,
    /// One wheel's motor is blocked: the wheel is held still.
    StuckWheel,
    /// One wheel spins in loose ground: its encoder turns 2.5 times as far
    /// as the wheel rolls.
    WheelSlip,
    /// One drive reports a fault statusword; its cause clears at the end.
    DriveFault,
    /// The CAN controller is bus-off: nothing is sent or received.
    CanBusOff,
    /// Device polling takes 3 ms a frame, so the io task overruns its
    /// budget every frame.
    OverrunStorm,
    /// The frame clock jumps forward by the duration.
    ClockJump,
}

pub const KINDS: [(FaultKind, &str); 9] = [
    (FaultKind::LidarDropout, "lidar-dropout"),
    (FaultKind::ImuGarbage, "imu-garbage"),
    (FaultKind::ImuDropout, "imu-dropout"),
    (FaultKind::StuckWheel, "stuck-wheel"),
    (FaultKind::WheelSlip, "wheel-slip"),
    (FaultKind::DriveFault, "drive-fault"),
    (FaultKind::CanBusOff, "can-bus-off"),
    (FaultKind::OverrunStorm, "overrun-storm"),
    (FaultKind::ClockJump, "clock-jump"),
];

impl FaultKind {
    pub fn name(self) -> &'static str {
        KINDS
            .iter()
            .find(|(k, _)| *k == self)
            .map_or("?", |(_, n)| n)
    }

    pub fn from_name(s: &str) -> Option<FaultKind> {
        KINDS.iter().find(|(_, n)| *n == s).map(|(k, _)| *k)
    }

    /// The health findings any of which means this fault was detected.
    pub fn findings(self) -> u16 {
        use finding::*;
        match self {
            FaultKind::LidarDropout => LIDAR_SILENT,
            FaultKind::ImuGarbage => IMU_GARBAGE | IMU_SILENT,
            FaultKind::ImuDropout => IMU_SILENT,
            FaultKind::StuckWheel | FaultKind::WheelSlip => WHEEL,
            FaultKind::DriveFault => DRIVE_FAULT,
            FaultKind::CanBusOff => CAN_ERROR | DRIVE_SILENT,
            FaultKind::OverrunStorm => OVERRUN_STORM,
            FaultKind::ClockJump => CLOCK_JUMP,
        }
    }

    /// Needs the simulated drives (not possible on recorded inputs).
    pub fn needs_sim(self) -> bool {
        matches!(
            self,
            FaultKind::StuckWheel | FaultKind::WheelSlip | FaultKind::DriveFault
        )
    }

    /// Not (only) in the recorded bytes, so a replay injects it again: it
    /// acts on the executive (its clock, slow polls), or the controller's
    /// errors are part of it (bus-off).
    pub fn injected_in_replay(self) -> bool {
        matches!(
            self,
            FaultKind::OverrunStorm | FaultKind::ClockJump | FaultKind::CanBusOff
        )
    }
}

/// One injected fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultSpec {
    pub kind: FaultKind,
    pub at_ns: u64,
    pub duration_ns: u64,
    /// 0-based wheel, for the wheel and drive faults.
    pub wheel: usize,
}

/// The default duration, s.
pub const DEFAULT_DURATION_S: f64 = 5.0;
/// Longest fault, s (a day).
const MAX_S: f64 = 86_400.0;

impl FaultSpec {
    pub fn parse(s: &str) -> Result<FaultSpec, String> {
        let usage = "write KIND@START[+DURATION][:WHEEL], e.g. lidar-dropout@20+5";
        let (kind, rest) = s
            .split_once('@')
            .ok_or_else(|| format!("\"{s}\" has no start time: {usage}"))?;
        let kind = FaultKind::from_name(kind.trim()).ok_or_else(|| {
            let names: Vec<&str> = KINDS.iter().map(|(_, n)| *n).collect();
            format!(
                "unknown fault \"{}\" (faults: {})",
                kind.trim(),
                names.join(", ")
            )
        })?;
        let (times, wheel) = match rest.split_once(':') {
            Some((t, w)) => (t, Some(w)),
            None => (rest, None),
        };
        let (start, duration) = match times.split_once('+') {
            Some((a, d)) => (a, Some(d)),
            None => (times, None),
        };
        let seconds = |what: &str, v: &str| -> Result<f64, String> {
            let x: f64 = v
                .trim()
                .parse()
                .map_err(|_| format!("{what} \"{v}\" in \"{s}\" is not a number of seconds"))?;
            if x.is_finite() && (0.0..=MAX_S).contains(&x) {
                Ok(x)
            } else {
                Err(format!(
                    "{what} {x} s in \"{s}\" is not within 0..={MAX_S} s"
                ))
            }
        };
        let at = seconds("the start", start)?;
        let duration = match duration {
            Some(d) => seconds("the duration", d)?,
            None => DEFAULT_DURATION_S,
        };
        if duration <= 0.0 {
            return Err(format!("the duration in \"{s}\" must be more than 0 s"));
        }
        let wheel = match wheel {
            None => 0,
            Some(w) => match w.trim().parse::<usize>() {
                Ok(n @ 1..=4) => n - 1,
                _ => return Err(format!("wheel \"{w}\" in \"{s}\" is not 1, 2, 3 or 4")),
            },
        };
        let ns = |x: f64| (x * 1e9).round() as u64;
        Ok(FaultSpec {
            kind,
            at_ns: ns(at),
            duration_ns: ns(duration),
            wheel,
        })
    }

    pub fn end_ns(&self) -> u64 {
        self.at_ns.saturating_add(self.duration_ns)
    }

    /// Is the fault acting at `t_ns`?
    pub fn active(&self, t_ns: u64) -> bool {
        (self.at_ns..self.end_ns()).contains(&t_ns)
    }
}

impl std::fmt::Display for FaultSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}@{}+{}",
            self.kind.name(),
            self.at_ns as f64 / 1e9,
            self.duration_ns as f64 / 1e9
        )?;
        if self.kind.needs_sim() {
            write!(f, ":{}", self.wheel + 1)?;
        }
        Ok(())
    }
}

/// Parse every spec, naming the first bad one.
pub fn parse_all(specs: &[String]) -> Result<Vec<FaultSpec>, String> {
    specs.iter().map(|s| FaultSpec::parse(s)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_with_defaults_and_print_back() {
        let f = FaultSpec::parse("stuck-wheel@30+4:3").expect("parses");
        assert_eq!(f.kind, FaultKind::StuckWheel);
        assert_eq!(
            (f.at_ns, f.duration_ns, f.wheel),
            (30_000_000_000, 4_000_000_000, 2)
        );
        assert_eq!(f.to_string(), "stuck-wheel@30+4:3");
        let g = FaultSpec::parse("lidar-dropout@2.5").expect("parses");
        assert_eq!(g.duration_ns, 5_000_000_000);
        assert_eq!(g.to_string(), "lidar-dropout@2.5+5");
        assert!(g.active(2_500_000_000) && !g.active(7_500_000_000));
        for (_, name) in KINDS {
            let s = format!("{name}@1+2");
            assert_eq!(FaultSpec::parse(&s).expect("parses").kind.name(), name);
        }
    }

    #[test]
    fn bad_specs_say_what_is_wrong() {
        for (s, says) in [
            ("lidar-dropout", "no start time"),
            ("laser-dropout@3", "unknown fault \"laser-dropout\""),
            ("imu-dropout@x", "is not a number"),
            ("imu-dropout@-1", "not within"),
            ("imu-dropout@NaN", "not within"),
            ("imu-dropout@1+0", "more than 0"),
            ("stuck-wheel@1+1:5", "is not 1, 2, 3 or 4"),
        ] {
            let e = FaultSpec::parse(s).expect_err(s);
            assert!(e.contains(says), "{s}: {e}");
        }
    }
}
