//! The internal simulator of section 2.3 of the paper. Before the rover
//! drives a plan, the plan is driven in simulation:
//!
//! 1. the keyframe clouds near the plan are integrated into a TSDF of
//!    5 cm voxels (the map the rover itself built, at its optimised poses);
//! 2. the TSDF is meshed (marching cubes) a tile at a time, and each tile
//!    becomes ground of a rapier3d world that holds the rover model at its
//!    estimated pose;
//! 3. a clone of the control component's plan follower drives the plan,
//!    its poses straight from the physics (no SLAM in the loop);
//! 4. the verdict: the goal reached within a tolerance and a time, or a
//!    tip-over, a stall, a timeout. The predicted trajectory, with times
//!    since the start of motion, is kept to compare with the real one.
//!
//! Everything runs in bounded slices ([`InternalSim::step`]) so the
//! executive can run it as anytime work.

mod case;
mod grip;
mod params;
mod prediction;
mod prefix;
mod ribbon;
mod run;
mod stance;
mod terrain;

pub use case::{CaseError, RecordedKeyframe, RecordingClouds, ValidationCase};
pub use params::SimulatorParams;
pub use prediction::{rmse_at_equal_times, Prediction, PREDICTION_POINTS};
pub use prefix::{driven_prefix, Prefix, PrefixRule};
pub use run::{CloudSource, InternalSim, Outcome, SimCounters, Verdict};
pub use stance::Stance;
pub use terrain::ReadRegion;
