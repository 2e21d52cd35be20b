//! Where the exploration stands.

/// Where the exploration is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExplorationPhase {
    /// Not exploring (following a route).
    #[default]
    Off,
    Exploring,
    Returning,
    /// Home: the mission is over.
    Finished,
    /// Over away from home: the rover cannot move.
    Stranded,
}

/// The exploration's phase and the goal it drives to.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExplorationStatus {
    pub phase: ExplorationPhase,
    /// The goal being driven to, when there is one.
    pub goal: Option<[f64; 3]>,
}
