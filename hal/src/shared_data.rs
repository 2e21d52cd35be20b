//! The real recordings in `../shared/data` beside the repository, used by
//! tests and benchmarks. A user's clone has none: callers skip, visibly.

use std::path::{Path, PathBuf};

/// `../shared/data/<rel>`, or `None` after printing a skip message when it
/// is absent.
pub fn path(rel: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipped: {} not found (shared data absent)", p.display());
        None
    }
}
