//! The recorder's fixed-capacity message buffers (a message that would not
//! fit is refused, never grown) and its time stamps.

use std::io::{self, Write};

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

/// A Unix time: seconds and nanoseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_writer_refuses_instead_of_growing() {
        let mut v = Vec::with_capacity(8);
        let cap = v.capacity();
        assert!(Bounded(&mut v).write_all(b"[1,2]").is_ok());
        assert_eq!(v, b"[1,2]");
        v.clear();
        assert!(Bounded(&mut v).write_all(b"a long string").is_err());
        assert_eq!(v.capacity(), cap);
    }
}
