//! Offline tools: importing captures and decoding device logs.

pub mod decode_can;
pub mod decode_hdl32e;
pub mod decode_xbus;
pub mod pcap2mcap;

pub type Error = Box<dyn std::error::Error>;
