//! The configuration exchange an MTi needs before it streams what Speleo
//! reads: GoToConfig, SetOutputConfiguration, GoToMeasurement, each answered
//! by an acknowledgement (message id + 1) or an Error message (0x42).
//!
//! [`ConfigSession`] is the master side as a state machine driven by time and
//! received frames; it never blocks, so the IMU driver can run it inside its
//! periodic task. [`OutputConfig`] is the SetOutputConfiguration payload:
//! `{data id: u16, frequency: u16}` pairs, 0xFFFF meaning "as fast as possible".

use crate::xbus::{self, XbusFrame};

pub const MID_SET_OUTPUT_CONFIGURATION: u8 = 0xC0;
pub const MID_GOTO_CONFIG_ACK: u8 = 0x31;
pub const MID_GOTO_MEASUREMENT_ACK: u8 = 0x11;
pub const MID_SET_OUTPUT_CONFIGURATION_ACK: u8 = 0xC1;
/// Most entries an output configuration holds.
pub const MAX_OUTPUTS: usize = 32;
/// Frequency value meaning "every sample".
pub const MAX_FREQUENCY: u16 = 0xFFFF;

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct OutputConfig {
    pub entries: heapless::Vec<(u16, u16), MAX_OUTPUTS>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputConfigError {
    OddLength(usize),
    TooMany(usize),
}

impl OutputConfig {
    /// What Speleo's drivers read: counters and time, orientation,
    /// acceleration and rate of turn at `rate_hz`, status.
    pub fn speleo(rate_hz: u16) -> Self {
        let mut c = OutputConfig::default();
        for e in [
            (xbus::did::PACKET_COUNTER, MAX_FREQUENCY),
            (xbus::did::SAMPLE_TIME_FINE, MAX_FREQUENCY),
            (xbus::did::QUATERNION, rate_hz),
            (xbus::did::ACCELERATION, rate_hz),
            (xbus::did::RATE_OF_TURN, rate_hz),
            (xbus::did::STATUS_WORD, MAX_FREQUENCY),
        ] {
            let _ = c.entries.push(e);
        }
        c
    }

    pub fn parse(payload: &[u8]) -> Result<Self, OutputConfigError> {
        if !payload.len().is_multiple_of(4) {
            return Err(OutputConfigError::OddLength(payload.len()));
        }
        if payload.len() / 4 > MAX_OUTPUTS {
            return Err(OutputConfigError::TooMany(payload.len() / 4));
        }
        let mut c = OutputConfig::default();
        for e in payload.chunks_exact(4) {
            let _ = c.entries.push((
                u16::from_be_bytes([e[0], e[1]]),
                u16::from_be_bytes([e[2], e[3]]),
            ));
        }
        Ok(c)
    }

    pub fn payload(&self) -> heapless::Vec<u8, { MAX_OUTPUTS * 4 }> {
        let mut out = heapless::Vec::new();
        for (id, f) in &self.entries {
            let _ = out.extend_from_slice(&id.to_be_bytes());
            let _ = out.extend_from_slice(&f.to_be_bytes());
        }
        out
    }
}

/// Xsens error codes (Error message payload).
pub fn error_name(code: u8) -> &'static str {
    match code {
        0x03 => "invalid period",
        0x04 => "invalid message",
        0x1E => "timer overflow",
        0x20 => "invalid baud rate",
        0x21 => "invalid parameter",
        0x28 => "device error",
        0x29 => "data overflow",
        0x2A => "buffer overflow",
        _ => "unknown error",
    }
}

/// Where the exchange is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigState {
    GoingToConfig,
    SettingOutputs,
    GoingToMeasurement,
    /// The device streams the configured outputs.
    Measuring,
    /// The device answered with an error, or never answered.
    Failed(ConfigFailure),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigFailure {
    /// Error message from the device, with its code, during `step`.
    DeviceError { step: u8, code: u8 },
    /// No acknowledgement after all retries for the message `step`.
    NoAnswer { step: u8 },
    /// The device acknowledged a different output configuration.
    ConfigMismatch,
}

impl core::fmt::Display for ConfigFailure {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ConfigFailure::DeviceError { step, code } => write!(
                f,
                "MTi refused message 0x{step:02X}: error 0x{code:02X} ({})",
                error_name(*code)
            ),
            ConfigFailure::NoAnswer { step } => {
                write!(f, "MTi did not acknowledge message 0x{step:02X}")
            }
            ConfigFailure::ConfigMismatch => {
                write!(f, "MTi acknowledged a different output configuration")
            }
        }
    }
}

/// The master side of the exchange. Call [`ConfigSession::poll`] every
/// frame with the time; it returns the frame to send, if any. Feed every
/// received frame to [`ConfigSession::on_frame`].
pub struct ConfigSession {
    config: OutputConfig,
    state: ConfigState,
    sent_at: Option<u64>,
    attempts: u32,
    timeout_ns: u64,
    max_attempts: u32,
}

impl ConfigSession {
    pub fn new(config: OutputConfig, timeout_ns: u64, max_attempts: u32) -> Self {
        ConfigSession {
            config,
            state: ConfigState::GoingToConfig,
            sent_at: None,
            attempts: 0,
            timeout_ns,
            max_attempts: max_attempts.max(1),
        }
    }

    pub fn state(&self) -> ConfigState {
        self.state
    }

    fn current_message(&self) -> Option<u8> {
        match self.state {
            ConfigState::GoingToConfig => Some(xbus::MID_GOTO_CONFIG),
            ConfigState::SettingOutputs => Some(MID_SET_OUTPUT_CONFIGURATION),
            ConfigState::GoingToMeasurement => Some(xbus::MID_GOTO_MEASUREMENT),
            _ => None,
        }
    }

    /// The frame to send now (first try or a retry after the timeout).
    pub fn poll(&mut self, now_ns: u64) -> Option<heapless::Vec<u8, 256>> {
        let mid = self.current_message()?;
        if let Some(t) = self.sent_at {
            if now_ns.saturating_sub(t) < self.timeout_ns {
                return None;
            }
            if self.attempts >= self.max_attempts {
                self.state = ConfigState::Failed(ConfigFailure::NoAnswer { step: mid });
                return None;
            }
        }
        self.sent_at = Some(now_ns);
        self.attempts += 1;
        let mut out = heapless::Vec::new();
        let payload = if mid == MID_SET_OUTPUT_CONFIGURATION {
            self.config.payload()
        } else {
            heapless::Vec::new()
        };
        xbus::encode_frame(mid, &payload, &mut out);
        Some(out)
    }

    /// A frame from the device. Returns true when it was part of the exchange.
    pub fn on_frame(&mut self, f: &XbusFrame<'_>) -> bool {
        let Some(mid) = self.current_message() else {
            return false;
        };
        if f.mid == xbus::MID_ERROR {
            let code = f.payload.first().copied().unwrap_or(0);
            self.state = ConfigState::Failed(ConfigFailure::DeviceError { step: mid, code });
            return true;
        }
        if f.mid != mid.wrapping_add(1) {
            return false;
        }
        if mid == MID_SET_OUTPUT_CONFIGURATION
            && OutputConfig::parse(f.payload).ok().as_ref() != Some(&self.config)
        {
            self.state = ConfigState::Failed(ConfigFailure::ConfigMismatch);
            return true;
        }
        self.state = match self.state {
            ConfigState::GoingToConfig => ConfigState::SettingOutputs,
            ConfigState::SettingOutputs => ConfigState::GoingToMeasurement,
            _ => ConfigState::Measuring,
        };
        self.sent_at = None;
        self.attempts = 0;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::xbus::XbusDecoder;

    fn frame_of(bytes: &[u8]) -> (u8, Vec<u8>) {
        let mut d = XbusDecoder::new();
        let mut got = None;
        d.push(bytes, &mut |f| got = Some((f.mid, f.payload.to_vec())));
        got.expect("one frame")
    }

    #[test]
    fn the_recorded_output_configuration_parses() {
        let Some(p) = crate::shared_data::path("xsens/1/outputconfig.bin") else {
            return;
        };
        let bytes = std::fs::read(&p).expect("readable");
        let c = OutputConfig::parse(&bytes).expect("parses");
        assert_eq!(c.entries.len(), 13);
        assert_eq!(c.entries[0], (0x1020, 0xFFFF));
        assert_eq!(c.entries[4], (0x2030, 100));
        assert_eq!(c.entries[12], (0x7010, 4));
        assert_eq!(&c.payload()[..], &bytes[..]);
    }

    #[test]
    fn a_full_exchange_reaches_measurement() {
        let cfg = OutputConfig::speleo(100);
        let mut s = ConfigSession::new(cfg.clone(), 100, 3);
        let ack = |mid: u8, payload: &[u8]| -> Vec<u8> {
            let mut v: heapless::Vec<u8, 256> = heapless::Vec::new();
            xbus::encode_frame(mid, payload, &mut v);
            v.to_vec()
        };
        let sent = s.poll(0).expect("GoToConfig");
        assert_eq!(frame_of(&sent).0, 0x30);
        assert!(s.poll(50).is_none(), "waits for the answer");
        let a = ack(0x31, &[]);
        let mut d = XbusDecoder::new();
        d.push(&a, &mut |f| assert!(s.on_frame(&f)));
        let sent = s.poll(60).expect("SetOutputConfiguration");
        let (mid, payload) = frame_of(&sent);
        assert_eq!(mid, 0xC0);
        assert_eq!(OutputConfig::parse(&payload), Ok(cfg.clone()));
        d.push(&ack(0xC1, &payload), &mut |f| assert!(s.on_frame(&f)));
        assert_eq!(frame_of(&s.poll(70).expect("GoToMeasurement")).0, 0x10);
        d.push(&ack(0x11, &[]), &mut |f| assert!(s.on_frame(&f)));
        assert_eq!(s.state(), ConfigState::Measuring);
        assert!(s.poll(1000).is_none());
    }

    #[test]
    fn errors_and_silence_fail_with_a_reason() {
        let mut s = ConfigSession::new(OutputConfig::speleo(100), 100, 2);
        s.poll(0);
        let mut v: heapless::Vec<u8, 16> = heapless::Vec::new();
        xbus::encode_frame(0x42, &[0x04], &mut v);
        let mut d = XbusDecoder::new();
        d.push(&v, &mut |f| assert!(s.on_frame(&f)));
        assert_eq!(
            s.state(),
            ConfigState::Failed(ConfigFailure::DeviceError {
                step: 0x30,
                code: 0x04
            })
        );
        let mut s = ConfigSession::new(OutputConfig::speleo(100), 100, 2);
        assert!(s.poll(0).is_some());
        assert!(s.poll(100).is_some(), "one retry");
        assert!(s.poll(200).is_none());
        assert_eq!(
            s.state(),
            ConfigState::Failed(ConfigFailure::NoAnswer { step: 0x30 })
        );
        assert!(s.state() != ConfigState::Measuring);
    }
}
