//! OMG CDR (little endian, plain XCDR1 as ROS 2 writes it) for the bulky
//! topics: raw device bytes and point clouds go in as bytes, not base64 JSON,
//! and Foxglove reads them through their `ros2msg` schemas.
//!
//! Alignment is relative to the first byte after the 4-byte encapsulation
//! header, as the ROS 2 middleware does.

use std::io::{self, Write};

/// The encapsulation header of little-endian plain CDR.
const HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Writes CDR into any `Write` (a bounded, pre-allocated buffer in the tap).
pub struct CdrWriter<W: Write> {
    w: W,
    /// Bytes written after the header.
    pos: usize,
}

impl<W: Write> CdrWriter<W> {
    pub fn new(mut w: W) -> io::Result<Self> {
        w.write_all(&HEADER)?;
        Ok(CdrWriter { w, pos: 0 })
    }

    fn align(&mut self, n: usize) -> io::Result<()> {
        const ZEROS: [u8; 8] = [0; 8];
        let pad = (n - self.pos % n) % n;
        self.raw(&ZEROS[..pad])
    }

    fn raw(&mut self, b: &[u8]) -> io::Result<()> {
        self.w.write_all(b)?;
        self.pos += b.len();
        Ok(())
    }

    pub fn u8(&mut self, v: u8) -> io::Result<()> {
        self.raw(&[v])
    }

    pub fn bool(&mut self, v: bool) -> io::Result<()> {
        self.u8(v as u8)
    }

    pub fn u32(&mut self, v: u32) -> io::Result<()> {
        self.align(4)?;
        self.raw(&v.to_le_bytes())
    }

    pub fn i32(&mut self, v: i32) -> io::Result<()> {
        self.align(4)?;
        self.raw(&v.to_le_bytes())
    }

    pub fn u16(&mut self, v: u16) -> io::Result<()> {
        self.align(2)?;
        self.raw(&v.to_le_bytes())
    }

    pub fn u64(&mut self, v: u64) -> io::Result<()> {
        self.align(8)?;
        self.raw(&v.to_le_bytes())
    }

    pub fn f32(&mut self, v: f32) -> io::Result<()> {
        self.align(4)?;
        self.raw(&v.to_le_bytes())
    }

    pub fn f64(&mut self, v: f64) -> io::Result<()> {
        self.align(8)?;
        self.raw(&v.to_le_bytes())
    }

    /// A `builtin_interfaces/Time`.
    pub fn time(&mut self, sec: u64, nsec: u32) -> io::Result<()> {
        // int32 seconds: Unix times up to 2038, as ROS 2 has them.
        self.i32(sec.min(i32::MAX as u64) as i32)?;
        self.u32(nsec)
    }

    pub fn string(&mut self, s: &str) -> io::Result<()> {
        self.u32(s.len() as u32 + 1)?;
        self.raw(s.as_bytes())?;
        self.u8(0)
    }

    /// A string made of `parts` with `sep` between them, written without
    /// joining them first.
    pub fn string_joined<'s>(
        &mut self,
        parts: impl Iterator<Item = &'s str> + Clone,
        sep: &str,
    ) -> io::Result<()> {
        let (n, len) = parts
            .clone()
            .fold((0usize, 0usize), |(n, l), p| (n + 1, l + p.len()));
        let total = len + sep.len() * n.saturating_sub(1);
        self.u32(total as u32 + 1)?;
        for (i, p) in parts.enumerate() {
            if i > 0 {
                self.raw(sep.as_bytes())?;
            }
            self.raw(p.as_bytes())?;
        }
        self.u8(0)
    }

    /// The length of a sequence; its elements follow.
    pub fn sequence_len(&mut self, n: usize) -> io::Result<()> {
        self.u32(n as u32)
    }

    /// A `uint8[]`.
    pub fn bytes(&mut self, b: &[u8]) -> io::Result<()> {
        self.sequence_len(b.len())?;
        self.raw(b)
    }

    /// Elements of a `uint8[]` whose length was written with `sequence_len`.
    pub fn bytes_part(&mut self, b: &[u8]) -> io::Result<()> {
        self.raw(b)
    }
}

/// Why a CDR message could not be read.
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
pub enum CdrError {
    #[error("not little-endian CDR (encapsulation {0:02x?})")]
    Encapsulation([u8; 2]),
    #[error("ends at byte {0} inside a field")]
    Truncated(usize),
    #[error("a string is not terminated or not UTF-8")]
    BadString,
}

/// Reads CDR from a byte slice, never past its end.
pub struct CdrReader<'a> {
    b: &'a [u8],
    /// Offset after the header.
    pos: usize,
}

impl<'a> CdrReader<'a> {
    pub fn new(b: &'a [u8]) -> Result<Self, CdrError> {
        match b.get(..4) {
            Some([0x00, 0x01, _, _]) => Ok(CdrReader { b: &b[4..], pos: 0 }),
            Some(h) => Err(CdrError::Encapsulation([h[0], h[1]])),
            None => Err(CdrError::Truncated(b.len())),
        }
    }

    fn take(&mut self, n: usize, align: usize) -> Result<&'a [u8], CdrError> {
        let start = self.pos + (align - self.pos % align) % align;
        let end = start
            .checked_add(n)
            .ok_or(CdrError::Truncated(self.pos + 4))?;
        let s = self
            .b
            .get(start..end)
            .ok_or(CdrError::Truncated(self.b.len() + 4))?;
        self.pos = end;
        Ok(s)
    }

    pub fn u8(&mut self) -> Result<u8, CdrError> {
        Ok(self.take(1, 1)?[0])
    }

    pub fn bool(&mut self) -> Result<bool, CdrError> {
        Ok(self.u8()? != 0)
    }

    pub fn u32(&mut self) -> Result<u32, CdrError> {
        let s = self.take(4, 4)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }

    pub fn i32(&mut self) -> Result<i32, CdrError> {
        Ok(self.u32()? as i32)
    }

    pub fn u64(&mut self) -> Result<u64, CdrError> {
        let s = self.take(8, 8)?;
        let mut b = [0u8; 8];
        b.copy_from_slice(s);
        Ok(u64::from_le_bytes(b))
    }

    pub fn string(&mut self) -> Result<&'a str, CdrError> {
        let n = self.u32()? as usize;
        let s = self.take(n, 1)?;
        match s.split_last() {
            Some((0, text)) => std::str::from_utf8(text).map_err(|_| CdrError::BadString),
            _ => Err(CdrError::BadString),
        }
    }

    pub fn bytes(&mut self) -> Result<&'a [u8], CdrError> {
        let n = self.u32()? as usize;
        self.take(n, 1)
    }
}

/// Write a `RawInput`.
pub fn write_raw_input<W: Write>(
    w: W,
    sec: u64,
    nsec: u32,
    device: &str,
    data: &[u8],
) -> io::Result<()> {
    let mut c = CdrWriter::new(w)?;
    c.time(sec, nsec)?;
    c.string(device)?;
    c.bytes(data)
}

/// A decoded `RawInput`.
#[derive(Debug, PartialEq, Eq)]
pub struct RawInputRef<'a> {
    pub sec: i32,
    pub nsec: u32,
    pub device: &'a str,
    pub data: &'a [u8],
}

pub fn read_raw_input(b: &[u8]) -> Result<RawInputRef<'_>, CdrError> {
    let mut r = CdrReader::new(b)?;
    Ok(RawInputRef {
        sec: r.i32()?,
        nsec: r.u32()?,
        device: r.string()?,
        data: r.bytes()?,
    })
}

/// The parts of a `PointCloud2` a reader of our clouds needs.
#[derive(Debug)]
pub struct PointCloud2Ref<'a> {
    pub sec: i32,
    pub nsec: u32,
    pub frame_id: &'a str,
    pub width: u32,
    /// (name, offset, datatype).
    pub fields: Vec<(&'a str, u32, u8)>,
    pub point_step: u32,
    pub data: &'a [u8],
}

pub fn read_point_cloud2(b: &[u8]) -> Result<PointCloud2Ref<'_>, CdrError> {
    let mut r = CdrReader::new(b)?;
    let (sec, nsec, frame_id) = (r.i32()?, r.u32()?, r.string()?);
    let _height = r.u32()?;
    let width = r.u32()?;
    let n = r.u32()? as usize;
    let mut fields = Vec::with_capacity(n.min(64));
    for _ in 0..n {
        let (name, offset, datatype) = (r.string()?, r.u32()?, r.u8()?);
        let _count = r.u32()?;
        fields.push((name, offset, datatype));
    }
    let _big_endian = r.bool()?;
    let point_step = r.u32()?;
    let _row_step = r.u32()?;
    let data = r.bytes()?;
    Ok(PointCloud2Ref {
        sec,
        nsec,
        frame_id,
        width,
        fields,
        point_step,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_inputs_round_trip_with_ros2_alignment() {
        let mut v = Vec::new();
        write_raw_input(&mut v, 1_700_000_000, 5, "imu", &[1, 2, 3]).expect("write");
        // header 4 + time 8 + string (4 + "imu\0") 8 + len 4 + 3 bytes.
        assert_eq!(v.len(), 4 + 8 + 8 + 4 + 3);
        let r = read_raw_input(&v).expect("read");
        assert_eq!(
            r,
            RawInputRef {
                sec: 1_700_000_000,
                nsec: 5,
                device: "imu",
                data: &[1, 2, 3]
            }
        );
        // "can\0" then padding: a 5-letter device name needs 3 pad bytes.
        let mut v = Vec::new();
        write_raw_input(&mut v, 1, 2, "lidar", &[9]).expect("write");
        assert_eq!(v.len(), 4 + 8 + 4 + 6 + 2 + 4 + 1);
        assert_eq!(read_raw_input(&v).expect("read").data, &[9]);
    }

    #[test]
    fn damaged_messages_are_errors_not_panics() {
        let mut v = Vec::new();
        write_raw_input(&mut v, 1, 2, "lidar", &[9; 100]).expect("write");
        for cut in 0..v.len() {
            assert!(read_raw_input(&v[..cut]).is_err(), "{cut}");
        }
        let mut big = v.clone();
        // A sequence length far past the end.
        let at = 4 + 8 + 4 + 6 + 2;
        big[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(read_raw_input(&big).is_err());
        assert_eq!(
            read_raw_input(&[1, 0, 0, 0]).err(),
            Some(CdrError::Encapsulation([1, 0]))
        );
    }
}
