//! The example configurations in `examples/` load and pass validation, and
//! every one the README names exists: the README's lines stay true as the
//! configuration grows.

use std::path::{Path, PathBuf};

use speleo_firmware::config::Config;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples")
}

#[test]
fn every_example_configuration_loads_and_validates() {
    let mut n = 0;
    for e in std::fs::read_dir(examples()).expect("examples/") {
        let p = e.expect("entry").path();
        if p.extension().is_some_and(|x| x == "toml") {
            // A twin's file adds its wires to a configuration; the ground
            // tools' tests load it.
            let text = std::fs::read_to_string(&p).expect("read");
            let table: toml::Table = text.parse().expect("TOML");
            if table.contains_key("twin") {
                continue;
            }
            let cfg = Config::load(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            cfg.validate()
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            n += 1;
        }
    }
    assert!(n >= 3, "{n} example configurations");
    let budget = Config::load(&examples().join("budget.toml")).expect("budget.toml");
    assert_eq!(budget.exploration.energy_budget_wh, 6.0);
}

#[test]
fn every_example_the_readme_names_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for doc in ["README.md", "examples/README.md"] {
        let text = std::fs::read_to_string(root.join(doc)).expect("readme");
        for (i, _) in text.match_indices("examples/") {
            let name: String = text[i..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || "/._-".contains(*c))
                .collect();
            if name.ends_with(".toml") {
                assert!(
                    root.join(&name).is_file(),
                    "{doc} names {name}, which is not there"
                );
            }
        }
    }
}
