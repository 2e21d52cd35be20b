//! `speleo decode hdl32e`: frames and points of an HDL-32E capture.

use std::io::{BufWriter, Write};
use std::path::Path;

use speleo_hal::hdl32e::position::PositionPacket;
use speleo_hal::hdl32e::{
    Calibration, DataPacket, Decoder, FrameAssembler, Interpolation, PacketError, DATA_PORT,
    POSITION_PORT,
};
use speleo_hal::pcap::read_udp;

use crate::Error;

pub struct Options<'a> {
    pub calib: Option<&'a Path>,
    pub csv: Option<&'a Path>,
    pub frame: Option<u64>,
    pub interpolation: Interpolation,
    pub cut_angle_deg: f64,
}

pub fn run(capture: &Path, o: &Options<'_>, out: &mut dyn Write) -> Result<(), Error> {
    let cal = match o.calib {
        Some(p) => Calibration::load(p)?,
        None => Calibration::nominal(),
    };
    let (dgrams, pc) = read_udp(capture)?;
    let decoder = Decoder::new(&cal).with_interpolation(o.interpolation);
    let mut asm = FrameAssembler::new(decoder, o.cut_angle_deg, 1_000_000);
    let mut csv = match o.csv {
        Some(p) => {
            let f = std::fs::File::create(p)
                .map_err(|e| format!("cannot create {}: {e}", p.display()))?;
            let mut w = BufWriter::new(f);
            writeln!(w, "frame,x,y,z,intensity,ring,time")?;
            Some(w)
        }
        None => None,
    };
    let mut bad = [0u64; 4];
    let mut positions = 0u64;
    let mut bad_positions = 0u64;
    let mut first_nmea = None;
    let mut frames = 0u64;
    let mut total = 0u64;
    let mut io_error = None;
    let mut on_frame = |f: &speleo_hal::hdl32e::frames::Frame<'_>| {
        frames += 1;
        total += f.points.len() as u64;
        let _ = writeln!(out, "frame {}: {} points", f.index, f.points.len());
        if let Some(w) = csv.as_mut() {
            if o.frame.is_none_or(|n| n == f.index) {
                for p in f.points {
                    if let Err(e) = writeln!(
                        w,
                        "{},{},{},{},{},{},{}",
                        f.index, p.x, p.y, p.z, p.intensity, p.ring, p.time
                    ) {
                        io_error.get_or_insert(e);
                    }
                }
            }
        }
    };
    let (mut data, mut other) = (0u64, 0u64);
    for d in &dgrams {
        match d.dst.port() {
            DATA_PORT => {
                data += 1;
                match DataPacket::parse(&d.payload) {
                    Ok(p) => asm.push(&p, &mut on_frame),
                    Err(PacketError::WrongLength(_)) => bad[0] += 1,
                    Err(PacketError::BadFlag { .. }) => bad[1] += 1,
                    Err(PacketError::BadAzimuth { .. }) => bad[2] += 1,
                    Err(PacketError::BadTimestamp(_)) => bad[3] += 1,
                }
            }
            POSITION_PORT => match PositionPacket::parse(&d.payload) {
                Ok(p) => {
                    positions += 1;
                    first_nmea.get_or_insert(p.nmea);
                }
                Err(_) => bad_positions += 1,
            },
            _ => other += 1,
        }
    }
    asm.flush(&mut on_frame);
    if let Some(e) = io_error {
        return Err(e.into());
    }
    if let Some(mut w) = csv {
        w.flush()?;
    }
    let c = asm.counters;
    writeln!(
        out,
        "{frames} frames, {total} points from {data} data packets ({} bad length, {} bad block flag, {} bad azimuth, {} bad timestamp)",
        bad[0], bad[1], bad[2], bad[3]
    )?;
    writeln!(
        out,
        "lost packets {}, out of order {}, clock jumps followed {}, gaps {}, dropped points {}",
        c.lost_packets, c.out_of_order, c.resyncs, c.gaps, c.dropped_points
    )?;
    writeln!(
        out,
        "{positions} position packets ({bad_positions} malformed){}",
        first_nmea.map_or(String::new(), |n| format!(", first NMEA: {n}"))
    )?;
    writeln!(
        out,
        "capture: {} frames, {} UDP, {} other, {} truncated, {} fragments; {other} datagrams to other ports",
        pc.frames, pc.udp, pc.other, pc.truncated, pc.fragments
    )?;
    Ok(())
}
