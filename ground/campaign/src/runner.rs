//! Runs a planned campaign's cases as separate `speleo sim` processes,
//! N at a time, or one case alone (a cluster's array task).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::manifest::{Manifest, CONFIG, LOG, REPORT};
use crate::matrix::Case;
use crate::outcome::{host_name, tail, Outcome, Status};

/// The folder in a case's where its validations are dumped.
pub const VALIDATIONS: &str = "validations";
/// Lines of a failed case's log kept in its outcome.
const LOG_TAIL_LINES: usize = 20;
/// The status of a `speleo sim` a signal cut short.
const INTERRUPTED_STATUS: u8 = 130;
/// How often a running case is looked at.
const POLL: Duration = Duration::from_millis(50);

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RunTally {
    /// Cases finished before this run began, or run by another runner on
    /// the same folder meanwhile (skipped).
    pub skipped: usize,
    /// Cases run now, and those of them that did not run to their end.
    pub ran: usize,
    pub failed: usize,
}

/// The program a case runs: `speleo` itself, with arguments before `sim`
/// (tests point it elsewhere).
#[derive(Clone, Debug)]
pub struct Program {
    pub exe: PathBuf,
    pub leading_args: Vec<String>,
    /// Each case writes its internal simulator's validations into its
    /// folder's [`VALIDATIONS`] (`speleo sim --dump-validations`), for
    /// `speleo campaign validations` to replay on the true worlds.
    pub dump_validations: bool,
    /// Set when the campaign is to stop (a signal): no case is started
    /// after it, and the running ones are asked to end (SIGTERM), which
    /// leaves them without an outcome, to run again.
    pub stop: &'static AtomicBool,
}

static NEVER: AtomicBool = AtomicBool::new(false);

impl Program {
    /// The running binary.
    pub fn this() -> Result<Program, String> {
        let exe = std::env::current_exe().map_err(|e| format!("the running binary: {e}"))?;
        Ok(Program {
            exe,
            leading_args: Vec::new(),
            dump_validations: false,
            stop: &NEVER,
        })
    }
}

/// Runs one case to its end and records how it ended; a case already
/// finished is left as it is (`None`).
pub fn run_case(
    dir: &Path,
    m: &Manifest,
    id: usize,
    p: &Program,
) -> Result<Option<Outcome>, String> {
    let case = m.cases.get(id).ok_or_else(|| {
        format!(
            "case {id}: the campaign has cases 0 to {}",
            m.case_count.saturating_sub(1)
        )
    })?;
    let cd = Manifest::case_dir(dir, case);
    // Another runner on the same folder (a second machine, a cluster's
    // retry) may hold the case: it is theirs. The lock goes with the
    // process that holds it, however it ends.
    let Some(_lock) = CaseLock::take(&cd)? else {
        return Ok(None);
    };
    if let Some(done) = crate::outcome::Outcome::load(&cd) {
        done?;
        return Ok(None);
    }
    let o = execute(&cd, case, p, m.timeout_s)?;
    // Stopped from outside (a cluster's preemption, an operator): not the
    // mission's doing, so no outcome, and the next run starts it again.
    if o.status != Status::Killed {
        o.save(&cd)?;
    }
    Ok(Some(o))
}

/// An exclusive hold on a case's folder (`flock` on its `lock` file),
/// released when dropped.
struct CaseLock {
    _file: std::fs::File,
}

impl CaseLock {
    /// The case's lock, or `None` when another process holds it.
    fn take(case_dir: &Path) -> Result<Option<CaseLock>, String> {
        use std::os::fd::AsRawFd;
        let path = case_dir.join("lock");
        let f = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        // SAFETY: flock on a descriptor this function owns.
        let r = unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
        if r == 0 {
            Ok(Some(CaseLock { _file: f }))
        } else {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() == Some(libc::EWOULDBLOCK) {
                Ok(None)
            } else {
                Err(format!("{}: cannot lock: {e}", path.display()))
            }
        }
    }
}

/// Runs `case` in `cd` (its configuration there), writing its report and
/// log there.
pub fn execute(cd: &Path, case: &Case, p: &Program, timeout_s: f64) -> Result<Outcome, String> {
    let report = cd.join(REPORT);
    let log_path = cd.join(LOG);
    // What an interrupted earlier attempt left is not this run's.
    let _ = std::fs::remove_file(&report);
    let log =
        std::fs::File::create(&log_path).map_err(|e| format!("{}: {e}", log_path.display()))?;
    let log2 = log
        .try_clone()
        .map_err(|e| format!("{}: {e}", log_path.display()))?;
    let mut cmd = Command::new(&p.exe);
    cmd.args(&p.leading_args)
        .arg("sim")
        .arg("--no-progress")
        .arg("--config")
        .arg(cd.join(CONFIG))
        .arg("--report")
        .arg(&report);
    if p.dump_validations {
        cmd.arg("--dump-validations").arg(cd.join(VALIDATIONS));
    }
    cmd
        // A log file, not a terminal: no colour codes in it.
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(log2);
    die_with_parent(&mut cmd);
    let limit = Duration::try_from_secs_f64(timeout_s)
        .map_err(|e| format!("timeout_s = {timeout_s}: {e}"))?;
    let started = Instant::now();
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("case {}: cannot start {}: {e}", case.id, p.exe.display()))?;
    let (status, timed_out) = wait(&mut child, limit, p.stop)?;
    let wall_time_s = started.elapsed().as_secs_f64();
    let signal = std::os::unix::process::ExitStatusExt::signal(&status);
    // A signal that stops a process from outside, as against one a
    // process raises on itself by crashing (SIGSEGV, SIGABRT...).
    // A case that ended itself on a signal's request says so by its status.
    let from_outside = matches!(
        signal,
        Some(libc::SIGKILL | libc::SIGTERM | libc::SIGINT | libc::SIGHUP)
    ) || status.code() == Some(i32::from(INTERRUPTED_STATUS));
    let status_kind = if timed_out {
        Status::Hung
    } else if from_outside {
        Status::Killed
    } else if status.success() && report.exists() {
        Status::Ran
    } else {
        Status::Crashed
    };
    Ok(Outcome {
        status: status_kind,
        exit_code: status.code(),
        signal,
        wall_time_s,
        host: host_name(),
        log_tail: if status_kind == Status::Ran {
            Vec::new()
        } else {
            tail(&log_path, LOG_TAIL_LINES)
        },
    })
}

/// Waits for the child, killing it past `limit`; whether it was killed so.
fn wait(
    child: &mut Child,
    limit: Duration,
    stop: &AtomicBool,
) -> Result<(ExitStatus, bool), String> {
    let started = Instant::now();
    let mut asked_to_stop = false;
    loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            return Ok((s, false));
        }
        // Out of the terminal's process group, the case did not see the
        // Ctrl-C: it is passed on, once, and the case ends at its next frame.
        if !asked_to_stop && stop.load(Ordering::Relaxed) {
            asked_to_stop = true;
            // SAFETY: kill(2) on the pid of a child not yet reaped.
            unsafe {
                libc::kill(child.id() as libc::pid_t, libc::SIGTERM);
            }
        }
        if started.elapsed() >= limit {
            let _ = child.kill();
            let s = child.wait().map_err(|e| e.to_string())?;
            return Ok((s, true));
        }
        std::thread::sleep(POLL);
    }
}

/// A case's process leaves the terminal's process group (Ctrl-C stops the
/// campaign, not its cases one by one, which would read as failures) and
/// dies with the runner, so a killed campaign leaves no orphans and no
/// outcome: the next run starts those cases again.
fn die_with_parent(cmd: &mut Command) {
    use std::os::unix::process::CommandExt;
    let runner = std::process::id() as libc::pid_t;
    // SAFETY: between fork and exec only async-signal-safe calls are made
    // (setpgid, prctl, getppid), and nothing is allocated.
    unsafe {
        cmd.pre_exec(move || {
            libc::setpgid(0, 0);
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
            // The runner may have died between fork and prctl (the runner
            // may itself be PID 1, in a container: compare with its pid).
            if libc::getppid() != runner {
                libc::_exit(1);
            }
            Ok(())
        });
    }
}

/// Runs every unfinished case, `jobs` at a time, with a progress bar
/// (cases done, failed, time left) when `progress`.
pub fn run_all(dir: &Path, p: &Program, jobs: usize, progress: bool) -> Result<RunTally, String> {
    let m = Manifest::load(dir)?;
    let mut pending = Vec::new();
    let mut tally = RunTally::default();
    for c in &m.cases {
        match Outcome::load(&Manifest::case_dir(dir, c)) {
            Some(done) => {
                done?;
                tally.skipped += 1;
            }
            None => pending.push(c.id),
        }
    }
    // The shortest missions first: the campaign's first answers come
    // early, and the long ones left at the end share the cores.
    pending.sort_by(|&a, &b| {
        m.cases[a]
            .duration_s
            .total_cmp(&m.cases[b].duration_s)
            .then(a.cmp(&b))
    });
    let bar = if progress {
        indicatif::ProgressBar::new(m.case_count as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:30} {pos}/{len} cases, {msg} [{elapsed_precise}, ETA {eta_precise}]",
        )
        .map_err(|e| e.to_string())?,
    );
    bar.set_position(tally.skipped as u64);
    bar.reset_eta();
    bar.set_message("0 failed");
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<(usize, Result<Option<Outcome>, String>)>();
    let jobs = jobs.max(1).min(pending.len().max(1));
    std::thread::scope(|s| {
        for _ in 0..jobs {
            let tx = tx.clone();
            let (m, pending, next) = (&m, &pending, &next);
            s.spawn(move || loop {
                if p.stop.load(Ordering::Relaxed) {
                    break;
                }
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&id) = pending.get(i) else { break };
                let r = run_case(dir, m, id, p);
                if tx.send((id, r)).is_err() {
                    break;
                }
            });
        }
        drop(tx);
        let mut first_error = None;
        // A hidden bar prints nothing: say it on stderr then.
        let say = |line: String| {
            if progress {
                bar.println(line);
            } else {
                eprintln!("{line}");
            }
        };
        for (id, r) in rx {
            match &r {
                // Finished or held by another runner meanwhile.
                Ok(None) => tally.skipped += 1,
                _ => tally.ran += 1,
            }
            match r {
                Ok(None) => {}
                Ok(Some(o)) if o.status == Status::Ran => {}
                Ok(Some(o)) => {
                    tally.failed += 1;
                    say(format!(
                        "case {id} ({}): {:?} after {:.0} s{}",
                        m.cases[id].key(),
                        o.status,
                        o.wall_time_s,
                        o.log_tail
                            .last()
                            .map_or(String::new(), |l| format!(": {l}"))
                    ));
                }
                Err(e) => {
                    tally.failed += 1;
                    say(format!("case {id}: {e}"));
                    first_error.get_or_insert(e);
                }
            }
            bar.inc(1);
            bar.set_message(format!("{} failed", tally.failed));
        }
        bar.finish();
        match first_error {
            // The tool itself could not run a case (no binary, no disk):
            // the campaign cannot go on meaningfully.
            Some(e) if tally.ran == tally.failed => Err(e),
            _ => Ok(()),
        }
    })?;
    Ok(tally)
}

/// Runs a finished case again in a scratch folder (`again/` in its
/// folder): its recorded output hash and the new one.
pub fn verify_case(
    dir: &Path,
    m: &Manifest,
    id: usize,
    p: &Program,
) -> Result<(String, String), String> {
    let case = m
        .cases
        .get(id)
        .ok_or_else(|| format!("case {id}: the campaign has {} cases", m.case_count))?;
    let cd = Manifest::case_dir(dir, case);
    let recorded = crate::summary::output_hash(&cd.join(REPORT))
        .ok_or_else(|| format!("case {id} has no report to compare with; run it first"))?;
    let scratch = cd.join("again");
    std::fs::create_dir_all(&scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
    std::fs::copy(cd.join(CONFIG), scratch.join(CONFIG))
        .map_err(|e| format!("{}: {e}", scratch.display()))?;
    let o = execute(&scratch, case, p, m.timeout_s)?;
    if o.status != Status::Ran {
        return Err(format!(
            "case {id} again: {:?}{}",
            o.status,
            o.log_tail
                .last()
                .map_or(String::new(), |l| format!(": {l}"))
        ));
    }
    let again = crate::summary::output_hash(&scratch.join(REPORT))
        .ok_or_else(|| format!("case {id} again wrote no output hash"))?;
    Ok((recorded, again))
}
