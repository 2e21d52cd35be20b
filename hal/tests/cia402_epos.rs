//! The maxon EPOS enable sequence captured in ../shared/data/can (node 2):
//! fed the drive's statuswords, the supervisor answers with the controlwords
//! the real master sent, and the drive reaches operation enabled. Skipped
//! when the data is absent.

use speleo_hal::can::CanFrame;
use speleo_hal::canopen::sdo::Sdo;
use speleo_hal::canopen::supervisor::{DrivesState, InputCounters, Supervisor, SupervisorParams};
use speleo_hal::canopen::{heartbeat, NmtState};
use speleo_hal::cia402::{self, DriveState, Pdo};

/// `0x182 | 40 07 | meaning` lines of the trace.
fn trace() -> Option<Vec<CanFrame>> {
    let p = speleo_hal::shared_data::path("can/machinekit_issue589_maxon_epos_ds402_enable.txt")?;
    let text = std::fs::read_to_string(p).ok()?;
    let mut frames = Vec::new();
    for line in text.lines().filter(|l| l.starts_with("0x")) {
        let mut cols = line.split('|');
        let id = u16::from_str_radix(cols.next()?.trim().trim_start_matches("0x"), 16).ok()?;
        let data: Vec<u8> = cols
            .next()?
            .split_whitespace()
            .map(|b| u8::from_str_radix(b, 16))
            .collect::<Result<_, _>>()
            .ok()?;
        frames.push(CanFrame::new(id, &data));
    }
    Some(frames)
}

#[test]
fn the_captured_epos_sequence_reaches_operation_enabled() {
    let Some(frames) = trace() else {
        return;
    };
    // The PDO part of the trace: statuswords from 0x182, controlwords to 0x202.
    let pdo: Vec<&CanFrame> = frames
        .iter()
        .filter(|f| f.id == 0x182 || f.id == 0x202)
        .collect();
    assert_eq!(pdo.len(), 7);
    let mut st = DrivesState::default();
    let mut c = InputCounters::default();
    // Node 2 is up, in profile velocity mode and operational (CANopen side).
    st.apply(&heartbeat(2, NmtState::Operational), 1, &mut c);
    st.apply(
        &Sdo::DownloadResponse {
            index: 0x6060,
            sub: 0,
        }
        .response(2),
        1,
        &mut c,
    );
    let mut sup = Supervisor::new(SupervisorParams {
        heartbeat_timeout_ns: u64::MAX / 2,
        command_timeout_ns: 100_000_000,
        retry_ns: 100_000_000,
        boot_grace_ns: u64::MAX / 2,
        max_velocity: 10_000,
        fault_reset_ns: 0,
    });
    let mut t = 10;
    let mut checked = 0;
    for pair in pdo.windows(2) {
        let (status, next) = (pair[0], pair[1]);
        if status.id != 0x182 || next.id != 0x202 {
            continue;
        }
        // The trace's statusword PDO carries 2 bytes; ours also carries velocity.
        let sw = u16::from_le_bytes([status.payload()[0], status.payload()[1]]);
        st.apply(&cia402::tpdo1(2, sw, 0), t, &mut c);
        let mut sent = Vec::new();
        sup.plan(t, &st, Some((t, [0.0; 4])), false, &mut |f| sent.push(f));
        let ours = sent.iter().find_map(|f| match cia402::decode(f) {
            Ok(Pdo::Command {
                node: 2,
                controlword,
                ..
            }) => Some(controlword),
            _ => None,
        });
        let theirs = u16::from_le_bytes([next.payload()[0], next.payload()[1]]);
        assert_eq!(ours, Some(theirs), "after statusword 0x{sw:04X}");
        checked += 1;
        t += 10_000_000;
    }
    assert_eq!(checked, 3);
    let last = pdo.last().expect("trace");
    let sw = u16::from_le_bytes([last.payload()[0], last.payload()[1]]);
    st.apply(&cia402::tpdo1(2, sw, 0), t, &mut c);
    assert_eq!(st.nodes[1].state, DriveState::OperationEnabled);
    // The SDO read of the statusword in the same trace agrees.
    let sdo = frames.iter().find(|f| f.id == 0x582).expect("SDO answer");
    assert_eq!(
        Sdo::parse_response(sdo.payload()),
        Some(Sdo::UploadResponse {
            index: 0x6041,
            sub: 0,
            value: 0x0737,
            len: 2
        })
    );
}
