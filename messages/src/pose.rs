//! Where the rover is, as odometry and SLAM estimate it.

/// The SLAM estimate of the rover's pose in the map frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlamPose {
    pub position: [f64; 3],
    /// (w, x, y, z).
    pub orientation: [f64; 4],
    pub keyframes: u32,
}

/// Odometry pose of base_link in the odom frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OdomPose {
    pub position: [f64; 3],
    /// w, x, y, z
    pub orientation: [f64; 4],
    pub distance_m: f64,
}
