//! Twin of the Xsens MTi: MTData2 frames with orientation, acceleration,
//! rate of turn, packet counter, sample time and status, with white noise and
//! a gyro bias random walk from a datasheet-like model.
//!
//! The MTi samples far faster than it reports and integrates in between
//! (strapdown integration), so rate of turn and acceleration are the means
//! over each output interval: leg strikes are averaged, not aliased. The IMU
//! may be mounted slightly rotated against base_link (and so against the
//! LiDAR): that misalignment is the error the SLAM bias state estimates.

use crate::noise::Noise;
use speleo_hal::mtdata2::Precision;
use speleo_hal::outbox::Outbox;
use speleo_hal::xbus::{self, XbusDecoder};
use speleo_hal::xsens_config::{OutputConfig, MID_SET_OUTPUT_CONFIGURATION};
use speleo_physics::body::BodyState;
use speleo_physics::quat::{self, Quat};

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
    /// IMU frame against base_link: roll, pitch, yaw, rad.
    pub misalignment_rpy: [f64; 3],
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
            misalignment_rpy: [0.0; 3],
        }
    }
}

pub struct ImuTwin {
    p: ImuParams,
    noise: Noise,
    period_ns: u64,
    next_sample_ns: u64,
    counter: u16,
    gyro_bias: [f64; 3],
    /// Heading error of the device's own orientation estimate (the
    /// integrated z gyro bias and noise: it drifts).
    yaw_drift: f64,
    /// IMU to base_link.
    mount: Quat,
    /// Sums of the true rate of turn and specific force (base_link) since
    /// the last sample, and their count.
    sum_rate: [f64; 3],
    sum_force: [f64; 3],
    summed: u32,
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

impl ImuTwin {
    pub fn new(p: ImuParams, seed: u64) -> Self {
        let mut noise = Noise::new(seed, 0x1_0001);
        let gyro_bias = [
            noise.gaussian() * p.gyro_bias_sigma,
            noise.gaussian() * p.gyro_bias_sigma,
            noise.gaussian() * p.gyro_bias_sigma,
        ];
        let period_ns = 1_000_000_000 / p.rate_hz.max(1) as u64;
        let [roll, pitch, yaw] = p.misalignment_rpy;
        ImuTwin {
            next_sample_ns: p.phase_ns,
            p,
            noise,
            period_ns,
            counter: 0,
            gyro_bias,
            yaw_drift: 0.0,
            mount: quat::from_ypr(yaw, pitch, roll),
            sum_rate: [0.0; 3],
            sum_force: [0.0; 3],
            summed: 0,
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

    /// Integrate the true motion of one simulation step.
    pub fn observe(&mut self, s: &BodyState) {
        for k in 0..3 {
            self.sum_rate[k] += s.angular_velocity[k];
            self.sum_force[k] += s.specific_force[k];
        }
        self.summed += 1;
    }

    /// Take a sample if one is due at `t_ns`, from the motion observed since
    /// the last one (or `s` alone if none was observed).
    pub fn maybe_sample(&mut self, t_ns: u64, s: &BodyState) {
        if t_ns < self.next_sample_ns {
            return;
        }
        self.next_sample_ns += self.period_ns;
        let dt = (t_ns - self.last_sample_ns) as f64 * 1e-9;
        self.last_sample_ns = t_ns;
        let (rate_b, force_b) = if self.summed > 0 {
            let n = self.summed as f64;
            (self.sum_rate.map(|v| v / n), self.sum_force.map(|v| v / n))
        } else {
            (s.angular_velocity, s.specific_force)
        };
        self.sum_rate = [0.0; 3];
        self.sum_force = [0.0; 3];
        self.summed = 0;
        // Into the IMU's own (misaligned) axes.
        let rate = quat::rotate_inv(&self.mount, rate_b);
        let force = quat::rotate_inv(&self.mount, force_b);
        let hz = self.p.rate_hz as f64;
        let g_sigma = self.p.gyro_noise_density * libm::sqrt(hz);
        let a_sigma = self.p.accel_noise_density * libm::sqrt(hz);
        let walk = self.p.gyro_bias_walk * libm::sqrt(dt);
        for b in self.gyro_bias.iter_mut() {
            *b += self.noise.gaussian() * walk;
        }
        let mut gyro = [0.0; 3];
        for k in 0..3 {
            gyro[k] = rate[k] + self.gyro_bias[k] + self.noise.gaussian() * g_sigma;
        }
        let mut acc = [0.0; 3];
        for k in 0..3 {
            acc[k] = force[k] + self.noise.gaussian() * a_sigma;
        }
        // Roll and pitch are held by gravity; heading drifts with the
        // integrated z error.
        self.yaw_drift = crate::rover::wrap_angle(self.yaw_drift + (gyro[2] - rate[2]) * dt);
        let imu_to_world = quat::mul(&s.orientation, &self.mount);
        let q = quat::mul(&quat::from_ypr(self.yaw_drift, 0.0, 0.0), &imu_to_world);
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

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_hal::xbus::parse_mtdata2;
    use speleo_physics::body::GRAVITY;

    /// Mean acceleration and orientation the twin reports for a rover at
    /// rest on level ground, decoded by the driver's parser.
    fn at_rest(misalignment_rpy: [f64; 3]) -> ([f64; 3], Quat) {
        let p = ImuParams {
            misalignment_rpy,
            ..ImuParams::default()
        };
        let mut imu = ImuTwin::new(p, 7);
        let rest = BodyState::default();
        let mut sum = [0.0; 3];
        let mut q = quat::IDENTITY;
        let mut n = 0.0;
        let mut decoder = XbusDecoder::new();
        for k in 1..=2000u64 {
            imu.observe(&rest);
            imu.maybe_sample(k * 1_000_000, &rest);
            while let Some((_, bytes)) = imu.outbox().pop_due(u64::MAX) {
                decoder.push(&bytes, &mut |f| {
                    let d = parse_mtdata2(f.payload).expect("valid MTData2");
                    let a = d.acceleration.expect("acceleration");
                    for i in 0..3 {
                        sum[i] += a[i] as f64;
                    }
                    q = d.quaternion.expect("orientation").map(|c| c as f64);
                    n += 1.0;
                });
            }
        }
        assert!(n > 150.0, "{n} samples");
        (sum.map(|s| s / n), q)
    }

    #[test]
    fn a_misaligned_imu_sees_gravity_tilted_by_its_misalignment() {
        let (level, _) = at_rest([0.0; 3]);
        assert!(level[0].abs() < 0.01 && level[1].abs() < 0.01, "{level:?}");
        assert!((level[2] - GRAVITY).abs() < 0.01, "{level:?}");
        // Rolled 2 deg about x against base_link: the IMU sees the gravity
        // reaction leaning 2 deg towards its +y axis.
        let roll = 2.0f64.to_radians();
        let (tilted, q) = at_rest([roll, 0.0, 0.0]);
        let seen = libm::atan2(tilted[1], tilted[2]);
        assert!((seen - roll).abs() < 0.002, "{} deg", seen.to_degrees());
        // Its orientation output carries the same roll (heading drifts only).
        let (_, _, r) = quat::to_ypr(&q);
        assert!((r - roll).abs() < 1e-3, "{} deg", r.to_degrees());
    }
}
