//! `speleo decode xbus`: every message of a raw MTi byte stream.

use std::io::Write;
use std::path::Path;

use serde_json::{json, Map, Value};
use speleo_hal::mtdata2::{items, Item};
use speleo_hal::xbus::{self, XbusDecoder};
use speleo_hal::xsens_config;

use crate::Error;

fn mid_name(mid: u8) -> &'static str {
    match mid {
        0x36 => "MTData2",
        0x32 => "MTData",
        0x30 => "GoToConfig",
        0x31 => "GoToConfigAck",
        0x10 => "GoToMeasurement",
        0x11 => "GoToMeasurementAck",
        0x3E => "WakeUp",
        0x3F => "WakeUpAck",
        0x40 => "Reset",
        0x41 => "ResetAck",
        0x00 => "ReqDID",
        0x01 => "DeviceID",
        0x42 => "Error",
        0x43 => "Warning",
        0xC0 => "SetOutputConfiguration",
        0xC1 => "OutputConfiguration",
        _ => "Unknown",
    }
}

fn item_json(id: u16, item: &Item<'_>) -> (String, Value) {
    match item {
        Item::PacketCounter(c) => ("PacketCounter".into(), json!(c)),
        Item::SampleTimeFine(t) => ("SampleTimeFine".into(), json!(t)),
        Item::SampleTimeCoarse(t) => ("SampleTimeCoarse".into(), json!(t)),
        Item::StatusByte(b) => ("StatusByte".into(), json!(b)),
        Item::StatusWord(w) => ("StatusWord".into(), json!(w)),
        Item::BaroPressure(p) => ("BaroPressure".into(), json!(p)),
        Item::UtcTime(t) => (
            "UTCTime".into(),
            json!(format!(
                "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:09}Z",
                t.year, t.month, t.day, t.hour, t.minute, t.second, t.nanos
            )),
        ),
        Item::Numbers {
            kind,
            precision,
            coords,
            values,
            len,
        } => {
            let mut m = Map::new();
            m.insert("precision".into(), json!(precision.name()));
            if let Some(c) = coords {
                m.insert("frame".into(), json!(c.name()));
            }
            let fields = kind.fields();
            for i in 0..*len {
                let k = if fields[i].is_empty() {
                    "value"
                } else {
                    fields[i]
                };
                m.insert(k.into(), json!(values[i]));
            }
            (kind.name().into(), Value::Object(m))
        }
        Item::GnssPvt(p) => ("GNSSPVTData".into(), pvt_json(p)),
        Item::GnssSatInfo(s) => (
            "GNSSSatInfo".into(),
            json!({"itow_ms": s.itow, "num_svs": s.len(),
                   "satellites": s.satellites().map(|v| json!({
                       "gnss_id": v.gnss_id, "sv_id": v.sv_id, "cno_dbhz": v.cno,
                       "quality": v.quality(), "used": v.used(), "health": v.health(),
                       "corrected": v.corrected()})).collect::<Vec<_>>()}),
        ),
        Item::Unknown { size, .. } => (format!("0x{id:04X}"), json!({"unknown_bytes": size})),
    }
}

/// Every field of a NAV-PVT record, in SI units and degrees (u-blox's
/// scalings: 1e-7 deg, mm, mm/s, 1e-5 deg, 0.01 for the DOPs).
fn pvt_json(p: &speleo_hal::mtdata2::GnssPvt) -> Value {
    let (mm, deg7, deg5, dop) = (1e-3, 1e-7, 1e-5, 0.01);
    json!({
        "itow_ms": p.itow,
        "date": format!("{:04}-{:02}-{:02}", p.year, p.month, p.day),
        "time": format!("{:02}:{:02}:{:02}", p.hour, p.min, p.sec),
        "valid": p.valid, "t_acc_ns": p.t_acc, "nano_ns": p.nano,
        "fix_type": p.fix_type, "flags": p.flags, "num_sv": p.num_sv,
        "lon_deg": f64::from(p.lon) * deg7, "lat_deg": f64::from(p.lat) * deg7,
        "height_m": f64::from(p.height) * mm, "hmsl_m": f64::from(p.hmsl) * mm,
        "h_acc_m": f64::from(p.h_acc) * mm, "v_acc_m": f64::from(p.v_acc) * mm,
        "vel_n_mps": f64::from(p.vel_n) * mm, "vel_e_mps": f64::from(p.vel_e) * mm,
        "vel_d_mps": f64::from(p.vel_d) * mm, "g_speed_mps": f64::from(p.g_speed) * mm,
        "head_mot_deg": f64::from(p.head_mot) * deg5, "s_acc_mps": f64::from(p.s_acc) * mm,
        "head_acc_deg": f64::from(p.head_acc) * deg5, "head_veh_deg": f64::from(p.head_veh) * deg5,
        "gdop": f64::from(p.gdop) * dop, "pdop": f64::from(p.pdop) * dop,
        "tdop": f64::from(p.tdop) * dop, "vdop": f64::from(p.vdop) * dop,
        "hdop": f64::from(p.hdop) * dop, "ndop": f64::from(p.ndop) * dop,
        "edop": f64::from(p.edop) * dop,
    })
}

pub fn run(file: &Path, as_json: bool, out: &mut dyn Write) -> Result<(), Error> {
    let bytes = std::fs::read(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let mut d = XbusDecoder::new();
    let mut n = 0u64;
    let mut truncated = 0u64;
    let mut err = None;
    d.push(&bytes, &mut |f| {
        n += 1;
        let mut obj = Map::new();
        obj.insert("message".into(), json!(n - 1));
        obj.insert("mid".into(), json!(format!("0x{:02X}", f.mid)));
        obj.insert("name".into(), json!(mid_name(f.mid)));
        match f.mid {
            xbus::MID_MTDATA2 => {
                let mut m = Map::new();
                for it in items(f.payload) {
                    match it {
                        Ok((id, item)) => {
                            let (k, v) = item_json(id, &item);
                            m.insert(k, v);
                        }
                        Err(t) => {
                            truncated += 1;
                            m.insert("truncated_at".into(), json!(t.offset));
                        }
                    }
                }
                obj.insert("items".into(), Value::Object(m));
            }
            xbus::MID_ERROR => {
                let code = f.payload.first().copied().unwrap_or(0);
                obj.insert("error".into(), json!(xsens_config::error_name(code)));
            }
            0xC0 | 0xC1 => {
                if let Ok(c) = xsens_config::OutputConfig::parse(f.payload) {
                    let e: Vec<Value> = c
                        .entries
                        .iter()
                        .map(|(id, hz)| json!({"id": format!("0x{id:04X}"), "hz": hz}))
                        .collect();
                    obj.insert("outputs".into(), Value::Array(e));
                }
            }
            _ => {
                obj.insert("payload_bytes".into(), json!(f.payload.len()));
            }
        }
        let r = if as_json {
            writeln!(out, "{}", Value::Object(obj))
        } else {
            let name = obj.remove("name").unwrap_or_default();
            let rest: Vec<String> = obj
                .into_iter()
                .filter(|(k, _)| k != "message" && k != "mid")
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            writeln!(
                out,
                "#{} {} {}",
                n - 1,
                name.as_str().unwrap_or(""),
                rest.join(" ")
            )
        };
        if let Err(e) = r {
            err.get_or_insert(e);
        }
    });
    if let Some(e) = err {
        return Err(e.into());
    }
    let c = d.counters;
    let summary = format!(
        "{} good frames, {} bad checksums, {} bytes skipped, {} oversize, {} truncated payloads",
        c.frames, c.bad_checksums, c.skipped_bytes, c.oversize, truncated
    );
    if as_json {
        writeln!(
            out,
            "{}",
            json!({"summary": {"good_frames": c.frames, "bad_checksums": c.bad_checksums,
                   "bytes_skipped": c.skipped_bytes, "oversize": c.oversize,
                   "truncated_payloads": truncated}})
        )?;
    } else {
        writeln!(out, "{summary}")?;
    }
    if c.frames == 0 {
        return Err(format!("no Xbus frame in {}: {summary}", file.display()).into());
    }
    Ok(())
}
