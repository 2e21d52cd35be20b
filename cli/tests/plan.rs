//! `speleo plan --sbpl-env` as a user meets it: the same plan, bit for
//! bit, from two processes; clear errors for bad files.

use std::path::Path;
use std::process::{Command, Output};

fn speleo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args(args)
        .output()
        .expect("speleo runs")
}

/// A 60 x 60 maze of 0.1 m cells with cell costs, start and goal in
/// opposite corners.
fn write_env(path: &Path) {
    let (w, h) = (60usize, 60usize);
    let mut s = format!(
        "discretization(cells): {w} {h}\nobsthresh: 9\ncost_inscribed_thresh: 9\n\
         cost_possibly_circumscribed_thresh: 0\ncellsize(meters): 0.1\nnominalvel(mpersecs): 1.0\n\
         timetoturn45degsinplace(secs): 1.0\nstart(meters,rads): 0.15 0.15 0\n\
         end(meters,rads): 5.85 5.85 1.5708\nenvironment:\n"
    );
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for y in 0..h {
        for x in 0..w {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            // Walls every 10 rows with a gap, and scattered costs.
            let wall = y % 10 == 5 && (x + y) % 60 > 6;
            let corner = (x < 3 && y < 3) || (x > 56 && y > 56);
            let c = if wall && !corner { 9 } else { (seed % 4) as u8 };
            s += &format!("{c} ");
        }
        s += "\n";
    }
    std::fs::write(path, s).expect("write env");
}

/// 16 headings: straight on (1 and 3 cells) and gentle turns, forward only.
fn write_mprim(path: &Path) {
    let mut s =
        String::from("resolution_m: 0.1\nnumberofangles: 16\ntotalnumberofprimitives: 64\n");
    let mut id = 0;
    for a in 0..16i32 {
        let th = a as f64 * std::f64::consts::TAU / 16.0;
        for (len, turn) in [(1.0, 0), (3.0, 0), (2.0, 1), (2.0, -1)] {
            let th1 = th + turn as f64 * std::f64::consts::TAU / 16.0;
            let mid = (th + th1) / 2.0;
            let (ex, ey) = (
                (len * mid.cos()).round() as i32,
                (len * mid.sin()).round() as i32,
            );
            s += &format!(
                "primID: {id}\nstartangle_c: {a}\nendpose_c: {ex} {ey} {}\nadditionalactioncostmult: 1\nintermediateposes: 2\n0 0 {th}\n{} {} {th1}\n",
                a + turn,
                ex as f64 * 0.1,
                ey as f64 * 0.1
            );
            id += 1;
        }
    }
    std::fs::write(path, s).expect("write mprim");
}

#[test]
fn the_same_plan_comes_out_of_two_processes_and_bad_files_are_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (env, prims) = (dir.path().join("maze.cfg"), dir.path().join("p.mprim"));
    write_env(&env);
    write_mprim(&prims);
    let run = |report: &str| {
        let r = dir.path().join(report);
        let out = speleo(&[
            "plan",
            "--sbpl-env",
            env.to_str().expect("utf8"),
            "--mprim",
            prims.to_str().expect("utf8"),
            "--eps",
            "2.5",
            "--quantum",
            "97",
            "--report",
            r.to_str().expect("utf8"),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&r).expect("report")).expect("json");
        v
    };
    let (a, b) = (run("a.json"), run("b.json"));
    assert!(a["cost"].as_u64().is_some(), "{a}");
    assert!(a["path"].as_array().is_some_and(|p| p.len() > 10), "{a}");
    for k in ["cost", "path", "expansions", "heuristic_at_start"] {
        assert_eq!(a[k], b[k], "{k}");
    }
    let costs = |v: &serde_json::Value| -> Vec<(u64, u64)> {
        v["rounds"]
            .as_array()
            .expect("rounds")
            .iter()
            .map(|r| {
                (
                    r["cost"].as_u64().unwrap_or(0),
                    r["expansions"].as_u64().unwrap_or(0),
                )
            })
            .collect()
    };
    assert_eq!(costs(&a), costs(&b));

    // A truncated primitive file: an error naming the file and the line.
    let text = std::fs::read_to_string(&prims).expect("read");
    std::fs::write(&prims, &text[..text.len() / 2]).expect("write");
    let out = speleo(&[
        "plan",
        "--sbpl-env",
        env.to_str().expect("utf8"),
        "--mprim",
        prims.to_str().expect("utf8"),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("p.mprim") && err.contains("line"), "{err}");
}
