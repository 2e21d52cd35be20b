//! The exploration behaviour of section 2.4 of the paper: candidates at
//! the border of the known map, scored by distance, unexplored ground
//! nearby and an optional target; a coverage map so that borders that
//! cannot be seen past are not tried forever; and the rover's track, for
//! the way home when nothing is left to explore, or time or the energy
//! budget runs out; and the energy meter that budget reads.
//!
//! The planner task runs the candidate scan in slices over the graph it
//! grows and plans to the candidates in turn; see the firmware.

pub mod candidates;
pub mod coverage;
pub mod energy;
pub mod explorer;
pub mod trail;
pub mod way_home;

pub use candidates::{Candidate, CandidateParams, CandidateScan, Pass, ScanCensus, MAX_CANDIDATES};
pub use coverage::CoverageMap;
pub use energy::{EnergyMeter, PowerModel};
pub use explorer::{Explorer, ExplorerParams, ExplorerPhase, ReturnReason};
pub use trail::Trail;
