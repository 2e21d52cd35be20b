#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NavigatorCounters {
    /// Queries begun (every kind of end below counts one).
    pub queries: u64,
    /// No ground patch near the rover, or none drivable.
    pub no_start: u64,
    /// No drivable node near the point ahead on the route.
    pub no_goal: u64,
    /// The goal cannot be reached within the window.
    pub no_path: u64,
    /// At least one plan published.
    pub solved: u64,
    /// Proven optimal.
    pub optimal: u64,
    /// Stopped at `max_expansions` with the best plan so far.
    pub abandoned: u64,
    pub expansions: u64,
    pub plans_published: u64,
    /// Largest graph grown, and graphs that hit `max_nodes`.
    pub nodes_max: u64,
    pub graphs_full: u64,
    /// Queries skipped because the lattice refused the graph (a window
    /// larger than configured, which validation prevents).
    pub lattice_errors: u64,
}
