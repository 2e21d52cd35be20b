//! Configuration files on arbitrary text: parsed; when they parse, checked,
//! their schedule built, their fault specs read, and written back to TOML,
//! which must parse to the same configuration.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_firmware::config::Config;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(cfg) = Config::from_toml(text) else {
        return;
    };
    if cfg.validate().is_ok() {
        let _ = speleo_firmware::schedule_table::build(&cfg);
        let _ = speleo_firmware::faults::parse_all(&cfg.sim.faults);
    }
    let again = cfg.to_toml();
    let back = Config::from_toml(&again)
        .unwrap_or_else(|e| panic!("written configuration does not parse: {e}\n{again}"));
    assert_eq!(back.to_toml(), again, "a configuration changes when written twice");
});
