//! Configures the MTi (GoToConfig, SetOutputConfiguration, GoToMeasurement)
//! and decodes its serial bytes (Xbus MTData2) into samples.

use speleo_hal::xbus::{self, XbusDecoder};
use speleo_hal::xsens_config::{ConfigSession, OutputConfig};
use speleo_hal::Device;
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;
use speleo_messages::ImuSample;

pub struct ImuDriver {
    decoder: XbusDecoder,
    session: ConfigSession,
    /// Nanoseconds a byte takes on the serial line (10 bits).
    byte_ns: u64,
}

impl ImuDriver {
    /// Ask for Speleo's outputs at `rate_hz`; each configuration message is
    /// retried after `timeout_ns`, `attempts` times in all. `baud`: the
    /// serial line's rate, to date each sample from its message's arrival.
    pub fn new(rate_hz: u16, timeout_ns: u64, attempts: u32, baud: u32) -> Self {
        ImuDriver {
            decoder: XbusDecoder::new(),
            session: ConfigSession::new(OutputConfig::speleo(rate_hz), timeout_ns, attempts),
            byte_ns: 10 * 1_000_000_000 / baud.max(1) as u64,
        }
    }
}

impl Task<Bus> for ImuDriver {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let raw = &bus.raw;
        let ring = &mut bus.imu;
        let counters = &mut bus.counters;
        let session = &mut self.session;
        let byte_ns = self.byte_ns;
        for (entry, bytes) in raw.of(Device::Imu) {
            let t = entry.receive_time_ns;
            self.decoder.push(bytes, &mut |f| {
                if session.on_frame(&f) {
                    return;
                }
                if f.mid != xbus::MID_MTDATA2 {
                    counters.imu_other_messages += 1;
                    return;
                }
                let sample = match xbus::parse_mtdata2(f.payload) {
                    Ok(d) => match (d.quaternion, d.acceleration, d.rate_of_turn) {
                        (Some(q), Some(a), Some(g)) => ImuSample {
                            packet_counter: d.packet_counter.unwrap_or(0),
                            sample_time_fine: d.sample_time_fine.unwrap_or(0),
                            orientation: q.map(f64::from),
                            acceleration: a.map(f64::from),
                            rate_of_turn: g.map(f64::from),
                            status_word: d.status_word.unwrap_or(0),
                        },
                        _ => {
                            counters.imu_bad_items += 1;
                            return;
                        }
                    },
                    Err(_) => {
                        counters.imu_bad_items += 1;
                        return;
                    }
                };
                // The sample was taken before its message crossed the line:
                // preamble, bus id, message id, length (3 bytes when
                // extended), payload and checksum. At 921.6 kBd a 60-byte
                // message takes 0.65 ms, a tenth of a degree of a rocking
                // rover's attitude.
                let len = f.payload.len();
                let frame_bytes = 5 + len as u64 + if len >= 255 { 2 } else { 0 };
                ring.publish(t.saturating_sub(frame_bytes * byte_ns), sample);
            });
        }
        counters.imu = self.decoder.counters;
        if let Some(msg) = self.session.poll(cx.time_ns) {
            bus.imu_tx.push(msg);
        }
        bus.imu_config = self.session.state();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_hal::ImuPort;
    use speleo_physics::BodyState;
    use speleo_twin::imu::{ImuParams, ImuTwin};

    use crate::tasks::test_context as cx;

    #[test]
    fn a_sample_is_dated_before_its_message_crossed_the_line() {
        let mut bus = Bus::new();
        let mut imu = ImuTwin::new(ImuParams::default(), 1);
        let baud = ImuParams::default().baud;
        let mut driver = ImuDriver::new(100, 100_000_000, 5, baud);
        let taken_ns = 10_000_000;
        imu.maybe_sample(taken_ns, &BodyState::default());
        imu.poll(20_000_000, &mut bus.raw).expect("sim port");
        let arrived = bus.raw.entries()[0].receive_time_ns;
        // Tens of bytes at 921.6 kBd: over half a millisecond on the line.
        assert!(arrived > taken_ns + 500_000, "{arrived}");
        driver.run(&mut bus, &cx(2));
        let stamp = bus.imu.latest().map(|s| s.stamp_ns);
        let off = stamp.map(|s| s.abs_diff(taken_ns));
        assert!(off.is_some_and(|d| d < 1_000), "{stamp:?}");
    }
}
