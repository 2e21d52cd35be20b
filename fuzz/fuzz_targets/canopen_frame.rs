//! Any 16-byte SocketCAN records through the CAN, CANopen and CiA 402
//! decoders, the drive state tracking and the supervisor.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_hal::can::CanFrame;
use speleo_hal::canopen::classify;
use speleo_hal::canopen::supervisor::{DrivesState, InputCounters, Supervisor, SupervisorParams};

fuzz_target!(|data: &[u8]| {
    let mut st = DrivesState::default();
    let mut c = InputCounters::default();
    let mut sup = Supervisor::new(SupervisorParams {
        heartbeat_timeout_ns: 300,
        command_timeout_ns: 100,
        retry_ns: 50,
        boot_grace_ns: 1000,
        max_velocity: 5000,
    });
    for (t, rec) in data.chunks(16).enumerate() {
        let Ok(f) = CanFrame::from_socketcan(rec) else {
            continue;
        };
        let _ = classify(&f);
        st.apply(&f, t as u64 * 10, &mut c);
        let mut n = 0;
        let r = sup.plan(t as u64 * 10, &st, Some((t as u64 * 10, [1.0; 4])), false, &mut |_| n += 1);
        // Never a velocity while something holds the wheels: checked by the
        // unit tests; here only that it terminates with at most 4 PDOs + SYNC
        // + bring-up frames.
        assert!(n <= 9, "{n} frames, {r:?}");
    }
});
