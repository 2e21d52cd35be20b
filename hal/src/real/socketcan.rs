//! A raw SocketCAN socket (`PF_CAN`, `CAN_RAW`), non-blocking. Frames are
//! read and written as the kernel's 16-byte `struct can_frame`, so what is
//! recorded is exactly what the kernel delivered.

use std::ffi::CString;
use std::io;

use crate::can::{CanFrame, SOCKETCAN_FRAME_LEN};
use crate::{CanBus, Device, HalError, InputSink};

/// At most this many frames per poll (4 drives x 2 PDOs a frame, with room).
const MAX_PER_POLL: usize = 256;

pub struct SocketCan {
    fd: libc::c_int,
    time: std::sync::Arc<dyn crate::TimeSource>,
}

fn io_err(source: io::Error) -> HalError {
    HalError::Io {
        device: "can",
        source,
    }
}

impl SocketCan {
    pub fn open(
        interface: &str,
        time: std::sync::Arc<dyn crate::TimeSource>,
    ) -> Result<Self, HalError> {
        let name = CString::new(interface).map_err(|_| {
            HalError::Config(format!(
                "devices.can_interface = \"{interface}\": contains a NUL byte"
            ))
        })?;
        // SAFETY: `name` is a valid NUL-terminated string.
        let index = unsafe { libc::if_nametoindex(name.as_ptr()) };
        if index == 0 {
            return Err(io_err(io::Error::other(format!(
                "no CAN interface \"{interface}\": {}",
                io::Error::last_os_error()
            ))));
        }
        // SAFETY: plain socket(2) call.
        let fd = unsafe {
            libc::socket(
                libc::PF_CAN,
                libc::SOCK_RAW | libc::SOCK_NONBLOCK | libc::SOCK_CLOEXEC,
                libc::CAN_RAW,
            )
        };
        if fd < 0 {
            return Err(io_err(io::Error::last_os_error()));
        }
        // SAFETY: an all-zero sockaddr_can is a valid starting value.
        let mut addr: libc::sockaddr_can = unsafe { std::mem::zeroed() };
        addr.can_family = libc::AF_CAN as libc::sa_family_t;
        addr.can_ifindex = index as libc::c_int;
        // SAFETY: `addr` is a valid sockaddr_can and the length matches it.
        let rc = unsafe {
            libc::bind(
                fd,
                &addr as *const libc::sockaddr_can as *const libc::sockaddr,
                std::mem::size_of::<libc::sockaddr_can>() as libc::socklen_t,
            )
        };
        if rc < 0 {
            let e = io::Error::last_os_error();
            // SAFETY: fd was opened above and is closed once.
            unsafe { libc::close(fd) };
            return Err(io_err(e));
        }
        Ok(SocketCan { fd, time })
    }
}

impl Drop for SocketCan {
    fn drop(&mut self) {
        // SAFETY: the socket is owned by this value and closed once.
        unsafe { libc::close(self.fd) };
    }
}

impl CanBus for SocketCan {
    fn poll(&mut self, _now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        let mut buf = [0u8; SOCKETCAN_FRAME_LEN];
        for _ in 0..MAX_PER_POLL {
            // SAFETY: `buf` is valid for writes of its length.
            let n = unsafe { libc::read(self.fd, buf.as_mut_ptr().cast(), buf.len()) };
            if n < 0 {
                let e = io::Error::last_os_error();
                return match e.kind() {
                    io::ErrorKind::WouldBlock => Ok(()),
                    io::ErrorKind::Interrupted => continue,
                    _ => Err(io_err(e)),
                };
            }
            // A short read is recorded as it is; the driver counts it malformed.
            sink.input(Device::Can, self.time.now_ns(), &buf[..n as usize]);
        }
        Ok(())
    }

    fn send(&mut self, _now_ns: u64, frame: &CanFrame) -> Result<(), HalError> {
        let bytes = frame.to_socketcan();
        // SAFETY: `bytes` is valid for reads of its length.
        let n = unsafe { libc::write(self.fd, bytes.as_ptr().cast(), bytes.len()) };
        if n < 0 {
            let e = io::Error::last_os_error();
            if e.kind() == io::ErrorKind::WouldBlock {
                return Err(HalError::TxFull);
            }
            return Err(io_err(e));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_interface_is_named() {
        let e = SocketCan::open("nosuchcan7", std::sync::Arc::new(crate::real::FixedTime(0)))
            .err()
            .map(|e| e.to_string());
        let e = e.unwrap_or_default();
        assert!(e.contains("nosuchcan7"), "{e}");
    }
}
