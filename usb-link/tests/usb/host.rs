//! The modelled host: enumeration (GET_DESCRIPTOR for the device, configuration and
//! strings, SET_ADDRESS, SET_CONFIGURATION), the CDC-ACM class requests a serial
//! driver sends (SET_LINE_CODING, GET_LINE_CODING, SET_CONTROL_LINE_STATE), and bulk
//! transfers as Linux's cdc-acm does them: OUT split into packets, IN read into
//! transfers of [`Rig::transfer_size`] bytes that end only on a short packet (a
//! zero-length one included) or when full. Between any two tokens the device runs one
//! iteration of its loop, so the host never waits on a device that does not run.

use super::bus::Token;
use super::rig::Rig;

/// Device iterations a host waits for an answer before declaring the device dead (a
/// liveness bound, far above what any answer takes).
const PATIENCE: u32 = 10_000;

/// Address the host assigns.
pub const ADDRESS: u8 = 5;

/// Line coding the host sets: 115200 baud, 1 stop bit, no parity, 8 data bits.
pub const LINE_CODING: [u8; 7] = [0x00, 0xC2, 0x01, 0x00, 0, 0, 8];

/// The control line state bits of SET_CONTROL_LINE_STATE.
pub const DTR: u16 = 1;
/// Request to send.
pub const RTS: u16 = 2;

/// An endpoint as the configuration descriptor states it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EpDesc {
    /// Endpoint address (bit 7 = IN).
    pub address: u8,
    /// bmAttributes & 3: 2 bulk, 3 interrupt.
    pub kind: u8,
    /// wMaxPacketSize.
    pub max: usize,
}

/// What enumeration found.
#[derive(Debug, Clone)]
pub struct Cdc {
    /// The 18-byte device descriptor.
    pub device: Vec<u8>,
    /// iManufacturer, iProduct, iSerialNumber strings (None where the index is 0).
    pub strings: [Option<String>; 3],
    /// The communication interface (class 2, subclass 2) number.
    pub comm_interface: u8,
    /// Its notification endpoint (interrupt IN).
    pub notify: EpDesc,
    /// The data interface's (class 10) bulk IN endpoint.
    pub bulk_in: EpDesc,
    /// Its bulk OUT endpoint.
    pub bulk_out: EpDesc,
}

impl Cdc {
    /// idVendor and idProduct.
    pub fn vid_pid(&self) -> (u16, u16) {
        let d = &self.device;
        (
            u16::from_le_bytes([d[8], d[9]]),
            u16::from_le_bytes([d[10], d[11]]),
        )
    }
}

/// The device stalled a control request.
#[derive(Debug, PartialEq, Eq)]
pub struct Stalled;

fn setup_packet(request_type: u8, request: u8, value: u16, index: u16, length: u16) -> [u8; 8] {
    let [v0, v1] = value.to_le_bytes();
    let [i0, i1] = index.to_le_bytes();
    let [l0, l1] = length.to_le_bytes();
    [request_type, request, v0, v1, i0, i1, l0, l1]
}

/// UTF-16LE string descriptor to text.
fn string_of(desc: &[u8]) -> String {
    let len = usize::from(desc[0]).min(desc.len());
    let units: Vec<u16> = desc[2..len]
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    String::from_utf16(&units).expect("string descriptor is UTF-16")
}

impl Rig {
    /// Runs the device until it has handled everything on EP0 (at least once).
    fn settle(&mut self) {
        self.step();
        for _ in 0..PATIENCE {
            if self.wire.ep0_settled() {
                return;
            }
            self.step();
        }
        panic!("the device does not handle EP0");
    }

    /// Sends an OUT packet, retrying while the device NAKs.
    fn out_packet(&mut self, index: usize, data: &[u8]) -> Result<(), Stalled> {
        for _ in 0..PATIENCE {
            match self.wire.out(index, data) {
                Token::Ack(_) => return Ok(()),
                Token::Stall => return Err(Stalled),
                Token::Nak => {
                    self.step();
                }
            }
        }
        panic!("OUT endpoint {index} NAKs for ever");
    }

    /// Takes an IN packet, retrying while the device NAKs.
    fn in_packet(&mut self, index: usize) -> Result<Vec<u8>, Stalled> {
        for _ in 0..PATIENCE {
            match self.wire.inn(index) {
                Token::Ack(p) => return Ok(p),
                Token::Stall => return Err(Stalled),
                Token::Nak => {
                    self.step();
                }
            }
        }
        panic!("IN endpoint {index} NAKs for ever");
    }

    /// A control transfer with an IN data stage of at most `length` bytes.
    pub fn control_in(
        &mut self,
        request_type: u8,
        request: u8,
        value: u16,
        index: u16,
        length: u16,
    ) -> Result<Vec<u8>, Stalled> {
        let max = self.ep0_max;
        self.wire
            .setup(setup_packet(request_type, request, value, index, length));
        self.settle();
        let mut data = Vec::new();
        loop {
            let p = self.in_packet(0)?;
            self.settle();
            data.extend_from_slice(&p);
            if p.len() < max || data.len() >= usize::from(length) {
                break;
            }
        }
        // Status stage: a zero-length OUT.
        self.out_packet(0, &[])?;
        self.settle();
        Ok(data)
    }

    /// A control transfer with an OUT data stage (possibly empty).
    pub fn control_out(
        &mut self,
        request_type: u8,
        request: u8,
        value: u16,
        index: u16,
        data: &[u8],
    ) -> Result<(), Stalled> {
        let max = self.ep0_max;
        let length = u16::try_from(data.len()).expect("short control data");
        self.wire
            .setup(setup_packet(request_type, request, value, index, length));
        self.settle();
        for chunk in data.chunks(max) {
            self.out_packet(0, chunk)?;
            self.settle();
        }
        // Status stage: a zero-length IN.
        let status = self.in_packet(0)?;
        assert!(status.is_empty(), "status stage carried data");
        self.settle();
        Ok(())
    }

    /// GET_DESCRIPTOR.
    pub fn get_descriptor(&mut self, kind: u8, index: u8, lang: u16, length: u16) -> Vec<u8> {
        let value = u16::from(kind) << 8 | u16::from(index);
        self.control_in(0x80, 6, value, lang, length)
            .unwrap_or_else(|_| panic!("GET_DESCRIPTOR {kind}/{index} stalled"))
    }

    /// Enumerates the device as a host does after plug-in, and configures it.
    pub fn enumerate(&mut self) -> Cdc {
        self.wire.bus_reset();
        self.step();
        // The first 8 bytes give EP0's packet size.
        let head = self.get_descriptor(1, 0, 0, 8);
        let ep0_max = usize::from(head[7]);
        self.control_out(0x00, 5, ADDRESS.into(), 0, &[])
            .expect("SET_ADDRESS");
        assert_eq!(
            self.wire.state().address,
            ADDRESS,
            "SET_ADDRESS took no effect"
        );
        self.ep0_max = ep0_max;
        let device = self.get_descriptor(1, 0, 0, 18);
        assert_eq!((device.len(), device[1]), (18, 1), "device descriptor");
        let head = self.get_descriptor(2, 0, 0, 9);
        let total = u16::from_le_bytes([head[2], head[3]]);
        let config = self.get_descriptor(2, 0, 0, total);
        assert_eq!(config.len(), usize::from(total), "configuration descriptor");
        let langs = self.get_descriptor(3, 0, 0, 255);
        let lang = u16::from_le_bytes([langs[2], langs[3]]);
        let strings = [device[14], device[15], device[16]]
            .map(|i| (i != 0).then(|| string_of(&self.get_descriptor(3, i, lang, 255))));
        let mut cdc = parse_config(&config);
        cdc.device = device;
        cdc.strings = strings;
        self.control_out(0x00, 9, 1, 0, &[])
            .expect("SET_CONFIGURATION");
        self.cdc = Some(cdc.clone());
        cdc
    }

    fn cdc(&self) -> &Cdc {
        self.cdc.as_ref().expect("enumerated")
    }

    /// SET_CONTROL_LINE_STATE.
    pub fn set_control_lines(&mut self, lines: u16) {
        let iface = self.cdc().comm_interface.into();
        self.control_out(0x21, 0x22, lines, iface, &[])
            .expect("SET_CONTROL_LINE_STATE");
    }

    /// SET_LINE_CODING.
    pub fn set_line_coding(&mut self, coding: &[u8; 7]) {
        let iface = self.cdc().comm_interface.into();
        self.control_out(0x21, 0x20, 0, iface, coding)
            .expect("SET_LINE_CODING");
    }

    /// GET_LINE_CODING.
    pub fn get_line_coding(&mut self) -> Vec<u8> {
        let iface = self.cdc().comm_interface.into();
        self.control_in(0xA1, 0x21, 0, iface, 7)
            .expect("GET_LINE_CODING")
    }

    /// Opens the port as Linux does: line coding, then DTR and RTS; reading starts.
    pub fn open_port(&mut self) {
        if self.cdc.is_none() {
            self.enumerate();
        }
        self.set_line_coding(&LINE_CODING);
        self.set_control_lines(DTR | RTS);
        self.reading = true;
    }

    /// Closes the port as Linux does: reading stops, what the application had not read
    /// is dropped, DTR and RTS fall.
    pub fn close_port(&mut self) {
        self.reading = false;
        self.transfer.clear();
        self.received.clear();
        self.set_control_lines(0);
    }

    /// Sends `bytes` on the bulk OUT endpoint, a packet at a time.
    pub fn write_bulk(&mut self, bytes: &[u8]) {
        let out = self.cdc().bulk_out;
        for chunk in bytes.chunks(out.max) {
            self.out_packet(usize::from(out.address & 0x0F), chunk)
                .expect("bulk OUT stalled");
            self.step();
        }
    }

    /// One IN token to the data endpoint (if the host is reading); a packet goes into
    /// the transfer in progress, which completes on a short packet or when full.
    /// Returns whether a packet came.
    pub fn poll_bulk_in(&mut self) -> bool {
        if !self.reading {
            return false;
        }
        let ep = self.cdc().bulk_in;
        match self.wire.inn(usize::from(ep.address & 0x0F)) {
            Token::Ack(p) => {
                assert!(p.len() <= ep.max, "oversized packet");
                self.transfer.extend_from_slice(&p);
                if p.len() < ep.max || self.transfer.len() >= self.transfer_size {
                    self.transfers.push(self.transfer.len());
                    self.received.extend(self.transfer.drain(..));
                }
                true
            }
            Token::Nak => false,
            Token::Stall => panic!("bulk IN stalled"),
        }
    }

    /// One IN token to the notification endpoint: what the device sent there, if any.
    pub fn poll_notify(&mut self) -> Option<Vec<u8>> {
        let ep = self.cdc().notify;
        match self.wire.inn(usize::from(ep.address & 0x0F)) {
            Token::Ack(p) => Some(p),
            Token::Nak => None,
            Token::Stall => panic!("notification endpoint stalled"),
        }
    }

    /// Device iteration, then an IN token: the host and device running side by side.
    /// Returns whether the device is busy or a packet came.
    pub fn step_both(&mut self) -> bool {
        let busy = self.step();
        self.poll_bulk_in() || busy
    }
}

/// Finds the CDC interfaces and their endpoints in a configuration descriptor.
fn parse_config(config: &[u8]) -> Cdc {
    let mut comm = None;
    let mut class = 0u8;
    let (mut notify, mut bulk_in, mut bulk_out) = (None, None, None);
    let mut at = 0;
    while at + 2 <= config.len() {
        let d = &config[at..at + usize::from(config[at])];
        assert!(!d.is_empty(), "zero-length descriptor");
        match d[1] {
            4 => {
                class = d[5];
                if (d[5], d[6]) == (2, 2) {
                    comm = Some(d[2]);
                }
            }
            5 => {
                let ep = EpDesc {
                    address: d[2],
                    kind: d[3] & 3,
                    max: usize::from(u16::from_le_bytes([d[4], d[5]])),
                };
                match (class, ep.address & 0x80 != 0, ep.kind) {
                    (2, true, 3) => notify = Some(ep),
                    (10, true, 2) => bulk_in = Some(ep),
                    (10, false, 2) => bulk_out = Some(ep),
                    other => panic!("unexpected endpoint {other:?}"),
                }
            }
            _ => {}
        }
        at += d.len();
    }
    Cdc {
        device: Vec::new(),
        strings: [None, None, None],
        comm_interface: comm.expect("a CDC communication interface"),
        notify: notify.expect("a notification endpoint"),
        bulk_in: bulk_in.expect("a bulk IN endpoint"),
        bulk_out: bulk_out.expect("a bulk OUT endpoint"),
    }
}
