//! What the drivers make of the sensors' bytes.

/// One decoded IMU sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImuSample {
    pub packet_counter: u16,
    pub sample_time_fine: u32,
    /// w, x, y, z
    pub orientation: [f64; 4],
    pub acceleration: [f64; 3],
    pub rate_of_turn: [f64; 3],
    pub status_word: u32,
}

/// One LiDAR revolution. Its storage is allocated at start-up and recycled.
#[derive(Clone, Debug, Default)]
pub struct Cloud {
    pub index: u64,
    /// Sensor time of the first firing, microseconds past the hour (plus
    /// whole hours since start).
    pub start_us: f64,
    /// When the packet that completed it had fired its last block, same
    /// clock (the cloud's stamp is that packet's arrival).
    pub end_us: f64,
    /// Point times are seconds after the first firing.
    pub points: Vec<speleo_hal::hdl32e::Point>,
    /// A whole turn from the cut angle (not the part turned before the
    /// packets began or after they stopped).
    pub whole: bool,
}

/// What the LiDAR driver counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LidarCounters {
    pub packets: u64,
    pub bad_length: u64,
    pub bad_flag: u64,
    pub bad_azimuth: u64,
    pub bad_timestamp: u64,
    pub lost_packets: u64,
    pub out_of_order: u64,
    pub resyncs: u64,
    pub gaps: u64,
    pub dropped_points: u64,
    pub frames: u64,
    /// Frames not published because every buffer was in use.
    pub dropped_frames: u64,
    pub position_packets: u64,
    pub bad_position_packets: u64,
    /// Sensor time of the latest position packet, us past the hour.
    pub position_time_us: u32,
}
