//! The flight software: configuration, the schedule table that wires tasks
//! to mailboxes, the flight commands (sim, replay, run), the MCAP recorder and the
//! mission's report. The ground tools (`speleo-tools`) and the `speleo`
//! binary (`speleo-cli`) build on it; it depends on neither.

pub mod args;
pub mod bus;
pub mod commands;
pub mod config;
pub mod exploration_figures;
pub mod faults;
pub mod maps_output;
pub mod mission;
pub mod output_paths;
pub mod params;
pub mod planner_figures;
pub mod realtime_figures;
pub mod record;
pub mod report;
pub mod schedule_table;
pub mod signals;
pub mod simulator_clouds;
pub mod simulator_host;
pub mod slam_figures;
pub mod tasks;
pub mod truth_map;
pub mod validation_dump;
