//! Any byte stream through the Xbus decoder in arbitrary read sizes, every
//! frame through the MTData2 item decoder.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_hal::mtdata2::items;
use speleo_hal::xbus::{parse_mtdata2, XbusDecoder};

fuzz_target!(|data: &[u8]| {
    let (split, rest) = match data.split_first() {
        Some((s, r)) => (*s as usize + 1, r),
        None => return,
    };
    let mut d = XbusDecoder::new();
    let mut frames = 0u64;
    for chunk in rest.chunks(split) {
        d.push(chunk, &mut |f| {
            frames += 1;
            let _ = parse_mtdata2(f.payload);
            for it in items(f.payload) {
                let _ = it;
            }
        });
    }
    assert_eq!(frames, d.counters.frames);
    assert!(d.counters.skipped_bytes <= rest.len() as u64);
});
