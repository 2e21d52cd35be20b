#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_hal::canopen::candump::parse_line;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        for (i, line) in text.lines().enumerate() {
            let _ = parse_line(i + 1, line);
        }
    }
});
