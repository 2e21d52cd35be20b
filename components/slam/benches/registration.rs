//! GICP registration speed on one thread: preprocessing of both clouds
//! (0.25 m voxels, k=10 covariances, kd-trees) plus alignment, on the real
//! HDL-32E pair of ../shared/data/velodyne (frames 8 -> 9, skipped when
//! absent; the rover barely moves between them, so also with frame 8 moved
//! by 5 deg yaw, 1 deg roll and (0.5, 0.2, 0.05) m) and on a synthetic
//! room. The figures to compare with PyPI small_gicp's `align(target,
//! source, downsampling_resolution=0.25, num_threads=1)` on the same
//! clouds are `real_pair*/prepare_both_and_align`; `small_gicp_reference.py`
//! beside this file times small_gicp on the real pair (medians on the
//! 2-core machine, same session: 34.4 ms here against its 52.3 ms, one
//! cloud prepared in 13.9 ms against its 20.1 ms). `align` against
//! `align_with_surface_information` is the cost of the degeneracy check's
//! sums.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use speleo_slam::registration::{align, GicpParams, PreparedCloud};

const VOXEL_M: f64 = 0.25;

type Cloud = Vec<[f64; 3]>;

/// (source, target) = frames 8 and 9 of the real capture.
fn hdl32e_pair() -> Option<(Cloud, Cloud)> {
    use speleo_hal::hdl32e::{Calibration, DataPacket, Decoder, FrameAssembler, DATA_PORT};
    let pcap = speleo_hal::shared_data::path("velodyne/monterey-first-100-packets.pcap")?;
    let (dgrams, _) = speleo_hal::pcap::read_udp(&pcap).ok()?;
    let mut asm = FrameAssembler::new(Decoder::new(&Calibration::nominal()), 0.0, 200_000);
    let mut frames: Vec<Cloud> = Vec::new();
    for d in dgrams.iter().filter(|d| d.dst.port() == DATA_PORT) {
        if let Ok(p) = DataPacket::parse(&d.payload) {
            asm.push(&p, |f| {
                frames.push(
                    f.points
                        .iter()
                        .map(|p| [p.x as f64, p.y as f64, p.z as f64])
                        .collect(),
                )
            });
        }
    }
    let tgt = frames.get(9)?.clone();
    let src = frames.get(8)?.clone();
    Some((src, tgt))
}

/// Points on the walls, floor, ceiling and two pillars of a 12 x 8 x 3 m
/// room, 3 cm apart: a stand-in for a cave chamber.
fn room() -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    let boxes = [
        ([-6.0, -4.0, -1.0], [6.0, 4.0, 2.0]),
        ([1.0, 1.0, -1.0], [1.6, 1.8, 2.0]),
        ([-3.0, -2.5, -1.0], [-2.2, -1.0, 2.0]),
    ];
    let step = 0.03;
    for (lo, hi) in boxes {
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let (nu, nv) = (
                    ((hi[u] - lo[u]) / step) as usize,
                    ((hi[v] - lo[v]) / step) as usize,
                );
                for i in 0..nu {
                    for j in 0..nv {
                        let mut p = [0.0; 3];
                        p[axis] = side;
                        p[u] = lo[u] + i as f64 * step;
                        p[v] = lo[v] + j as f64 * step;
                        out.push(p);
                    }
                }
            }
        }
    }
    out
}

fn bench_pair(c: &mut Criterion, name: &str, src: &[[f64; 3]], tgt: &[[f64; 3]]) {
    let params = GicpParams::default();
    let cap = src.len().max(tgt.len());
    let mut s = PreparedCloud::with_capacity(cap);
    let mut t = PreparedCloud::with_capacity(cap);
    let mut g = c.benchmark_group(name);
    g.bench_function("prepare_both_and_align", |b| {
        b.iter(|| {
            t.prepare(tgt.iter().copied(), VOXEL_M);
            s.prepare(src.iter().copied(), VOXEL_M);
            align(&s, &t, &Isometry3::identity(), &params)
        })
    });
    g.bench_function("prepare_one", |b| {
        b.iter(|| t.prepare(tgt.iter().copied(), VOXEL_M))
    });
    s.prepare(src.iter().copied(), VOXEL_M);
    g.bench_function("align", |b| {
        b.iter(|| align(&s, &t, &Isometry3::identity(), &params))
    });
    // The degeneracy check's sums (`GicpParams::surface_information`),
    // against `align` above in the same run.
    let judged = GicpParams {
        surface_information: true,
        ..params
    };
    g.bench_function("align_with_surface_information", |b| {
        b.iter(|| align(&s, &t, &Isometry3::identity(), &judged))
    });
    g.finish();
}

fn moved(k: &Isometry3<f64>, pts: &[[f64; 3]]) -> Cloud {
    pts.iter()
        .map(|p| {
            let q = k * nalgebra::Point3::new(p[0], p[1], p[2]);
            [q.x, q.y, q.z]
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    if let Some((src, tgt)) = hdl32e_pair() {
        bench_pair(c, "real_pair", &src, &tgt);
        let k = Isometry3::from_parts(
            Translation3::new(0.5, 0.2, 0.05),
            UnitQuaternion::from_euler_angles(1f64.to_radians(), 0.0, 5f64.to_radians()),
        );
        bench_pair(c, "real_pair_moved", &moved(&k, &src), &tgt);
    }
    let tgt = room();
    let k = Isometry3::from_parts(
        Translation3::new(0.3, -0.2, 0.05),
        UnitQuaternion::from_euler_angles(0.01, -0.02, 0.1),
    );
    bench_pair(c, "synthetic_room", &moved(&k, &tgt), &tgt);
}

criterion_group!(benches, bench);
criterion_main!(benches);
