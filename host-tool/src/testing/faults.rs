//! Link fault injection: a [`Transport`] wrapper that damages the byte stream at set rates with a deterministic seed.
//!
//! Device to host, frame by frame (split at 0x00): bit flips, dropped bytes, truncated,
//! duplicated and reordered frames, stalls (nothing arrives for a while) and a
//! disconnect after a number of frames. Host to device: bit flips in commands. It keeps
//! a ledger ([`FaultStats`]) of every reading the device sent and of every reading that
//! reached the host intact, so a test can prove that nothing intact was lost and that
//! everything lost was reported. Works around any transport: the in-process simulated
//! device, or a serial port to the firmware in QEMU.

use std::collections::{BTreeSet, VecDeque};
use std::io;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use brdf_core::frame::{FrameDecoder, MAX_FRAME_LEN};
use brdf_core::protocol::{Event, Reading};
use brdf_core::sim::XorShift32;

use crate::device::Transport;

/// How often each fault happens. Byte rates are per byte, frame rates per frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FaultRates {
    /// Probability that a received byte has one bit flipped.
    pub bit_flip: f64,
    /// Probability that a received byte is lost.
    pub drop_byte: f64,
    /// Probability that a frame arrives twice.
    pub duplicate: f64,
    /// Probability that a frame is held back and arrives after the next one.
    pub reorder: f64,
    /// Probability that a frame is cut short (its delimiter still arrives).
    pub truncate: f64,
    /// Probability that the link goes quiet before a frame.
    pub stall: f64,
    /// How long a stall lasts.
    pub stall_for: Duration,
    /// The link breaks (every call fails) after this many frames from the device.
    pub disconnect_after: Option<u64>,
    /// Probability that a byte sent to the device has one bit flipped.
    pub host_bit_flip: f64,
}

/// What the injector did and what got through, shared between connections.
#[derive(Debug, Clone, Default)]
pub struct FaultStats {
    /// Frames the device sent.
    pub frames: u64,
    /// Bits flipped in received bytes.
    pub flipped: u64,
    /// Received bytes dropped.
    pub dropped_bytes: u64,
    /// Frames duplicated.
    pub duplicated: u64,
    /// Frames reordered.
    pub reordered: u64,
    /// Frames truncated.
    pub truncated: u64,
    /// Stalls.
    pub stalls: u64,
    /// Disconnects.
    pub disconnects: u64,
    /// Bits flipped in bytes sent to the device.
    pub host_flipped: u64,
    /// `(sweep_id, seq)` of every reading the device sent.
    pub sent: BTreeSet<(u32, u32)>,
    /// `(sweep_id, seq)` of every reading that reached the host intact.
    pub intact: BTreeSet<(u32, u32)>,
    /// Every intact reading, in order of arrival (duplicates included).
    pub intact_readings: Vec<Reading>,
}

impl FaultStats {
    /// Readings the device sent that never reached the host intact.
    pub fn lost(&self) -> BTreeSet<(u32, u32)> {
        self.sent.difference(&self.intact).copied().collect()
    }
}

/// Fault draws from the workspace's one generator, brdf-core's xorshift32.
#[derive(Debug, Clone, Copy)]
pub struct Draws(XorShift32);

impl Draws {
    /// Seeds it (scrambled, so that small seeds do not start with small draws).
    pub fn new(seed: u64) -> Self {
        let folded = (seed ^ (seed >> 32)) as u32;
        Draws(XorShift32::new(
            folded.wrapping_mul(0x9E37_79B9) ^ 0x5851_F42D,
        ))
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && f64::from(self.0.uniform()) < p
    }

    /// Uniform in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        ((f64::from(self.0.uniform()) * n as f64) as usize).min(n - 1)
    }
}

/// A transport that damages what passes through it (see the module documentation).
pub struct FaultyTransport<T> {
    inner: T,
    rates: FaultRates,
    rng: Draws,
    /// Bytes of the device's current, unfinished frame.
    partial: Vec<u8>,
    /// Damaged bytes ready for the host.
    out: VecDeque<u8>,
    /// A frame held back to arrive after the next one.
    held: Option<Vec<u8>>,
    stall_until: Option<Instant>,
    frames: u64,
    dead: bool,
    /// Decodes the device's undamaged stream (what it sent).
    original: FrameDecoder<MAX_FRAME_LEN>,
    /// Decodes the damaged stream (what the host gets).
    delivered: FrameDecoder<MAX_FRAME_LEN>,
    stats: Arc<Mutex<FaultStats>>,
}

fn broken() -> io::Error {
    io::Error::new(
        io::ErrorKind::BrokenPipe,
        "fault injection: link disconnected",
    )
}

impl<T: Transport> FaultyTransport<T> {
    /// Wraps `inner`; faults are drawn from `seed`, the ledger goes to `stats`.
    pub fn new(inner: T, rates: FaultRates, seed: u64, stats: Arc<Mutex<FaultStats>>) -> Self {
        FaultyTransport {
            inner,
            rates,
            rng: Draws::new(seed),
            partial: Vec::new(),
            out: VecDeque::new(),
            held: None,
            stall_until: None,
            frames: 0,
            dead: false,
            original: FrameDecoder::new(),
            delivered: FrameDecoder::new(),
            stats,
        }
    }

    /// The wrapped transport.
    pub fn inner(&mut self) -> &mut T {
        &mut self.inner
    }

    fn frame(&mut self, mut f: Vec<u8>) {
        let mut st = self.stats.lock().expect("fault stats");
        st.frames += 1;
        for &b in &f {
            if let Some(Ok(Event::Reading(r))) = self.original.push::<Event>(b) {
                st.sent.insert((r.sweep_id, r.seq));
            }
        }
        self.frames += 1;
        if self.rates.disconnect_after.is_some_and(|n| self.frames > n) {
            st.disconnects += 1;
            self.dead = true;
            return;
        }
        let r = self.rates;
        if self.rng.chance(r.stall) {
            st.stalls += 1;
            self.stall_until = Some(Instant::now() + r.stall_for);
        }
        if f.len() > 1 && self.rng.chance(r.truncate) {
            st.truncated += 1;
            let keep = self.rng.below(f.len() - 1);
            f.truncate(keep);
            f.push(0);
        }
        if r.bit_flip > 0.0 {
            for b in f.iter_mut() {
                if self.rng.chance(r.bit_flip) {
                    *b ^= 1 << self.rng.below(8);
                    st.flipped += 1;
                }
            }
        }
        if r.drop_byte > 0.0 {
            let before = f.len();
            f.retain(|_| !self.rng.chance(r.drop_byte));
            st.dropped_bytes += (before - f.len()) as u64;
        }
        let dup = self.rng.chance(r.duplicate);
        if self.held.is_none() && self.rng.chance(r.reorder) {
            st.reordered += 1;
            self.held = Some(f);
            return;
        }
        self.out.extend(&f);
        if dup {
            st.duplicated += 1;
            self.out.extend(&f);
        }
        if let Some(h) = self.held.take() {
            self.out.extend(h);
        }
    }
}

impl<T: Transport> Transport for FaultyTransport<T> {
    fn close(&mut self) {
        self.inner.close();
    }

    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        if self.dead {
            return Err(broken());
        }
        if self.rates.host_bit_flip > 0.0 {
            let mut b = bytes.to_vec();
            let mut flipped = 0;
            for x in b.iter_mut() {
                if self.rng.chance(self.rates.host_bit_flip) {
                    *x ^= 1 << self.rng.below(8);
                    flipped += 1;
                }
            }
            self.stats.lock().expect("fault stats").host_flipped += flipped;
            return self.inner.send(&b);
        }
        self.inner.send(bytes)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if self.dead {
            return Err(broken());
        }
        if let Some(t) = self.stall_until {
            let now = Instant::now();
            if now < t {
                std::thread::sleep(timeout.min(t - now));
                return Ok(0);
            }
            self.stall_until = None;
        }
        if self.out.is_empty() {
            let mut tmp = [0u8; 4096];
            let n = self.inner.recv(&mut tmp, timeout)?;
            for &b in &tmp[..n] {
                self.partial.push(b);
                if b == 0 {
                    let f = std::mem::take(&mut self.partial);
                    self.frame(f);
                    if self.dead {
                        return Err(broken());
                    }
                }
            }
            if n == 0 {
                // Nothing more from the device for now: a held frame goes out late.
                if let Some(h) = self.held.take() {
                    self.out.extend(h);
                }
            }
            if self.stall_until.is_some() {
                return Ok(0);
            }
        }
        let n = buf.len().min(self.out.len());
        let mut st = self.stats.lock().expect("fault stats");
        for (slot, b) in buf.iter_mut().zip(self.out.drain(..n)) {
            *slot = b;
            if let Some(Ok(Event::Reading(r))) = self.delivered.push::<Event>(b) {
                st.intact.insert((r.sweep_id, r.seq));
                st.intact_readings.push(r);
            }
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A transport that yields fixed bytes once.
    struct Canned(Vec<u8>);

    impl Transport for Canned {
        fn send(&mut self, _: &[u8]) -> io::Result<()> {
            Ok(())
        }
        fn recv(&mut self, buf: &mut [u8], _: Duration) -> io::Result<usize> {
            let n = buf.len().min(self.0.len());
            buf[..n].copy_from_slice(&self.0[..n]);
            self.0.drain(..n);
            Ok(n)
        }
    }

    #[test]
    fn no_faults_pass_everything_through() {
        let mut bytes = Vec::new();
        let mut buf = [0u8; 64];
        for seq in 0..5 {
            let r = Reading {
                sweep_id: 1,
                seq,
                theta_i: 0.0,
                theta_r: 0.0,
                value: 1.0,
                std: 0.0,
                n: 1,
                t_ms: 0,
            };
            let n = brdf_core::frame::encode(&Event::Reading(r), &mut buf).unwrap();
            bytes.extend(&buf[..n]);
        }
        let stats = Arc::new(Mutex::new(FaultStats::default()));
        let mut t = FaultyTransport::new(
            Canned(bytes.clone()),
            FaultRates::default(),
            1,
            stats.clone(),
        );
        let mut got: Vec<u8> = Vec::new();
        let mut rx = [0u8; 4096];
        for _ in 0..3 {
            let n = t.recv(&mut rx, Duration::ZERO).unwrap();
            got.extend(&rx[..n]);
        }
        assert_eq!(got, bytes);
        let st = stats.lock().unwrap();
        assert_eq!((st.frames, st.sent.len(), st.intact.len()), (5, 5, 5));
        assert!(st.lost().is_empty());
    }
}
