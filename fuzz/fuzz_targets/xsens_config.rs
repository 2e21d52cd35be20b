//! The configuration exchange fed arbitrary device answers.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_hal::xbus::XbusDecoder;
use speleo_hal::xsens_config::{ConfigSession, OutputConfig};

fuzz_target!(|data: &[u8]| {
    let _ = OutputConfig::parse(data);
    let mut s = ConfigSession::new(OutputConfig::speleo(100), 10, 3);
    let mut d = XbusDecoder::new();
    for (t, chunk) in data.chunks(7).enumerate() {
        let _ = s.poll(t as u64 * 5);
        d.push(chunk, &mut |f| {
            s.on_frame(&f);
        });
    }
});
