//! A simulated full-speed USB device controller: usb-device's [`UsbBus`] on the device
//! side, packet-level tokens (SETUP, OUT, IN with ACK/NAK/STALL) on the host side, one
//! packet buffer per endpoint as in real controllers. Control, bulk and interrupt
//! endpoints behave alike at this level; what differs (transfer sizes, ZLPs, polling)
//! is the host model's business (`host.rs`).
//!
//! Written here because the existing testers do not cover this: usbd-class-tester
//! 0.3 does control and interrupt transfers only (no bulk, no bus reset), and
//! mock-usb-bus 0.1 has no SETUP packets, stalls or SET_ADDRESS (those panic), so
//! nothing can enumerate on it.

use std::sync::{Arc, Mutex, MutexGuard};

use usb_device::bus::{PollResult, UsbBus};
use usb_device::endpoint::{EndpointAddress, EndpointType};
use usb_device::{Result, UsbDirection, UsbError};

/// Device-side writes refused (endpoint still full) within one service-loop iteration
/// beyond which the firmware is taken to be spinning: a write that blocks until the
/// host reads would never return, since the host cannot run meanwhile. A loop that
/// returns does a handful of such writes per iteration.
pub const SPIN_LIMIT: u32 = 10_000;

/// One endpoint's single packet buffer.
#[derive(Debug)]
pub struct Ep {
    /// Transfer type, as allocated.
    pub ty: EndpointType,
    /// Largest packet (bytes).
    pub max: usize,
    /// The packet waiting: for IN, written by the device and not yet taken by the host;
    /// for OUT, sent by the host and not yet read by the device.
    pub packet: Option<Vec<u8>>,
    /// Answering STALL.
    pub stalled: bool,
}

/// What the wire and the controller's registers hold.
#[derive(Debug, Default)]
pub struct State {
    /// OUT endpoints by number.
    pub out: [Option<Ep>; 16],
    /// IN endpoints by number.
    pub inn: [Option<Ep>; 16],
    /// EP0 OUT holds a SETUP packet (not an OUT data packet).
    pub setup: bool,
    /// IN packets taken by the host, not yet reported by `poll` (bit per endpoint).
    pub in_complete: u16,
    /// A bus reset waits to be reported.
    pub reset: bool,
    /// A suspend (the bus fell idle) waits to be reported.
    pub suspend: bool,
    /// Address the device answers to (0 until SET_ADDRESS takes effect).
    pub address: u8,
    /// Device-side writes refused since the rig last cleared the count.
    pub spins: u32,
}

/// The host's answer to a token.
#[derive(Debug, PartialEq, Eq)]
pub enum Token {
    /// Accepted (OUT) or a packet (IN).
    Ack(Vec<u8>),
    /// Not now: OUT buffer still full, or no IN packet ready.
    Nak,
    /// The endpoint is halted.
    Stall,
}

/// The device side: what usb-device drives.
pub struct SimBus(pub Arc<Mutex<State>>);

/// Locks the shared state (a panicked test poisons it; the panic is the report).
pub fn lock(s: &Mutex<State>) -> MutexGuard<'_, State> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

impl SimBus {
    fn state(&self) -> MutexGuard<'_, State> {
        lock(&self.0)
    }
}

impl UsbBus for SimBus {
    fn alloc_ep(
        &mut self,
        dir: UsbDirection,
        addr: Option<EndpointAddress>,
        ty: EndpointType,
        max: u16,
        _interval: u8,
    ) -> Result<EndpointAddress> {
        let mut s = self.state();
        let eps = match dir {
            UsbDirection::Out => &mut s.out,
            UsbDirection::In => &mut s.inn,
        };
        let index = match addr {
            Some(a) if eps[a.index()].is_some() => return Err(UsbError::InvalidEndpoint),
            Some(a) => a.index(),
            None if ty == EndpointType::Control => 0,
            None => (1..16)
                .find(|&i| eps[i].is_none())
                .ok_or(UsbError::EndpointOverflow)?,
        };
        eps[index] = Some(Ep {
            ty,
            max: max.into(),
            packet: None,
            stalled: false,
        });
        Ok(EndpointAddress::from_parts(index, dir))
    }

    fn enable(&mut self) {
        // A device coming up sees a bus reset first.
        self.state().reset = true;
    }

    fn reset(&self) {
        let mut guard = self.state();
        let s = &mut *guard;
        for ep in s.out.iter_mut().chain(s.inn.iter_mut()).flatten() {
            ep.packet = None;
            ep.stalled = false;
        }
        s.setup = false;
        s.in_complete = 0;
        s.address = 0;
    }

    fn set_device_address(&self, addr: u8) {
        self.state().address = addr;
    }

    fn write(&self, addr: EndpointAddress, buf: &[u8]) -> Result<usize> {
        let mut s = self.state();
        let ep = s.inn[addr.index()]
            .as_mut()
            .ok_or(UsbError::InvalidEndpoint)?;
        if buf.len() > ep.max {
            return Err(UsbError::BufferOverflow);
        }
        if ep.packet.is_some() {
            s.spins += 1;
            assert!(
                s.spins <= SPIN_LIMIT,
                "the firmware keeps writing to the full endpoint {addr:?} without returning \
                 to its loop: a write that blocks until the host reads"
            );
            return Err(UsbError::WouldBlock);
        }
        ep.packet = Some(buf.to_vec());
        Ok(buf.len())
    }

    fn read(&self, addr: EndpointAddress, buf: &mut [u8]) -> Result<usize> {
        let mut s = self.state();
        let ep = s.out[addr.index()]
            .as_mut()
            .ok_or(UsbError::InvalidEndpoint)?;
        let Some(p) = &ep.packet else {
            return Err(UsbError::WouldBlock);
        };
        if p.len() > buf.len() {
            return Err(UsbError::BufferOverflow);
        }
        let n = p.len();
        buf[..n].copy_from_slice(p);
        ep.packet = None;
        if addr.index() == 0 {
            s.setup = false;
        }
        Ok(n)
    }

    fn set_stalled(&self, addr: EndpointAddress, stalled: bool) {
        let mut s = self.state();
        let eps = match addr.direction() {
            UsbDirection::Out => &mut s.out,
            UsbDirection::In => &mut s.inn,
        };
        if let Some(ep) = eps[addr.index()].as_mut() {
            ep.stalled = stalled;
        }
    }

    fn is_stalled(&self, addr: EndpointAddress) -> bool {
        let s = self.state();
        let eps = match addr.direction() {
            UsbDirection::Out => &s.out,
            UsbDirection::In => &s.inn,
        };
        eps[addr.index()].as_ref().is_some_and(|ep| ep.stalled)
    }

    fn suspend(&self) {}

    fn resume(&self) {}

    fn poll(&self) -> PollResult {
        let mut s = self.state();
        if std::mem::take(&mut s.reset) {
            return PollResult::Reset;
        }
        if std::mem::take(&mut s.suspend) {
            return PollResult::Suspend;
        }
        let mut ep_out = 0u16;
        let mut ep_setup = 0u16;
        for (i, ep) in s.out.iter().enumerate() {
            if ep.as_ref().is_some_and(|ep| ep.packet.is_some()) {
                if i == 0 && s.setup {
                    ep_setup |= 1;
                } else {
                    ep_out |= 1 << i;
                }
            }
        }
        let ep_in_complete = std::mem::take(&mut s.in_complete);
        if ep_out | ep_setup | ep_in_complete == 0 {
            PollResult::None
        } else {
            PollResult::Data {
                ep_out,
                ep_in_complete,
                ep_setup,
            }
        }
    }
}

/// The host's end of the wire.
#[derive(Clone)]
pub struct Wire(pub Arc<Mutex<State>>);

impl Wire {
    /// A fresh bus: the device side to hand usb-device, and the host's end.
    pub fn new() -> (SimBus, Wire) {
        let s = Arc::new(Mutex::new(State::default()));
        (SimBus(s.clone()), Wire(s))
    }

    /// The shared state.
    pub fn state(&self) -> MutexGuard<'_, State> {
        lock(&self.0)
    }

    /// The bus falls idle: the host suspends the port, or the cable is pulled on a
    /// board that does not sense VBUS.
    pub fn suspend(&self) {
        self.state().suspend = true;
    }

    /// The host resets the bus (a re-plug, or the host restarting the device).
    pub fn bus_reset(&self) {
        self.state().reset = true;
    }

    /// A SETUP packet to EP0: always accepted, clears a halt and any IN data left from
    /// the previous transfer (as controllers do).
    pub fn setup(&self, packet: [u8; 8]) {
        let mut s = self.state();
        let out = s.out[0].as_mut().expect("EP0 OUT allocated");
        out.packet = Some(packet.to_vec());
        out.stalled = false;
        let inn = s.inn[0].as_mut().expect("EP0 IN allocated");
        inn.packet = None;
        inn.stalled = false;
        s.in_complete &= !1;
        s.setup = true;
    }

    /// An OUT token with `data` to endpoint `index`.
    pub fn out(&self, index: usize, data: &[u8]) -> Token {
        let mut s = self.state();
        let ep = s.out[index].as_mut().expect("OUT endpoint allocated");
        assert!(data.len() <= ep.max, "host sent an oversized packet");
        if ep.stalled {
            Token::Stall
        } else if ep.packet.is_some() {
            Token::Nak
        } else {
            ep.packet = Some(data.to_vec());
            Token::Ack(Vec::new())
        }
    }

    /// An IN token to endpoint `index`.
    pub fn inn(&self, index: usize) -> Token {
        let mut s = self.state();
        let ep = s.inn[index].as_mut().expect("IN endpoint allocated");
        if ep.stalled {
            return Token::Stall;
        }
        match ep.packet.take() {
            Some(p) => {
                s.in_complete |= 1 << index;
                Token::Ack(p)
            }
            None => Token::Nak,
        }
    }

    /// Nothing left for the device to notice on EP0 (its last events handled).
    pub fn ep0_settled(&self) -> bool {
        let s = self.state();
        s.in_complete & 1 == 0 && s.out[0].as_ref().is_none_or(|ep| ep.packet.is_none())
    }
}
