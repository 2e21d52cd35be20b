//! The ground tools: what is run on a desk, not on the rover. Decoding
//! device captures, pose graphs, scan registration, meshing, planning on
//! SBPL lattices and worlds, replaying the internal simulator's cases,
//! execution-time budgets, plots and campaigns. Builds on the flight
//! software (`speleo-firmware`), which never depends on it.

pub mod args;
pub mod campaign;
pub mod commands;
pub mod decode_can;
pub mod decode_hdl32e;
pub mod decode_xbus;
pub mod g2o;
pub mod hil;
pub mod info;
pub mod mesh;
pub mod pcap2mcap;
pub mod plan;
pub mod plan_world;
pub mod plot;
pub mod register;
pub mod twin;
pub mod validate;
pub mod validations;
pub mod wcet;

/// A tool's error, printed by the `speleo` binary.
pub type Error = Box<dyn std::error::Error>;
