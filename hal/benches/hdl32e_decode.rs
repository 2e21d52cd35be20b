//! HDL-32E decoding speed on the real capture (../shared/data/velodyne), in
//! points per second on one thread: packets parsed and decoded into a
//! preallocated point buffer, as the on-board driver does.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use speleo_hal::hdl32e::{Calibration, DataPacket, Decoder, Interpolation, Point, DATA_PORT};

fn bench(c: &mut Criterion) {
    let Some(pcap) = speleo_hal::shared_data::path("velodyne/monterey-first-100-packets.pcap")
    else {
        return;
    };
    let (dgrams, _) = speleo_hal::pcap::read_udp(&pcap).expect("capture");
    let packets: Vec<Vec<u8>> = dgrams
        .into_iter()
        .filter(|d| d.dst.port() == DATA_PORT)
        .map(|d| d.payload)
        .collect();
    let cal = Calibration::nominal();
    let mut points: Vec<Point> = Vec::with_capacity(1_100_000);
    let mut total = 0u64;
    let dec = Decoder::new(&cal);
    for b in &packets {
        if let Ok(p) = DataPacket::parse(b) {
            dec.decode_with(&p, |_| total += 1);
        }
    }
    let mut g = c.benchmark_group("hdl32e_decode");
    g.throughput(Throughput::Elements(total));
    for (name, mode) in [
        ("continuous", Interpolation::Continuous),
        ("fixed_pairs", Interpolation::FixedPairs),
        ("veloview", Interpolation::VeloView),
    ] {
        let dec = Decoder::new(&cal).with_interpolation(mode);
        g.bench_function(format!("{name}_capture_{total}_points"), |b| {
            b.iter(|| {
                points.clear();
                for bytes in &packets {
                    if let Ok(p) = DataPacket::parse(bytes) {
                        dec.decode_into(&p, &mut points);
                    }
                }
                std::hint::black_box(points.len())
            })
        });
    }
    // The whole path from the capture file, as velodyne-decoder's read_pcap.
    g.bench_function(format!("pcap_file_to_frames_{total}_points"), |b| {
        b.iter(|| {
            let (dgrams, _) = speleo_hal::pcap::read_udp(&pcap).expect("capture");
            let mut asm = speleo_hal::hdl32e::FrameAssembler::new(Decoder::new(&cal), 0.0, 200_000);
            let mut n = 0usize;
            for d in dgrams.iter().filter(|d| d.dst.port() == DATA_PORT) {
                if let Ok(p) = DataPacket::parse(&d.payload) {
                    asm.push(&p, |f| n += f.points.len());
                }
            }
            asm.flush(|f| n += f.points.len());
            std::hint::black_box(n)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
