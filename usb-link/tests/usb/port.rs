//! The port as gonio sees it: a [`Transport`] over the modelled host's bulk endpoints
//! (so gonio's own framing, decoder and capture engine run on top), and a
//! [`Connector`] that opens it. A host that stops reading for a while is a setting.

use std::io;
use std::time::Duration;

use gonio::device::{Connector, FramedLink, LinkError, Transport};

use super::rig::{Pause, Rig};

/// Iterations with nothing scheduled on the device and nothing arriving after which a
/// receive reports that nothing came (the USB pipeline is empty well before).
const QUIET_STEPS: u32 = 64;

/// A pause in reading: once `after` bytes have arrived, the host sends no IN tokens
/// for `for_us` of device time, then reads again.
#[derive(Debug, Clone, Copy)]
pub struct Stall {
    /// Bytes received before the pause.
    pub after: usize,
    /// Length of the pause (microseconds of simulated time).
    pub for_us: u64,
}

/// The open port.
pub struct UsbPort<'a> {
    /// The rig (device and host).
    pub rig: &'a mut Rig,
    /// Bytes handed to gonio so far.
    pub delivered: usize,
    /// A pause still to come.
    pub stall: Option<Stall>,
}

impl<'a> UsbPort<'a> {
    /// Opens the port (enumerating the device first if needed).
    pub fn open(rig: &'a mut Rig) -> Self {
        rig.open_port();
        UsbPort {
            rig,
            delivered: 0,
            stall: None,
        }
    }

    fn maybe_stall(&mut self) {
        let Some(s) = self.stall else { return };
        if self.delivered < s.after {
            return;
        }
        self.stall = None;
        let steps = self.rig.steps;
        self.rig.reading = false;
        self.rig.run_device_for(s.for_us);
        self.rig.reading = true;
        self.rig.paused = Some(Pause {
            steps: self.rig.steps - steps,
            busy: self.rig.service.ctrl.is_busy(),
            sending: self.rig.service.sending(),
        });
    }
}

impl Transport for UsbPort<'_> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.rig.write_bulk(bytes);
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.maybe_stall();
        let mut quiet = 0;
        for _ in 0..1_000_000 {
            if !self.rig.received.is_empty() {
                let n = buf.len().min(self.rig.received.len());
                for (b, x) in buf.iter_mut().zip(self.rig.received.drain(..n)) {
                    *b = x;
                }
                self.delivered += n;
                return Ok(n);
            }
            if self.rig.step_both() {
                quiet = 0;
            } else {
                quiet += 1;
                if quiet > QUIET_STEPS {
                    break;
                }
            }
        }
        // Nothing to say: wait like a quiet device (a millisecond at most).
        std::thread::sleep(timeout.min(Duration::from_millis(1)));
        Ok(0)
    }

    fn close(&mut self) {
        self.rig.close_port();
    }
}

/// Opens the rig's port once (a rig on the bench cannot get lost).
pub struct UsbConnector<'a> {
    rig: Option<&'a mut Rig>,
    stall: Option<Stall>,
}

impl<'a> UsbConnector<'a> {
    /// A connector to `rig`'s port, whose host pauses reading as `stall` says.
    pub fn new(rig: &'a mut Rig, stall: Option<Stall>) -> Self {
        UsbConnector {
            rig: Some(rig),
            stall,
        }
    }
}

impl<'a> Connector for UsbConnector<'a> {
    type T = UsbPort<'a>;

    fn connect(&mut self) -> Result<FramedLink<UsbPort<'a>>, LinkError> {
        let rig = self
            .rig
            .take()
            .ok_or(LinkError::Timeout("the port was opened already"))?;
        let mut port = UsbPort::open(rig);
        port.stall = self.stall;
        Ok(FramedLink::new(port))
    }

    fn can_reconnect(&self) -> bool {
        false
    }
}
