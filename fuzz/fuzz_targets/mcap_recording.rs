//! Recordings on arbitrary bytes (seeded with a real one): read as `speleo
//! replay` reads them, with the run's configuration when there is one. A
//! bad file is an error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_firmware::config::Config;
use speleo_firmware::record::read;

fuzz_target!(|data: &[u8]| {
    let _ = read::scan_records(data);
    let Ok(rec) = read::parse(data, "fuzz.mcap") else {
        return;
    };
    let _ = rec.last_complete_frame();
    let _ = rec.epoch_ns();
    if let Some(text) = rec.run.get("config") {
        let _ = Config::from_toml(text).map(|c| c.validate());
    }
});
