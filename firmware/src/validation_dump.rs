//! `[simulator] dump_dir` (`speleo sim --dump-validations DIR`): every
//! validation's inputs (start, plan, the keyframe clouds as the simulator
//! read them) and the verdict written as DIR/validation-NNNN.case, for
//! `speleo validate` to replay one away from the mission. A debugging aid:
//! it allocates and writes files from the planner task, so it is off on
//! a flight. In a simulation the true track is written beside them at
//! the end (DIR/truth.csv), so `speleo validate --world` can put a case
//! where the rover really stood.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use speleo_navigator::ValidationRecord;
use speleo_simulator::{Stance, ValidationCase, Verdict};

pub struct ValidationDump {
    dir: PathBuf,
    /// The validation under way, filled as the simulator reads the clouds.
    pub case: RefCell<ValidationCase>,
    pub written: u64,
    pub failed: u64,
}

impl ValidationDump {
    /// Dumps into `dir`, made if missing.
    pub fn new(dir: &Path) -> Result<Self, String> {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("the validation dump folder {}: {e}", dir.display()))?;
        Ok(ValidationDump {
            dir: dir.to_path_buf(),
            case: RefCell::new(ValidationCase::default()),
            written: 0,
            failed: 0,
        })
    }
}

impl ValidationRecord for ValidationDump {
    fn begin(
        &mut self,
        now_ns: u64,
        start: Stance,
        way_back: bool,
        plan: &mut dyn Iterator<Item = [f64; 4]>,
    ) {
        self.case.borrow_mut().begin(now_ns, start, way_back, plan);
    }

    fn case(&self) -> &RefCell<ValidationCase> {
        &self.case
    }

    /// The verdict is in: the case written as validation `index` (the
    /// mission's count, from 1). A failed write is logged and counted;
    /// the mission goes on.
    fn finish(&mut self, index: u64, verdict: Verdict) {
        let path = self.dir.join(format!("validation-{index:04}.case"));
        let mut case = self.case.borrow_mut();
        case.verdict = Some(verdict);
        let written = std::fs::File::create(&path).and_then(|f| {
            let mut w = std::io::BufWriter::new(f);
            case.write(&mut w)?;
            std::io::Write::flush(&mut w)
        });
        match written {
            Ok(()) => {
                self.written += 1;
                tracing::info!(
                    outcome = ?verdict.outcome,
                    keyframes = case.keyframes.len(),
                    points = case.points(),
                    "validation {index}'s inputs written to {}",
                    path.display()
                );
            }
            Err(e) => {
                self.failed += 1;
                tracing::warn!(
                    "validation {index}'s inputs not written to {}: {e}",
                    path.display()
                );
            }
        }
    }
}

/// Name of the true track's file in the dump folder.
pub const TRUTH_FILE: &str = "truth.csv";
/// Every this many frames of the true track are written (0.1 s at
/// 100 Hz: the rover stands still when a validation begins).
const TRUTH_EVERY: usize = 10;

/// The simulation's true track (time, base_link position and orientation
/// in the world) as DIR/truth.csv.
pub fn write_truth(dir: &Path, samples: &[(u64, [f64; 3], [f64; 4])]) -> std::io::Result<()> {
    use std::io::Write;
    let f = std::fs::File::create(dir.join(TRUTH_FILE))?;
    let mut w = std::io::BufWriter::new(f);
    writeln!(w, "t_ns,x_m,y_m,z_m,qw,qx,qy,qz")?;
    for (t, p, q) in samples.iter().step_by(TRUTH_EVERY) {
        writeln!(
            w,
            "{t},{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.9}",
            p[0], p[1], p[2], q[0], q[1], q[2], q[3]
        )?;
    }
    w.flush()
}
