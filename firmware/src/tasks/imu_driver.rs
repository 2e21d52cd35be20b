//! Decodes the IMU's serial bytes (Xbus MTData2) into samples.

use speleo_hal::xbus::{self, XbusDecoder};
use speleo_hal::Device;
use speleo_scheduler::{Context, Task};

use crate::bus::{Bus, ImuSample};

#[derive(Default)]
pub struct ImuDriver {
    decoder: XbusDecoder,
}

impl Task<Bus> for ImuDriver {
    fn run(&mut self, bus: &mut Bus, _cx: &Context) {
        let raw = &bus.raw;
        let ring = &mut bus.imu;
        let counters = &mut bus.counters;
        for (entry, bytes) in raw.of(Device::Imu) {
            let t = entry.receive_time_ns;
            self.decoder.push(bytes, &mut |f| {
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
    }
}
