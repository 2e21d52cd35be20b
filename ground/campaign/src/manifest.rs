//! A planned campaign on disk: `DIR/manifest.toml` lists the cases, and
//! each case's folder holds the configuration it runs with.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::matrix::{Case, Matrix};

/// `DIR/manifest.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub name: String,
    /// The array size a cluster job is submitted with (`--array=0-N-1`).
    pub case_count: usize,
    pub timeout_s: f64,
    #[serde(rename = "case")]
    pub cases: Vec<Case>,
}

pub const MANIFEST: &str = "manifest.toml";
/// A case's outputs, beside its `config.toml`.
pub const REPORT: &str = "report.json";
pub const LOG: &str = "log.txt";
pub const OUTCOME: &str = "outcome.json";
pub const CONFIG: &str = "config.toml";

impl Manifest {
    /// Reads `DIR/manifest.toml`.
    pub fn load(dir: &Path) -> Result<Manifest, String> {
        let path = dir.join(MANIFEST);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            format!(
                "{}: {e} (is {} a campaign planned with `speleo campaign plan`?)",
                path.display(),
                dir.display()
            )
        })?;
        let m: Manifest = toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        if !crate::matrix::timeout_ok(m.timeout_s) {
            return Err(format!(
                "{}: timeout_s = {}: must lie within 1..=1000000 s",
                path.display(),
                m.timeout_s
            ));
        }
        if m.case_count != m.cases.len() || m.cases.iter().enumerate().any(|(i, c)| c.id != i) {
            return Err(format!(
                "{}: case_count {} and the {} cases listed do not agree",
                path.display(),
                m.case_count,
                m.cases.len()
            ));
        }
        Ok(m)
    }

    /// A case's folder.
    pub fn case_dir(dir: &Path, case: &Case) -> PathBuf {
        dir.join(case.dir_name())
    }
}

/// Writes a planned campaign into `dir`: the manifest, a copy of the
/// matrix and each case's configuration. A folder that already holds
/// another campaign is refused; planning the same matrix again changes
/// nothing.
pub fn write(dir: &Path, matrix_text: &str, matrix: &Matrix, cases: &[Case]) -> Result<(), String> {
    let manifest = Manifest {
        name: matrix.name.clone(),
        case_count: cases.len(),
        timeout_s: matrix.timeout_s,
        cases: cases.to_vec(),
    };
    let body = toml::to_string(&manifest).map_err(|e| e.to_string())?;
    let text = format!(
        "# Campaign \"{}\": {} cases, each run as `speleo sim --config {}/NNNN/{CONFIG}`.\n\
         # Run: speleo campaign run DIR [--jobs N] | --case K; judge: speleo campaign report DIR.\n\n{body}",
        matrix.name,
        cases.len(),
        "cases"
    );
    let path = dir.join(MANIFEST);
    if let Ok(old) = std::fs::read_to_string(&path) {
        if old != text {
            return Err(format!(
                "{} already holds another campaign; plan into a new folder",
                dir.display()
            ));
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for c in cases {
        let cd = Manifest::case_dir(dir, c);
        std::fs::create_dir_all(&cd).map_err(|e| format!("{}: {e}", cd.display()))?;
        let cfg = toml::to_string(&c.config(matrix.variant(&c.variant)))
            .map_err(|e| format!("case {}: {e}", c.id))?;
        let cfg = format!("# Case {}: {}\n{cfg}", c.id, c.key());
        write_atomic(&cd.join(CONFIG), cfg.as_bytes())?;
    }
    write_atomic(&dir.join("matrix.toml"), matrix_text.as_bytes())?;
    write_atomic(&path, text.as_bytes())
}

/// Writes a file whole or not at all (a temporary beside it, renamed).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let tmp = path.with_extension("partial");
    std::fs::write(&tmp, bytes).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("{}: {e}", path.display()))
}
