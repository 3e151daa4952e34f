//! Serial ports: the [`SerialTransport`] (a USB CDC device or a pseudo-terminal) and the
//! [`SerialConnector`] that finds a device again after a loss.

use std::io::{self, Read, Write};
use std::path::Path;
use std::time::Duration;

use super::link::{FramedLink, LinkError, Transport};
use super::{Connector, ports};

/// A serial port (USB CDC device or pseudo-terminal).
pub struct SerialTransport {
    port: Box<dyn serialport::SerialPort>,
    /// The path it was opened with.
    pub path: String,
}

impl SerialTransport {
    /// Opens `path` at 115200 baud, 8N1, no flow control (the baud rate does not
    /// matter for USB CDC or QEMU, but real UARTs need one).
    pub fn open(path: &str) -> Result<Self, LinkError> {
        let port = serialport::new(path, 115_200)
            .timeout(Duration::from_millis(20))
            .open()
            .map_err(|e| LinkError::Open {
                path: path.to_string(),
                reason: e.to_string(),
            })?;
        Ok(SerialTransport {
            port,
            path: path.to_string(),
        })
    }
}

impl Transport for SerialTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.port
            .set_timeout(timeout.max(Duration::from_millis(1)))
            .map_err(io::Error::other)?;
        match self.port.read(buf) {
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
