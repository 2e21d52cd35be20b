//! A simulated world that looks ahead (steps the next frame's stretch and
//! launches its LiDAR rays while the frame's tasks run) delivers exactly
//! what one that only advances at each frame's start delivers.

use speleo_hal::{Device, Hardware, InputSink};
use speleo_twin::lidar::LidarParams;
use speleo_twin::world::World;
use speleo_twin::{TwinHardware, TwinParams};

/// Every input with its device and time, in order.
#[derive(Default)]
struct Log(Vec<(Device, u64, Vec<u8>)>);

impl InputSink for Log {
    fn input(&mut self, device: Device, t_ns: u64, bytes: &[u8]) {
        self.0.push((device, t_ns, bytes.to_vec()));
    }
}

fn run(look_ahead: bool, threads: usize) -> (Log, [f64; 3]) {
    let world = World::build("lava-tube", 1).expect("tube");
    let params = TwinParams {
        lidar: Some(LidarParams {
            cast_threads: threads,
            ..LidarParams::default()
        }),
        ..TwinParams::default()
    };
    let mut hw = TwinHardware::with_world(&params, &world).expect("hardware");
    let mut log = Log::default();
    let frame = 10_000_000;
    for k in 0..60u64 {
        let now = k * frame;
        hw.advance_to(now);
        hw.lidar().poll(now, &mut log).expect("lidar");
        hw.imu().poll(now, &mut log).expect("imu");
        hw.can().poll(now, &mut log).expect("can");
        if look_ahead {
            hw.look_ahead(now + frame);
            // The truth stays at the frame's start until the next advance.
            assert_eq!(hw.ground_truth(), hw.truth_probe().get());
        }
    }
    (log, hw.ground_truth().position)
}

#[test]
fn looking_ahead_delivers_the_same_inputs_at_the_same_times() {
    let (plain, p0) = run(false, 2);
    let (ahead, p1) = run(true, 2);
    let (one_thread, p2) = run(true, 1);
    let lidar = plain.0.iter().filter(|i| i.0 == Device::Lidar).count();
    // 0.59 s of a 10 Hz head: ~1,060 packets.
    assert!(lidar > 1000, "{lidar} LiDAR packets");
    assert!(plain.0.iter().any(|i| i.0 == Device::Imu));
    assert_eq!(plain.0, ahead.0);
    assert_eq!(plain.0, one_thread.0);
    assert_eq!(p0, p1);
    assert_eq!(p0, p2);
}

#[test]
fn the_lidar_sends_a_position_packet_every_5_ms_on_its_own_clock() {
    use speleo_hal::hdl32e::position::PositionPacket;
    let (log, _) = run(true, 2);
    let positions: Vec<(u64, PositionPacket)> = log
        .0
        .iter()
        .filter(|i| i.0 == Device::LidarPosition)
        .map(|i| (i.1, PositionPacket::parse(&i.2).expect("512 bytes")))
        .collect();
    // 0.59 s of inputs: about 200 a second.
    assert!(
        (115..=120).contains(&positions.len()),
        "{}",
        positions.len()
    );
    for pair in positions.windows(2) {
        assert_eq!(pair[1].0 - pair[0].0, 5_000_000);
        assert_eq!(pair[1].1.timestamp_us - pair[0].1.timestamp_us, 5_000);
    }
    // No GPS receiver reaches a cave: no sentence.
    assert!(positions.iter().all(|(_, p)| p.nmea.is_empty()));
}
