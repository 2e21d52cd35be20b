//! The house's rules on which crate may depend on which, checked on the
//! dependency graph `cargo metadata` resolves (normal dependencies, followed
//! transitively; dev-dependencies and build scripts aside).

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// Each workspace crate's normal dependencies, by package name.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    // This machine's platform only: the others' crates need not be fetched.
    let rustc = Command::new("rustc")
        .arg("-vV")
        .output()
        .expect("rustc runs");
    let host = String::from_utf8_lossy(&rustc.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .expect("rustc names its host");
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--offline",
            "--filter-platform",
        ])
        .arg(host)
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("metadata is JSON");
    let name_of: BTreeMap<&str, &str> = meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| (text(&p["id"]), text(&p["name"])))
        .collect();
    let mut g = BTreeMap::new();
    for node in meta["resolve"]["nodes"].as_array().expect("resolve") {
        let from = name_of[text(&node["id"])].to_string();
        let deps: BTreeSet<String> = node["deps"]
            .as_array()
            .expect("a node's deps")
            .iter()
            .filter(|d| {
                d["dep_kinds"]
                    .as_array()
                    .expect("a dependency's kinds")
                    .iter()
                    .any(|k| k["kind"].is_null())
            })
            .map(|d| name_of[text(&d["pkg"])].to_string())
            .collect();
        g.entry(from).or_insert_with(BTreeSet::new).extend(deps);
    }
    g
}

/// A string field of the metadata.
fn text(v: &serde_json::Value) -> &str {
    v.as_str().expect("cargo metadata gives a string here")
}

/// Every crate `from` depends on, directly or not.
fn reach(g: &BTreeMap<String, BTreeSet<String>>, from: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo = vec![from.to_string()];
    while let Some(c) = todo.pop() {
        for d in g.get(&c).into_iter().flatten() {
            if seen.insert(d.clone()) {
                todo.push(d.clone());
            }
        }
    }
    seen
}

/// The workspace's crates whose manifest lies under `folder`.
fn crates_under(folder: &str) -> Vec<String> {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let mut names = Vec::new();
    for e in std::fs::read_dir(format!("{root}/{folder}")).expect("folder exists") {
        let manifest = e.expect("entry").path().join("Cargo.toml");
        let Ok(text) = std::fs::read_to_string(&manifest) else {
            continue;
        };
        let name = text
            .lines()
            .find_map(|l| l.strip_prefix("name = \""))
            .and_then(|r| r.strip_suffix('"'))
            .unwrap_or_else(|| panic!("{} names its package", manifest.display()));
        names.push(name.to_string());
    }
    assert!(!names.is_empty(), "no crate under {folder}");
    names
}

fn assert_never(g: &BTreeMap<String, BTreeSet<String>>, from: &str, forbidden: &[&str]) {
    let r = reach(g, from);
    for f in forbidden {
        assert!(
            !r.contains(*f),
            "{from} depends on {f}, which the house forbids"
        );
    }
}

#[test]
fn no_component_and_no_message_depends_on_firmware() {
    let g = graph();
    for c in crates_under("components") {
        assert_never(&g, &c, &["speleo-firmware"]);
    }
    assert_never(&g, "speleo-messages", &["speleo-firmware"]);
}

#[test]
fn flight_code_does_not_depend_on_the_ground_tools() {
    // The tools build on the flight software, never the reverse: the
    // binary that flies is the one whose commands the tools drive.
    let g = graph();
    let flight = [
        "speleo-firmware",
        "speleo-messages",
        "speleo-hal",
        "speleo-scheduler",
    ];
    let components = crates_under("components");
    for c in flight
        .iter()
        .copied()
        .chain(components.iter().map(String::as_str))
    {
        assert_never(&g, c, &["speleo-tools", "speleo-cli"]);
    }
}

/// The simulation's heavy crates: rigid-body physics and collision
/// (rapier3d, parry3d) and the LiDAR twin's ray casting (obvhs, glam).
const SIMULATION_CRATES: [&str; 4] = ["rapier3d", "parry3d", "obvhs", "glam"];

#[test]
fn the_flight_hal_builds_without_the_simulation() {
    // The hardware twin and the physics live in speleo-twin and
    // speleo-physics; the HAL the rover flies keeps to its devices.
    let g = graph();
    assert_never(&g, "speleo-hal", &SIMULATION_CRATES);
}

#[test]
fn the_internal_simulator_does_not_depend_on_the_hal() {
    // It drives the physics rover on the rover's own map: it borrows the
    // physics, never the twin; the HAL's codecs reach it only through the
    // messages it reads (plans, stop reasons).
    let g = graph();
    assert_never(&g, "speleo-simulator", &["speleo-twin"]);
    let direct = &g["speleo-simulator"];
    assert!(!direct.contains("speleo-hal"), "{direct:?}");
    assert!(direct.contains("speleo-physics"), "{direct:?}");
}

#[test]
fn the_rules_are_checked_on_a_graph_that_has_the_crates() {
    // A rule over a crate the graph lacks would pass for nothing.
    let g = graph();
    for c in [
        "speleo-firmware",
        "speleo-messages",
        "speleo-hal",
        "speleo-planner",
        "speleo-physics",
        "speleo-twin",
        "speleo-simulator",
        "speleo-tools",
        "speleo-cli",
    ] {
        assert!(g.contains_key(c), "{c} is not in the graph");
    }
    assert!(reach(&g, "speleo-firmware").contains("speleo-messages"));
    assert!(reach(&g, "speleo-cli").contains("speleo-tools"));
    // The forbidden crates are in the graph under these names: the twin
    // reaches them all, and the HAL whose codecs it encodes with.
    let twin = reach(&g, "speleo-twin");
    for c in SIMULATION_CRATES {
        assert!(twin.contains(c), "speleo-twin does not reach {c}");
    }
    assert!(twin.contains("speleo-hal"));
}
