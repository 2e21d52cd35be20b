//! How a case's process ended (`cases/NNNN/outcome.json`): written once
//! the process is gone, so a case without one has not run to its end.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::manifest::{write_atomic, OUTCOME};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The mission ran to its end and wrote its report.
    Ran,
    /// The process exited with an error, or without a report.
    Crashed,
    /// It ran past the campaign's `timeout_s` and was killed.
    Hung,
    /// A signal from outside stopped it (a cluster's preemption, an
    /// operator, the OOM killer): never saved, so the case runs again.
    Killed,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    pub status: Status,
    pub exit_code: Option<i32>,
    pub signal: Option<i32>,
    pub wall_time_s: f64,
    /// Where it ran (a cluster's node).
    pub host: String,
    /// The last lines of its log, for a case that did not run.
    pub log_tail: Vec<String>,
}

impl Outcome {
    /// The case's outcome; `None` when it has none yet. A file that
    /// cannot be read or parsed is an error, not "not run": the case's
    /// results are not overwritten on a passing fault of the filesystem.
    pub fn load(case_dir: &Path) -> Option<Result<Outcome, String>> {
        let path = case_dir.join(OUTCOME);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
            Err(e) => return Some(Err(format!("{}: {e}", path.display()))),
        };
        Some(serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display())))
    }

    pub fn save(&self, case_dir: &Path) -> Result<(), String> {
        let text = serde_json::to_string_pretty(self).map_err(|e| e.to_string())?;
        write_atomic(&case_dir.join(OUTCOME), (text + "\n").as_bytes())
    }
}

/// The last `n` lines of a log.
pub fn tail(path: &Path, n: usize) -> Vec<String> {
    let text = std::fs::read(path).unwrap_or_default();
    let text = String::from_utf8_lossy(&text);
    // A progress bar's carriage returns leave only what was last drawn.
    let lines: Vec<String> = text
        .lines()
        .map(|l| l.rsplit('\r').next().unwrap_or(l).to_string())
        .filter(|l| !l.trim().is_empty())
        .collect();
    lines[lines.len().saturating_sub(n)..].to_vec()
}

/// This machine's name.
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}
