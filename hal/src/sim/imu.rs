//! Twin of the Xsens MTi: MTData2 frames with orientation, acceleration,
//! rate of turn, packet counter, sample time and status, with white noise and
//! a gyro bias random walk from a datasheet-like model.

use super::noise::Noise;
use super::rover::Rover;
use crate::outbox::Outbox;
use crate::xbus::{self, did, Mtdata2Builder};

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
    outbox: Outbox<16, 128>,
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
        }
    }

    pub(crate) fn outbox(&mut self) -> &mut Outbox<16, 128> {
        &mut self.outbox
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
        let mut b = Mtdata2Builder::new();
        b.u16(did::PACKET_COUNTER, self.counter)
            .u32(did::SAMPLE_TIME_FINE, (t_ns / 100_000) as u32)
            .f32s(did::QUATERNION, &q.map(|v| v as f32))
            .f32s(did::ACCELERATION, &acc.map(|v| v as f32))
            .f32s(did::RATE_OF_TURN, &gyro.map(|v| v as f32))
            .u32(did::STATUS_WORD, 0x0000_0003);
        let mut frame: heapless::Vec<u8, 128> = heapless::Vec::new();
        if xbus::encode_frame(xbus::MID_MTDATA2, b.payload(), &mut frame) {
            // The last byte arrives after the whole frame crossed the line (10 bits a byte).
            let wire_ns = frame.len() as u64 * 10 * 1_000_000_000 / self.p.baud.max(1) as u64;
            self.outbox.push(t_ns + wire_ns, &frame);
        }
    }
}
