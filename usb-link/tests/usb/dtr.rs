//! The host closes the port (DTR off) in the middle of a sweep and opens it again: the
//! device stops (sweep aborted, laser off), drops what nobody will read, and the next
//! host starts on a clean stream and resumes the sweep (docs/protocol.md, Link).

use std::collections::BTreeSet;
use std::time::Duration;

use brdf_core::frame::{FrameDecoder, MAX_FRAME_LEN};
use brdf_core::protocol::{Command, Event, SweepDone};
use gonio::capture::HostPlan;
use gonio::device::FramedLink;
use usb_link::MAX_PACKET;

use super::port::UsbPort;
use super::rig::Rig;

/// Wall-clock bound on one answer (the device runs on simulated time; this only stops
/// a broken test from hanging).
const ANSWER: Duration = Duration::from_secs(20);

/// Events until `done` says stop; readings' seqs go into `seqs`.
fn until(
    link: &mut FramedLink<UsbPort<'_>>,
    seqs: &mut Vec<u32>,
    mut done: impl FnMut(&Event, usize) -> bool,
) -> Event {
    loop {
        let ev = link
            .recv(ANSWER)
            .expect("link works")
            .expect("the device answers");
        if let Event::Reading(r) = &ev {
            seqs.push(r.seq);
        }
        if done(&ev, seqs.len()) {
            return ev;
        }
    }
}

#[test]
fn dtr_dropped_mid_sweep_stops_the_device_and_a_reopened_port_resumes_cleanly() {
    let plan = HostPlan::paper(&Default::default()).unwrap();
    let first = plan
        .sweeps_for(&BTreeSet::new(), 1, u16::MAX)
        .remove(0)
        .plan;
    let mut rig = Rig::new();
    let mut seqs = Vec::new();
    {
        let mut link = FramedLink::new(UsbPort::open(&mut rig));
        link.handshake(ANSWER).expect("handshake");
        link.send(&Command::Home).unwrap();
        until(&mut link, &mut seqs, |e, _| matches!(e, Event::Status(_)));
        link.send(&Command::StartSweep(first)).unwrap();
        until(&mut link, &mut seqs, |_, n| n >= 40);
        // The application closes the port mid-sweep.
        link.close();
    }
    assert!(!rig.link.host_open());
    rig.run_device_for(2_000_000);
    assert!(
        !rig.service.ctrl.is_busy(),
        "the sweep ran on after the host closed the port"
    );
    let arms = |rig: &Rig| {
        let c = &rig.service.ctrl;
        (c.source().position(), c.detector().position())
    };
    let stopped_at = arms(&rig);
    rig.run_device_for(1_000_000);
    assert_eq!(arms(&rig), stopped_at, "an arm moved after the stop");

    // Reopened: nothing stale beyond the one packet that sat in the endpoint when the
    // host stopped reading, then the device answers as after power-up.
    rig.open_port();
    for _ in 0..1_000 {
        rig.step_both();
    }
    let stale: Vec<u8> = rig.received.drain(..).collect();
    assert!(
        stale.len() <= MAX_PACKET,
        "{} stale bytes after reopening",
        stale.len()
    );
    // What the device said after the close (the answer to the Abort it gave itself)
    // was not kept for the next host.
    let mut decoder = FrameDecoder::<MAX_FRAME_LEN>::new();
    let late: Vec<Event> = stale
        .iter()
        .filter_map(|&b| decoder.push::<Event>(b)?.ok())
        .filter(|e| !matches!(e, Event::Reading(_)))
        .collect();
    assert!(late.is_empty(), "the next host got {late:?}");
    let mut link = FramedLink::new(UsbPort::open(&mut rig));
    link.handshake(ANSWER).expect("handshake after reopening");
    link.send(&Command::Abort).unwrap();
    let mut none = Vec::new();
    match until(&mut link, &mut none, |e, _| {
        matches!(e, Event::Status(_) | Event::SweepDone(_))
    }) {
        Event::Status(s) => {
            assert!(!s.laser, "laser left on");
            // Stopped mid-move (steps may have been lost): home again, as capture does.
            if !s.homed {
                link.send(&Command::Home).unwrap();
                until(&mut link, &mut none, |e, _| matches!(e, Event::Status(_)));
            }
        }
        other => panic!("a sweep was still running: {other:?}"),
    }
    assert!(none.is_empty(), "readings of the closed session: {none:?}");

    // Resuming measures exactly what is missing.
    let present: BTreeSet<u32> = seqs.iter().copied().collect();
    assert_eq!(present.len(), seqs.len(), "a reading came twice");
    let rest = plan.sweeps_for(&present, 2, u16::MAX).remove(0).plan;
    link.send(&Command::StartSweep(rest)).unwrap();
    let done = until(&mut link, &mut seqs, |e, _| {
        matches!(e, Event::SweepDone(_))
    });
    assert!(
        matches!(done, Event::SweepDone(SweepDone { aborted: false, .. })),
        "{done:?}"
    );
    let all: BTreeSet<u32> = seqs.iter().copied().collect();
    assert_eq!((all.len(), seqs.len()), (153, 153), "each point once");
    assert_eq!(all, (0..153).collect());
}

/// docs/protocol.md tells client writers what this file checks: keep it saying so.
#[test]
fn the_protocol_page_states_what_a_close_does() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/protocol.md");
    let doc = std::fs::read_to_string(path).expect("docs/protocol.md");
    let words = doc.split_whitespace().collect::<Vec<_>>().join(" ");
    for said in [
        "When DTR falls, the device goes to its safe state (as on `Abort`)",
        "discards everything it would send until DTR rises again",
        "except at most one 64-byte packet already waiting in the USB endpoint",
        "A host that never raises DTR is served as usual",
    ] {
        assert!(words.contains(said), "docs/protocol.md should say '{said}'");
    }
}
