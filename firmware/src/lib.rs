//! The `speleo` flight software: configuration, the schedule table that wires
//! tasks to mailboxes, the modes (sim, replay, run), the MCAP recorder and the
//! reports. `main.rs` is only the entry point.

pub mod bus;
pub mod campaign;
pub mod cli;
pub mod config;
pub mod exploration_figures;
pub mod faults;
pub mod maps_output;
pub mod mission;
pub mod modes;
pub mod planner_figures;
pub mod plot;
pub mod record;
pub mod report;
pub mod schedule_table;
pub mod sim_clouds;
pub mod sim_host;
pub mod slam_figures;
pub mod tasks;
pub mod tools;
pub mod validation_dump;
pub mod wcet;
pub mod wiring;
