//! The firmware's USB link: a CDC-ACM serial port (usb-device + usbd-serial) mapped onto
//! brdf-core's [`Link`], generic over usb-device's [`UsbBus`] so that the board binary
//! only supplies its bus (the STM32F411's OTG FS) and the host can test the rest
//! against a simulated bus (`tests/`).
//!
//! What it guarantees the service loop (and the tests check):
//! - **Never blocks.** [`Link::write`] takes what fits in the port's buffer now and
//!   returns; a host that stops reading leaves the frame with the service, which keeps
//!   it (and the controller pauses its sweep) until the host reads again: nothing is lost.
//! - **Every transfer ends.** A write that ends on a full 64-byte packet is followed by
//!   a zero-length packet (usbd-serial does this once the last full packet is taken), so
//!   a host reading with a larger buffer gets the frame instead of waiting for more.
//! - **A host that closes the port stops the device.** When DTR falls (the host closed
//!   the port, or its process died) the link hands the controller an `Abort` (motion
//!   stops within one step, the laser goes off), empties the port's transmit buffer and
//!   discards output until DTR rises again, so the next host starts on a clean stream.
//!   A host that never raises DTR is served as usual. docs/protocol.md says the same
//!   for client writers.
//! - **A bus that goes away stops the device too.** USB suspend (the host suspended
//!   the port, or the cable was pulled on a board whose VBUS is not sensed: the bus
//!   falls idle) and a bus reset of a configured device (re-plugged, or the host
//!   restarted it) hand the controller an `Abort` as well: the safe state.
//! - **VBUS loss stops the device at once.** A board that senses VBUS (self-powered,
//!   VBUS wired to the sense pin) reports it with [`UsbLink::set_vbus`] every loop;
//!   when VBUS falls the link does what a dropped DTR does (an `Abort` for the
//!   controller, the port's buffers emptied, output discarded) without waiting the
//!   3 ms the bus takes to be seen suspended. When VBUS returns the next host starts
//!   on a clean stream, DTR raised or not.
//! - **Descriptors from one source**: VID, PID, manufacturer and product strings are
//!   brdf-core's [`identity`](brdf_core::identity), which `gonio ports` matches.
#![no_std]
#![deny(missing_docs)]

use brdf_core::frame;
use brdf_core::identity::{USB_MANUFACTURER, USB_PID, USB_PRODUCT, USB_VID};
use brdf_core::protocol::Command;
use brdf_core::service::Link;
use usb_device::UsbError;
use usb_device::bus::{UsbBus, UsbBusAllocator};
use usb_device::class::UsbClass;
use usb_device::device::{
    StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid,
};
use usbd_serial::SerialPort;

/// Largest packet of the CDC data endpoints (bytes): full-speed bulk maximum, fixed by
/// usbd-serial.
pub const MAX_PACKET: usize = 64;

/// Room for the `Abort` frame handed to the controller when the host goes away (a
/// leading 0x00 plus a frame of a few bytes).
const ABORT_LEN: usize = 16;

/// The USB CDC-ACM port as the service's [`Link`].
pub struct UsbLink<'a, B: UsbBus> {
    dev: UsbDevice<'a, B>,
    serial: SerialPort<'a, B>,
    /// DTR as last seen.
    dtr: bool,
    /// The device state as last seen (suspend and bus resets are noticed by change).
    state: UsbDeviceState,
    /// DTR fell after having been raised (the host closed the port) or VBUS fell:
    /// output is discarded.
    closed: bool,
    /// VBUS as last reported by the board ([`UsbLink::set_vbus`]); true on boards that
    /// do not sense it.
    vbus: bool,
    /// Bytes of the pending `Abort` not yet handed to the controller.
    abort: [u8; ABORT_LEN],
    abort_len: usize,
    abort_off: usize,
    errors: u32,
}

impl<'a, B: UsbBus> UsbLink<'a, B> {
    /// The serial port and the USB device on `bus`, with the firmware's identity and
    /// `serial_number` (the chip's unique ID, by which `gonio` finds a device again).
    pub fn new(bus: &'a UsbBusAllocator<B>, serial_number: &'a str) -> Self {
        // The port is created first: its interfaces and endpoints are allocated before
        // the device is built, as usb-device requires.
        let serial = SerialPort::new(bus);
        let dev = UsbDeviceBuilder::new(bus, UsbVidPid(USB_VID, USB_PID))
            .device_class(usbd_serial::USB_CLASS_CDC)
            .strings(&[StringDescriptors::default()
                .manufacturer(USB_MANUFACTURER)
                .product(USB_PRODUCT)
                .serial_number(serial_number)])
            // One language is within usb-device's limit of 16.
            .expect("one string language")
            .build();
        UsbLink {
            dev,
            serial,
            dtr: false,
            state: UsbDeviceState::Default,
            closed: false,
            vbus: true,
            abort: [0; ABORT_LEN],
            abort_len: 0,
            abort_off: 0,
            errors: 0,
        }
    }

    /// Whether the host holds the port open (DTR raised).
    pub fn host_open(&self) -> bool {
        self.dtr
    }

    /// USB errors other than "would block" seen so far (a board may log them).
    pub fn errors(&self) -> u32 {
        self.errors
    }

    /// Reports whether VBUS is present, on a board that senses it: call it every loop,
    /// before [`Link::poll`]. A fall is the host gone (see the crate docs); boards that
    /// do not sense VBUS never call it.
    pub fn set_vbus(&mut self, present: bool) {
        if self.vbus && !present {
            self.closed = true;
            // Clears DTR and both buffers: nothing of this session reaches the next.
            self.serial.reset();
            self.dtr = false;
            self.queue_abort();
        } else if !self.vbus && present {
            // A new session: served as usual, as a host that never raises DTR is.
            self.closed = false;
        }
        self.vbus = present;
    }

    /// Whether VBUS is present as last reported (true on boards that do not sense it).
    pub fn vbus(&self) -> bool {
        self.vbus
    }

    /// Reacts to a change of DTR (see the crate docs).
    fn watch_dtr(&mut self) {
        let dtr = self.serial.dtr();
        if self.dtr && !dtr {
            self.closed = true;
            // What the departed host did not read is not for the next one.
            self.serial.reset();
            self.queue_abort();
        } else if dtr {
            self.closed = false;
        }
        self.dtr = dtr;
    }

    /// Reacts to a suspend or to a bus reset of a configured device (see the crate
    /// docs): the host is gone for now.
    fn watch_bus(&mut self) {
        let state = self.dev.state();
        let gone = (state == UsbDeviceState::Suspend && self.state != UsbDeviceState::Suspend)
            || (self.state == UsbDeviceState::Configured && state == UsbDeviceState::Default);
        if gone {
            self.queue_abort();
        }
        self.state = state;
    }

    /// Queues `0x00 ++ frame(Abort)`: the 0x00 ends any command the host left half sent.
    fn queue_abort(&mut self) {
        self.abort[0] = 0;
        // The frame is a few bytes; ABORT_LEN leaves room.
        let n = frame::encode(&Command::Abort, &mut self.abort[1..]).unwrap_or(0);
        self.abort_len = if n == 0 { 0 } else { 1 + n };
        self.abort_off = 0;
    }
}

impl<B: UsbBus> Link for UsbLink<'_, B> {
    fn poll(&mut self) {
        self.dev.poll(&mut [&mut self.serial]);
        self.watch_bus();
        self.watch_dtr();
    }

    fn read(&mut self, buf: &mut [u8]) -> usize {
        if self.abort_off < self.abort_len {
            let pending = &self.abort[self.abort_off..self.abort_len];
            let n = pending.len().min(buf.len());
            buf[..n].copy_from_slice(&pending[..n]);
            self.abort_off += n;
            return n;
        }
        match self.serial.read(buf) {
            Ok(n) => n,
            Err(UsbError::WouldBlock) => 0,
            Err(_) => {
                self.errors = self.errors.wrapping_add(1);
                0
            }
        }
    }

    fn write(&mut self, bytes: &[u8]) -> usize {
        if self.closed {
            return bytes.len();
        }
        match self.serial.write(bytes) {
            Ok(n) => n,
            Err(UsbError::WouldBlock) => 0,
            Err(_) => {
                self.errors = self.errors.wrapping_add(1);
                0
            }
        }
    }
}
