//! `speleo decode can`: a candump log as CANopen / CiA 402 events.

use std::io::Write;
use std::path::Path;

use speleo_hal::canopen::candump::{parse_line, LineError};
use speleo_hal::canopen::sdo::{abort_text, Sdo};
use speleo_hal::canopen::{classify, Event};
use speleo_hal::cia402::{DriveState, Pdo};

use crate::Error;

fn object(index: u16) -> &'static str {
    match index {
        0x1000 => "device type",
        0x1017 => "producer heartbeat time",
        0x1018 => "identity",
        0x6040 => "controlword",
        0x6041 => "statusword",
        0x6060 => "modes of operation",
        0x6061 => "modes of operation display",
        0x6064 => "position actual value",
        0x606C => "velocity actual value",
        0x60FF => "target velocity",
        _ => "object",
    }
}

fn controlword(cw: u16) -> &'static str {
    if cw & 0x80 != 0 {
        "fault reset"
    } else if cw & 0x0F == 0x0F {
        "enable operation"
    } else if cw & 0x0F == 0x07 {
        "switch on"
    } else if cw & 0x07 == 0x06 {
        "shutdown"
    } else if cw & 0x06 == 0x02 {
        "quick stop"
    } else if cw & 0x02 == 0 {
        "disable voltage"
    } else {
        "other"
    }
}

fn sdo_text(sdo: &Sdo) -> String {
    match *sdo {
        Sdo::UploadRequest { index, sub } => {
            format!("read 0x{index:04X}:{sub:02X} ({})", object(index))
        }
        Sdo::UploadResponse {
            index,
            sub,
            value,
            len,
        } => {
            let extra = match (index, value) {
                (0x1000, v) if v & 0xFFFF == 0x0192 => " (CiA 402 drive)".to_string(),
                (0x6041, v) => format!(" ({:?})", DriveState::from_statusword(v as u16)),
                (0x6040, v) => format!(" ({})", controlword(v as u16)),
                _ => String::new(),
            };
            format!(
                "0x{index:04X}:{sub:02X} ({}) = 0x{value:0w$X}{extra}",
                object(index),
                w = 2 * len as usize
            )
        }
        Sdo::DownloadRequest {
            index,
            sub,
            value,
            len,
        } => {
            let extra = if index == 0x6040 {
                format!(" ({})", controlword(value as u16))
            } else {
                String::new()
            };
            format!(
                "write 0x{index:04X}:{sub:02X} ({}) = 0x{value:0w$X}{extra}",
                object(index),
                w = 2 * len as usize
            )
        }
        Sdo::DownloadResponse { index, sub } => format!("0x{index:04X}:{sub:02X} written"),
        Sdo::Abort { index, sub, code } => {
            format!(
                "abort 0x{index:04X}:{sub:02X}: 0x{code:08X} ({})",
                abort_text(code)
            )
        }
    }
}

pub fn describe(e: &Event) -> String {
    match e {
        Event::Nmt { command, node } => {
            let who = if *node == 0 { "all nodes".to_string() } else { format!("node {node}") };
            format!("NMT {command:?} {who}")
        }
        Event::Sync => "SYNC".into(),
        Event::Emcy {
            node,
            code,
            register,
        } => format!("EMCY node {node}: error code 0x{code:04X}, register 0x{register:02X}"),
        Event::Heartbeat { node, state } => format!("heartbeat node {node}: {state:?}"),
        Event::Pdo(Pdo::Command {
            node,
            controlword: cw,
            target_velocity,
        }) => format!(
            "RPDO1 node {node}: controlword 0x{cw:04X} ({}), target velocity {target_velocity} mrad/s",
            controlword(*cw)
        ),
        Event::Pdo(Pdo::Status {
            node,
            statusword,
            velocity,
        }) => format!(
            "TPDO1 node {node}: statusword 0x{statusword:04X} ({:?}), velocity {velocity} mrad/s",
            DriveState::from_statusword(*statusword)
        ),
        Event::Pdo(Pdo::Position {
            node,
            position,
            torque: None,
        }) => format!("TPDO2 node {node}: position {position}"),
        Event::Pdo(Pdo::Position {
            node,
            position,
            torque: Some(t),
        }) => format!(
            "TPDO2 node {node}: position {position}, torque {t}/1000 of rated ({:.3} N m)",
            speleo_hal::cia402::torque_nm(*t)
        ),
        Event::Pdo(Pdo::Sync) => "SYNC".into(),
        Event::SdoRequest { node, sdo } => format!("SDO to node {node}: {}", sdo_text(sdo)),
        Event::SdoResponse { node, sdo } => format!("SDO from node {node}: {}", sdo_text(sdo)),
        Event::Other { id } => format!("other traffic (COB-ID 0x{id:03X})"),
        Event::Malformed { id, len } => format!("malformed frame (COB-ID 0x{id:03X}, {len} bytes)"),
    }
}

pub fn run(file: &Path, out: &mut dyn Write) -> Result<(), Error> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let (mut frames, mut unreadable, mut fd, mut malformed) = (0u64, 0u64, 0u64, 0u64);
    for (i, line) in text.lines().enumerate() {
        match parse_line(i + 1, line) {
            Ok(None) => {}
            Ok(Some(f)) => {
                frames += 1;
                let e = classify(&f.frame);
                if matches!(e, Event::Malformed { .. }) {
                    malformed += 1;
                }
                let t = f.time_s.map_or(String::new(), |t| format!("({t:.6}) "));
                writeln!(
                    out,
                    "{t}{} {:03X}: {}",
                    f.interface,
                    f.frame.id,
                    describe(&e)
                )?;
            }
            Err(LineError::CanFd(n)) => {
                fd += 1;
                writeln!(
                    out,
                    "line {n}: CAN FD frame (not used by the drives), skipped"
                )?;
            }
            Err(LineError::Unreadable(n, why)) => {
                unreadable += 1;
                writeln!(out, "line {n}: unreadable ({why}), skipped")?;
            }
        }
    }
    writeln!(
        out,
        "{frames} frames ({malformed} malformed), {unreadable} unreadable lines, {fd} CAN FD lines"
    )?;
    if frames == 0 {
        return Err(format!(
            "no CAN frame in {} (a candump log: `(time) iface id#data` lines)",
            file.display()
        )
        .into());
    }
    Ok(())
}
