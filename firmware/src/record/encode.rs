//! JSON encodings of the recorded messages, written into fixed-capacity
//! buffers: a message that would not fit is refused, never grown.

use std::io::{self, Write};

use serde::ser::{SerializeSeq, Serializer};
use serde::Serialize;

/// Writes into a `Vec` up to its capacity and fails past it.
pub struct Bounded<'a>(pub &'a mut Vec<u8>);

impl Write for Bounded<'_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if self.0.len() + buf.len() > self.0.capacity() {
            return Err(io::Error::new(
                io::ErrorKind::WriteZero,
                "message buffer full",
            ));
        }
        self.0.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// Foxglove's time: seconds and nanoseconds.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Time {
    pub sec: u64,
    pub nsec: u32,
}

impl Time {
    pub fn from_ns(ns: u64) -> Time {
        Time {
            sec: ns / 1_000_000_000,
            nsec: (ns % 1_000_000_000) as u32,
        }
    }
}

#[derive(Serialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl From<[f64; 3]> for Vector3 {
    fn from(v: [f64; 3]) -> Self {
        Vector3 {
            x: v[0],
            y: v[1],
            z: v[2],
        }
    }
}

#[derive(Serialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quaternion {
    /// From (w, x, y, z).
    pub fn wxyz(q: [f64; 4]) -> Self {
        Quaternion {
            x: q[1],
            y: q[2],
            z: q[3],
            w: q[0],
        }
    }
}

#[derive(Serialize)]
pub struct Pose {
    pub position: Vector3,
    pub orientation: Quaternion,
}

#[derive(Serialize)]
pub struct PoseInFrame<'a> {
    pub timestamp: Time,
    pub frame_id: &'a str,
    pub pose: Pose,
}

#[derive(Serialize)]
pub struct FrameTransform<'a> {
    pub timestamp: Time,
    pub parent_frame_id: &'a str,
    pub child_frame_id: &'a str,
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// Serialise an iterator as a JSON array without collecting it.
pub struct SeqOf<I>(pub std::cell::Cell<Option<I>>);

impl<I> SeqOf<I> {
    pub fn new(it: I) -> Self {
        SeqOf(std::cell::Cell::new(Some(it)))
    }
}

impl<I, T> Serialize for SeqOf<I>
where
    I: Iterator<Item = T>,
    T: Serialize,
{
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(None)?;
        if let Some(it) = self.0.take() {
            for item in it {
                seq.serialize_element(&item)?;
            }
        }
        seq.end()
    }
}

#[derive(Serialize)]
pub struct CanFrameJson<'a> {
    pub id: u32,
    pub data: &'a [u8],
}

#[derive(Serialize)]
pub struct ImuSampleJson {
    pub timestamp: Time,
    pub packet_counter: u16,
    pub sample_time_fine: u32,
    pub orientation: Quaternion,
    pub acceleration: Vector3,
    pub rate_of_turn: Vector3,
    pub status_word: u32,
}

#[derive(Serialize)]
pub struct WheelJson {
    pub state: &'static str,
    pub statusword: u16,
    pub velocity_rad_s: f64,
    pub position_counts: i32,
    /// Torque actual at the wheel, N m; `None` (null) when the drive does
    /// not map it.
    pub torque_nm: Option<f64>,
    pub nmt: &'static str,
    pub profile_velocity_mode: bool,
    pub emergencies: u32,
    pub last_emergency: u16,
}

#[derive(Serialize)]
pub struct WheelCommandJson {
    pub timestamp: Time,
    pub speed: f64,
    pub yaw_rate: f64,
    pub wheel_speeds: [f64; 4],
    pub segment: u32,
    pub done: bool,
}

#[derive(Serialize)]
pub struct Color {
    pub r: f64,
    pub g: f64,
    pub b: f64,
    pub a: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_writer_refuses_instead_of_growing() {
        let mut v = Vec::with_capacity(8);
        let cap = v.capacity();
        assert!(serde_json::to_writer(Bounded(&mut v), &[1, 2]).is_ok());
        assert_eq!(v, b"[1,2]");
        v.clear();
        assert!(serde_json::to_writer(Bounded(&mut v), &"a long string").is_err());
        assert_eq!(v.capacity(), cap);
    }

    #[test]
    fn sequences_serialise_lazily() {
        let s = serde_json::to_string(&SeqOf::new((1..4).map(|i| i * 2))).expect("json");
        assert_eq!(s, "[2,4,6]");
    }
}
