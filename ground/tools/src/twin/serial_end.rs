//! The twin's end of a serial line: a pseudo-terminal whose other end the
//! flight binary opens as if it were the device's port, or a real serial
//! device (a null-modem cable to the rover's computer).

use std::fs::File;
use std::io::{ErrorKind, Read, Write};
use std::os::fd::{AsRawFd, FromRawFd};
use std::path::{Path, PathBuf};

/// Where a serial line of the twin is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SerialSetting {
    /// A new pseudo-terminal; its port's path is also linked from here
    /// (a symbolic link), so a configuration can name a fixed path.
    Pty { link: Option<PathBuf> },
    /// A serial device at a baud rate.
    Device { path: String, baud: u32 },
}

/// One open end of a serial line: reads and writes never block.
pub enum SerialEnd {
    Pty(Pty),
    Device {
        port: Box<dyn serialport::SerialPort>,
        path: String,
    },
}

impl SerialEnd {
    pub fn open(s: &SerialSetting) -> std::io::Result<SerialEnd> {
        match s {
            SerialSetting::Pty { link } => Pty::open(link.as_deref()).map(SerialEnd::Pty),
            SerialSetting::Device { path, baud } => {
                let port = serialport::new(path, *baud)
                    .timeout(std::time::Duration::ZERO)
                    .open()
                    .map_err(|e| std::io::Error::other(format!("{path}: {e}")))?;
                Ok(SerialEnd::Device {
                    port,
                    path: path.clone(),
                })
            }
        }
    }

    /// The path the flight binary opens.
    pub fn port_path(&self) -> &str {
        match self {
            SerialEnd::Pty(p) => p.port_path(),
            SerialEnd::Device { path, .. } => path,
        }
    }

    /// Read what is waiting into `buf` (0: nothing).
    pub fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let got = match self {
            SerialEnd::Pty(p) => p.master.read(buf),
            SerialEnd::Device { port, .. } => {
                let waiting = port.bytes_to_read().map_err(std::io::Error::other)? as usize;
                if waiting == 0 {
                    return Ok(0);
                }
                let n = waiting.min(buf.len());
                port.read(&mut buf[..n])
            }
        };
        match got {
            Ok(n) => Ok(n),
            Err(e) if would_block(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }

    /// Write as much of `bytes` as the line takes now; the count written.
    pub fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        let put = match self {
            SerialEnd::Pty(p) => p.master.write(bytes),
            SerialEnd::Device { port, .. } => port.write(bytes),
        };
        match put {
            Ok(n) => Ok(n),
            Err(e) if would_block(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }
}

fn would_block(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
    )
}

/// A pseudo-terminal pair. The twin keeps the port's end open too, in raw
/// mode: nothing is echoed or translated before the flight binary opens
/// it, and the twin's reads wait instead of failing while no one has.
pub struct Pty {
    master: File,
    _port: File,
    port_path: String,
    link: Option<PathBuf>,
}

impl Pty {
    /// Open a pair; link `link` (replacing an older link there) to its port.
    pub fn open(link: Option<&Path>) -> std::io::Result<Pty> {
        let last = std::io::Error::last_os_error;
        // SAFETY: plain libc calls on descriptors this function owns; the
        // name from ptsname is copied before any other pty call.
        let (master, port_path) = unsafe {
            let fd = libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY | libc::O_NONBLOCK);
            if fd < 0 {
                return Err(last());
            }
            let master = File::from_raw_fd(fd);
            if libc::grantpt(fd) != 0 || libc::unlockpt(fd) != 0 {
                return Err(last());
            }
            let name = libc::ptsname(fd);
            if name.is_null() {
                return Err(last());
            }
            let path = std::ffi::CStr::from_ptr(name)
                .to_string_lossy()
                .into_owned();
            (master, path)
        };
        let port = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(libc::O_NOCTTY)
            .open(&port_path)?;
        make_raw(&port)?;
        if let Some(l) = link {
            if l.symlink_metadata()
                .is_ok_and(|m| m.file_type().is_symlink())
            {
                std::fs::remove_file(l)?;
            }
            if let Some(dir) = l.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            std::os::unix::fs::symlink(&port_path, l).map_err(|e| {
                std::io::Error::new(e.kind(), format!("linking {}: {e}", l.display()))
            })?;
        }
        Ok(Pty {
            master,
            _port: port,
            port_path,
            link: link.map(Path::to_path_buf),
        })
    }

    /// The link when there is one, else the port's own path.
    pub fn port_path(&self) -> &str {
        match &self.link {
            Some(l) => l.to_str().unwrap_or(&self.port_path),
            None => &self.port_path,
        }
    }
}

impl Drop for Pty {
    fn drop(&mut self) {
        if let Some(l) = &self.link {
            let _ = std::fs::remove_file(l);
        }
    }
}

use std::os::unix::fs::OpenOptionsExt;

/// Raw mode, as `cfmakeraw` sets it: bytes pass untouched.
fn make_raw(f: &File) -> std::io::Result<()> {
    // SAFETY: termios is plain data filled by tcgetattr on a descriptor
    // `f` owns.
    unsafe {
        let mut t: libc::termios = std::mem::zeroed();
        if libc::tcgetattr(f.as_raw_fd(), &mut t) != 0 {
            return Err(std::io::Error::last_os_error());
        }
        libc::cfmakeraw(&mut t);
        if libc::tcsetattr(f.as_raw_fd(), libc::TCSANOW, &t) != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_cross_a_pty_untouched_both_ways_and_its_link_goes_with_it() {
        let dir = tempfile::tempdir().expect("tempdir");
        let link = dir.path().join("imu");
        let mut end = SerialEnd::open(&SerialSetting::Pty {
            link: Some(link.clone()),
        })
        .expect("pty");
        assert_eq!(end.port_path(), link.to_str().expect("utf-8"));
        let mut port = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&link)
            .expect("the port through its link");
        make_raw(&port).expect("raw");
        // Carriage returns and line feeds are not translated.
        port.write_all(b"S8\r\n\x00\xff").expect("write");
        let mut buf = [0u8; 64];
        let mut got = Vec::new();
        for _ in 0..200 {
            let n = end.read(&mut buf).expect("read");
            got.extend_from_slice(&buf[..n]);
            if got.len() >= 6 {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        assert_eq!(got, b"S8\r\n\x00\xff");
        assert_eq!(end.write(b"\r\x07").expect("write"), 2);
        let mut back = [0u8; 2];
        port.read_exact(&mut back).expect("read back");
        assert_eq!(&back, b"\r\x07");
        assert_eq!(end.read(&mut buf).expect("nothing waiting"), 0);
        drop(end);
        assert!(link.symlink_metadata().is_err(), "the link is removed");
    }
}
