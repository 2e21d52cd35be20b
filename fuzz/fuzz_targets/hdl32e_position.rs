#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_hal::hdl32e::position::PositionPacket;

fuzz_target!(|data: &[u8]| {
    let _ = PositionPacket::parse(data);
});
