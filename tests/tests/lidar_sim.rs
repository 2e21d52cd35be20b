//! The simulated HDL-32E in a mission: its packets go through the real
//! driver, revolutions are recorded as point clouds that land in place on the
//! cave (through the recorded transforms, as a viewer draws them), and the
//! run replays identically.

use std::process::ExitCode;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use speleo_firmware::record::cdr::read_point_cloud2;
use speleo_tests::{read_json, replay, sim_with_config, MessageDecoder, Scratch};
use speleo_twin::lidar::LidarWorld;
use speleo_twin::world::World;

/// A ROS pose or transform (position or translation, and orientation or
/// rotation, decoded to JSON) as an isometry.
fn pose(position: &serde_json::Value, q: &serde_json::Value) -> Isometry3<f64> {
    let f = |v: &serde_json::Value, k: &str| v[k].as_f64().expect("number");
    Isometry3::from_parts(
        Translation3::new(f(position, "x"), f(position, "y"), f(position, "z")),
        UnitQuaternion::from_quaternion(Quaternion::new(
            f(q, "w"),
            f(q, "x"),
            f(q, "y"),
            f(q, "z"),
        )),
    )
}

#[test]
fn simulated_clouds_land_on_the_cave_and_replay_identically() {
    let s = Scratch::new();
    let cfg = s.path("lidar.toml");
    std::fs::write(&cfg, "[record]\ncloud_every = 1\n").expect("config");
    let log = s.path("l.mcap");
    sim_with_config(5, 6.0, Some(&cfg), Some(&log), Some(&s.path("a.json")));
    let bytes = std::fs::read(&log).expect("recording");

    // The transforms a viewer chains: world -> map -> odom -> base_link -> lidar.
    let mut world_map = None;
    let mut map_odom: Vec<(u64, Isometry3<f64>)> = Vec::new();
    let mut odom: Vec<(u64, Isometry3<f64>)> = Vec::new();
    let mut base_lidar = None;
    let mut last_cloud = None;
    let mut clouds = 0;
    let mut decoder = MessageDecoder::default();
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        let tf = |v: &serde_json::Value| {
            let t = &v["transforms"][0];
            let x = &t["transform"];
            (
                t["header"]["frame_id"].as_str().unwrap_or("").to_string(),
                t["child_frame_id"].as_str().unwrap_or("").to_string(),
                pose(&x["translation"], &x["rotation"]),
            )
        };
        match m.channel.topic.as_str() {
            "/sim/tf" => {
                let (parent, child, p) = tf(&decoder.decode(&m));
                assert_eq!((parent.as_str(), child.as_str()), ("world", "map"));
                world_map = Some(p);
            }
            "/tf_static" => {
                let v = decoder.decode(&m);
                for t in v["transforms"].as_array().expect("transforms") {
                    if t["child_frame_id"] == "lidar" {
                        let x = &t["transform"];
                        base_lidar = Some(pose(&x["translation"], &x["rotation"]));
                    }
                }
            }
            "/tf" => {
                let (parent, child, p) = tf(&decoder.decode(&m));
                if (parent.as_str(), child.as_str()) == ("map", "odom") {
                    map_odom.push((m.publish_time, p));
                }
            }
            "/odom" => {
                let v = decoder.decode(&m);
                assert_eq!(v["header"]["frame_id"], "odom");
                assert_eq!(v["child_frame_id"], "base_link");
                let p = &v["pose"]["pose"];
                odom.push((m.publish_time, pose(&p["position"], &p["orientation"])));
            }
            "/lidar/points" => {
                clouds += 1;
                last_cloud = Some((m.publish_time, m.data.into_owned()));
            }
            _ => {}
        }
    }
    // ~10 revolutions a second.
    assert!(clouds >= 55, "{clouds}");
    let (stamp, data) = last_cloud.expect("a cloud");
    let cloud = read_point_cloud2(&data).expect("a PointCloud2");
    assert_eq!(cloud.frame_id, "lidar");
    assert_eq!(cloud.point_step, 20);
    assert_eq!(&cloud.fields[..3], &[("x", 0, 7), ("y", 4, 7), ("z", 8, 7)]);
    // The odometry pose at the revolution's stamp.
    let (_, odom_base) = odom
        .iter()
        .rev()
        .find(|(t, _)| *t <= stamp)
        .expect("odometry before the cloud");
    // map -> odom at that time: identity until SLAM has its first keyframe.
    let map_odom = map_odom
        .iter()
        .rev()
        .find(|(t, _)| *t <= stamp)
        .map_or(Isometry3::identity(), |(_, p)| *p);
    let to_world =
        world_map.expect("/sim/tf") * map_odom * odom_base * base_lidar.expect("/tf_static");

    let world = World::build("lava-tube", 5).expect("tube");
    let mesh = LidarWorld::new(&world.mesh).expect("mesh");
    let mut d: Vec<f64> = cloud
        .data
        .chunks_exact(20)
        .step_by(23)
        .map(|p| {
            let f = |o: usize| f32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]]) as f64;
            let w = to_world * nalgebra::Point3::from(Vector3::new(f(0), f(4), f(8)));
            mesh.distance_to_surface([w.x, w.y, w.z])
        })
        .collect();
    d.sort_by(f64::total_cmp);
    let (median, p90) = (d[d.len() / 2], d[d.len() * 9 / 10]);
    eprintln!("cloud against the mesh: median {median:.3} m, p90 {p90:.3} m");
    // Range noise is 2 cm; the rest is odometry drift after 6 s of driving
    // and the motion within the revolution.
    assert!(
        median < 0.10 && p90 < 0.30,
        "median {median} m, p90 {p90} m"
    );

    assert_eq!(replay(&log, Some(&s.path("r.json"))), ExitCode::SUCCESS);
    let r = read_json(&s.path("r.json"));
    assert_eq!(r["replay"]["identical"], true);
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
}
