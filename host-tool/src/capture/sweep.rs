//! The state of one device sweep while it runs, and what each event from the device
//! means for it: which readings are ours, how many were lost on the way (the gap
//! accounting), when the sweep is over. No link here: the capture loop does the I/O and
//! asks this type what to do, so the rules are unit-tested on events alone.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use brdf_core::protocol::{ErrorCode, Event, Reading, SweepPlan};

use super::connect::DEVICE_TEXT_MAX;
use super::plan::DeviceSweep;

/// How long to listen after a SweepDone for readings that come late.
pub(super) const LINGER: Duration = Duration::from_millis(200);

/// How long to wait for the device's answer to a Ctrl-C Abort.
const ABORT_ANSWER: Duration = Duration::from_secs(5);

/// Times a StartSweep is sent again after a corrupted or refused command.
const MAX_RESTARTS: u32 = 10;

/// How a device sweep ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Outcome {
    /// Over: every reading that arrived is recorded; the next round measures the rest.
    Done,
    /// Stopped by the user (Ctrl-C).
    Interrupted,
    /// The link broke or the device stopped answering (why).
    Lost(String),
}

/// What the capture loop does after an event.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Step {
    /// Nothing more (an event of another sweep, progress, a late reading's sweep done...).
    Wait,
    /// Record this reading of ours in the file.
    Record(Reading),
    /// The reading of ours with this device `seq` (it follows) is clipped: this many
    /// detector conversions were at full scale.
    Saturated {
        /// The device's `seq` of the reading.
        seq: u32,
        /// Conversions at full scale.
        conversions: u32,
    },
    /// The sweep is over.
    End(Outcome),
    /// A reading of ours that cannot be placed (a seq outside the sweep): counted as
    /// rejected, not written (why, one line).
    Reject(String),
    /// The device's plan is not the plan gonio sent (why, one line): the capture stops.
    OtherPlan(String),
    /// The device was still running our sweep when it was stopped for making no
    /// progress: alive, but stalled; the capture gives up.
    Stalled,
    /// Send [`SweepState::plan`] again, after an Abort when `abort_first` (the device was
    /// busy: the plan already carries a fresh sweep id).
    Restart {
        /// Stop what the device is doing first.
        abort_first: bool,
    },
    /// The sweep failed: the capture stops with this message; with `mark_failed` the
    /// file's status line says `failed`.
    Fail {
        /// One line for the user.
        why: String,
        /// Whether the capture marks the file failed before stopping.
        mark_failed: bool,
    },
}

/// Device sequence numbers of one sweep: the next one expected, and those skipped so
/// far (lost, unless they still come late). Every change returns the change in the
/// capture's `gaps` counter (readings the device sent that never arrived).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(super) struct Sequence {
    /// The next device `seq` expected.
    pub expected: u32,
    /// Sequence numbers skipped and not (yet) arrived late.
    pub skipped: BTreeSet<u32>,
}

impl Sequence {
    /// Starting at `first` (the plan's `skip`).
    pub fn starting_at(first: u32) -> Self {
        Sequence {
            expected: first,
            skipped: BTreeSet::new(),
        }
    }

    /// A reading `seq` arrived: a jump counts the skipped ones as gaps, a late one
    /// takes its gap back.
    pub fn arrived(&mut self, seq: u32) -> i64 {
        let change = if seq > self.expected {
            self.sent_before(seq)
        } else if self.skipped.remove(&seq) {
            -1
        } else {
            0
        };
        self.expected = self.expected.max(seq + 1);
        change
    }

    /// The device says it sent every reading before `next`: those not arrived are gaps.
    pub fn sent_before(&mut self, next: u32) -> i64 {
        if next <= self.expected {
            return 0;
        }
        let lost = next - self.expected;
        self.skipped.extend(self.expected..next);
        self.expected = next;
        i64::from(lost)
    }
}

/// One device sweep as the host follows it.
#[derive(Debug, Clone)]
pub(super) struct SweepState {
    /// The plan as last sent; its sweep id changes when a busy device is restarted.
    pub plan: SweepPlan,
    /// Every sweep id this sweep was started under: readings of an aborted start that
    /// were already on their way are still readings of these points.
    ids: Vec<u32>,
    /// Device sequence numbers seen and skipped.
    pub seq: Sequence,
    /// The device's `seq` after the last reading of this sweep; also the plan length
    /// the device's Progress must report.
    pub end_seq: u32,
    /// The device has started this sweep (a reading or progress of it arrived).
    pub started: bool,
    /// StartSweep re-sent this many times after corrupted or refused commands.
    pub restarts: u32,
    /// When the user asked to stop (Ctrl-C) and Abort was sent.
    pub abort_sent_at: Option<Instant>,
    /// Abort sent because the device made no progress for longer than a point may
    /// take: a SweepDone (aborted) means it was stalled, a Status that it had finished.
    pub stop_sent: bool,
    /// `SetLaser(false)` sent to a silent device that answers Ping, to learn whether it
    /// still runs our sweep (answered `Busy`) or finished it and its SweepDone was lost
    /// (answered `Status`; the laser is off after a sweep anyway).
    pub probe_sent: bool,
    /// When the device's SweepDone arrived; readings may still come late for [`LINGER`].
    pub done_at: Option<Instant>,
}

impl SweepState {
    /// A sweep about to be started with `sw.plan`.
    pub fn new(sw: &DeviceSweep) -> Self {
        let skip = u32::from(sw.plan.skip);
        SweepState {
            plan: sw.plan.clone(),
            ids: vec![sw.plan.sweep_id],
            seq: Sequence::starting_at(skip),
            end_seq: skip + sw.map.len() as u32,
            started: false,
            restarts: 0,
            abort_sent_at: None,
            stop_sent: false,
            probe_sent: false,
            done_at: None,
        }
    }

    /// How long to wait for the next event: a short linger once the SweepDone came.
    pub fn recv_timeout(&self) -> Duration {
        if self.done_at.is_some() {
            LINGER
        } else {
            Duration::from_millis(200)
        }
    }

    /// Whether the sweep is over by time alone at `now`: the Abort went unanswered, or
    /// the linger after SweepDone is over (at once when nothing is missing).
    pub fn over_at(&self, now: Instant) -> Option<Outcome> {
        if self
            .abort_sent_at
            .is_some_and(|t| now.duration_since(t) > ABORT_ANSWER)
        {
            return Some(Outcome::Interrupted);
        }
        if self
            .done_at
            .is_some_and(|t| self.seq.skipped.is_empty() || now.duration_since(t) >= LINGER)
        {
            return Some(Outcome::Done);
        }
        None
    }

    /// What `ev` means for this sweep. `gaps` is the capture's counter of readings
    /// lost on the way; `next_id` numbers a restart's fresh sweep id.
    pub fn on_event(&mut self, ev: Event, gaps: &mut u64, next_id: &mut u32, now: Instant) -> Step {
        let mut count = |change: i64| *gaps = gaps.saturating_add_signed(change);
        let id = self.plan.sweep_id;
        match ev {
            Event::Reading(r) if self.ids.contains(&r.sweep_id) => {
                self.started = true;
                // Memory follows the plan, never a seq the device sends.
                if r.seq < u32::from(self.plan.skip) || r.seq >= self.end_seq {
                    return Step::Reject(format!(
                        "reading seq {} is outside the sweep's {}..{}",
                        r.seq, self.plan.skip, self.end_seq
                    ));
                }
                count(self.seq.arrived(r.seq));
                Step::Record(r)
            }
            Event::Saturated(s) if self.ids.contains(&s.sweep_id) => Step::Saturated {
                seq: s.seq,
                conversions: s.conversions,
            },
            Event::Progress(p) if p.sweep_id == id => {
                self.started = true;
                if p.total != self.end_seq {
                    return Step::OtherPlan(format!(
                        "the device's Progress counts {} readings in the plan, gonio's plan for this sweep has {}",
                        p.total, self.end_seq
                    ));
                }
                // `done` counts the skipped points: a sweep starts at `skip` (a device
                // that counts from 0 ignores the resume) and never runs past the plan.
                // (Not `done == skip` on the first one seen: the start's Progress may
                // be lost on a noisy link and the next incidence's arrive first.)
                let skip = u32::from(self.plan.skip);
                if p.done < skip || p.done > p.total {
                    return Step::OtherPlan(format!(
                        "the device's Progress says {} of {} readings done, gonio's plan for this sweep starts at {} (skip)",
                        p.done, p.total, skip
                    ));
                }
                Step::Wait
            }
            Event::Status(_) if self.stop_sent || self.probe_sent => {
                // The device had finished: the readings after the last one that
                // arrived were all sent and lost.
                count(self.seq.sent_before(self.end_seq));
                Step::End(Outcome::Done)
            }
            Event::SweepDone(d) if d.sweep_id == id => {
                count(self.seq.sent_before(d.next_seq.min(self.end_seq)));
                if self.abort_sent_at.is_some() {
                    Step::End(Outcome::Interrupted)
                } else if self.stop_sent && d.aborted {
                    Step::Stalled
                } else if self.stop_sent {
                    Step::End(Outcome::Done)
                } else if d.aborted {
                    Step::Fail {
                        why: "the device aborted the sweep".into(),
                        mark_failed: false,
                    }
                } else {
                    // Readings still missing may yet come late (reordered on the way):
                    // listen a little longer before the next round re-measures them.
                    self.done_at = Some(now);
                    Step::Wait
                }
            }
            Event::Error(e) if !self.started => match e.code {
                // Our StartSweep (or another command: these errors do not say which)
                // was corrupted on the way, or the device is still busy with
                // something: try again, up to MAX_RESTARTS times on a noisy link.
                ErrorCode::CorruptFrame | ErrorCode::UnknownCommand | ErrorCode::Busy
                    if self.restarts < MAX_RESTARTS =>
                {
                    self.restarts += 1;
                    let busy = e.code == ErrorCode::Busy;
                    if busy {
                        // The aborted run's SweepDone must not end the new one.
                        self.plan.sweep_id = *next_id;
                        *next_id += 1;
                        self.ids.push(self.plan.sweep_id);
                    }
                    Step::Restart { abort_first: busy }
                }
                ErrorCode::CorruptFrame | ErrorCode::UnknownCommand => Step::Fail {
                    why: format!(
                        "the link corrupted the sweep command {} times in a row ({}); check the cable, then continue with --resume",
                        self.restarts,
                        crate::text::escape_line(&e.detail, DEVICE_TEXT_MAX)
                    ),
                    mark_failed: true,
                },
                _ => Step::Fail {
                    why: format!(
                        "device refused the sweep: {}",
                        crate::text::escape_line(&e.detail, DEVICE_TEXT_MAX)
                    ),
                    mark_failed: true,
                },
            },
            Event::Error(e)
                if matches!(
                    e.code,
                    ErrorCode::DetectorFault
                        | ErrorCode::HomingFailed
                        | ErrorCode::OutOfLimits
                        | ErrorCode::LimitSwitch
                ) =>
            {
                Step::Fail {
                    why: format!(
                        "device error during the sweep: {}",
                        crate::text::escape_line(&e.detail, DEVICE_TEXT_MAX)
                    ),
                    mark_failed: true,
                }
            }
            // Errors about frames we sent during the sweep (a corrupted Ping) and
            // events of other sweeps are not this sweep's business.
            _ => Step::Wait,
        }
    }
}

#[cfg(test)]
#[path = "sweep_tests.rs"]
mod tests;
