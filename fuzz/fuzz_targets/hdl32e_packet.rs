//! Any datagram through the HDL-32E path: parse, decode in every
//! interpolation mode, assemble frames, and re-encode what parsed.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_hal::hdl32e::encode::encode_points;
use speleo_hal::hdl32e::{Calibration, DataPacket, Decoder, FrameAssembler, Interpolation};

fuzz_target!(|data: &[u8]| {
    let cal = Calibration::nominal();
    // Two packets from one input, so frame assembly sees a sequence.
    for bytes in [data, data.get(1206..).unwrap_or(&[])] {
        let Ok(p) = DataPacket::parse(bytes) else {
            continue;
        };
        for mode in [Interpolation::Continuous, Interpolation::VeloView, Interpolation::FixedPairs] {
            let mut d = Decoder::new(&cal).with_interpolation(mode);
            d.keep_empty = true;
            let mut pts = Vec::new();
            d.decode_with(&p, |pt| pts.push(pt));
            let back = encode_points(&cal, &p.blocks.map(|b| b.azimuth), &pts, p.timestamp_us, p.factory)
                .expect("decoded points encode");
            assert_eq!(&back[..], bytes);
        }
        let mut asm = FrameAssembler::new(Decoder::new(&cal), 90.0, 1000);
        asm.push(&p, |_| {});
        asm.push(&p, |_| {});
        asm.flush(|_| {});
    }
});
