//! The service loop every board runs (firmware boards and the host's simulated
//! devices): bytes from the link into the controller, ticks when the controller asks,
//! frames from the controller back out, never blocking on the link.

use embedded_hal::digital::OutputPin;

use crate::axis::{AxisPins, Tick};
use crate::controller::{Controller, Detector};
use crate::frame::MAX_FRAME_LEN;

/// A byte link to the host that never blocks.
pub trait Link {
    /// Lets the link do its housekeeping (USB polling); called every iteration.
    fn poll(&mut self) {}
    /// Reads the bytes available now into `buf`; returns how many (0 if none).
    fn read(&mut self, buf: &mut [u8]) -> usize;
    /// Writes what the link takes now from `bytes`; returns how many.
    fn write(&mut self, bytes: &[u8]) -> usize;
}

/// The controller plus the frame being sent.
pub struct Service<S, D, L, DET> {
    /// The controller.
    pub ctrl: Controller<S, D, L, DET>,
    tx: [u8; MAX_FRAME_LEN],
    tx_len: usize,
    tx_off: usize,
    next_tick: Option<u64>,
}

impl<S: AxisPins, D: AxisPins, L: OutputPin, DET: Detector> Service<S, D, L, DET> {
    /// Wraps a controller.
    pub fn new(ctrl: Controller<S, D, L, DET>) -> Self {
        Service {
            ctrl,
            tx: [0; MAX_FRAME_LEN],
            tx_len: 0,
            tx_off: 0,
            next_tick: None,
        }
    }

    /// One iteration at time `now_us`. Returns when the controller next wants a tick
    /// (`None`: only after new input), so a board can sleep or, with simulated time,
    /// jump its clock there.
    pub fn poll<K: Link>(&mut self, link: &mut K, now_us: u64) -> Option<u64> {
        link.poll();
        let mut rx = [0u8; 64];
        loop {
            let n = link.read(&mut rx);
            if n == 0 {
                break;
            }
            self.ctrl.receive(&rx[..n], now_us);
            // A command may have started work.
            self.next_tick = Some(self.next_tick.map_or(now_us, |t| t.min(now_us)));
        }
        if self.next_tick.is_some_and(|t| t <= now_us) {
            self.next_tick = match self.ctrl.tick(now_us) {
                Tick::Wait(us) => Some(now_us + us as u64),
                Tick::Idle => None,
            };
        }
        self.flush(link);
        self.next_tick
    }

    /// True while a frame is only partly sent.
    pub fn sending(&self) -> bool {
        self.tx_off < self.tx_len
    }

    fn flush<K: Link>(&mut self, link: &mut K) {
        loop {
            if self.tx_off == self.tx_len {
                match self.ctrl.next_frame(&mut self.tx) {
                    Some(n) => {
                        self.tx_len = n;
                        self.tx_off = 0;
                    }
                    None => return,
                }
            }
            let n = link.write(&self.tx[self.tx_off..self.tx_len]);
            if n == 0 {
                return;
            }
            self.tx_off += n;
        }
    }
}
