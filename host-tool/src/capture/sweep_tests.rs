//! Tests of the sweep state on events alone (no link, no device).

use brdf_core::protocol::{ErrorEvent, Grid, PointSettings, Progress, Status, SweepDone};

use super::*;

/// A device sweep of `n` readings starting at device seq `skip`, sweep id 7.
fn sweep(skip: u16, n: u32) -> DeviceSweep {
    DeviceSweep {
        plan: SweepPlan {
            sweep_id: 7,
            grid: Grid::Paper,
            exclude_retro_deg: 0.0,
            settings: PointSettings {
                samples: 4,
                settle_ms: 50,
                dark: false,
            },
            skip,
        },
        map: (u32::from(skip)..u32::from(skip) + n).collect(),
    }
}

fn reading(sweep_id: u32, seq: u32) -> Event {
    Event::Reading(Reading {
        sweep_id,
        seq,
        theta_i: 0.0,
        theta_r: 0.0,
        value: 1.0,
        std: 0.0,
        n: 1,
        t_ms: 0,
    })
}

fn done(sweep_id: u32, next_seq: u32, aborted: bool) -> Event {
    Event::SweepDone(SweepDone {
        sweep_id,
        count: 0,
        next_seq,
        aborted,
    })
}

fn error(code: ErrorCode) -> Event {
    Event::Error(ErrorEvent {
        code,
        detail: heapless::String::try_from("x").unwrap(),
    })
}

/// Feeds `events`; returns the steps and the gap counter.
fn feed(state: &mut SweepState, events: Vec<Event>) -> (Vec<Step>, u64) {
    let (mut gaps, mut next_id) = (0, 100);
    let now = Instant::now();
    let steps = events
        .into_iter()
        .map(|ev| state.on_event(ev, &mut gaps, &mut next_id, now))
        .collect();
    (steps, gaps)
}

#[test]
fn readings_in_order_are_recorded_without_gaps() {
    let mut s = SweepState::new(&sweep(0, 3));
    let (steps, gaps) = feed(&mut s, (0..3).map(|k| reading(7, k)).collect());
    assert!(steps.iter().all(|s| matches!(s, Step::Record(_))));
    assert_eq!(gaps, 0);
    assert!(s.started);
    assert_eq!(s.seq.expected, 3);
}

#[test]
fn a_jump_counts_gaps_and_a_late_reading_takes_its_gap_back() {
    let mut s = SweepState::new(&sweep(10, 6));
    let (_, gaps) = feed(&mut s, vec![reading(7, 10), reading(7, 13)]);
    assert_eq!(gaps, 2);
    assert_eq!(s.seq.skipped, [11, 12].into());
    let mut gaps = 2;
    let step = s.on_event(reading(7, 11), &mut gaps, &mut 0, Instant::now());
    assert!(matches!(step, Step::Record(_)));
    assert_eq!(gaps, 1, "11 came late, not lost");
    // A duplicate changes nothing.
    s.on_event(reading(7, 11), &mut gaps, &mut 0, Instant::now());
    assert_eq!((gaps, s.seq.expected), (1, 14));
}

#[test]
fn sweep_done_counts_the_tail_and_lingers_for_late_readings() {
    let mut s = SweepState::new(&sweep(0, 5));
    let t0 = Instant::now();
    let mut gaps = 0;
    s.on_event(reading(7, 0), &mut gaps, &mut 0, t0);
    assert_eq!(
        s.on_event(done(7, 5, false), &mut gaps, &mut 0, t0),
        Step::Wait
    );
    assert_eq!(gaps, 4);
    assert_eq!(s.recv_timeout(), LINGER);
    // Missing readings: linger before the sweep is over.
    assert_eq!(s.over_at(t0), None);
    assert_eq!(s.over_at(t0 + LINGER), Some(Outcome::Done));
    // Everything came late after all: over at once, no gap left.
    for k in 1..5 {
        s.on_event(reading(7, k), &mut gaps, &mut 0, t0);
    }
    assert_eq!(gaps, 0);
    assert_eq!(s.over_at(t0), Some(Outcome::Done));
}

#[test]
fn a_stopped_silent_device_ends_the_sweep_and_its_unsent_tail_is_counted() {
    let mut s = SweepState::new(&sweep(3, 4));
    let mut gaps = 0;
    s.on_event(reading(7, 3), &mut gaps, &mut 0, Instant::now());
    // Not ours to act on before we stopped it.
    let status = Event::Status(Status {
        source_deg: 0.0,
        detector_deg: 0.0,
        laser: false,
        homed: true,
    });
    assert_eq!(
        s.on_event(status.clone(), &mut gaps, &mut 0, Instant::now()),
        Step::Wait
    );
    s.stop_sent = true;
    assert_eq!(
        s.on_event(status, &mut gaps, &mut 0, Instant::now()),
        Step::End(Outcome::Done)
    );
    assert_eq!(gaps, 3, "seqs 4, 5 and 6 were sent and lost");
}

#[test]
fn ctrl_c_ends_with_the_sweep_done_or_after_the_answer_timeout() {
    let mut s = SweepState::new(&sweep(0, 5));
    let t0 = Instant::now();
    s.abort_sent_at = Some(t0);
    assert_eq!(s.over_at(t0 + Duration::from_secs(1)), None);
    assert_eq!(
        s.over_at(t0 + Duration::from_secs(6)),
        Some(Outcome::Interrupted)
    );
    let (steps, _) = feed(&mut s, vec![done(7, 2, true)]);
    assert_eq!(steps, [Step::End(Outcome::Interrupted)]);
}

#[test]
fn a_busy_device_is_restarted_under_a_fresh_id_and_old_readings_still_count() {
    let mut s = SweepState::new(&sweep(0, 3));
    let (mut gaps, mut next_id) = (0, 100);
    let now = Instant::now();
    assert_eq!(
        s.on_event(error(ErrorCode::Busy), &mut gaps, &mut next_id, now),
        Step::Restart { abort_first: true }
    );
    assert_eq!((s.plan.sweep_id, next_id), (100, 101));
    // The aborted run's SweepDone does not end the new one...
    assert_eq!(
        s.on_event(done(7, 0, true), &mut gaps, &mut next_id, now),
        Step::Wait
    );
    // ... but its readings are readings of these points.
    assert!(matches!(
        s.on_event(reading(7, 0), &mut gaps, &mut next_id, now),
        Step::Record(_)
    ));
    assert!(matches!(
        s.on_event(reading(100, 1), &mut gaps, &mut next_id, now),
        Step::Record(_)
    ));
    // Other sweeps' events are not ours.
    assert_eq!(
        s.on_event(reading(55, 2), &mut gaps, &mut next_id, now),
        Step::Wait
    );
    let progress = Event::Progress(Progress {
        sweep_id: 55,
        done: 1,
        total: 3,
        theta_i: 0.0,
    });
    assert_eq!(
        s.on_event(progress, &mut gaps, &mut next_id, now),
        Step::Wait
    );
}

#[test]
fn a_corrupted_start_is_retried_ten_times_then_fails() {
    let mut s = SweepState::new(&sweep(0, 3));
    let (steps, _) = feed(
        &mut s,
        (0..11).map(|_| error(ErrorCode::CorruptFrame)).collect(),
    );
    assert!(
        steps[..10]
            .iter()
            .all(|s| *s == Step::Restart { abort_first: false })
    );
    match &steps[10] {
        Step::Fail { why, mark_failed } => {
            assert!(
                why.contains("corrupted the sweep command 10 times"),
                "{why}"
            );
            assert!(*mark_failed);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(s.plan.sweep_id, 7, "no fresh id without Busy");
}

#[test]
fn device_errors_fail_the_sweep() {
    let mut s = SweepState::new(&sweep(0, 3));
    let (steps, _) = feed(&mut s, vec![error(ErrorCode::OutOfLimits)]);
    assert!(
        matches!(&steps[0], Step::Fail { why, mark_failed: true } if why.starts_with("device refused the sweep"))
    );
    let mut s = SweepState::new(&sweep(0, 3));
    let (steps, _) = feed(&mut s, vec![reading(7, 0), error(ErrorCode::DetectorFault)]);
    assert!(
        matches!(&steps[1], Step::Fail { why, mark_failed: true } if why.starts_with("device error during the sweep"))
    );
    // The device aborting on its own is an error, the file not marked.
    let mut s = SweepState::new(&sweep(0, 3));
    let (steps, _) = feed(&mut s, vec![done(7, 1, true)]);
    assert!(matches!(
        &steps[0],
        Step::Fail {
            mark_failed: false,
            ..
        }
    ));
}

#[test]
fn a_seq_outside_the_sweep_is_rejected_and_allocates_nothing() {
    let mut s = SweepState::new(&sweep(10, 6));
    let (steps, gaps) = feed(
        &mut s,
        vec![reading(7, u32::MAX), reading(7, 100_000_000), reading(7, 9)],
    );
    assert!(
        steps.iter().all(|s| matches!(s, Step::Reject(_))),
        "{steps:?}"
    );
    assert_eq!((gaps, s.seq.expected), (0, 10));
    assert!(s.seq.skipped.is_empty());
    // A SweepDone claiming 0xFFFFFFFF readings counts at most the sweep's own.
    let (_, gaps) = feed(&mut s, vec![done(7, u32::MAX, false)]);
    assert_eq!(gaps, 6);
    assert_eq!(s.seq.skipped.len(), 6);
}

#[test]
fn a_progress_of_another_plan_length_is_another_plan() {
    let mut s = SweepState::new(&sweep(0, 3));
    let progress = |total| {
        Event::Progress(Progress {
            sweep_id: 7,
            done: 0,
            total,
            theta_i: 0.0,
        })
    };
    let (steps, _) = feed(&mut s, vec![progress(3), progress(5)]);
    assert_eq!(steps[0], Step::Wait);
    assert!(
        matches!(&steps[1], Step::OtherPlan(why) if why.contains("counts 5") && why.contains("has 3")),
        "{:?}",
        steps[1]
    );
}

#[test]
fn a_probe_tells_a_finished_sweep_from_a_running_one() {
    let status = Event::Status(Status {
        source_deg: 0.0,
        detector_deg: 0.0,
        laser: false,
        homed: true,
    });
    let busy = Event::Error(ErrorEvent::new(ErrorCode::Busy, "busy"));
    let mut s = SweepState::new(&sweep(0, 4));
    let mut gaps = 0;
    s.on_event(reading(7, 0), &mut gaps, &mut 0, Instant::now());
    s.probe_sent = true;
    // Still running: Busy is no reason to stop.
    assert_eq!(
        s.on_event(busy, &mut gaps, &mut 0, Instant::now()),
        Step::Wait
    );
    // Idle: its SweepDone was lost, the readings after seq 0 with it.
    assert_eq!(
        s.on_event(status, &mut gaps, &mut 0, Instant::now()),
        Step::End(Outcome::Done)
    );
    assert_eq!(gaps, 3);
    // Stopped for making no progress, and it was still running: stalled.
    let mut s = SweepState::new(&sweep(0, 4));
    s.on_event(reading(7, 0), &mut gaps, &mut 0, Instant::now());
    s.stop_sent = true;
    let (steps, _) = feed(&mut s, vec![done(7, 1, true)]);
    assert_eq!(steps, [Step::Stalled]);
}

#[test]
fn progress_done_counts_the_skipped_points_on_resume() {
    let progress = |done, total| {
        Event::Progress(Progress {
            sweep_id: 7,
            done,
            total,
            theta_i: 0.0,
        })
    };
    // A resume with skip = 150 of 153: done starts at 150 and stays within the plan.
    let mut s = SweepState::new(&sweep(150, 3));
    let (steps, _) = feed(&mut s, vec![progress(150, 153), progress(152, 153)]);
    assert_eq!(steps, [Step::Wait, Step::Wait]);
    // A device counting from 0 ignored the skip: another plan.
    let mut s = SweepState::new(&sweep(150, 3));
    let (steps, _) = feed(&mut s, vec![progress(0, 153)]);
    assert!(
        matches!(&steps[0], Step::OtherPlan(why) if why.contains("0 of 153") && why.contains("starts at 150")),
        "{steps:?}"
    );
    // done past the plan's end is a lie too.
    let mut s = SweepState::new(&sweep(0, 3));
    let (steps, _) = feed(&mut s, vec![progress(4, 3)]);
    assert!(matches!(&steps[0], Step::OtherPlan(_)), "{steps:?}");
    let doc = crate::capture::protocol_doc_words();
    assert!(doc.contains("a `Progress.done` below the sweep's `skip` or above `total`"));
}
