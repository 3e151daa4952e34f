//! Serial ports: the [`SerialTransport`] (a USB CDC device or a pseudo-terminal) and the
//! [`SerialConnector`] that finds a device again after a loss.

use std::io::{self, Read, Write};
use std::path::Path;
use std::time::Duration;

use super::link::{Connector, FramedLink, LinkError, Transport};
use super::ports;

/// A serial port (USB CDC device or pseudo-terminal).
pub struct SerialTransport {
    /// `None` once closed.
    port: Option<Box<dyn serialport::SerialPort>>,
    /// The path it was opened with.
    pub path: String,
}

impl SerialTransport {
    /// Opens `path` at 115200 baud, 8N1, no flow control (the baud rate does not
    /// matter for USB CDC or QEMU, but real UARTs need one), and locks it: besides the
    /// tty's exclusive mode (TIOCEXCL, which root bypasses) an advisory `flock`, which
    /// binds root too, so two gonio processes never share a port (a capture waiting to
    /// reconnect cannot take a device that another one measures on a reused path).
    pub fn open(path: &str) -> Result<Self, LinkError> {
        use nix::fcntl::{FlockArg, flock};
        use std::os::fd::AsRawFd;
        let cannot = |reason: String| LinkError::Open {
            path: path.to_string(),
            reason,
        };
        let port = serialport::new(path, 115_200)
            .timeout(Duration::from_millis(20))
            .open_native()
            .map_err(|e| match not_a_port(Path::new(path)) {
                Some(what) => LinkError::NotAPort {
                    path: path.to_string(),
                    what: what.to_string(),
                },
                // Nothing at that path: most often the device is unplugged or has
                // another name; say where to look.
                None if std::fs::symlink_metadata(path).is_err() => cannot(format!(
                    "{e}: no such port; is the device plugged in? (gonio ports lists the ports found)"
                )),
                None => cannot(e.to_string()),
            })?;
        flock(port.as_raw_fd(), FlockArg::LockExclusiveNonblock).map_err(|e| {
            cannot(format!(
                "in use by another program (it holds the port's lock: {e})"
            ))
        })?;
        Ok(SerialTransport {
            port: Some(Box::new(port)),
            path: path.to_string(),
        })
    }
}

/// What `path` is when it plainly cannot be a serial port (a regular file, a
/// directory, a device that is not a terminal such as /dev/null); `None` when it may be
/// one, or cannot be looked at (the open's own error then says why).
fn not_a_port(path: &Path) -> Option<&'static str> {
    use std::io::IsTerminal;
    use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
    let meta = std::fs::metadata(path).ok()?;
    let kind = meta.file_type();
    if kind.is_dir() {
        return Some("a directory");
    }
    if kind.is_file() {
        return Some("a regular file");
    }
    if !kind.is_char_device() {
        return Some("a special file that is not a character device");
    }
    // Non-blocking and without becoming the controlling terminal: only asked whether
    // it is a terminal, never read.
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(nix::libc::O_NONBLOCK | nix::libc::O_NOCTTY)
        .open(path)
        .ok()?;
    (!f.is_terminal()).then_some("a device that is not a terminal")
}

impl SerialTransport {
    fn port(&mut self) -> io::Result<&mut Box<dyn serialport::SerialPort>> {
        self.port
            .as_mut()
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotConnected, "port closed"))
    }
}

impl Transport for SerialTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        let port = self.port()?;
        port.write_all(bytes)?;
        port.flush()
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let port = self.port()?;
        port.set_timeout(timeout.max(Duration::from_millis(1)))
            .map_err(io::Error::other)?;
        match port.read(buf) {
            Ok(n) => Ok(n),
            // A signal (Ctrl-C) interrupting the wait is not a lost device.
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
                ) =>
            {
                Ok(0)
            }
            Err(e) => Err(e),
        }
    }

    fn close(&mut self) {
        // Dropping the port releases its exclusive lock (TIOCEXCL) and descriptor.
        self.port = None;
    }

    fn port_name(&self) -> Option<&str> {
        Some(&self.path)
    }
}

/// A serial device, re-found after a loss by its path or, when the OS gave it another
/// name, by its USB serial number.
pub struct SerialConnector {
    path: String,
    usb_serial: Option<String>,
}

impl SerialConnector {
    /// A connector for `path`.
    pub fn new(path: &str) -> Self {
        SerialConnector {
            path: path.to_string(),
            usb_serial: usb_serial_of(path),
        }
    }
}

fn usb_serial_of(path: &str) -> Option<String> {
    ports::usb_serial_of(&ports::available_ports().ok()?, Path::new(path))
}

impl Connector for SerialConnector {
    type T = SerialTransport;

    fn connect(&mut self) -> Result<FramedLink<SerialTransport>, LinkError> {
        match SerialTransport::open(&self.path) {
            Ok(t) => Ok(FramedLink::new(t)),
            Err(e) => {
                // The device may be back under another name: find it by serial number.
                let serial = self.usb_serial.clone().ok_or(e)?;
                let infos = ports::available_ports()
                    .map_err(|e| LinkError::Io(std::io::Error::other(e)))?;
                let p = ports::find_by_usb_serial(&infos, &serial).ok_or(LinkError::Timeout(
                    "device with that USB serial number not present",
                ))?;
                self.path = p.port_name.clone();
                Ok(FramedLink::new(SerialTransport::open(&self.path)?))
            }
        }
    }

    fn can_reconnect(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{PtyDevice, SimConfig};

    #[test]
    fn a_port_is_held_by_one_opener_and_released_on_close() {
        let dev = PtyDevice::start(&SimConfig::new(
            brdf_core::Preset::by_name("fe-0.115").unwrap(),
            0.0,
            1,
        ))
        .unwrap();
        let path = dev.path().to_str().unwrap();
        let mut first = SerialTransport::open(path).unwrap();
        let err = SerialTransport::open(path)
            .err()
            .expect("second opener refused");
        // Refused by the tty's exclusive mode (not root) or by the lock (root).
        let m = err.to_string();
        assert!(m.contains("in use") || m.contains("exclusive"), "{m}");
        // What a reconnect does first: release the old port, then open it again.
        first.close();
        SerialTransport::open(path).unwrap();
    }
}
