//! Helpers shared by the command's integration tests.

#![allow(dead_code)] // each test file uses some of them

use std::process::{Command, Output};

/// `speleo ARGS --no-progress`, run to its end.
pub fn speleo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args(args)
        .arg("--no-progress")
        .output()
        .expect("speleo runs")
}

/// Bytes of an output stream as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}
