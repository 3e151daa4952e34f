//! A hostile device: wraps a device's transport and rewrites what the device says, one
//! [`Lie`] per failure a capture must survive (bad values, wild angles, a seq or count
//! that would drive allocation, another plan, control characters in its text). Lies
//! are told in the first sweep only, so a capture that rejects them and measures again
//! can finish.

use std::collections::VecDeque;
use std::io;
use std::time::Duration;

use brdf_core::frame::{self, FrameDecoder, MAX_FRAME_LEN};
use brdf_core::protocol::{ErrorCode, ErrorEvent, Event};

use crate::device::{Connector, FramedLink, InProcessDevice, LinkError, Transport};

/// What the hostile device lies about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lie {
    /// brdf NaN or infinite, std NaN or negative, on every other reading.
    Values,
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
}

/// A transport whose device lies as its [`Lie`] says.
pub struct HostileTransport<T> {
    inner: T,
    lie: Lie,
    decoder: FrameDecoder<MAX_FRAME_LEN>,
    out: VecDeque<u8>,
    first_sweep: Option<u32>,
    previous: Option<(f32, f32)>,
}

impl<T: Transport> HostileTransport<T> {
    /// `inner`'s device, lying.
    pub fn new(inner: T, lie: Lie) -> Self {
        HostileTransport {
            inner,
            lie,
            decoder: FrameDecoder::new(),
            out: VecDeque::new(),
            first_sweep: None,
            previous: None,
        }
    }

    fn in_first_sweep(&mut self, sweep_id: u32) -> bool {
        *self.first_sweep.get_or_insert(sweep_id) == sweep_id
    }

    fn rewrite(&mut self, ev: Event) -> Vec<Event> {
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
        self.inner.send(bytes)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if self.out.is_empty() {
            let mut tmp = [0u8; 1024];
            let n = self.inner.recv(&mut tmp, timeout)?;
            for &b in &tmp[..n] {
                if let Some(Ok(ev)) = self.decoder.push::<Event>(b) {
                    for ev in self.rewrite(ev) {
                        let mut frame = [0u8; MAX_FRAME_LEN];
                        let len = frame::encode(&ev, &mut frame).expect("events fit a frame");
                        self.out.extend(&frame[..len]);
                    }
                }
            }
        }
        let n = buf.len().min(self.out.len());
        for (b, x) in buf.iter_mut().zip(self.out.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}

/// Connects once to an in-process simulated device that lies.
pub struct HostileConnector(Option<HostileTransport<InProcessDevice>>);

impl HostileConnector {
    /// `device`, lying as `lie` says.
    pub fn new(device: InProcessDevice, lie: Lie) -> Self {
        HostileConnector(Some(HostileTransport::new(device, lie)))
    }
}

impl Connector for HostileConnector {
    type T = HostileTransport<InProcessDevice>;

    fn connect(&mut self) -> Result<FramedLink<Self::T>, LinkError> {
        self.0
            .take()
            .map(FramedLink::new)
            .ok_or(LinkError::Timeout("the hostile device is gone"))
    }

    fn can_reconnect(&self) -> bool {
        false
    }
}
