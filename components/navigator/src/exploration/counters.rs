/// What the exploration did, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExplorationCounters {
    /// Queries that scanned for candidates, and those that found none.
    pub scans: u64,
    pub scans_empty: u64,
    /// Goals planned to (candidates and points home), and those with no path.
    pub goals_attempted: u64,
    pub goals_unreachable: u64,
    /// Goals refused before planning for a rock under the body there.
    pub goals_on_rocks: u64,
    /// Plans handed to the control task.
    pub plans_executed: u64,
    /// Queries that found no plan from where the rover stood (going home)
    /// or no ground under it, after which it drove back along its own
    /// track.
    pub retraces: u64,
    /// Retraces the internal simulation refused (not driven).
    pub retraces_refused: u64,
    /// Returns home that found something explorable on the way and went
    /// back to exploring.
    pub resumes: u64,
    /// Stuck stops after which the rover backed out (straight, backward
    /// or forward) and the place became an obstacle for the planner.
    pub backed_out: u64,
    /// Back-outs the internal simulation refused (not driven): they
    /// tilted the simulated rover past the limit or left the ground.
    pub back_outs_refused: u64,
    /// Times nothing was left but barred places, which were forgotten
    /// to explore on (once a mission).
    pub second_looks: u64,
    /// Places the rover slid back or stalled climbing a slope, from which
    /// the ground up is barred for exploring (see [`SLIDE_PITCH_DEG`]).
    pub slides: u64,
    /// Rims the safety monitor stopped the rover at (a drop seen ahead),
    /// around which no path goes from then on (see [`RIM_RADIUS_M`]).
    pub rims: u64,
    /// Plans driven in the internal simulator, those it passed and those
    /// it refused (by outcome: timeout, tip-over, stuck, missed, no ground,
    /// no way back, overhang, fall, too steep for its grip).
    pub validations: u64,
    pub validated: u64,
    pub rejected_by_sim: u64,
    pub sim_outcomes: [u64; 9],
    /// Refusals by the pessimistic rollout of plans the nominal one
    /// passed.
    pub refused_when_pessimistic: u64,
    pub sim_physics_steps: u64,
    pub sim_triangles_max: u64,
    /// Refused plans whose first part, the part the simulated rover drove
    /// well, was driven when no goal of the query passed (see
    /// [`Partial`]).
    pub partial_plans: u64,
}
