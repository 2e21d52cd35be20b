//! Every output a command will write, checked before its mission starts:
//! a missing folder or a read-only one is named at once, not after an
//! hour of mission whose figures then have nowhere to go.

use std::path::Path;

use crate::args::Outputs;

/// `path` can be created or replaced as a file: its folder exists and
/// takes a new file, and it is not itself a folder. `what` names the
/// option for the message.
pub fn check_file(path: &Path, what: &str) -> Result<(), String> {
    if path.is_dir() {
        return Err(format!(
            "{what} {}: is a folder, not a file",
            path.display()
        ));
    }
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        return Err(format!(
            "{what} {}: no folder {} to write it in",
            path.display(),
            folder.display()
        ));
    }
    // Writing is the only sure test (permissions, read-only mounts, ACLs).
    let probe = folder.join(format!(".speleo-write-check-{}", std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(format!(
            "{what} {}: cannot write in {}: {e}",
            path.display(),
            folder.display()
        )),
    }
}

/// `path` is a folder to write files in, made now if it is missing.
pub fn check_folder(path: &Path, what: &str) -> Result<(), String> {
    std::fs::create_dir_all(path)
        .map_err(|e| format!("{what} {}: cannot make the folder: {e}", path.display()))?;
    check_file(&path.join("probe"), what)
}

/// The outputs every flight command shares.
pub fn check(out: &Outputs) -> Result<(), String> {
    if let Some(p) = &out.record {
        check_file(p, "--record")?;
    }
    if let Some(p) = &out.report {
        check_file(p, "--report")?;
    }
    if let Some(p) = &out.mesh {
        check_file(p, "--mesh")?;
    }
    if let Some(p) = &out.export_scans {
        check_folder(p, "--export-scans")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_folder_or_a_folder_for_a_file_is_named() {
        let d = tempfile::tempdir().expect("tmp");
        assert!(check_file(&d.path().join("r.json"), "--report").is_ok());
        let e = check_file(&d.path().join("no/such/r.json"), "--report").expect_err("missing");
        assert!(e.contains("--report") && e.contains("no folder"), "{e}");
        let e = check_file(d.path(), "--plot").expect_err("folder");
        assert!(e.contains("is a folder"), "{e}");
        let scans = d.path().join("scans/run1");
        assert!(check_folder(&scans, "--export-scans").is_ok());
        assert!(scans.is_dir());
        // Nothing is left behind by the checks.
        assert_eq!(std::fs::read_dir(&scans).expect("dir").count(), 0);
    }
}
