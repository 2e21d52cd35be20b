//! The planner's plans.

/// Poses a published plan holds at most.
pub const PLAN_POSES: usize = 512;

/// The planner's latest plan: its states' ground positions and headings
/// in the map frame, start first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlanMsg {
    /// Query number (1 for the first).
    pub query: u64,
    /// Travel time, ms.
    pub cost_ms: u32,
    /// Proven bound on cost over the optimum (1: optimal).
    pub eps: f32,
    pub optimal: bool,
    /// The query is over and this plan is to be driven (exploration);
    /// earlier plans of a query only show its progress.
    pub execute: bool,
    /// x, y, z, yaw.
    pub poses: heapless::Vec<[f32; 4], PLAN_POSES>,
}
