//! The bus goes away mid-sweep (USB suspend, a bus reset of the configured device
//! after a re-plug, or VBUS lost on a self-powered board that senses it): the device
//! goes to its safe state, as when DTR falls.

use std::time::Duration;

use brdf_core::protocol::{Command, Event, PointSettings, SafeReason, SweepPlan};
use gonio::device::FramedLink;

use super::port::UsbPort;
use super::rig::Rig;

const ANSWER: Duration = Duration::from_secs(20);

/// A rig whose sweep has sent a few readings, the port still open.
fn sweeping() -> Rig {
    let mut rig = Rig::new();
    {
        let mut link = FramedLink::new(UsbPort::open(&mut rig));
        link.handshake(ANSWER).expect("handshake");
        link.send(&Command::Home).unwrap();
        while !matches!(link.recv(ANSWER).unwrap(), Some(Event::Status(_))) {}
        let settings = PointSettings {
            settle_ms: 5,
            samples: 4,
            dark: false,
        };
        link.send(&Command::StartSweep(SweepPlan::paper(3, settings)))
            .unwrap();
        let mut n = 0;
        while n < 5 {
            if let Some(Event::Reading(_)) = link.recv(ANSWER).unwrap() {
                n += 1;
            }
        }
    }
    assert!(rig.service.ctrl.is_busy());
    rig
}

fn assert_safe(rig: &Rig, what: &str) {
    let c = &rig.service.ctrl;
    assert!(!c.is_busy(), "{what}: the sweep ran on");
    assert!(!c.laser_on(), "{what}: laser on");
    assert!(
        !c.source().pins().enabled && !c.detector().pins().enabled,
        "{what}: drivers enabled"
    );
    assert_eq!(c.last_safe(), Some(SafeReason::Abort), "{what}");
}

#[test]
fn a_suspended_bus_ends_in_the_safe_state() {
    let mut rig = sweeping();
    rig.wire.suspend();
    rig.run_device_for(200_000);
    assert_safe(&rig, "suspend");
}

#[test]
fn a_bus_reset_of_the_configured_device_ends_in_the_safe_state() {
    let mut rig = sweeping();
    rig.wire.bus_reset();
    rig.run_device_for(200_000);
    assert_safe(&rig, "bus reset");
}

#[test]
fn vbus_lost_ends_in_the_safe_state_at_once_and_a_replugged_host_starts_clean() {
    let mut rig = sweeping();
    let arms = |rig: &Rig| {
        let c = &rig.service.ctrl;
        (c.source().position(), c.detector().position())
    };
    // The cable is pulled: the bus has not yet been seen suspended (that takes 3 ms
    // of idle bus), but the board's sense pin reads VBUS gone on its next loop.
    rig.vbus = false;
    rig.step();
    assert_safe(&rig, "VBUS lost, one loop later");
    assert!(!rig.link.host_open(), "DTR still seen raised");
    let stopped_at = arms(&rig);
    rig.run_device_for(1_000_000);
    assert_eq!(arms(&rig), stopped_at, "an arm moved after VBUS was lost");
    assert_safe(&rig, "VBUS lost, a second later");

    // Plugged in again: the host enumerates the device afresh and opens the port; it
    // hears nothing of the old session, and the device answers as after power-up.
    rig.vbus = true;
    rig.cdc = None;
    rig.transfer.clear();
    rig.received.clear();
    let mut link = FramedLink::new(UsbPort::open(&mut rig));
    link.handshake(ANSWER).expect("handshake after the re-plug");
    link.send(&Command::GetStatus).unwrap();
    loop {
        match link.recv(ANSWER).unwrap() {
            Some(Event::DeviceStatus(s)) => {
                assert!(!s.laser, "laser on after the re-plug");
                assert!(!s.busy, "a sweep ran on");
                break;
            }
            Some(Event::Reading(r)) => panic!("a reading of the old session: {r:?}"),
            _ => {}
        }
    }
}
