//! Writers of the standard ROS 2 types the recorded messages are built from
//! (headers, vectors, poses, transforms), in CDR, straight into the
//! recorder's bounded buffers.

use std::io::{self, Write};

use super::cdr::CdrWriter;
use super::encode::Time;

/// A transform from `parent` to `child`: translation and (w, x, y, z) rotation.
#[derive(Clone, Copy, Debug)]
pub struct Transform<'a> {
    pub stamp: Time,
    pub parent: &'a str,
    pub child: &'a str,
    pub translation: [f64; 3],
    pub rotation: [f64; 4],
}

/// `std_msgs/Header`.
pub fn header<W: Write>(c: &mut CdrWriter<W>, stamp: Time, frame_id: &str) -> io::Result<()> {
    c.time(stamp.sec, stamp.nsec)?;
    c.string(frame_id)
}

/// `geometry_msgs/Vector3` or `Point`.
pub fn vector3<W: Write>(c: &mut CdrWriter<W>, v: [f64; 3]) -> io::Result<()> {
    v.iter().try_for_each(|x| c.f64(*x))
}

/// `geometry_msgs/Quaternion` from (w, x, y, z).
pub fn quaternion<W: Write>(c: &mut CdrWriter<W>, [w, x, y, z]: [f64; 4]) -> io::Result<()> {
    [x, y, z, w].iter().try_for_each(|v| c.f64(*v))
}

/// `geometry_msgs/Pose`.
pub fn pose<W: Write>(c: &mut CdrWriter<W>, position: [f64; 3], q: [f64; 4]) -> io::Result<()> {
    vector3(c, position)?;
    quaternion(c, q)
}

/// `n` zeros of a covariance: unknown, by ROS convention.
pub fn unknown_covariance<W: Write>(c: &mut CdrWriter<W>, n: usize) -> io::Result<()> {
    (0..n).try_for_each(|_| c.f64(0.0))
}

/// `geometry_msgs/TransformStamped`.
pub fn transform_stamped<W: Write>(c: &mut CdrWriter<W>, t: &Transform<'_>) -> io::Result<()> {
    header(c, t.stamp, t.parent)?;
    c.string(t.child)?;
    vector3(c, t.translation)?;
    quaternion(c, t.rotation)
}

/// `tf2_msgs/TFMessage` of `transforms`.
pub fn tf_message<W: Write>(w: W, transforms: &[Transform<'_>]) -> io::Result<()> {
    let mut c = CdrWriter::new(w)?;
    c.sequence_len(transforms.len())?;
    transforms
        .iter()
        .try_for_each(|t| transform_stamped(&mut c, t))
}

/// `geometry_msgs/PoseStamped`.
pub fn pose_stamped<W: Write>(
    w: W,
    stamp: Time,
    frame_id: &str,
    position: [f64; 3],
    q: [f64; 4],
) -> io::Result<()> {
    let mut c = CdrWriter::new(w)?;
    header(&mut c, stamp, frame_id)?;
    pose(&mut c, position, q)
}

/// Decimal digits of `v` in `buf`, without allocating.
pub fn decimal(v: u64, buf: &mut [u8; 20]) -> &str {
    let mut i = buf.len();
    let mut v = v;
    loop {
        i -= 1;
        buf[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    std::str::from_utf8(&buf[i..]).unwrap_or("0")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_are_written_in_place() {
        let mut b = [0; 20];
        assert_eq!(decimal(0, &mut b), "0");
        assert_eq!(decimal(907, &mut b), "907");
        assert_eq!(decimal(u64::MAX, &mut b), "18446744073709551615");
    }
}
