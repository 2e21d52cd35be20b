//! `speleo decode` and `speleo pcap2mcap`: device captures and logs read,
//! printed or imported as a recording.

use std::process::ExitCode;

use speleo_firmware::config::Config;

use crate::args::{DecodeCommand, Pcap2mcapArgs};
use crate::Error;

pub fn pcap2mcap(a: Pcap2mcapArgs) -> Result<ExitCode, Error> {
    let cfg = match &a.config {
        Some(p) => Config::load(p)?,
        None => {
            // A real capture is looked at revolution by revolution: its
            // replays record every decoded cloud unless configured otherwise.
            let mut c = Config::default();
            c.record.cloud_every = 1;
            c
        }
    };
    let s = crate::pcap2mcap::run(&a.capture, &a.out, &cfg)?;
    println!(
        "{}: {} data packets, {} position packets over {} frames ({} other datagrams left out)",
        a.out.display(),
        s.data_packets,
        s.position_packets,
        s.frames,
        s.other
    );
    Ok(ExitCode::SUCCESS)
}

pub fn decode(d: DecodeCommand) -> Result<ExitCode, Error> {
    use crate::{decode_can, decode_hdl32e, decode_xbus};
    use speleo_hal::hdl32e::Interpolation;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    match d {
        DecodeCommand::Hdl32e(a) => {
            let interpolation = match a.interpolation.as_str() {
                "continuous" => Interpolation::Continuous,
                "veloview" => Interpolation::VeloView,
                "velodyne-decoder" => Interpolation::FixedPairs,
                other => {
                    return Err(format!(
                        "--interpolation {other}: use continuous, veloview or velodyne-decoder"
                    )
                    .into())
                }
            };
            decode_hdl32e::run(
                &a.capture,
                &decode_hdl32e::Options {
                    calib: a.calib.as_deref(),
                    csv: a.csv.as_deref(),
                    frame: a.frame,
                    interpolation,
                    cut_angle_deg: a.cut_angle,
                },
                &mut out,
            )?
        }
        DecodeCommand::Xbus(a) => decode_xbus::run(&a.file, a.json, &mut out)?,
        DecodeCommand::Can(a) => decode_can::run(&a.file, &mut out)?,
    }
    std::io::Write::flush(&mut out)?;
    Ok(ExitCode::SUCCESS)
}
