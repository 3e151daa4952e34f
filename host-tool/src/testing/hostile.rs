//! A hostile device: wraps a device's transport and rewrites what the device says (or
//! hears), one [`Lie`] per failure a capture must survive (bad values, wild angles, a
//! seq or count that would drive allocation, another plan, control characters in its
//! text, a slow device, floods, an ignored command, a link dropped on every sweep).
//! Lies about readings are told in the first sweep only, so a capture that rejects
//! them and measures again can finish.

use std::collections::VecDeque;
use std::io;
use std::time::{Duration, Instant};

use brdf_core::frame::{self, FrameDecoder, MAX_FRAME_LEN};
use brdf_core::protocol::{Command, ErrorCode, ErrorEvent, Event, Progress};

use crate::device::{Connector, FramedLink, InProcessDevice, LinkError, SimConfig, Transport};

/// How long [`Lie::Slow`] holds each reading (wall time): longer than the capture's
/// `--event-timeout` in the tests, shorter than the plan's time per point.
pub const SLOW_READING: Duration = Duration::from_millis(1500);

/// What the hostile device lies about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lie {
    /// brdf NaN or infinite, std NaN or negative, on every other reading.
    Values,
    /// brdf 1e-35 (seq 5) and 3e38 (seq 9): finite, but outside the range a sweep file
    /// holds (`sweep_file::brdf_in_range`).
    Magnitudes,
    /// theta_i = 1000, theta_r = -1e30, or 7 degrees off, on three readings in four.
    Angles,
    /// A reading with seq 0xFFFFFFFF and one 10^8 ahead, and a SweepDone whose count
    /// and next seq are 0xFFFFFFFF.
    HugeSeq,
    /// Progress counts two readings more than the plan sent (another stop rule).
    Total,
    /// Every reading after the first reports the previous point's angles (a plan
    /// numbered differently).
    Shifted,
    /// Info.board holds newlines (lines added to a file header if written raw).
    Board,
    /// A DetectorFault whose detail holds an ANSI escape and a newline.
    ErrorText,
    /// Each reading arrives [`SLOW_READING`] after the previous one (a long settle);
    /// Pong is answered at once: slow but alive.
    Slow,
    /// After two readings, only Pongs, 20 at a time, and nothing else.
    FloodPong,
    /// After two readings, only Progress of the running sweep, 20 at a time.
    FloodProgress,
    /// After two readings, nothing but Pong: alive, but the sweep makes no progress.
    Stall,
    /// Every StartSweep is dropped before the device hears it; it answers all else.
    IgnoreStart,
    /// The link breaks on every StartSweep (each connection is a fresh device).
    DropOnStart,
}

/// A transport whose device lies as its [`Lie`] says.
pub struct HostileTransport<T> {
    inner: T,
    lie: Lie,
    decoder: FrameDecoder<MAX_FRAME_LEN>,
    /// Commands on their way to the device, decoded to drop or act on.
    commands: FrameDecoder<MAX_FRAME_LEN>,
    frame_out: Vec<u8>,
    /// Frames held until their time ([`Lie::Slow`]).
    held: VecDeque<(Instant, Vec<u8>)>,
    last_release: Option<Instant>,
    out: VecDeque<u8>,
    first_sweep: Option<u32>,
    previous: Option<(f32, f32)>,
    readings: u32,
    last_progress: Option<Progress>,
    broken: bool,
}

impl<T: Transport> HostileTransport<T> {
    /// `inner`'s device, lying.
    pub fn new(inner: T, lie: Lie) -> Self {
        HostileTransport {
            inner,
            lie,
            decoder: FrameDecoder::new(),
            commands: FrameDecoder::new(),
            frame_out: Vec::new(),
            held: VecDeque::new(),
            last_release: None,
            out: VecDeque::new(),
            first_sweep: None,
            previous: None,
            readings: 0,
            last_progress: None,
            broken: false,
        }
    }

    fn flooding(&self) -> bool {
        matches!(self.lie, Lie::FloodPong | Lie::FloodProgress) && self.readings >= 2
    }

    fn encode(ev: &Event) -> Vec<u8> {
        let mut frame = [0u8; MAX_FRAME_LEN];
        let len = frame::encode(ev, &mut frame).expect("events fit a frame");
        frame[..len].to_vec()
    }

    /// Queues `ev` for the host, held back as the lie says.
    fn queue(&mut self, ev: &Event) {
        let now = Instant::now();
        let at = match (self.lie, ev) {
            (Lie::Slow, Event::Pong(_)) => {
                // Answered at once, ahead of the readings held back.
                self.out.extend(Self::encode(ev));
                return;
            }
            (Lie::Slow, _) => {
                let base = self.last_release.map_or(now, |t| t.max(now));
                let at = if matches!(ev, Event::Reading(_)) {
                    base + SLOW_READING
                } else {
                    base
                };
                self.last_release = Some(at);
                at
            }
            _ => now,
        };
        self.held.push_back((at, Self::encode(ev)));
    }

    fn in_first_sweep(&mut self, sweep_id: u32) -> bool {
        *self.first_sweep.get_or_insert(sweep_id) == sweep_id
    }

    fn rewrite(&mut self, ev: Event) -> Vec<Event> {
        if let Event::Progress(p) = &ev {
            self.last_progress = Some(*p);
        }
        if self.flooding()
            || (self.lie == Lie::Stall && self.readings >= 2 && !matches!(ev, Event::Pong(_)))
        {
            return Vec::new();
        }
        if let Event::Reading(_) = ev {
            self.readings += 1;
        }
        match (self.lie, ev) {
            (Lie::Values, Event::Reading(mut r)) if self.in_first_sweep(r.sweep_id) => {
                match r.seq % 4 {
                    0 => r.value = f32::NAN,
                    1 => r.std = -1.0,
                    2 => r.value = f32::INFINITY,
                    _ => {}
                }
                vec![Event::Reading(r)]
            }
            (Lie::Magnitudes, Event::Reading(mut r)) if self.in_first_sweep(r.sweep_id) => {
                match r.seq {
                    5 => r.value = 1e-35,
                    9 => r.value = 3e38,
                    _ => {}
                }
                vec![Event::Reading(r)]
            }
            (Lie::Angles, Event::Reading(mut r)) if self.in_first_sweep(r.sweep_id) => {
                match r.seq % 4 {
                    0 => r.theta_i = 1000.0,
                    1 => r.theta_r = -1e30,
                    2 => r.theta_r += 7.0,
                    _ => {}
                }
                vec![Event::Reading(r)]
            }
            (Lie::HugeSeq, Event::Reading(r)) if self.in_first_sweep(r.sweep_id) && r.seq == 0 => {
                let mut max = r;
                max.seq = u32::MAX;
                let mut jump = r;
                jump.seq = 100_000_000;
                vec![Event::Reading(max), Event::Reading(jump), Event::Reading(r)]
            }
            (Lie::HugeSeq, Event::SweepDone(mut d)) => {
                d.count = u32::MAX;
                d.next_seq = u32::MAX;
                vec![Event::SweepDone(d)]
            }
            (Lie::Total, Event::Progress(mut p)) => {
                p.total += 2;
                vec![Event::Progress(p)]
            }
            (Lie::Shifted, Event::Reading(mut r)) => {
                let here = (r.theta_i, r.theta_r);
                if let Some((i, t)) = self.previous {
                    r.theta_i = i;
                    r.theta_r = t;
                }
                self.previous = Some(here);
                vec![Event::Reading(r)]
            }
            (Lie::Board, Event::Info(mut info)) => {
                info.board = heapless::String::try_from("x\n0,0,1\nZ").expect("fits");
                vec![Event::Info(info)]
            }
            (Lie::ErrorText, Event::Reading(r)) if r.seq == 3 => vec![
                Event::Reading(r),
                Event::Error(ErrorEvent {
                    code: ErrorCode::DetectorFault,
                    detail: heapless::String::try_from("\u{1b}[31mred\nline").expect("fits"),
                }),
            ],
            (_, ev) => vec![ev],
        }
    }
}

impl<T: Transport> Transport for HostileTransport<T> {
    fn close(&mut self) {
        self.inner.close();
    }

    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        if self.broken {
            return Err(io::ErrorKind::BrokenPipe.into());
        }
        if !matches!(self.lie, Lie::IgnoreStart | Lie::DropOnStart) {
            return self.inner.send(bytes);
        }
        for &b in bytes {
            self.frame_out.push(b);
            let decoded = self.commands.push::<Command>(b);
            if b != 0 {
                continue;
            }
            let frame = std::mem::take(&mut self.frame_out);
            match decoded {
                Some(Ok(Command::StartSweep(_))) if self.lie == Lie::IgnoreStart => {}
                Some(Ok(Command::StartSweep(_))) => {
                    self.broken = true;
                    return Err(io::ErrorKind::BrokenPipe.into());
                }
                _ => self.inner.send(&frame)?,
            }
        }
        // Bytes of an unfinished frame wait for its end.
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if self.broken {
            return Err(io::ErrorKind::BrokenPipe.into());
        }
        let deadline = Instant::now() + timeout;
        loop {
            let now = Instant::now();
            while self.held.front().is_some_and(|(at, _)| *at <= now) {
                let (_, f) = self.held.pop_front().expect("front exists");
                self.out.extend(f);
            }
            if self.out.is_empty() && self.flooding() {
                let ev = match (self.lie, self.last_progress) {
                    (Lie::FloodProgress, Some(p)) => Event::Progress(p),
                    _ => Event::Pong(0xF100D),
                };
                for _ in 0..20 {
                    self.out.extend(Self::encode(&ev));
                }
            }
            if !self.out.is_empty() {
                let n = buf.len().min(self.out.len());
                for (b, x) in buf.iter_mut().zip(self.out.drain(..n)) {
                    *b = x;
                }
                return Ok(n);
            }
            if now >= deadline {
                return Ok(0);
            }
            let mut tmp = [0u8; 1024];
            let slice = deadline
                .saturating_duration_since(now)
                .min(Duration::from_millis(5));
            let n = self.inner.recv(&mut tmp, slice)?;
            for &b in &tmp[..n] {
                if let Some(Ok(ev)) = self.decoder.push::<Event>(b) {
                    for ev in self.rewrite(ev) {
                        self.queue(&ev);
                    }
                }
            }
        }
    }
}

/// Connects to an in-process simulated device that lies: once, or (for
/// [`Lie::DropOnStart`]) again and again, each time to a fresh device.
pub struct HostileConnector {
    cfg: SimConfig,
    lie: Lie,
    /// Connections made so far.
    pub connections: u32,
}

impl HostileConnector {
    /// A device measuring as `cfg` says, lying as `lie` says.
    pub fn new(cfg: SimConfig, lie: Lie) -> Self {
        HostileConnector {
            cfg,
            lie,
            connections: 0,
        }
    }
}

impl Connector for HostileConnector {
    type T = HostileTransport<InProcessDevice>;

    fn connect(&mut self) -> Result<FramedLink<Self::T>, LinkError> {
        if self.connections > 0 && !self.can_reconnect() {
            return Err(LinkError::Timeout("the hostile device is gone"));
        }
        self.connections += 1;
        Ok(FramedLink::new(HostileTransport::new(
            InProcessDevice::new(&self.cfg),
            self.lie,
        )))
    }

    fn can_reconnect(&self) -> bool {
        self.lie == Lie::DropOnStart
    }
}
