//! The host end of the wire protocol: a [`Transport`] (byte pipe to a device), the
//! [`FramedLink`] over it (framing, the handshake with its version check, receive
//! statistics) and [`LinkError`].

use std::collections::VecDeque;
use std::fmt;
use std::io::{self, Write};
use std::time::{Duration, Instant};

use brdf_core::frame::{self, FrameDecoder, FrameError, FrameStats, MAX_FRAME_LEN};
use brdf_core::protocol::{
    Command, Event, HOST_LEASE_MS, Info, PROTOCOL_VERSION, peek_info_version,
};

/// A link that sent nothing for this long sends a `Ping`, so the device's host lease
/// ([`HOST_LEASE_MS`]) never runs out while gonio waits: a fifth of the lease.
pub const KEEPALIVE: Duration = Duration::from_millis(HOST_LEASE_MS as u64 / 5);
/// The token of the lease-keeping `Ping`; its `Pong` is taken by the link, never
/// returned.
pub const KEEPALIVE_TOKEN: u32 = 0x6C65_6173; // "leas"

/// A byte pipe to a device.
pub trait Transport {
    /// Sends all of `bytes`.
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Receives what arrives within `timeout` into `buf`; `Ok(0)` when nothing came.
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;
    /// Releases the device (a serial port's exclusive lock) before it is opened again;
    /// sending or receiving afterwards fails.
    fn close(&mut self) {}
    /// Where the device is, for messages (a serial port's path); `None` for devices
    /// that have no name a user gave.
    fn port_name(&self) -> Option<&str> {
        None
    }
}

/// Why talking to the device failed.
#[derive(Debug)]
pub enum LinkError {
    /// The port could not be opened.
    Open {
        /// Port path.
        path: String,
        /// What the OS said.
        reason: String,
    },
    /// The path names something that is not a serial port (a regular file, /dev/null):
    /// the user's mistake, not the device's.
    NotAPort {
        /// Port path.
        path: String,
        /// What it is instead (`a regular file`, `a device that is not a terminal`).
        what: String,
    },
    /// Reading or writing failed (e.g. the device was unplugged).
    Io(io::Error),
    /// Nothing arrived in time.
    Timeout(&'static str),
    /// Nothing answered the handshake: no gonio device at `port`, or its firmware is
    /// not running.
    NoAnswer {
        /// The port, when the transport has one.
        port: Option<String>,
        /// How long it was asked, in seconds.
        secs: u64,
    },
    /// Writing the raw frame log (`--raw`) failed: an error on the host's side (a full
    /// disk), not the device's. What arrived was decoded before the log was written.
    Log(io::Error),
    /// The device speaks another protocol version.
    Version {
        /// The device's version.
        device: u16,
    },
    /// The device's Info names this gonio's protocol version but does not decode.
    BadInfo,
    /// The device's Info decodes but does not hold together (why, one line).
    Implausible(String),
}

impl fmt::Display for LinkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkError::Open { path, reason } => write!(f, "cannot open {path}: {reason}"),
            LinkError::NotAPort { path, what } => write!(
                f,
                "cannot open {path}: not a serial port ({what}): give the device's port, e.g. /dev/ttyACM0 (gonio ports lists the ports found)"
            ),
            LinkError::Io(e) => write!(f, "device link failed: {e}"),
            LinkError::Timeout(what) => write!(f, "device did not answer: {what}"),
            LinkError::NoAnswer {
                port: Some(port),
                secs,
            } => write!(
                f,
                "nothing answered on {port} within {secs} s: no gonio device there, or its firmware is not running; \
                 check the port (gonio ports marks gonio devices with '*') and the cable, or flash the firmware (gonio flash)"
            ),
            LinkError::NoAnswer { port: None, secs } => {
                write!(f, "the device did not answer the handshake within {secs} s")
            }
            LinkError::Log(e) => write!(
                f,
                "writing the raw frame log failed on this computer ({e}), not on the device"
            ),
            LinkError::Version { device } if *device > PROTOCOL_VERSION => write!(
                f,
                "device speaks protocol v{device}, this gonio speaks v{PROTOCOL_VERSION}: update gonio"
            ),
            LinkError::Version { device } => write!(
                f,
                "device speaks protocol v{device}, this gonio speaks v{PROTOCOL_VERSION}: update the firmware (gonio flash)"
            ),
            LinkError::Implausible(why) => write!(
                f,
                "the device's Info does not hold together ({why}): a broken or foreign firmware build; reflash it (gonio flash)"
            ),
            LinkError::BadInfo => write!(
                f,
                "the device's Info says protocol v{PROTOCOL_VERSION}, as this gonio, but does not decode (a broken or foreign firmware build): reflash it (gonio flash)"
            ),
        }
    }
}

impl std::error::Error for LinkError {}

impl From<io::Error> for LinkError {
    fn from(e: io::Error) -> Self {
        LinkError::Io(e)
    }
}

/// Frames over a transport: commands out, events in, with counters of what was
/// dropped and an optional log of every raw byte received.
pub struct FramedLink<T> {
    transport: T,
    decoder: FrameDecoder<MAX_FRAME_LEN>,
    inbox: VecDeque<Event>,
    raw_log: Option<Box<dyn Write + Send>>,
    /// A raw-log write that failed, reported once the events decoded before it are taken.
    log_error: Option<io::Error>,
    foreign_version: Option<u16>,
    /// An Info of our protocol version arrived that did not decode.
    bad_info: bool,
    /// When a frame (or raw bytes) last went to the device.
    last_sent: Instant,
}

impl<T: Transport> FramedLink<T> {
    /// Wraps a transport.
    pub fn new(transport: T) -> Self {
        FramedLink {
            transport,
            decoder: FrameDecoder::new(),
            inbox: VecDeque::new(),
            raw_log: None,
            log_error: None,
            foreign_version: None,
            bad_info: false,
            last_sent: Instant::now(),
        }
    }

    /// Logs every received byte to `w` (a raw frame log for later replay).
    pub fn set_raw_log(&mut self, w: Box<dyn Write + Send>) {
        self.raw_log = Some(w);
    }

    /// Releases the device: a reconnect to the same port must not find it still held.
    pub fn close(&mut self) {
        self.transport.close();
    }

    /// The transport.
    pub fn transport(&mut self) -> &mut T {
        &mut self.transport
    }

    /// Frames received and dropped (CRC, COBS, too long, undecodable).
    pub fn stats(&self) -> FrameStats {
        self.decoder.stats()
    }

    /// Sends one command.
    pub fn send(&mut self, cmd: &Command) -> Result<(), LinkError> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = frame::encode(cmd, &mut buf).expect("every command fits MAX_FRAME_LEN");
        self.transport.send(&buf[..n])?;
        self.last_sent = Instant::now();
        Ok(())
    }

    /// Sends raw bytes (tests of the device's robustness).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.transport.send(bytes)?;
        self.last_sent = Instant::now();
        Ok(())
    }

    /// The next event, waiting at most `timeout`; `Ok(None)` if none came. Dropped
    /// frames are counted in [`FramedLink::stats`], never returned. Bytes are decoded
    /// before they are logged: when the raw log fails, every event that arrived is
    /// still returned first, then [`LinkError::Log`] (once; the log is closed).
    pub fn recv(&mut self, timeout: Duration) -> Result<Option<Event>, LinkError> {
        let deadline = Instant::now() + timeout;
        let mut buf = [0u8; 4096];
        loop {
            if let Some(ev) = self.inbox.pop_front() {
                return Ok(Some(ev));
            }
            if let Some(e) = self.log_error.take() {
                return Err(LinkError::Log(e));
            }
            // Keep the device's host lease while waiting.
            if self.last_sent.elapsed() >= KEEPALIVE {
                self.send(&Command::Ping(KEEPALIVE_TOKEN))?;
            }
            let left = deadline
                .saturating_duration_since(Instant::now())
                .min(KEEPALIVE);
            let n = self.transport.recv(&mut buf, left)?;
            for &b in &buf[..n] {
                match self.decoder.push::<Event>(b) {
                    Some(Ok(Event::Pong(KEEPALIVE_TOKEN))) => {}
                    Some(Ok(ev)) => self.inbox.push_back(ev),
                    Some(Err(FrameError::Decode)) => {
                        // Intact but not ours: a device of another protocol version
                        // still shows its version in an Info.
                        match peek_info_version(self.decoder.undecoded_payload()) {
                            Some(PROTOCOL_VERSION) => self.bad_info = true,
                            Some(v) => self.foreign_version = Some(v),
                            None => {}
                        }
                    }
                    Some(Err(_)) | None => {}
                }
            }
            if let Some(log) = &mut self.raw_log {
                if let Err(e) = log.write_all(&buf[..n]) {
                    self.raw_log = None;
                    self.log_error = Some(e);
                }
            }
            if self.log_error.is_some() {
                continue;
            }
            if self.inbox.is_empty() && Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }

    /// Handshake: Ping every 50 ms until the matching Pong (bytes sent before the
    /// device listens are lost), then GetInfo; checks the protocol version. Events
    /// other than the awaited ones are dropped.
    pub fn handshake(&mut self, timeout: Duration) -> Result<Info, LinkError> {
        let deadline = Instant::now() + timeout;
        let token = 0x676F_6E69; // "goni"
        'ping: loop {
            if Instant::now() >= deadline {
                return Err(LinkError::NoAnswer {
                    port: self.transport.port_name().map(str::to_string),
                    secs: timeout.as_secs_f64().round() as u64,
                });
            }
            // Flush line noise in front of the first frame.
            self.send_raw(&[0])?;
            self.send(&Command::Ping(token))?;
            let wait_until = Instant::now() + Duration::from_millis(50);
            while Instant::now() < wait_until {
                if let Some(Event::Pong(t)) = self.recv(Duration::from_millis(10))? {
                    if t == token {
                        // Bytes before this Pong were sent to an earlier session (the
                        // tail of a frame the last link left half read, a keep-alive's
                        // Pong sent after it closed): not this session's drops. The
                        // decoder is empty between frames, so nothing else is lost.
                        self.decoder = FrameDecoder::new();
                        break 'ping;
                    }
                }
            }
        }
        // Asked again every 500 ms: on a noisy link the GetInfo or the Info may be lost.
        let mut ask_at = Instant::now();
        while Instant::now() < deadline {
            if Instant::now() >= ask_at {
                self.send(&Command::GetInfo)?;
                ask_at = Instant::now() + Duration::from_millis(500);
            }
            let slice = deadline
                .saturating_duration_since(Instant::now())
                .min(Duration::from_millis(50));
            if let Some(Event::Info(info)) = self.recv(slice)? {
                if info.protocol != PROTOCOL_VERSION {
                    return Err(LinkError::Version {
                        device: info.protocol,
                    });
                }
                check_info(&info).map_err(LinkError::Implausible)?;
                return Ok(info);
            }
            if let Some(device) = self.foreign_version {
                return Err(LinkError::Version { device });
            }
        }
        if self.bad_info {
            return Err(LinkError::BadInfo);
        }
        Err(LinkError::Timeout("no Info to GetInfo"))
    }
}

/// Most microsteps per degree a device may claim (a 0.000001-degree resolution).
const MAX_STEPS_PER_DEG: f32 = 1e6;

/// Checks what an `Info` states before anything relies on it: each arm's travel finite,
/// ordered and within the protocol's ranges (source in [0, 90], detector in
/// [-90, 90] degrees), a resolution finite and above 0, plans of at least one point.
pub fn check_info(info: &Info) -> Result<(), String> {
    let arm = |name: &str, l: &brdf_core::protocol::ArmLimits, lo: f32, hi: f32| {
        if !(l.min_deg.is_finite() && l.max_deg.is_finite() && l.min_deg < l.max_deg) {
            return Err(format!(
                "{name} travel {} .. {} degrees",
                l.min_deg, l.max_deg
            ));
        }
        if l.min_deg < lo || l.max_deg > hi {
            return Err(format!(
                "{name} travel {} .. {} degrees is outside [{lo}, {hi}]",
                l.min_deg, l.max_deg
            ));
        }
        if !(l.steps_per_deg.is_finite() && l.steps_per_deg > 0.0)
            || l.steps_per_deg > MAX_STEPS_PER_DEG
        {
            return Err(format!(
                "{name} arm {} microsteps per degree",
                l.steps_per_deg
            ));
        }
        Ok(())
    };
    arm("source", &info.source, 0.0, 90.0)?;
    arm("detector", &info.detector, -90.0, 90.0)?;
    if info.max_points == 0 {
        return Err("plans of 0 points at most".into());
    }
    Ok(())
}

/// Opens (and re-opens) the link to a device.
pub trait Connector {
    /// The transport it yields.
    type T: Transport;
    /// Opens the link; does not handshake.
    fn connect(&mut self) -> Result<FramedLink<Self::T>, LinkError>;
    /// Whether trying again after a lost link can help (a serial device may come back;
    /// an in-process one cannot get lost).
    fn can_reconnect(&self) -> bool;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{InProcessDevice, SimConfig};

    /// A raw log on a full disk.
    struct Full;

    impl Write for Full {
        fn write(&mut self, _: &[u8]) -> io::Result<usize> {
            Err(io::Error::from_raw_os_error(28))
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    /// Answers every command with a Pong to the handshake's Ping and an Info of this
    /// protocol version that is cut short.
    struct BrokenInfo(VecDeque<u8>);

    impl Transport for BrokenInfo {
        fn send(&mut self, _: &[u8]) -> io::Result<()> {
            let mut buf = [0u8; 64];
            let n = frame::encode(&Event::Pong(0x676F_6E69), &mut buf).unwrap();
            self.0.extend(&buf[..n]);
            // Variant 0 (Info) and its first field, the version, then nothing.
            let n = frame::encode(&(0u8, PROTOCOL_VERSION), &mut buf).unwrap();
            self.0.extend(&buf[..n]);
            Ok(())
        }
        fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
            Self::recv_from(&mut self.0, buf, timeout)
        }
    }

    impl BrokenInfo {
        fn recv_from(q: &mut VecDeque<u8>, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
            let n = q.len().min(buf.len());
            if n == 0 {
                std::thread::sleep(timeout.min(Duration::from_millis(5)));
            }
            for (b, x) in buf.iter_mut().zip(q.drain(..n)) {
                *b = x;
            }
            Ok(n)
        }
    }

    /// Answers the handshake with the given Info.
    struct Lying(VecDeque<u8>, Info);

    impl Transport for Lying {
        fn send(&mut self, _: &[u8]) -> io::Result<()> {
            let mut buf = [0u8; 128];
            let n = frame::encode(&Event::Pong(0x676F_6E69), &mut buf).unwrap();
            self.0.extend(&buf[..n]);
            let n = frame::encode(&Event::Info(self.1.clone()), &mut buf).unwrap();
            self.0.extend(&buf[..n]);
            Ok(())
        }
        fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
            BrokenInfo::recv_from(&mut self.0, buf, timeout)
        }
    }

    /// One way an Info may lie.
    type Lie = fn(&mut Info);

    #[test]
    fn an_info_that_does_not_hold_together_is_refused_with_what_it_said() {
        let good = brdf_core::sim::simulated_controller(
            "sim",
            [0, 1, 0],
            brdf_core::sim::VirtualSample::new(
                brdf_core::Preset::by_name("fe-0.115").unwrap(),
                0.0,
                1,
            ),
        );
        let info = {
            let mut c = good;
            c.receive(&frame_of(&Command::GetInfo), 0);
            match c.next_event() {
                Some(Event::Info(i)) => i,
                other => panic!("{other:?}"),
            }
        };
        assert_eq!(check_info(&info), Ok(()));
        let lies: [(Lie, &str); 6] = [
            (
                |i| i.detector.min_deg = f32::NAN,
                "detector travel NaN .. 90",
            ),
            (|i| i.source.max_deg = -5.0, "source travel 0 .. -5"),
            (|i| i.source.max_deg = 1e30, "outside [0, 90]"),
            (
                |i| i.detector.steps_per_deg = 0.0,
                "detector arm 0 microsteps",
            ),
            (
                |i| i.source.steps_per_deg = f32::INFINITY,
                "source arm inf microsteps",
            ),
            (|i| i.max_points = 0, "plans of 0 points"),
        ];
        for (lie, says) in lies {
            let mut bad = info.clone();
            lie(&mut bad);
            let mut link = FramedLink::new(Lying(VecDeque::new(), bad));
            let t0 = Instant::now();
            let err = link.handshake(Duration::from_secs(5)).unwrap_err();
            assert!(t0.elapsed() < Duration::from_secs(2), "answered at once");
            let msg = err.to_string();
            assert!(matches!(err, LinkError::Implausible(_)), "{msg}");
            assert!(
                msg.contains(says) && msg.contains("does not hold together"),
                "{msg}"
            );
            assert!(!msg.contains('\n'));
        }
    }

    fn frame_of(cmd: &Command) -> Vec<u8> {
        let mut buf = [0u8; 64];
        let n = frame::encode(cmd, &mut buf).unwrap();
        buf[..n].to_vec()
    }

    #[test]
    fn an_info_of_our_version_that_does_not_decode_says_so() {
        let mut link = FramedLink::new(BrokenInfo(VecDeque::new()));
        let err = link.handshake(Duration::from_millis(400)).unwrap_err();
        assert!(matches!(err, LinkError::BadInfo), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("does not decode"), "{msg}");
        assert!(
            !msg.contains("update"),
            "no version advice when versions agree: {msg}"
        );
    }

    #[test]
    fn events_are_decoded_before_a_failing_log_and_the_error_is_ours() {
        let dev = InProcessDevice::new(&SimConfig::new(
            brdf_core::Preset::by_name("fe-0.115").unwrap(),
            0.0,
            1,
        ));
        let mut link = FramedLink::new(dev);
        link.set_raw_log(Box::new(Full));
        link.send(&Command::Ping(7)).unwrap();
        let mut got = Vec::new();
        let err = loop {
            match link.recv(Duration::from_millis(100)) {
                Ok(Some(ev)) => got.push(ev),
                Ok(None) => panic!("no error from the full log"),
                Err(e) => break e,
            }
        };
        assert_eq!(
            got,
            vec![Event::Pong(7)],
            "the chunk that failed to log was decoded"
        );
        assert!(matches!(err, LinkError::Log(_)));
        let msg = err.to_string();
        assert!(
            msg.contains("on this computer") && msg.contains("not on the device"),
            "{msg}"
        );
        // Reported once; the link itself still works.
        link.send(&Command::Ping(8)).unwrap();
        assert_eq!(
            link.recv(Duration::from_millis(500)).unwrap(),
            Some(Event::Pong(8))
        );
    }
}
