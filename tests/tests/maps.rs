//! The maps of a simulated run: the report's `maps` and `planner`
//! sections, the TSDF mesh of the keyframes against the world's true
//! surface, the exported scans meshed again by `speleo mesh --scans`, and
//! `speleo mesh --record` giving the run's own mesh back from its
//! recording.

use std::path::Path;

use nalgebra::{Isometry3, Matrix3, Point3, Translation3, UnitQuaternion, Vector3};
use speleo_firmware::args::Outputs;
use speleo_tests::{read_json, Scratch};
use speleo_tools::args::MeshArgs;
use speleo_tools::commands::mesh;
use speleo_twin::lidar::LidarWorld;

const SEED: u64 = 1;
const SECONDS: f64 = 20.0;

fn mesh_tool(scans: Option<&Path>, record: Option<&Path>, out: &Path, report: &Path) {
    let code = mesh::mesh(
        MeshArgs {
            scans: scans.map(Path::to_path_buf),
            poses: scans.map(|d| d.join("poses.txt")),
            record: record.map(Path::to_path_buf),
            voxel: 0.05,
            trunc: 3.0,
            max_blocks: 1 << 15,
            out: out.to_path_buf(),
            report: Some(report.to_path_buf()),
        },
        false,
    )
    .unwrap_or_else(|e| panic!("speleo mesh failed: {e}"));
    assert_eq!(code, std::process::ExitCode::SUCCESS);
}

fn read_mesh(path: &Path) -> speleo_physics::Mesh {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    speleo_physics::terrain::ply::parse(&bytes)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A KITTI line: sensor -> map.
fn kitti(line: &str) -> Isometry3<f64> {
    let v: Vec<f64> = line
        .split_whitespace()
        .map(|t| t.parse().unwrap_or_else(|e| panic!("{t}: {e}")))
        .collect();
    assert_eq!(v.len(), 12, "{line}");
    let r = Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
    Isometry3::from_parts(
        Translation3::new(v[3], v[7], v[11]),
        UnitQuaternion::from_matrix(&r),
    )
}

/// A TUM line: base -> world.
fn tum(line: &str) -> Isometry3<f64> {
    let v: Vec<f64> = line
        .split_whitespace()
        .map(|t| t.parse().unwrap_or_else(|e| panic!("{t}: {e}")))
        .collect();
    assert_eq!(v.len(), 8, "{line}");
    let q = nalgebra::Quaternion::new(v[7], v[4], v[5], v[6]);
    Isometry3::from_parts(
        Translation3::new(v[1], v[2], v[3]),
        UnitQuaternion::from_quaternion(q),
    )
}

#[test]
fn the_runs_mesh_lies_on_the_tube_and_comes_back_from_scans_and_from_the_recording() {
    let s = Scratch::new();
    let (log, report, mesh, scans) = (
        s.path("run.mcap"),
        s.path("run.json"),
        s.path("run.ply"),
        s.path("scans"),
    );
    let trajectory = s.path("kf.tum");
    let config = s.path("maps.toml");
    // A TSDF pool of 32k blocks (128 MiB) is plenty for 20 s.
    std::fs::write(&config, "[maps]\ntsdf_max_blocks = 32768\n").unwrap_or_else(|e| panic!("{e}"));
    speleo_firmware::commands::sim(
        speleo_firmware::args::SimArgs {
            world: None,
            start: None,
            seed: Some(SEED),
            noise_seed: None,
            duration: Some(SECONDS),
            config: Some(config.clone()),
            route: true,
            trajectory: Some(trajectory.clone()),
            faults: Vec::new(),
            dump_validations: None,
            out: Outputs {
                record: Some(log.clone()),
                report: Some(report.clone()),
                mesh: Some(mesh.clone()),
                export_scans: Some(scans.clone()),
                live: None,
            },
        },
        false,
    )
    .unwrap_or_else(|e| panic!("sim failed: {e}"));
    let r = read_json(&report);
    let m = &r["maps"];
    let n = |k: &str| m[k].as_f64().unwrap_or(f64::NAN);
    assert!(n("keyframes_mapped") >= 5.0, "{m}");
    for k in [
        "mls_cells",
        "mls_patches",
        "tsdf_blocks",
        "mesh_triangles",
        "memory_bytes",
    ] {
        assert!(n(k) > 0.0, "{k}: {m}");
    }
    assert_eq!(m["mls_full"], false, "{m}");
    assert_eq!(m["tsdf_full"], false, "{m}");
    assert_eq!(
        r["scheduler"]["allocations_after_init"], 0,
        "{}",
        r["scheduler"]
    );
    // The planner plans on these maps as they grow: a query every 10 s,
    // each proven optimal.
    let p = &r["planner"];
    let k = |key: &str| p[key].as_u64().unwrap_or(u64::MAX);
    assert!(k("calls") >= 2 && k("solved") >= 1, "{p}");
    assert!(k("optimal") >= 1 && k("plans_published") >= 1, "{p}");
    assert!(k("graph_nodes_max") > 1000 && k("graphs_full") == 0, "{p}");
    assert!(p["first_solution_ms_max"].as_u64().is_some(), "{p}");

    // The mesh (map frame) against the true tube (world frame). SLAM's
    // first keyframe in both frames gives the map's place in the world.
    let poses = std::fs::read_to_string(scans.join("poses.txt")).unwrap_or_else(|e| panic!("{e}"));
    let traj = std::fs::read_to_string(&trajectory).unwrap_or_else(|e| panic!("{e}"));
    let (Some(p0), Some(t0)) = (poses.lines().next(), traj.lines().next()) else {
        panic!("no keyframe");
    };
    let mount = Isometry3::translation(0.0, 0.0, 0.35);
    let world_from_map = tum(t0) * (kitti(p0) * mount.inverse()).inverse();
    let world =
        speleo_twin::world::World::build("lava-tube", SEED).unwrap_or_else(|e| panic!("{e}"));
    let truth = LidarWorld::new(&world.mesh).unwrap_or_else(|e| panic!("{e}"));
    let ours = read_mesh(&mesh);
    let mut d: Vec<f64> = ours
        .vertices
        .iter()
        .step_by(7)
        .map(|v| {
            let p =
                world_from_map * Point3::from(Vector3::new(v[0] as f64, v[1] as f64, v[2] as f64));
            truth.distance_to_surface([p.x, p.y, p.z])
        })
        .collect();
    d.sort_by(f64::total_cmp);
    let (median, p90) = (d[d.len() / 2], d[d.len() * 9 / 10]);
    println!(
        "mesh: {} vertices; distance to the true surface: median {:.4} m, 90% {:.4} m",
        ours.vertices.len(),
        median,
        p90
    );
    // Half a voxel, with SLAM's error on top.
    assert!(median < 0.025, "median {median} m");
    assert!(p90 < 0.06, "90th percentile {p90} m");

    // The exported scans, meshed by the tool: the same surface (the scans
    // went through the sensor frame and f32, so not to the bit).
    let (again, again_report) = (s.path("again.ply"), s.path("again.json"));
    mesh_tool(Some(&scans), None, &again, &again_report);
    let a = read_mesh(&again);
    let ratio = a.triangles.len() as f64 / ours.triangles.len() as f64;
    assert!(
        (ratio - 1.0).abs() < 0.01,
        "{} vs {} triangles",
        a.triangles.len(),
        ours.triangles.len()
    );

    // The recording run through the drivers and SLAM again: the same
    // keyframes at the same poses, so the very same mesh.
    let (replayed, replayed_report) = (s.path("replayed.ply"), s.path("replayed.json"));
    mesh_tool(None, Some(&log), &replayed, &replayed_report);
    let same = std::fs::read(&replayed).ok() == std::fs::read(&mesh).ok();
    assert!(same, "the mesh of the recording differs from the run's");
}

#[test]
fn speleo_mesh_refuses_bad_input_with_a_clear_error() {
    let s = Scratch::new();
    let dir = s.path("scans");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let run = |scans: &Path| {
        mesh::mesh(
            MeshArgs {
                scans: Some(scans.to_path_buf()),
                poses: Some(scans.join("poses.txt")),
                record: None,
                voxel: 0.05,
                trunc: 3.0,
                max_blocks: 64,
                out: s.path("out.ply"),
                report: None,
            },
            false,
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
    };
    assert!(run(&dir).contains("no .ply scans"), "{}", run(&dir));
    let ply = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n";
    std::fs::write(dir.join("a.ply"), ply).unwrap_or_else(|e| panic!("{e}"));
    assert!(run(&dir).contains("poses.txt"), "{}", run(&dir));
    std::fs::write(
        dir.join("poses.txt"),
        "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(run(&dir).contains("2 poses for 1 scans"), "{}", run(&dir));
    std::fs::write(dir.join("poses.txt"), "1 0 0 0 0 1 0 0 0 0 1\n")
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(run(&dir).contains("line 1"), "{}", run(&dir));
    std::fs::write(dir.join("poses.txt"), "1 0 0 0 0 1 0 0 0 0 1 0\n")
        .unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(
        dir.join("a.ply"),
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5\n",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(run(&dir).contains("a.ply"), "{}", run(&dir));
    std::fs::write(dir.join("a.ply"), ply).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(run(&dir), "", "one point is a valid (tiny) input");
}
