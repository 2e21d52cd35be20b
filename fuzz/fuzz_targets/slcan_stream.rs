#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_hal::slcan::{encode_frame, Event, SlcanDecoder};

fuzz_target!(|data: &[u8]| {
    // Whatever an adapter sends is frames, answers or counted bad lines;
    // every frame decoded encodes to a line that decodes to it again.
    let mut d = SlcanDecoder::new();
    let mut frames = Vec::new();
    d.feed(data, |e| {
        if let Event::Frame(f, _) = e {
            frames.push(f);
        }
    });
    for f in frames {
        let (line, n) = encode_frame(&f);
        let mut again = SlcanDecoder::new();
        let mut back = None;
        again.feed(&line[..n], |e| {
            if let Event::Frame(g, _) = e {
                back = Some(g);
            }
        });
        assert_eq!(back, Some(f));
    }
});
