//! `speleo info`: a recording's contents on standard output.

use std::io::Write;
use std::process::ExitCode;

use crate::args::InfoArgs;
use crate::Error;

pub fn info(a: InfoArgs) -> Result<ExitCode, Error> {
    let i = crate::info::info(&a.file)?;
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&i)?)?;
    } else {
        write!(out, "path:        {}\n{i}", a.file.display())?;
    }
    if a.config {
        match &i.config {
            Some(c) => write!(out, "\n{c}")?,
            None => writeln!(out, "\n(the recording holds no configuration)")?,
        }
    }
    out.flush()?;
    Ok(ExitCode::SUCCESS)
}
