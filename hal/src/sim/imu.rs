//! Twin of the Xsens MTi: MTData2 frames with orientation, acceleration,
//! rate of turn, packet counter, sample time and status, with white noise and
//! a gyro bias random walk from a datasheet-like model.

use super::noise::Noise;
use super::rover::Rover;
use crate::mtdata2::Precision;
use crate::outbox::Outbox;
use crate::xbus::{self, XbusDecoder};
use crate::xsens_config::{OutputConfig, MID_SET_OUTPUT_CONFIGURATION};

#[derive(Clone, Debug, PartialEq)]
pub struct ImuParams {
    pub rate_hz: u32,
    /// Offset of the first sample from t = 0 (the device free-runs).
    pub phase_ns: u64,
    /// Gyro white noise density, rad/s/sqrt(Hz) (MTi-300: 0.01 deg/s/sqrt(Hz)).
    pub gyro_noise_density: f64,
    /// Accelerometer white noise density, m/s^2/sqrt(Hz) (MTi-300: 60 ug/sqrt(Hz)).
    pub accel_noise_density: f64,
    /// Standard deviation of the initial gyro bias, rad/s.
    pub gyro_bias_sigma: f64,
    /// Gyro bias random walk, rad/s/sqrt(s).
    pub gyro_bias_walk: f64,
    /// Serial line speed; sets when the last byte of a frame arrives.
    pub baud: u32,
}

impl Default for ImuParams {
    fn default() -> Self {
        ImuParams {
            rate_hz: 100,
            phase_ns: 3_000_000,
            gyro_noise_density: 0.01_f64.to_radians(),
            accel_noise_density: 60e-6 * 9.81,
            gyro_bias_sigma: 5e-4,
            gyro_bias_walk: 2e-5,
            baud: 921_600,
        }
    }
}

pub const GRAVITY: f64 = 9.81;

pub struct SimImu {
    p: ImuParams,
    noise: Noise,
    period_ns: u64,
    next_sample_ns: u64,
    counter: u16,
    gyro_bias: [f64; 3],
    /// The device's own yaw estimate (integrated gyro: drifts with the bias).
    yaw_estimate: f64,
    last_sample_ns: u64,
    outbox: Outbox<16, 256>,
    /// Streaming (measurement mode) or waiting for configuration.
    measuring: bool,
    config: OutputConfig,
    commands: XbusDecoder,
    /// Time of the latest sample, for stamping answers to commands.
    now_ns: u64,
    sample: usize,
}

/// Delay between a command and its acknowledgement.
const ANSWER_NS: u64 = 500_000;

/// Data ids the twin can produce (any precision / coordinate bits).
fn supported(id: u16) -> bool {
    matches!(
        id & 0xFFF0,
        0x1020 | 0x1060 | 0x2010 | 0x4020 | 0x8020 | 0xE020
    )
}

impl SimImu {
    pub fn new(p: ImuParams, seed: u64) -> Self {
        let mut noise = Noise::new(seed, 0x1_0001);
        let gyro_bias = [
            noise.gaussian() * p.gyro_bias_sigma,
            noise.gaussian() * p.gyro_bias_sigma,
            noise.gaussian() * p.gyro_bias_sigma,
        ];
        let period_ns = 1_000_000_000 / p.rate_hz.max(1) as u64;
        SimImu {
            next_sample_ns: p.phase_ns,
            p,
            noise,
            period_ns,
            counter: 0,
            gyro_bias,
            yaw_estimate: 0.0,
            last_sample_ns: 0,
            outbox: Outbox::new(),
            // A powered MTi streams its stored configuration.
            measuring: true,
            config: OutputConfig::speleo(100),
            commands: XbusDecoder::new(),
            now_ns: 0,
            sample: 0,
        }
    }

    pub(crate) fn outbox(&mut self) -> &mut Outbox<16, 256> {
        &mut self.outbox
    }

    fn answer(&mut self, mid: u8, payload: &[u8]) {
        let mut f: heapless::Vec<u8, 256> = heapless::Vec::new();
        if xbus::encode_frame(mid, payload, &mut f) {
            self.outbox.push(self.now_ns + ANSWER_NS, &f);
        }
    }

    /// Bytes from the master on the serial line.
    pub fn receive(&mut self, bytes: &[u8]) {
        let mut decoder = core::mem::take(&mut self.commands);
        let mut frames: heapless::Vec<(u8, heapless::Vec<u8, 256>), 4> = heapless::Vec::new();
        decoder.push(bytes, &mut |f| {
            let _ = frames.push((
                f.mid,
                heapless::Vec::from_slice(f.payload).unwrap_or_default(),
            ));
        });
        self.commands = decoder;
        for (mid, payload) in frames {
            match mid {
                xbus::MID_GOTO_CONFIG => {
                    self.measuring = false;
                    self.answer(mid + 1, &[]);
                }
                xbus::MID_GOTO_MEASUREMENT => {
                    self.measuring = true;
                    self.answer(mid + 1, &[]);
                }
                MID_SET_OUTPUT_CONFIGURATION if !self.measuring => {
                    match OutputConfig::parse(&payload) {
                        Ok(c) if c.entries.iter().all(|(id, _)| supported(*id)) => {
                            self.config = c;
                            self.answer(mid + 1, &payload);
                        }
                        // Invalid parameter.
                        _ => self.answer(xbus::MID_ERROR, &[0x21]),
                    }
                }
                // Invalid message (in this mode).
                _ => self.answer(xbus::MID_ERROR, &[0x04]),
            }
        }
    }

    pub fn dropped(&self) -> u64 {
        self.outbox.dropped()
    }

    /// Take a sample if one is due at `t_ns`.
    pub fn maybe_sample(&mut self, t_ns: u64, rover: &Rover) {
        if t_ns < self.next_sample_ns {
            return;
        }
        self.next_sample_ns += self.period_ns;
        let dt = (t_ns - self.last_sample_ns) as f64 * 1e-9;
        self.last_sample_ns = t_ns;
        let rate = self.p.rate_hz as f64;
        let g_sigma = self.p.gyro_noise_density * libm::sqrt(rate);
        let a_sigma = self.p.accel_noise_density * libm::sqrt(rate);
        let walk = self.p.gyro_bias_walk * libm::sqrt(dt);
        for b in self.gyro_bias.iter_mut() {
            *b += self.noise.gaussian() * walk;
        }
        let gyro = [
            self.gyro_bias[0] + self.noise.gaussian() * g_sigma,
            self.gyro_bias[1] + self.noise.gaussian() * g_sigma,
            rover.yaw_rate + self.gyro_bias[2] + self.noise.gaussian() * g_sigma,
        ];
        let acc = [
            rover.accel + self.noise.gaussian() * a_sigma,
            rover.speed * rover.yaw_rate + self.noise.gaussian() * a_sigma,
            GRAVITY + self.noise.gaussian() * a_sigma,
        ];
        self.yaw_estimate = super::rover::wrap_angle(self.yaw_estimate + gyro[2] * dt);
        let half = 0.5 * self.yaw_estimate;
        let q = [libm::cos(half), 0.0, 0.0, libm::sin(half)];
        self.counter = self.counter.wrapping_add(1);
        self.now_ns = t_ns;
        self.sample += 1;
        if !self.measuring {
            return;
        }
        let mut payload: heapless::Vec<u8, 255> = heapless::Vec::new();
        let rate = self.p.rate_hz.max(1) as usize;
        for &(id, freq) in &self.config.entries {
            // Decimate items asked for at a lower rate.
            let every = if freq == 0xFFFF || freq == 0 {
                1
            } else {
                (rate / freq as usize).max(1)
            };
            if !self.sample.is_multiple_of(every) {
                continue;
            }
            let mut item = [0u8; 3 + 8 * 4];
            let n = match id & 0xFFF0 {
                0x1020 => {
                    item[3..5].copy_from_slice(&self.counter.to_be_bytes());
                    2
                }
                0x1060 => {
                    item[3..7].copy_from_slice(&((t_ns / 100_000) as u32).to_be_bytes());
                    4
                }
                0xE020 => {
                    item[3..7].copy_from_slice(&3u32.to_be_bytes());
                    4
                }
                group => {
                    let values: &[f64] = match group {
                        0x2010 => &q,
                        0x4020 => &acc,
                        _ => &gyro,
                    };
                    let p = Precision::from_id(id);
                    for (k, v) in values.iter().enumerate() {
                        p.write(*v, &mut item[3 + k * p.size()..]);
                    }
                    values.len() * p.size()
                }
            };
            item[..2].copy_from_slice(&id.to_be_bytes());
            item[2] = n as u8;
            let _ = payload.extend_from_slice(&item[..3 + n]);
        }
        let mut frame: heapless::Vec<u8, 256> = heapless::Vec::new();
        if xbus::encode_frame(xbus::MID_MTDATA2, &payload, &mut frame) {
            // The last byte arrives after the whole frame crossed the line (10 bits a byte).
            let wire_ns = frame.len() as u64 * 10 * 1_000_000_000 / self.p.baud.max(1) as u64;
            self.outbox.push(t_ns + wire_ns, &frame);
        }
    }
}
