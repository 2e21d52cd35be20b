//! Where injected faults act: [`FaultyHardware`] stands between the tasks
//! and the hardware (devices that go quiet or talk noise, a blocked or
//! spinning wheel, a drive fault, a bus-off controller, slow device polls),
//! and [`FaultClock`] makes the frame clock jump.
//!
//! On recorded inputs only the faults that are not wholly in the recorded
//! bytes are injected again (see [`FaultKind::injected_in_replay`]).

use super::FaultKind;

use std::time::{Duration, Instant};

use speleo_hal::replay::ReplayHardware;
use speleo_hal::{CanBus, CanFrame, Device, HalError, Hardware, ImuPort, InputSink, LidarSource};
use speleo_scheduler::FrameClock;
use speleo_twin::drives::DrivesTwin;
use speleo_twin::TwinHardware;

use super::FaultSpec;

/// How far a slipping wheel's encoder turns for each turn it rolls.
pub const SPIN_FACTOR: f64 = 2.5;
/// How long each device poll takes during an overrun storm.
pub const STORM_POLL: Duration = Duration::from_millis(3);

/// Hardware that faults can be injected into.
pub trait FaultTarget: Hardware {
    /// The simulated drives, when the hardware is simulated.
    fn sim_drives(&mut self) -> Option<&mut DrivesTwin> {
        None
    }
}

impl FaultTarget for TwinHardware {
    fn sim_drives(&mut self) -> Option<&mut DrivesTwin> {
        Some(self.drives_mut())
    }
}

impl FaultTarget for ReplayHardware {}

/// `inner` with `faults` injected.
pub struct FaultyHardware<'a, H: FaultTarget> {
    inner: &'a mut H,
    faults: Vec<FaultSpec>,
    /// Whether each fault's effect on the simulated drives is in place.
    applied: Vec<bool>,
    /// The noise an IMU line delivers (xorshift64*, fixed seed).
    noise: u64,
}

impl<'a, H: FaultTarget> FaultyHardware<'a, H> {
    /// Inject every fault of `faults` (a simulation), or with `recorded`
    /// only those a recording does not hold (a replay).
    pub fn new(inner: &'a mut H, faults: &[FaultSpec], recorded: bool) -> Self {
        let faults: Vec<FaultSpec> = faults
            .iter()
            .filter(|f| !recorded || f.kind.injected_in_replay())
            .copied()
            .collect();
        FaultyHardware {
            applied: vec![false; faults.len()],
            inner,
            faults,
            noise: 0x9E37_79B9_7F4A_7C15,
        }
    }

    fn active(&self, kind: FaultKind, t_ns: u64) -> bool {
        self.faults.iter().any(|f| f.kind == kind && f.active(t_ns))
    }

    /// Put the drive-side faults in place or lift them, as due at `t_ns`.
    fn apply_drive_faults(&mut self, t_ns: u64) {
        for (f, applied) in self.faults.iter().zip(self.applied.iter_mut()) {
            let want = f.active(t_ns);
            if want == *applied || !f.kind.needs_sim() {
                continue;
            }
            *applied = want;
            let Some(d) = self.inner.sim_drives() else {
                continue;
            };
            match f.kind {
                FaultKind::StuckWheel => d.set_stuck(f.wheel, want),
                FaultKind::WheelSlip => d.set_spin(f.wheel, if want { SPIN_FACTOR } else { 1.0 }),
                // Its cause clears by itself at the end.
                FaultKind::DriveFault if want => d.inject_fault_until(f.wheel, f.end_ns()),
                _ => {}
            }
        }
    }
}

/// Swallows everything.
struct Discard;

impl InputSink for Discard {
    fn input(&mut self, _: Device, _: u64, _: &[u8]) {}
}

/// Hands on inputs with their bytes replaced by noise of the same length.
struct Garble<'s> {
    sink: &'s mut dyn InputSink,
    state: &'s mut u64,
}

impl InputSink for Garble<'_> {
    fn input(&mut self, device: Device, t_ns: u64, bytes: &[u8]) {
        let mut buf = [0u8; 256];
        for chunk in bytes.chunks(buf.len()) {
            for b in buf.iter_mut().take(chunk.len()) {
                *self.state ^= *self.state >> 12;
                *self.state ^= *self.state << 25;
                *self.state ^= *self.state >> 27;
                *b = (self.state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 56) as u8;
            }
            self.sink.input(device, t_ns, &buf[..chunk.len()]);
        }
    }
}

impl<H: FaultTarget> Hardware for FaultyHardware<'_, H> {
    fn advance_to(&mut self, now_ns: u64) {
        self.apply_drive_faults(now_ns);
        self.inner.advance_to(now_ns);
    }
    fn look_ahead(&mut self, next_ns: u64) {
        // A drive fault starts or ends at a frame's start, in `advance_to`:
        // with any scheduled, the world must not move on before it.
        if self.faults.iter().all(|f| !f.kind.needs_sim()) {
            self.inner.look_ahead(next_ns);
        }
    }
    fn world_over(&self) -> bool {
        self.inner.world_over()
    }
    fn lidar(&mut self) -> &mut dyn LidarSource {
        self
    }
    fn imu(&mut self) -> &mut dyn ImuPort {
        self
    }
    fn can(&mut self) -> &mut dyn CanBus {
        self
    }
}

impl<H: FaultTarget> LidarSource for FaultyHardware<'_, H> {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        // The io task polls the LiDAR first each frame: a slow poll here
        // is a slow frame start.
        if self.active(FaultKind::OverrunStorm, now_ns) {
            let t0 = Instant::now();
            while t0.elapsed() < STORM_POLL {
                std::hint::spin_loop();
            }
        }
        if self.active(FaultKind::LidarDropout, now_ns) {
            return self.inner.lidar().poll(now_ns, &mut Discard);
        }
        self.inner.lidar().poll(now_ns, sink)
    }
}

impl<H: FaultTarget> ImuPort for FaultyHardware<'_, H> {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        if self.active(FaultKind::ImuDropout, now_ns) {
            return self.inner.imu().poll(now_ns, &mut Discard);
        }
        if self.active(FaultKind::ImuGarbage, now_ns) {
            let mut noise = self.noise;
            let r = self.inner.imu().poll(
                now_ns,
                &mut Garble {
                    sink,
                    state: &mut noise,
                },
            );
            self.noise = noise;
            return r;
        }
        self.inner.imu().poll(now_ns, sink)
    }
    fn write(&mut self, bytes: &[u8]) -> Result<(), HalError> {
        self.inner.imu().write(bytes)
    }
}

impl<H: FaultTarget> CanBus for FaultyHardware<'_, H> {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        if self.active(FaultKind::CanBusOff, now_ns) {
            // The drives' frames are lost on the wire.
            self.inner.can().poll(now_ns, &mut Discard)?;
            return Err(HalError::BusOff);
        }
        self.inner.can().poll(now_ns, sink)
    }
    fn send(&mut self, now_ns: u64, frame: &CanFrame) -> Result<(), HalError> {
        if self.active(FaultKind::CanBusOff, now_ns) {
            return Err(HalError::BusOff);
        }
        self.inner.can().send(now_ns, frame)
    }
}

/// A frame clock that jumps forward at the `clock-jump` faults: the frame
/// due at a jump's start is followed by the one the jump's length later.
pub struct FaultClock<C: FrameClock> {
    inner: C,
    /// (start, frames skipped), by start.
    jumps: Vec<(u64, u64)>,
    next: usize,
}

impl<C: FrameClock> FaultClock<C> {
    pub fn new(inner: C, faults: &[FaultSpec]) -> Self {
        let frame_ns = inner.minor_frame_ns().max(1);
        let mut jumps: Vec<(u64, u64)> = faults
            .iter()
            .filter(|f| f.kind == FaultKind::ClockJump)
            .map(|f| (f.at_ns, f.duration_ns.div_ceil(frame_ns)))
            .collect();
        jumps.sort_unstable();
        FaultClock {
            inner,
            jumps,
            next: 0,
        }
    }
}

impl<C: FrameClock> FaultClock<C> {
    /// Frames the jumps skip among the first `frames` frame numbers: a run
    /// to frame `frames - 1` executes `frames` minus this many.
    pub fn skipped_within(&self, frames: u64) -> u64 {
        let mut f = 0;
        let mut skipped = 0;
        for &(at, skip) in &self.jumps {
            // The frame a jump starts from, at the earliest where it was due.
            let from = at.div_ceil(self.inner.minor_frame_ns().max(1)).max(f);
            if from >= frames {
                break;
            }
            skipped += skip.min(frames - from);
            f = from + skip;
        }
        skipped
    }
}

impl<C: FrameClock> FrameClock for FaultClock<C> {
    fn start(&mut self) {
        self.inner.start();
    }
    fn wait_frame(&mut self, frame: u64) -> u64 {
        let mut f = self.inner.wait_frame(frame);
        while let Some(&(at, skip)) = self.jumps.get(self.next) {
            if self.inner.frame_time_ns(f) < at {
                break;
            }
            f += skip;
            self.next += 1;
        }
        f
    }
    fn frame_time_ns(&self, frame: u64) -> u64 {
        self.inner.frame_time_ns(frame)
    }
    fn minor_frame_ns(&self) -> u64 {
        self.inner.minor_frame_ns()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_scheduler::VirtualClock;

    #[test]
    fn the_clock_jumps_once_by_the_fault_s_length() {
        let f = super::super::FaultSpec::parse("clock-jump@0.05+0.1").expect("spec");
        let mut c = FaultClock::new(VirtualClock::new(10_000), &[f]);
        let frames: Vec<u64> = (0..5).map(|k| c.wait_frame(k)).collect();
        // The executive asks for the frame after the one it ran.
        assert_eq!(frames, [0, 1, 2, 3, 4]);
        assert_eq!(c.wait_frame(5), 15);
        assert_eq!(c.wait_frame(16), 16);
        assert_eq!(c.skipped_within(100), 10);
        assert_eq!(c.skipped_within(5), 0);
        assert_eq!(c.skipped_within(8), 3);
    }

    #[test]
    fn garbage_keeps_each_input_s_length_and_time() {
        struct Keep(Vec<(u64, Vec<u8>)>);
        impl InputSink for Keep {
            fn input(&mut self, _: Device, t: u64, b: &[u8]) {
                self.0.push((t, b.to_vec()));
            }
        }
        let mut keep = Keep(Vec::new());
        let mut state = 1u64;
        let mut g = Garble {
            sink: &mut keep,
            state: &mut state,
        };
        g.input(Device::Imu, 7, &[0xFA; 300]);
        let total: usize = keep.0.iter().map(|(_, b)| b.len()).sum();
        assert_eq!(total, 300);
        assert!(keep.0.iter().all(|(t, _)| *t == 7));
        assert!(keep.0[0].1.iter().any(|b| *b != 0xFA));
    }
}
