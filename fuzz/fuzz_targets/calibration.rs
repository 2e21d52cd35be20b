//! Calibration files: VeloView XML and ROS YAML parsers on arbitrary text.
#![no_main]

use libfuzzer_sys::fuzz_target;
use speleo_hal::hdl32e::Calibration;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = Calibration::from_veloview_xml(text);
        let _ = Calibration::from_ros_yaml(text);
    }
});
