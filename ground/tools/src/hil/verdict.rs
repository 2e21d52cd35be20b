//! The bench's figures from the two reports, and their side-by-side print.

use serde_json::{json, Value};

/// The bench's verdict figures: the flight binary's final SLAM pose against
/// the twin's truth, in the map frame (level, at the true start, heading as
/// the rover started).
pub fn judge(flight: &Value, twin: &Value) -> Value {
    let f64s = |v: &Value| -> Option<Vec<f64>> {
        v.as_array()?
            .iter()
            .map(Value::as_f64)
            .collect::<Option<Vec<_>>>()
    };
    let start = f64s(&twin["run"]["truth_start"]);
    let end = f64s(&twin["run"]["truth_end"]);
    let believed = f64s(&flight["end"]["slam_position"]);
    let error = match (start, end, believed) {
        (Some(s), Some(e), Some(b)) if s.len() == 4 && e.len() == 4 && b.len() == 3 => {
            let (c, sn) = (s[3].cos(), s[3].sin());
            let (dx, dy, dz) = (e[0] - s[0], e[1] - s[1], e[2] - s[2]);
            let truth = [c * dx + sn * dy, -sn * dx + c * dy, dz];
            let d: f64 = (0..3).map(|i| (truth[i] - b[i]).powi(2)).sum();
            json!({
                "truth_in_map": truth,
                "believed_in_map": b,
                "position_error_m": d.sqrt(),
            })
        }
        _ => json!({ "position_error_m": null }),
    };
    json!({
        "pose": error,
        "truth_distance_m": twin["run"]["truth_distance_m"],
        "odometry_distance_m": flight["end"]["odometry_distance_m"],
        "explored_area_m2": flight["exploration"]["explored_area_m2"],
    })
}

pub fn print_side_by_side(flight: &Value, twin: &Value, bench: &Value) {
    let n = |v: &Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.2}"));
    println!("{:<34} {:>16} {:>16}", "", "flight (run)", "twin (truth)");
    println!(
        "{:<34} {:>16} {:>16}",
        "seconds",
        n(&flight["sim_time_s"]),
        n(&twin["run"]["seconds"])
    );
    println!(
        "{:<34} {:>16} {:>16}",
        "distance driven, m",
        n(&bench["odometry_distance_m"]),
        n(&bench["truth_distance_m"])
    );
    println!(
        "{:<34} {:>16} {:>16}",
        "position error at the end, m",
        n(&bench["pose"]["position_error_m"]),
        ""
    );
    let t = &bench["track"];
    println!(
        "{:<34} {:>16} {:>16}",
        "SLAM track error mean/p95/max, m",
        format!("{}/{}/{}", n(&t["mean_m"]), n(&t["p95_m"]), n(&t["max_m"])),
        ""
    );
    println!(
        "{:<34} {:>16} {:>16}",
        "explored area, m2",
        n(&bench["explored_area_m2"]),
        ""
    );
    println!(
        "{:<34} {:>16} {:>16}",
        "lidar packets",
        n(&flight["counters"]["lidar_packets"]),
        twin["links"]["lidar_packets_sent"].to_string()
    );
    let rt = &flight["realtime"];
    println!(
        "{:<34} {:>16} {:>16}",
        "frame start lateness p50/p99/max, us",
        format!(
            "{}/{}/{}",
            n(&rt["frame_start_lateness"]["p50_us"]),
            n(&rt["frame_start_lateness"]["p99_us"]),
            n(&rt["frame_start_lateness"]["max_us"])
        ),
        format!("{} slipped", twin["run"]["steps_slipped"])
    );
    for (key, label) in [
        (
            "lidar_to_wheel_command",
            "lidar -> wheel command p50/p99, ms",
        ),
        ("imu_to_odometry", "imu -> odometry p50/p99, ms"),
    ] {
        let ms = |v: &Value| {
            v.as_f64()
                .map_or("-".to_string(), |x| format!("{:.1}", x * 1e-3))
        };
        println!(
            "{:<34} {:>16} {:>16}",
            label,
            format!("{}/{}", ms(&rt[key]["p50_us"]), ms(&rt[key]["p99_us"])),
            ""
        );
    }
    println!(
        "{:<34} {:>16}",
        "real-time setup",
        format!(
            "{}; {}",
            rt["sched_fifo"].as_str().unwrap_or("-"),
            rt["mlockall"].as_str().unwrap_or("-")
        )
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_truth_is_taken_into_the_map_frame_before_it_is_compared() {
        // Started at (1, 2) heading +y; drove 3 m along +y: 3 m ahead in the map.
        let twin = json!({"run": {"truth_start": [1.0, 2.0, 0.0, std::f64::consts::FRAC_PI_2],
                                   "truth_end": [1.0, 5.0, 0.5, 1.6],
                                   "truth_distance_m": 3.0}});
        let flight = json!({"end": {"slam_position": [2.9, 0.1, 0.5], "odometry_distance_m": 3.1}});
        let b = judge(&flight, &twin);
        let e = b["pose"]["position_error_m"].as_f64().expect("an error");
        assert!((e - 0.02f64.sqrt()).abs() < 1e-9, "{e}");
        assert_eq!(b["truth_distance_m"], 3.0);
        // A report without an end pose gives no error, not a panic.
        let none = judge(&json!({}), &twin);
        assert!(none["pose"]["position_error_m"].is_null());
    }
}
