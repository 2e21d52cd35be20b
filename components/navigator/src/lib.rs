//! Speleo's navigator: the rover's decisions of where to go and how to get
//! out of trouble, as plain data in and plans out. [`Navigator::step`]
//! does one quantum of a query's work from a [`NavInput`] (the SLAM pose,
//! the control task's command, the drives' feedback, the serving map, the
//! keyframe clouds); the plans it published and the exploration's state
//! come back through [`Navigator::take_plans`] and [`Navigator::status`].
//! The internal simulation may be offloaded or recorded through a
//! [`Rehearsal`]; nothing here knows the bus, the schedule or the clock.

mod candidates;
mod counters;
pub mod exploration;
mod input;
mod navigator;
mod pick;
mod query;
mod rehearsal;
mod search;
mod trace;
mod validation;

pub use counters::NavigatorCounters;
pub use exploration::{Exploration, ExplorationCounters};
pub use input::{NavInput, Outbox};
pub use navigator::{Navigator, NavigatorParams, BODY_MARGIN_M, STEP_PHASES};
pub use rehearsal::{InStep, Rehearsal, ValidationRecord};

pub(crate) use navigator::{
    EXPLORE_GOAL_EXPANSIONS, EXPLORE_IMPROVE_EXPANSIONS, GOAL_NEAREST_M, GOAL_POINTS, GOAL_REACH_M,
    HISTORY, LEVEL_M, PICK_PER_UNIT, SCAN_PER_UNIT, START_CANDIDATES, START_REACH_M, WINDOW_GROWTH,
};
#[cfg(test)]
mod tests;
