//! Anytime planning over motion-primitive lattices (section 2.2 of the
//! reference paper).
//!
//! - [`arastar`]: ARA* (Likhachev, Gordon, Thrun 2004) over any
//!   [`Lattice`] of densely numbered states, in bounded steps of a fixed
//!   number of expansions, with integer keys so that the same inputs give
//!   the same plan, bit for bit, on any machine.
//! - [`mprim`]: SBPL's `.mprim` motion-primitive files.
//! - [`sbpl`]: SBPL's `EnvironmentNAVXYTHETALAT` (a 2D cost grid, point
//!   robot, `x, y, theta` states), read from its `.cfg` files, with the
//!   same action costs as SBPL, for cross-checking against it.
//! - [`heuristic`]: an exact cost-to-go over cells for lattices whose
//!   action costs depend on the cell and the action only (a relaxation
//!   that forgets the heading: admissible and consistent).

pub mod arastar;
pub mod heuristic;
pub mod mprim;
pub mod primitives;
pub mod sbpl;
pub mod surface;

pub use arastar::{AraParams, AraStar, Lattice, Progress};

/// Cost of an impossible transition or an unreachable state.
pub const INFINITE_COST: u32 = u32::MAX;
