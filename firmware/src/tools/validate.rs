//! `speleo validate CASE`: replay one validation a mission dumped
//! (`--dump-validations`) with the configuration's simulator: its verdict
//! beside the mission's, where it tilted most, and on request the world
//! it built (PLY) and its track step by step (CSV).

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use speleo_hal::sim::BodyState;
use speleo_simulator::{InternalSim, SimulatorParams, ValidationCase, Verdict};

use super::Error;

/// What a replay found.
pub struct Replayed {
    pub case: ValidationCase,
    pub verdict: Verdict,
    pub physics_steps: u64,
    pub triangles: usize,
    /// The most tilt, deg, and where the rover was then (map frame).
    pub max_tilt_deg: f64,
    pub max_tilt_at: [f64; 3],
    pub wall_ms: f64,
}

impl Replayed {
    /// The replay gave the verdict the mission got (outcome, driving time
    /// and goal error to the bit).
    pub fn same_as_on_board(&self) -> bool {
        self.case.verdict.is_some_and(|v| {
            v.outcome == self.verdict.outcome
                && v.drive_s.to_bits() == self.verdict.drive_s.to_bits()
                && v.goal_error_m.to_bits() == self.verdict.goal_error_m.to_bits()
        })
    }
}

pub fn read_case(path: &Path) -> Result<ValidationCase, Error> {
    let f =
        std::fs::File::open(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?;
    ValidationCase::read(&mut std::io::BufReader::new(f))
        .map_err(|e| format!("{}: {e}", path.display()).into())
}

/// Tilt of `s` from upright, deg, with its roll and pitch.
fn attitude(s: &BodyState) -> (f64, f64, f64, f64) {
    let [w, x, y, z] = s.orientation;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    let tilt = (1.0 - 2.0 * (x * x + y * y)).clamp(-1.0, 1.0).acos();
    (
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees(),
        tilt.to_degrees(),
    )
}

/// Replay `case` with `params`, a step at a time; each physics step's
/// state as a CSV row into `track` if given, and the world built into
/// `mesh` once the rover drives.
pub fn replay(
    case: ValidationCase,
    params: SimulatorParams,
    mut track: Option<&mut dyn Write>,
    mut mesh: Option<&mut dyn Write>,
) -> Result<Replayed, Error> {
    let dt = params.dt_s;
    let mut sim = InternalSim::new(params)?;
    sim.begin(case.start, case.plan.iter().copied());
    if let Some(t) = track.as_deref_mut() {
        writeln!(t, "t_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,tilt_deg")?;
    }
    let started = Instant::now();
    let (mut max_tilt_deg, mut max_tilt_at) = (0.0f64, [f64::NAN; 3]);
    let mut steps = 0u64;
    let verdict = loop {
        let driving = sim.work() == "drive";
        let v = sim.step(&case, 1);
        if driving {
            if steps == 0 {
                if let (Some(m), Some(world)) = (mesh.as_deref_mut(), sim.world_mesh()) {
                    world.write_ply(m)?;
                }
            }
            steps += 1;
            if let Some(s) = sim.rover_state() {
                let (roll, pitch, yaw, tilt) = attitude(s);
                if tilt > max_tilt_deg {
                    (max_tilt_deg, max_tilt_at) = (tilt, s.position);
                }
                if let Some(t) = track.as_deref_mut() {
                    let [x, y, z] = s.position;
                    let ts = steps as f64 * dt;
                    writeln!(
                        t,
                        "{ts:.2},{x:.4},{y:.4},{z:.4},{roll:.2},{pitch:.2},{yaw:.2},{tilt:.2}"
                    )?;
                }
            }
        }
        if let Some(v) = v {
            break v;
        }
    };
    Ok(Replayed {
        case,
        verdict,
        physics_steps: steps,
        triangles: sim.triangles(),
        max_tilt_deg,
        max_tilt_at,
        wall_ms: started.elapsed().as_secs_f64() * 1e3,
    })
}
