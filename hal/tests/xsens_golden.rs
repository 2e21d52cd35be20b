//! Every message of the real MTi captures in ../shared/data/xsens decodes to
//! the values of the golden file another implementation (xsens-go) produced:
//! item names, formats, coordinate systems and every value, compared exactly
//! (all four precisions convert to f64 without rounding). Skipped when the
//! data is absent.

use std::path::PathBuf;

use speleo_hal::mtdata2::{items, GnssPvt, Item, UtcTime};
use speleo_hal::xbus::{XbusDecoder, MID_MTDATA2};

fn data(set: u32) -> Option<PathBuf> {
    speleo_hal::shared_data::path(&format!("xsens/{set}"))
}

/// One message of a golden file: (header, value lines).
type Golden = Vec<(String, Vec<String>)>;

fn parse_golden(text: &str) -> Vec<Golden> {
    let mut out = Vec::new();
    for block in text.split("\n\n") {
        let mut msg: Golden = Vec::new();
        for line in block.lines() {
            if let Some(v) = line.strip_prefix("  ") {
                if let Some(last) = msg.last_mut() {
                    last.1.push(v.to_string());
                }
            } else if let Some(h) = line.strip_suffix(':') {
                msg.push((h.to_string(), Vec::new()));
            }
        }
        if !msg.is_empty() {
            out.push(msg);
        }
    }
    out
}

fn utc(t: &UtcTime) -> String {
    let mut s = format!(
        "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}",
        t.year, t.month, t.day, t.hour, t.minute, t.second
    );
    if t.nanos != 0 {
        let frac = format!("{:09}", t.nanos);
        s.push('.');
        s.push_str(frac.trim_end_matches('0'));
    }
    s.push('Z');
    s
}

fn pvt(p: &GnssPvt) -> Vec<String> {
    let f: [(&str, i64); 35] = [
        ("ITOW", p.itow as i64),
        ("Year", p.year as i64),
        ("Month", p.month as i64),
        ("Day", p.day as i64),
        ("Hour", p.hour as i64),
        ("Min", p.min as i64),
        ("Sec", p.sec as i64),
        ("Valid", p.valid as i64),
        ("TAcc", p.t_acc as i64),
        ("Nano", p.nano as i64),
        ("FixType", p.fix_type as i64),
        ("Flags", p.flags as i64),
        ("NumSV", p.num_sv as i64),
        ("Reserved1", p.reserved1 as i64),
        ("Lon", p.lon as i64),
        ("Lat", p.lat as i64),
        ("Height", p.height as i64),
        ("HMSL", p.hmsl as i64),
        ("HAcc", p.h_acc as i64),
        ("VAcc", p.v_acc as i64),
        ("VelN", p.vel_n as i64),
        ("VelE", p.vel_e as i64),
        ("VelD", p.vel_d as i64),
        ("GSpeed", p.g_speed as i64),
        ("HeadMot", p.head_mot as i64),
        ("SAcc", p.s_acc as i64),
        ("HeadAcc", p.head_acc as i64),
        ("HeadVeh", p.head_veh as i64),
        ("GDOP", p.gdop as i64),
        ("PDOP", p.pdop as i64),
        ("TDOP", p.tdop as i64),
        ("VDOP", p.vdop as i64),
        ("HDOP", p.hdop as i64),
        ("NDOP", p.ndop as i64),
        ("EDOP", p.edop as i64),
    ];
    f.iter().map(|(k, v)| format!("{k}:{v}")).collect()
}

/// Our decode of one item in the golden layout; numbers as f64 for exact
/// comparison.
fn ours(item: &Item<'_>) -> (String, Vec<(String, Option<f64>)>) {
    let s = |v: String| vec![(v, None)];
    match item {
        Item::PacketCounter(c) => (
            "PacketCounter".into(),
            vec![(String::new(), Some(*c as f64))],
        ),
        Item::SampleTimeFine(t) => (
            "SampleTimeFine".into(),
            vec![(String::new(), Some(*t as f64))],
        ),
        Item::UtcTime(t) => ("UTCTime".into(), s(utc(t))),
        Item::StatusWord(w) => ("StatusWord".into(), s(format!("{w:032b}"))),
        Item::StatusByte(b) => ("StatusByte".into(), s(format!("{b:08b}"))),
        Item::GnssPvt(p) => (
            "GNSSPVTData".into(),
            pvt(p).into_iter().map(|l| (l, None)).collect(),
        ),
        Item::Numbers {
            kind,
            precision,
            coords,
            values,
            len,
        } => {
            let header = match coords {
                Some(c) => format!("{}({},{})", kind.name(), c.name(), precision.name()),
                None => format!("{}({})", kind.name(), precision.name()),
            };
            let fields = kind.fields();
            let vals = (0..*len)
                .map(|i| (fields[i].to_string(), Some(values[i])))
                .collect();
            (header, vals)
        }
        other => (format!("{other:?}"), Vec::new()),
    }
}

fn check_set(set: u32) {
    let Some(dir) = data(set) else {
        return;
    };
    let bytes = std::fs::read(dir.join("output.bin")).expect("capture");
    let golden = parse_golden(&std::fs::read_to_string(dir.join("output.golden")).expect("golden"));
    let mut decoder = XbusDecoder::new();
    let mut messages = Vec::new();
    decoder.push(&bytes, &mut |f| {
        assert_eq!(f.mid, MID_MTDATA2);
        let items: Vec<_> = items(f.payload)
            .map(|r| ours(&r.expect("no truncated item").1))
            .collect();
        messages.push(items);
    });
    assert_eq!(decoder.counters.frames, 100, "set {set}");
    assert_eq!(decoder.counters.bad_checksums, 0);
    assert_eq!(decoder.counters.skipped_bytes, 0);
    assert_eq!(messages.len(), golden.len(), "set {set}");
    for (m, (got, want)) in messages.iter().zip(&golden).enumerate() {
        assert_eq!(got.len(), want.len(), "set {set} message {m}: item count");
        for ((gh, gv), (wh, wv)) in got.iter().zip(want) {
            assert_eq!(gh, wh, "set {set} message {m}");
            assert_eq!(gv.len(), wv.len(), "set {set} message {m} {wh}");
            for ((label, num), w) in gv.iter().zip(wv) {
                match num {
                    Some(x) => {
                        let (wl, wn) = match w.split_once(':') {
                            Some((l, n)) => (l, n),
                            None => ("", w.as_str()),
                        };
                        assert_eq!(label, wl, "set {set} message {m} {wh}");
                        let wn: f64 = wn.parse().expect("golden number");
                        assert_eq!(*x, wn, "set {set} message {m} {wh} {label}");
                    }
                    None => assert_eq!(label, w, "set {set} message {m} {wh}"),
                }
            }
        }
    }
}

#[test]
fn set1_float32() {
    check_set(1);
}

#[test]
fn set2_fixed_point_12_20() {
    check_set(2);
}

#[test]
fn set3_fixed_point_16_32() {
    check_set(3);
}

#[test]
fn set4_float64() {
    check_set(4);
}
