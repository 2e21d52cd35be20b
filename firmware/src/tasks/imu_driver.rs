//! Configures the MTi (GoToConfig, SetOutputConfiguration, GoToMeasurement)
//! and decodes its serial bytes (Xbus MTData2) into samples.

use speleo_hal::xbus::{self, XbusDecoder};
use speleo_hal::xsens_config::{ConfigSession, OutputConfig};
use speleo_hal::Device;
use speleo_scheduler::{Context, Task};

use crate::bus::{Bus, ImuSample};

pub struct ImuDriver {
    decoder: XbusDecoder,
    session: ConfigSession,
}

impl ImuDriver {
    /// Ask for Speleo's outputs at `rate_hz`; each configuration message is
    /// retried after `timeout_ns`, `attempts` times in all.
    pub fn new(rate_hz: u16, timeout_ns: u64, attempts: u32) -> Self {
        ImuDriver {
            decoder: XbusDecoder::new(),
            session: ConfigSession::new(OutputConfig::speleo(rate_hz), timeout_ns, attempts),
        }
    }
}

impl Task<Bus> for ImuDriver {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let raw = &bus.raw;
        let ring = &mut bus.imu;
        let counters = &mut bus.counters;
        let session = &mut self.session;
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
                ring.publish(t, sample);
            });
        }
        counters.imu = self.decoder.counters;
        if let Some(msg) = self.session.poll(cx.time_ns) {
            bus.imu_tx.push(msg);
        }
        bus.imu_config = self.session.state();
    }
}
