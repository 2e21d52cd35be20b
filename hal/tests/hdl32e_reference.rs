//! The HDL-32E decoder against answers produced outside this project, from
//! the real capture in ../shared/data/velodyne (skipped when absent):
//! VeloView's own test (frames, point counts, four points) and an
//! independent decode of packets 0 and 1 with velodyne-decoder 3.1.0.

use std::path::{Path, PathBuf};

use speleo_hal::hdl32e::encode::encode_points;
use speleo_hal::hdl32e::{
    Calibration, DataPacket, Decoder, FrameAssembler, Interpolation, Point, DATA_PORT,
};
use speleo_hal::pcap::read_udp;

fn data(name: &str) -> Option<PathBuf> {
    speleo_hal::shared_data::path(&format!("velodyne/{name}"))
}

fn data_packets(pcap: &Path) -> Vec<(Vec<u8>, u64)> {
    let (dgrams, _) = read_udp(pcap).expect("capture reads");
    dgrams
        .into_iter()
        .filter(|d| d.dst.port() == DATA_PORT && d.payload.len() == 1206)
        .map(|d| (d.payload, d.time_ns))
        .collect()
}

fn frames(decoder: Decoder, pcap: &Path) -> Vec<Vec<Point>> {
    let mut asm = FrameAssembler::new(decoder, 0.0, 200_000);
    let mut out = Vec::new();
    for (bytes, _) in data_packets(pcap) {
        let p = DataPacket::parse(&bytes).expect("valid packet");
        asm.push(&p, |f| out.push(f.points.to_vec()));
    }
    asm.flush(|f| out.push(f.points.to_vec()));
    assert_eq!(asm.counters.dropped_points, 0);
    out
}

#[test]
fn capture_counts() {
    let Some(pcap) = data("monterey-first-100-packets.pcap") else {
        return;
    };
    let (dgrams, c) = read_udp(&pcap).expect("reads");
    let data = dgrams.iter().filter(|d| d.dst.port() == 2368).count();
    let pos = dgrams.iter().filter(|d| d.dst.port() == 8308).count();
    assert_eq!((data, pos), (2702, 299));
    assert_eq!(c.truncated, 0);
    let positions: Vec<_> = dgrams
        .iter()
        .filter(|d| d.dst.port() == 8308)
        .map(|d| {
            speleo_hal::hdl32e::position::PositionPacket::parse(&d.payload).expect("512 bytes")
        })
        .collect();
    assert_eq!(positions.len(), 299);
}

#[test]
fn reproduces_veloviews_frames_and_points() {
    let (Some(pcap), Some(xml)) = (data("monterey-first-100-packets.pcap"), data("HDL-32.xml"))
    else {
        return;
    };
    let cal = Calibration::load(&xml).expect("calibration");
    let f = frames(
        Decoder::new(&cal).with_interpolation(Interpolation::VeloView),
        &pcap,
    );
    assert_eq!(f.len(), 19);
    for (i, n) in [(0, 27649), (2, 49485), (8, 49737), (11, 49778), (18, 396)] {
        assert_eq!(f[i].len(), n, "frame {i}");
    }
    // VeloView's axes: (x, y) = (-y, x) of ours.
    for (i, x, y, z, intensity) in [
        (1, 0.0218793, 7.83493, -1.28724, 1),
        (4000, 4.3613, 8.19206, -1.97267, 28),
        (16000, 77.564, -26.859, 3.82785, 63),
        (49733, 0.00501329, 5.74481, -1.79261, 1),
    ] {
        let p = f[8][i];
        let (vx, vy) = (-p.y as f64, p.x as f64);
        assert!(
            (vx - x).abs() <= 1e-4 && (vy - y).abs() <= 1e-4 && (p.z as f64 - z).abs() <= 1e-4,
            "point {i}: ({vx}, {vy}, {}) vs ({x}, {y}, {z})",
            p.z
        );
        assert_eq!(p.intensity, intensity);
    }
}

fn reference_csv(name: &str) -> Vec<[f64; 5]> {
    let Some(p) = data(&format!("reference/{name}")) else {
        return Vec::new();
    };
    std::fs::read_to_string(p)
        .expect("csv")
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().expect("number")).collect();
            // x, y, z, time, ring
            [v[0], v[1], v[2], v[4], v[6]]
        })
        .collect()
}

#[test]
fn matches_velodyne_decoder_point_for_point() {
    let Some(pcap) = data("monterey-first-100-packets.pcap") else {
        return;
    };
    let packets = data_packets(&pcap);
    let dec = Decoder::new(&Calibration::nominal()).with_interpolation(Interpolation::FixedPairs);
    for (k, name) in [
        (0, "hdl32e_monterey_nominalcal_packet0000.csv"),
        (1, "hdl32e_monterey_nominalcal_packet0001.csv"),
    ] {
        let want = reference_csv(name);
        let p = DataPacket::parse(&packets[k].0).expect("valid");
        let mut got = Vec::new();
        dec.decode_with(&p, |pt| {
            // That decoder drops points closer than 0.1 m.
            if pt.distance >= 0.1 {
                got.push(pt)
            }
        });
        assert_eq!(got.len(), want.len(), "packet {k}");
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            let err = ((g.x as f64 - w[0]).powi(2)
                + (g.y as f64 - w[1]).powi(2)
                + (g.z as f64 - w[2]).powi(2))
            .sqrt();
            assert!(
                err <= 1e-4,
                "packet {k} point {i}: {g:?} vs {w:?} ({err} m)"
            );
            assert!(
                (g.time as f64 - w[3]).abs() < 1e-9,
                "packet {k} point {i} time"
            );
            assert_eq!(g.ring as f64, w[4], "packet {k} point {i} ring");
        }
    }
}

#[test]
fn every_real_packet_encodes_back_to_its_bytes() {
    let Some(pcap) = data("monterey-first-100-packets.pcap") else {
        return;
    };
    let cal = Calibration::nominal();
    let mut dec = Decoder::new(&cal);
    dec.keep_empty = true;
    let packets = data_packets(&pcap);
    assert_eq!(packets.len(), 2702);
    for (i, (bytes, _)) in packets.iter().enumerate() {
        let p = DataPacket::parse(bytes).expect("valid");
        let mut pts = Vec::new();
        dec.decode_with(&p, |pt| pts.push(pt));
        let az = p.blocks.map(|b| b.azimuth);
        let back = encode_points(&cal, &az, &pts, p.timestamp_us, p.factory).expect("encodes");
        assert!(
            back[..] == bytes[..],
            "packet {i} differs after encode(decode(p))"
        );
    }
}
