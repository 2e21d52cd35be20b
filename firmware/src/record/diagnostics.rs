//! The rover's health as one `diagnostic_msgs/DiagnosticArray`: a status for
//! the executive, one per watched source, one for the findings and one with
//! the decoder and transport counters.

use speleo_hal::xsens_config::ConfigState;
use speleo_health::{finding, SOURCE_NAMES};
use speleo_messages::{Counters, HealthReport};
use speleo_scheduler::mailbox::Stamped as Published;
use speleo_scheduler::Mode;

use crate::record::cdr::CdrWriter;
use crate::record::messages::{imu_config_name, mode_name};
use crate::record::ros2::{decimal, header};
use crate::record::{RecorderTap, Topic};

/// The decoder and transport counters, by the names the recording gives them.
fn counter_values(c: &Counters) -> [(&'static str, u64); 16] {
    [
        ("imu_frames", c.imu.frames),
        ("imu_bad_checksums", c.imu.bad_checksums),
        ("imu_skipped_bytes", c.imu.skipped_bytes),
        ("imu_oversize", c.imu.oversize),
        ("imu_bad_items", c.imu_bad_items),
        ("imu_other_messages", c.imu_other_messages),
        ("imu_samples_lost", c.imu_samples_lost),
        ("can_frames", c.can_frames),
        ("can_malformed", c.can_malformed),
        ("can_unmapped", c.can_unmapped),
        ("can_bad_length", c.can_bad_length),
        ("can_tx_dropped", c.can_tx_dropped),
        ("raw_dropped", c.raw_dropped),
        ("hal_errors", c.hal_errors),
        ("can_errors", c.can_errors),
        ("can_transport_dropped", c.can_transport_dropped),
    ]
}

/// `diagnostic_msgs/DiagnosticStatus` levels.
const OK: u8 = 0;
const WARN: u8 = 1;
const ERROR: u8 = 2;

/// The health report `h`, the executive's mode, the IMU's configuration
/// state and the counters as one `diagnostic_msgs/DiagnosticArray`: a
/// status for the executive, one per watched source, one for the findings
/// and one with the counters.
pub(crate) fn emit_health(
    tap: &mut RecorderTap,
    (frame, now): (u64, u64),
    h: &Published<HealthReport>,
    mode: Mode,
    imu_config: ConfigState,
    counters: &Counters,
) {
    let stamp = tap.time(h.stamp_ns);
    let report = h.value;
    let mode = if report.safe_mode {
        "safe"
    } else {
        mode_name(mode)
    };
    let counters = counter_values(counters);
    tap.emit(Topic::Health, frame, now, h.stamp_ns, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, "base_link")?;
        c.sequence_len(1 + SOURCE_NAMES.len() + 2)?;
        let mut digits = [0; 20];

        c.u8(if mode == "safe" { WARN } else { OK })?;
        c.string("speleo: executive")?;
        c.string(mode)?;
        c.string("speleo")?;
        c.sequence_len(2)?;
        c.string("imu_config")?;
        c.string(imu_config_name(imu_config))?;
        c.string("drive_faults")?;
        c.string(decimal(report.drive_faults as u64, &mut digits))?;

        for (i, name) in SOURCE_NAMES.iter().enumerate() {
            let stale = report.stale_mask & (1 << i) != 0;
            c.u8(if stale { ERROR } else { OK })?;
            c.string(name)?;
            c.string(if stale { "stale" } else { "fresh" })?;
            c.string(name)?;
            c.sequence_len(0)?;
        }

        let findings = || finding::names(report.findings);
        c.u8(if report.findings != 0 { WARN } else { OK })?;
        c.string("speleo: findings")?;
        c.string_joined(findings(), ", ")?;
        c.string("speleo")?;
        c.sequence_len(findings().count())?;
        for f in findings() {
            c.string(f)?;
            c.string("true")?;
        }

        c.u8(OK)?;
        c.string("speleo: counters")?;
        c.string("")?;
        c.string("speleo")?;
        c.sequence_len(counters.len())?;
        for (name, v) in counters {
            c.string(name)?;
            c.string(decimal(v, &mut digits))?;
        }
        Ok(())
    });
}
