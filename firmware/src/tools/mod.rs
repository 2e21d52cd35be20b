//! Offline tools: importing captures, decoding device logs, pose graphs
//! and scan registration.

pub mod decode_can;
pub mod decode_hdl32e;
pub mod decode_xbus;
pub mod g2o;
pub mod mesh;
pub mod pcap2mcap;
pub mod plan;
pub mod plan_world;
pub mod register;
pub mod validate;

pub type Error = Box<dyn std::error::Error>;
