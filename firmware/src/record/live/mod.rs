//! The live view: the recorded channels served over the Foxglove WebSocket
//! protocol (`foxglove.websocket.v1`) while `sim`, `run` or `replay` runs.
//!
//! The recorder's writer thread offers every message it receives; each
//! connected viewer has a bounded queue and its own thread, so the executive
//! never allocates or waits for a viewer, and a viewer too slow for the
//! stream costs counted drops, never a late frame.

pub mod protocol;
pub mod server;

pub use server::{LiveCounters, LiveServer};

/// Foxglove's default port.
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:8765";
