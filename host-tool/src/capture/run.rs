//! [`capture`]: a plan run on a device, round after round until every point has a
//! reading: each device sweep followed (liveness apart from progress), every reading
//! checked and written as it arrives, a lost device waited for and reconnected.

use std::collections::{BTreeSet, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use brdf_core::protocol::{Command, DeviceStatus, Event, Reading};

use super::check::{self, Tolerance};
use super::connect::{HomingError, check_raw, device_line, prepare, rehome, restarted};
use super::error::{CaptureError, Result};
use super::liveness;
use super::plan::{DeviceSweep, HostPlan, PlanError};
use super::progress::ProgressSink;
use super::setup::{CaptureReport, CaptureSetup};
use super::sweep::{Outcome, Step, SweepState};
use super::watch::Watch;
use crate::device::{Connector, FramedLink, LinkError};
use crate::sweep_file::{
    Header, Row, SATURATED_PREFIX, SweepFileError, SweepStatus, SweepWriter, row_problem,
};

/// One capture in progress: the plan, the file being written and what it holds.
struct Run<'a, C: Connector> {
    conn: &'a mut C,
    setup: &'a CaptureSetup,
    plan: HostPlan,
    writer: SweepWriter,
    present: BTreeSet<u32>,
    progress: &'a mut dyn ProgressSink,
    interrupt: &'a AtomicBool,
    next_id: u32,
    reconnects: u32,
    dropped_before: u64,
    tol: Tolerance,
    /// The device's `Info.max_points`: no plan sent is longer.
    max_points: u16,
    /// The online fit and the `--until` targets.
    watch: Watch,
    /// A sequential plan's readings budget (its rounds measure one batch each).
    sequential: Option<usize>,
    /// A restart of the device, to be written before the next reading.
    restart_note: Option<String>,
    /// Readings of the running device sweep flagged saturated (device seq ->
    /// conversions at full scale), written as a warning before their row.
    saturated: std::collections::BTreeMap<u32, u32>,
}

/// How long the Abort sent to a stalled device may go unanswered.
const STOP_ANSWER: Duration = Duration::from_secs(5);

/// Rejected readings described on the terminal; later ones are only counted.
const REJECTS_SHOWN: u64 = 5;

/// The f64 nearest to an f32's shortest decimal form: the file then shows
/// `10102.495`, not `10102.4951171875`, and parsing it as f32 gives the device's value.
fn shortest(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(x as f64)
}

/// Makes and removes a private file beside `out`, so that a directory gonio cannot
/// write (read-only, a read-only mount, /proc) is found before the device is touched
/// (handshake, homing), not when the file is created after them.
fn probe_writable(out: &std::path::Path) -> Result<(), SweepFileError> {
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => std::path::Path::new("."),
    };
    tempfile::Builder::new()
        .prefix(".gonio-probe")
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| {
            SweepFileError::Invalid(format!(
                "cannot write {}: cannot create a file in {}: {e} (choose a directory you can write to)",
                out.display(),
                dir.display()
            ))
        })
}

/// Runs a capture. Returns the report; the caller turns an incomplete one into an
/// exit status. Bad input (a plan outside the device's travel, an existing file without
/// `--force`) is an error before anything is measured.
pub fn capture<C: Connector>(
    conn: &mut C,
    setup: &CaptureSetup,
    progress: &mut dyn ProgressSink,
    interrupt: &AtomicBool,
) -> Result<CaptureReport> {
    // Every output is checked (and a resumed file locked) before the device is touched.
    let resumed = if setup.resume {
        let (writer, data) = SweepWriter::resume(&setup.out)?;
        check::check_recorded(&data.rows, &data.points).map_err(|m| {
            SweepFileError::Invalid(format!(
                "{}: {m}: the file mixes two plans or was edited; cannot resume it",
                setup.out.display()
            ))
        })?;
        Some((writer, data))
    } else {
        SweepWriter::check_new(&setup.out, setup.force)?;
        probe_writable(&setup.out)?;
        None
    };
    if let Some(raw) = &setup.raw {
        check_raw(raw, &setup.out)?;
    }
    let prepared = prepare(conn, setup)?;
    let (mut link, info) = (prepared.link, prepared.info);
    let (writer, plan, present) = if let Some((writer, data)) = resumed {
        let plan = HostPlan::from_recorded(
            data.meta
                .get("plan")
                .map(String::as_str)
                .unwrap_or("recorded"),
            &data.points,
            data.meta.get("settings").map(String::as_str).unwrap_or(""),
        )?;
        let present: BTreeSet<u32> = data.rows.iter().filter_map(|r| r.seq).collect();
        (writer, plan, (present, data.rows))
    } else {
        let plan = setup
            .plan
            .clone()
            .ok_or_else(|| PlanError::from("no plan given"))?;
        plan.check_limits(&info.source, &info.detector)?;
        let header = Header {
            device: device_line(&info),
            plan: plan.description.clone(),
            settings: plan.settings_words(),
            sample: setup.sample.clone(),
            points: plan.points.iter().map(|p| (p.theta_i, p.theta_r)).collect(),
        };
        (
            SweepWriter::create_with(&setup.out, &header, &setup.measurement, setup.force)?,
            plan,
            (BTreeSet::new(), Vec::new()),
        )
    };
    let (present, rows) = present;
    let sequential = super::sequential::budget_of(&plan);
    let watch = Watch::new(
        &plan,
        rows,
        setup.until.clone(),
        progress.wants_fit() || sequential.is_some(),
    );
    plan.check_limits(&info.source, &info.detector)?;
    let first_id = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as u32)
        .unwrap_or(1);
    let mut run = Run {
        conn,
        setup,
        plan,
        writer,
        present,
        progress,
        interrupt,
        next_id: first_id,
        reconnects: 0,
        dropped_before: 0,
        tol: Tolerance::for_device(&info),
        max_points: info.max_points,
        watch,
        sequential,
        restart_note: None,
        saturated: Default::default(),
    };
    if run.plan.points.len() > usize::from(info.max_points) {
        run.progress.note(&format!(
            "capture: the plan's {} points are more than the device takes in one sweep ({}, its Info.max_points): sent as several, legs as compact grids, other points as lists of at most {}",
            run.plan.points.len(),
            info.max_points,
            usize::from(info.max_points).min(brdf_core::protocol::MAX_PLAN_POINTS)
        ));
    }
    if setup.resume {
        // The capture that wrote the file talked to the device: a device that has not
        // been to its safe state since it started has restarted since.
        run.warn_if_restarted(prepared.status.as_ref())?;
    }
    run.progress
        .start(run.plan.points.len() as u64, run.present.len() as u64);
    // A resumed file's readings may already meet the targets.
    run.watch.refit(run.progress);
    let status = run.all_rounds(&mut link);
    run.progress.finish();
    let status = match status? {
        // The targets met with the plan's last reading: the plan is complete, not
        // stopped short of it.
        SweepStatus::Until if run.present.len() == run.plan.points.len() => SweepStatus::Complete,
        s => s,
    };
    run.writer.counters().dropped = run.dropped_before + link.stats().dropped() as u64;
    run.writer.set_status(status)?;
    let missing: Vec<u32> = (0..run.plan.points.len() as u32)
        .filter(|k| !run.present.contains(k))
        .collect();
    Ok(CaptureReport {
        status,
        counters: *run.writer.counters(),
        missing,
        total: run.plan.points.len(),
        info,
        reconnects: run.reconnects,
        until: run.watch.standing(),
        until_met: run.watch.targets_met(),
    })
}

impl<C: Connector> Run<'_, C> {
    fn all_rounds(&mut self, link: &mut FramedLink<C::T>) -> Result<SweepStatus> {
        let mut round = 0;
        // Reconnects in a row after which no new reading arrived, and the count then.
        let mut fruitless = 0;
        let mut mark = self.present.len();
        let mut batch_mark = self.present.len();
        loop {
            let batch_done;
            let done = match self.sequential {
                Some(budget) => {
                    // Each batch is a new round: retries count within a batch.
                    if self.present.len() > batch_mark {
                        round = 0;
                        batch_mark = self.present.len();
                    }
                    batch_done = super::sequential::round_done(
                        &self.plan,
                        &self.present,
                        &self.watch,
                        budget,
                    );
                    &batch_done
                }
                None => &self.present,
            };
            let sweeps = self.plan.sweeps_for(done, self.next_id, self.max_points);
            if sweeps.is_empty() {
                // Only a sequential plan stops with points missing: at its budget.
                return Ok(if self.present.len() == self.plan.points.len() {
                    SweepStatus::Complete
                } else if self.watch.met() {
                    SweepStatus::Until
                } else {
                    SweepStatus::Budget
                });
            }
            if self.watch.met() {
                return Ok(SweepStatus::Until);
            }
            if round > self.setup.retries {
                self.progress.note(&format!(
                    "capture: {} readings still missing after {} rounds of re-measuring",
                    sweeps.iter().map(|s| s.map.len()).sum::<usize>(),
                    self.setup.retries
                ));
                return Ok(SweepStatus::Failed);
            }
            if round > 0 {
                let n: usize = sweeps.iter().map(|s| s.map.len()).sum();
                self.progress.note(&format!(
                    "capture: re-measuring {n} readings lost on the link or rejected"
                ));
            }
            round += 1;
            for sw in sweeps {
                self.next_id = sw.plan.sweep_id + 1;
                match self.one_sweep(link, &sw)? {
                    Outcome::Done if self.sequential.is_some() => {
                        self.watch.refit(self.progress);
                    }
                    Outcome::Done => {}
                    Outcome::Interrupted if self.interrupt.load(Ordering::Relaxed) => {
                        return Ok(SweepStatus::Interrupted);
                    }
                    // Stopped at the targets (the Abort below), not by the user.
                    Outcome::Interrupted => return Ok(SweepStatus::Until),
                    Outcome::Lost(why) => {
                        if self.present.len() > mark {
                            fruitless = 0;
                        }
                        mark = self.present.len();
                        fruitless += 1;
                        if fruitless > liveness::MAX_FRUITLESS_RECONNECTS
                            && self.conn.can_reconnect()
                        {
                            self.writer.set_status(SweepStatus::Failed)?;
                            return Err(CaptureError::Device(format!(
                                "gave up: the device was lost {fruitless} times in a row without a new reading in between (last: {why}); it drops the link while starting the sweep? continue later with --resume"
                            )));
                        }
                        self.reconnect(link, &why)?;
                        round = 0; // the loss was the link's, not a reading's
                        break;
                    }
                }
            }
        }
    }

    fn reconnect(&mut self, link: &mut FramedLink<C::T>, why: &str) -> Result {
        self.dropped_before += link.stats().dropped() as u64;
        if !self.conn.can_reconnect() {
            self.writer.set_status(SweepStatus::Failed)?;
            return Err(CaptureError::Device(format!("device lost: {why}")));
        }
        self.progress.note(&format!(
            "capture: device lost ({why}); waiting up to {} s for it to come back",
            self.setup.reconnect_for.as_secs()
        ));
        // Our own hold on the old port would make reopening the same path fail
        // ("Unable to acquire exclusive lock").
        link.close();
        let deadline = Instant::now() + self.setup.reconnect_for;
        loop {
            if self.interrupt.load(Ordering::Relaxed) {
                self.writer.set_status(SweepStatus::Interrupted)?;
                return Err(CaptureError::Device(
                    "interrupted while waiting for the device; continue with --resume".into(),
                ));
            }
            match prepare(self.conn, self.setup) {
                Ok(p) => {
                    *link = p.link;
                    self.reconnects += 1;
                    self.progress
                        .note("capture: device is back; measuring what is missing");
                    self.warn_if_restarted(p.status.as_ref())?;
                    return Ok(());
                }
                Err(e) if Instant::now() >= deadline => {
                    self.writer.set_status(SweepStatus::Failed)?;
                    return Err(CaptureError::Device(format!(
                        "device lost ({why}) and not back within {} s ({e}); continue later with --resume",
                        self.setup.reconnect_for.as_secs()
                    )));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(250)),
            }
        }
    }

    /// Warns (on the terminal, and in a `# warning:` line of the file before the next
    /// reading) when a device
    /// this capture talked to before has restarted since ([`restarted`]).
    fn warn_if_restarted(&mut self, status: Option<&DeviceStatus>) -> Result {
        let Some(why) = status.and_then(restarted) else {
            return Ok(());
        };
        if self.present.len() < self.plan.points.len() {
            self.progress.note(&format!("capture: warning: {why}"));
            // Written before the next reading: where the readings after the restart begin.
            self.restart_note = Some(why);
        }
        Ok(())
    }

    fn send(&mut self, link: &mut FramedLink<C::T>, cmd: &Command) -> Result<(), String> {
        link.send(cmd).map_err(|e| e.to_string())
    }

    /// Stops the device and the capture for a reason that is not the link's: the
    /// device is alive but useless (`why` says how), or our own side failed.
    fn give_up(&mut self, link: &mut FramedLink<C::T>, why: String) -> Result<Outcome> {
        let _ = link.send(&Command::Abort);
        self.writer.set_status(SweepStatus::Failed)?;
        Err(CaptureError::Device(why))
    }

    /// A receive error: ours (the raw log) stops the device and the capture; any other
    /// means the device was lost.
    fn on_link_error(&mut self, link: &mut FramedLink<C::T>, e: LinkError) -> Result<Outcome> {
        if let LinkError::Log(_) = e {
            let raw = self
                .setup
                .raw
                .as_ref()
                .map_or(String::new(), |p| format!(" {}", p.display()));
            return self.give_up(
                link,
                format!(
                    "--raw{raw}: {e}; the device was stopped (Abort sent) and the sweep file holds every reading that arrived; free space, then continue with --resume"
                ),
            );
        }
        Ok(Outcome::Lost(e.to_string()))
    }

    /// Why a device that answers Ping but brings no reading was given up on.
    fn stalled(&self, progress_at: Instant, allowed: Duration) -> String {
        format!(
            "gave up: the device answers Ping but brought no new reading for {:.0} s (a point of this plan may take {:.0} s: settle, samples, dark and the move at {} deg/s, with margin); check the arms and detector, then continue with --resume",
            progress_at.elapsed().as_secs_f64(),
            allowed.as_secs_f64(),
            liveness::ASSUMED_ARM_SPEED_DEG_S
        )
    }

    /// Time allowed for the next reading of `sw` the device owes (see [`liveness`]).
    fn allowance(&self, sw: &DeviceSweep, state: &SweepState) -> Duration {
        let k = state.seq.expected.saturating_sub(u32::from(sw.plan.skip)) as usize;
        let at = |k: usize| {
            sw.map
                .get(k)
                .and_then(|&i| self.plan.points.get(i as usize))
                .copied()
        };
        let Some(to) = at(k).or_else(|| at(sw.map.len().saturating_sub(1))) else {
            return liveness::MARGIN;
        };
        let from = k.checked_sub(1).and_then(at);
        liveness::point_allowance(&self.plan.settings, from, to)
    }

    /// Runs one device sweep: sends it, follows it with a [`SweepState`] and records
    /// its readings. Liveness is apart from progress: a silent device is pinged (no
    /// answer: lost), a live one asked whether it still runs the sweep; a device that
    /// is alive but brings no new reading within the time its next point may take,
    /// floods, or ignores StartSweep is given up on with a message saying which.
    fn one_sweep(&mut self, link: &mut FramedLink<C::T>, sw: &DeviceSweep) -> Result<Outcome> {
        let mut state = SweepState::new(sw);
        self.saturated.clear();
        if let Err(e) = self.send(link, &Command::StartSweep(state.plan.clone())) {
            return Ok(Outcome::Lost(e));
        }
        let mut silent_since = Instant::now();
        // The last new reading (or the start): progress, as opposed to liveness.
        let mut progress_at = Instant::now();
        // Events since the last new reading (a flood, when too many).
        let mut chatter = 0u32;
        let mut start_resends = 0u32;
        // When the Abort of a stalled sweep was sent.
        let mut stop_sent_at: Option<Instant> = None;
        // Events that arrived while waiting for a Pong: handled before new ones.
        let mut pending: VecDeque<Event> = VecDeque::new();
        // The device is lost, but what arrived while pinging is recorded first.
        let mut lost: Option<String> = None;
        loop {
            if state.abort_sent_at.is_none()
                && (self.interrupt.load(Ordering::Relaxed) || self.watch.met())
            {
                if let Err(e) = self.send(link, &Command::Abort) {
                    return Ok(Outcome::Lost(e));
                }
                state.abort_sent_at = Some(Instant::now());
            }
            if let Some(outcome) = state.over_at(Instant::now()) {
                return Ok(outcome);
            }
            if pending.is_empty() {
                if let Some(why) = lost.take() {
                    return Ok(Outcome::Lost(why));
                }
            }
            let allowed = self.allowance(sw, &state);
            if state.started
                && !state.stop_sent
                && state.abort_sent_at.is_none()
                && state.done_at.is_none()
                && progress_at.elapsed() > allowed
            {
                // Alive (or flooding) but no new reading in the time a point may take:
                // stop it; a SweepDone (aborted) says it was stalled, a Status that it
                // had finished and its last events were lost.
                if let Err(e) = self.send(link, &Command::Abort) {
                    return Ok(Outcome::Lost(e));
                }
                state.stop_sent = true;
                stop_sent_at = Some(Instant::now());
            }
            if stop_sent_at.is_some_and(|t| t.elapsed() > STOP_ANSWER) {
                // Not even the Abort was answered, though Pings are.
                return self.give_up(link, self.stalled(progress_at, allowed));
            }
            let ev = match pending.pop_front() {
                Some(ev) => Some(ev),
                None => match link.recv(state.recv_timeout()) {
                    Ok(ev) => ev,
                    Err(e) => return self.on_link_error(link, e),
                },
            };
            let Some(ev) = ev else {
                if silent_since.elapsed() >= self.setup.event_timeout {
                    self.writer.counters().timeouts += 1;
                    if !self.answers_ping(link, &mut pending)? {
                        lost = Some(format!(
                            "silent for {} s and no answer to Ping",
                            self.setup.event_timeout.as_secs()
                        ));
                        continue;
                    }
                    if !state.started {
                        // The StartSweep may have been lost on the way: send it again
                        // (a device already running it answers Busy, which is fine).
                        start_resends += 1;
                        if start_resends > liveness::MAX_START_RESENDS {
                            return self.give_up(link, format!(
                                "gave up: the device answers Ping but ignored the sweep command ({} times sent, {} s apart); check the firmware, then continue with --resume",
                                start_resends,
                                self.setup.event_timeout.as_secs()
                            ));
                        }
                        if let Err(e) = self.send(link, &Command::StartSweep(state.plan.clone())) {
                            return Ok(Outcome::Lost(e));
                        }
                    } else if pending.is_empty() && !state.stop_sent {
                        // Alive but silent while our sweep ran: still measuring (a long
                        // settle answers Busy), or finished with its SweepDone lost
                        // (answers Status: the laser is off after a sweep anyway).
                        if let Err(e) = self.send(link, &Command::SetLaser(false)) {
                            return Ok(Outcome::Lost(e));
                        }
                        state.probe_sent = true;
                    }
                    silent_since = Instant::now();
                }
                continue;
            };
            silent_since = Instant::now();
            let before = self.present.len();
            let step = state.on_event(
                ev,
                &mut self.writer.counters().gaps,
                &mut self.next_id,
                Instant::now(),
            );
            match step {
                Step::Wait => {}
                Step::Record(r) => {
                    if let Err(e) = self.record(sw, &r) {
                        // Another plan, or our own file failed: the device must
                        // not go on moving and lighting for nothing.
                        let _ = self.send(link, &Command::Abort);
                        return Err(e);
                    }
                }
                Step::Saturated { seq, conversions } => {
                    self.saturated.insert(seq, conversions);
                }
                Step::Reject(why) => self.reject(&why),
                Step::OtherPlan(why) => {
                    let _ = self.send(link, &Command::Abort);
                    return Err(self.other_plan(&why));
                }
                Step::End(outcome) => return Ok(outcome),
                Step::Stalled => return self.give_up(link, self.stalled(progress_at, allowed)),
                Step::Restart { abort_first } => {
                    if abort_first {
                        if let Err(e) = self.send(link, &Command::Abort) {
                            return Ok(Outcome::Lost(e));
                        }
                        // An Abort mid-move marks the device's position lost (its safe
                        // state): home again, as the connect does, or the StartSweep
                        // is refused "position lost".
                        match rehome(link, self.setup, &mut pending) {
                            Ok(()) => {}
                            Err(HomingError::Link(e)) => return self.on_link_error(link, e),
                            Err(HomingError::Failed(why)) => {
                                self.writer.set_status(SweepStatus::Failed)?;
                                return Err(CaptureError::Device(why));
                            }
                        }
                    }
                    std::thread::sleep(Duration::from_millis(50));
                    if let Err(e) = self.send(link, &Command::StartSweep(state.plan.clone())) {
                        return Ok(Outcome::Lost(e));
                    }
                    progress_at = Instant::now();
                }
                Step::Fail { why, mark_failed } => {
                    if mark_failed {
                        self.writer.set_status(SweepStatus::Failed)?;
                    }
                    return Err(CaptureError::Device(why));
                }
            }
            if self.present.len() > before {
                progress_at = Instant::now();
                chatter = 0;
            } else {
                chatter += 1;
                if chatter > liveness::FLOOD_EVENTS {
                    return self.give_up(link, format!(
                        "gave up: the device floods the link ({chatter} events, such as Pong or Progress, without a new reading); continue with --resume"
                    ));
                }
            }
        }
    }

    /// Pings the device; other events that arrive meanwhile (readings still on their
    /// way) are kept in `pending`, never dropped.
    fn answers_ping(
        &mut self,
        link: &mut FramedLink<C::T>,
        pending: &mut VecDeque<Event>,
    ) -> Result<bool> {
        let token = 0x7069_6e67;
        // Three tries: one Ping or Pong lost on a noisy link is not a lost device.
        for _ in 0..3 {
            if link.send(&Command::Ping(token)).is_err() {
                return Ok(false);
            }
            let deadline = Instant::now() + Duration::from_secs(1);
            while Instant::now() < deadline {
                match link.recv(Duration::from_millis(100)) {
                    Ok(Some(Event::Pong(t))) if t == token => return Ok(true),
                    Ok(Some(ev)) => pending.push_back(ev),
                    Ok(None) => {}
                    Err(e @ LinkError::Log(_)) => {
                        return Err(CaptureError::Device(format!("{e}; continue with --resume")));
                    }
                    Err(_) => return Ok(false),
                }
            }
        }
        Ok(false)
    }

    /// Counts a rejected reading (its point stays missing: the next round measures it).
    fn reject(&mut self, why: &str) {
        let c = self.writer.counters();
        c.rejected += 1;
        let n = c.rejected;
        if n <= REJECTS_SHOWN {
            let more = if n == REJECTS_SHOWN {
                "; further ones only counted"
            } else {
                ""
            };
            self.progress.note(&format!(
                "capture: rejected a reading: {}; its point is measured again{more}",
                crate::text::escape_line(why, 200)
            ));
        }
    }

    /// The device runs another plan than gonio's: the file is marked failed and the
    /// capture stops with a message naming both plans.
    fn other_plan(&mut self, why: &str) -> CaptureError {
        if let Err(e) = self.writer.set_status(SweepStatus::Failed) {
            return e.into();
        }
        CaptureError::Device(format!(
            "the device's plan disagrees with gonio's plan ({}, {} points): {}; nothing more is measured (check the firmware version), the file holds only readings that matched",
            crate::text::escape_line(&self.plan.description, 200),
            self.plan.points.len(),
            crate::text::escape_line(why, 200)
        ))
    }

    fn record(&mut self, sw: &DeviceSweep, r: &Reading) -> Result {
        let Some(seq) = sw.host_seq(r.seq) else {
            self.reject(&format!("reading seq {} is outside the sweep", r.seq));
            return Ok(());
        };
        let Some(want) = self.plan.points.get(seq as usize) else {
            self.reject(&format!("reading seq {} is outside the plan", r.seq));
            return Ok(());
        };
        let sweep_points = sw
            .map
            .iter()
            .filter_map(|&k| self.plan.points.get(k as usize).map(|p| (k, p)));
        match check::check_reading(r, seq, want, sweep_points, &self.tol) {
            check::Verdict::Good => {}
            check::Verdict::Reject(why) => {
                self.reject(&why);
                return Ok(());
            }
            check::Verdict::OtherPlan(why) => return Err(self.other_plan(&why)),
        }
        let row = Row {
            theta_i: shortest(r.theta_i),
            theta_r: shortest(r.theta_r),
            brdf: shortest(r.value),
            std: Some(shortest(r.std)),
            n: Some(r.n as u32),
            seq: Some(seq),
            t_ms: Some(r.t_ms as u64),
        };
        // What the file's readers would refuse (a brdf of 1e-35 or 3e38: finite, but
        // outside the range read) is not written: counted, its point measured again.
        if let Some(why) = row_problem(&row) {
            self.reject(&format!("reading {}: {why}", r.seq));
            return Ok(());
        }
        if self.present.contains(&seq) {
            return Ok(()); // a duplicate: already in the file
        }
        if let Some(why) = self.restart_note.take() {
            self.writer.warn(&why)?;
        }
        if let Some(k) = self.saturated.remove(&r.seq) {
            // The fit leaves it out unless told (docs/protocol.md, Saturated).
            self.writer.warn(&format!(
                "{SATURATED_PREFIX}{seq}: {k} detector conversions at full scale (the reading is clipped)"
            ))?;
        }
        if let Err(e) = self.writer.append(&row) {
            // The file ends at its last whole row (the writer cut a partial one away):
            // marked failed where the disk still allows it, and resumable.
            let _ = self.writer.set_status(SweepStatus::Failed);
            return Err(CaptureError::File(SweepFileError::Io(format!(
                "{e}; the file holds every reading before it: free space, then continue with --resume"
            ))));
        }
        self.present.insert(seq);
        self.progress
            .reading(self.present.len() as u64, r.theta_i, r.theta_r);
        self.progress.row(&row, self.writer.counters());
        self.watch.on_row(row, want.theta_i, self.progress);
        Ok(())
    }
}
