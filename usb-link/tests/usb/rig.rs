//! The test rig: the firmware's stack as the stm32f411 board runs it (brdf-core's
//! service loop over usb-link's [`UsbLink`] over usb-device and usbd-serial), on the
//! simulated bus, with simulated arms and sample and a simulated clock; plus the host's
//! state (what it has read). The host's operations are in `host.rs`.

use std::collections::VecDeque;

use brdf_core::identity::FIRMWARE_VERSION;
use brdf_core::presets::Preset;
use brdf_core::service::Service;
use brdf_core::sim::{SimArm, SimPin, VirtualSample, simulated_controller};
use usb_device::bus::UsbBusAllocator;
use usb_link::UsbLink;

use super::bus::{SimBus, Wire};
use super::host::Cdc;

/// The board name the rig's controller reports.
pub const BOARD: &str = "usb-sim";

/// The serial number the rig enumerates with (a chip's unique ID in hex).
pub const SERIAL: &str = "3A0047001851393038353133";

/// Preset, noise and seed of the rig's virtual sample (as host-tool's simulated device
/// is given them, so the two can be compared).
pub const PRESET: &str = "fe-0.115";
/// Relative noise of each detector sample.
pub const NOISE: f32 = 0.005;
/// Seed of the noise.
pub const SEED: u32 = 3;

/// Simulated time that passes in an iteration of the loop when the controller has
/// nothing scheduled (microseconds): the time a USB frame takes.
const IDLE_STEP_US: u64 = 1_000;

/// The firmware's service, as on the board but with simulated hardware.
pub type SimService = Service<SimArm, SimArm, SimPin, VirtualSample>;

/// What the device did while the host did not read.
#[derive(Debug, Clone, Copy)]
pub struct Pause {
    /// Loop iterations run.
    pub steps: u64,
    /// At the end, the controller was still busy (its sweep held, not over).
    pub busy: bool,
    /// At the end, the service still held a frame it could not hand the link.
    pub sending: bool,
}

/// Device and host around one simulated bus.
pub struct Rig {
    /// The host's end of the wire.
    pub wire: Wire,
    /// The firmware's link (the code under test).
    pub link: UsbLink<'static, SimBus>,
    /// The firmware's service loop and controller.
    pub service: SimService,
    /// Simulated time (microseconds).
    pub now_us: u64,
    /// When the rig started: the lease's wall clock.
    pub started: std::time::Instant,
    /// Service-loop iterations run.
    pub steps: u64,
    /// EP0's packet size as the host knows it (8 until the device descriptor says).
    pub ep0_max: usize,
    /// The port as enumerated (after [`Rig::enumerate`]).
    pub cdc: Option<Cdc>,
    /// Bytes of the bulk IN transfer in progress (not yet seen by the application).
    pub transfer: Vec<u8>,
    /// Size of the host's bulk IN transfers (Linux's cdc-acm reads 2 packets at a time).
    pub transfer_size: usize,
    /// Bytes of completed transfers, for the application to read.
    pub received: VecDeque<u8>,
    /// Lengths of the completed bulk IN transfers, in order.
    pub transfers: Vec<usize>,
    /// What a pause in reading (port.rs's `Stall`) saw.
    pub paused: Option<Pause>,
    /// The host sends IN tokens to the data endpoint (an application reads the port).
    pub reading: bool,
    /// VBUS at the board's sense pin, reported to the link every loop as a self-powered
    /// stm32f411 board does (true: plugged in).
    pub vbus: bool,
}

impl Rig {
    /// A powered device on a fresh bus, not yet enumerated.
    pub fn new() -> Rig {
        let (bus, wire) = Wire::new();
        // The allocator must outlive the link's borrows, as the board's static does.
        let alloc: &'static UsbBusAllocator<SimBus> =
            Box::leak(Box::new(UsbBusAllocator::new(bus)));
        let link = UsbLink::new(alloc, SERIAL);
        let preset = Preset::by_name(PRESET).expect("preset exists");
        let sample = VirtualSample::new(preset, NOISE, SEED);
        let service = Service::new(simulated_controller(BOARD, FIRMWARE_VERSION, sample));
        Rig {
            wire,
            link,
            service,
            now_us: 0,
            started: std::time::Instant::now(),
            steps: 0,
            ep0_max: 8,
            cdc: None,
            transfer: Vec::new(),
            transfer_size: 128,
            received: VecDeque::new(),
            transfers: Vec::new(),
            paused: None,
            reading: false,
            vbus: true,
        }
    }

    /// One iteration of the firmware's main loop. Returns whether the controller has
    /// something scheduled (a sweep, homing or jog under way, or a frame to send).
    pub fn step(&mut self) -> bool {
        self.wire.state().spins = 0;
        // The host keeps its lease in wall time (as on the QEMU board).
        self.service
            .ctrl
            .set_lease_clock(self.started.elapsed().as_micros() as u64);
        self.link.set_vbus(self.vbus);
        let next = self.service.poll(&mut self.link, self.now_us);
        self.steps += 1;
        // The clock jumps to the controller's next tick, as on the QEMU board; with
        // nothing scheduled a USB frame's time passes.
        self.now_us = match next {
            Some(at) => self.now_us.max(at),
            None => self.now_us + IDLE_STEP_US,
        };
        next.is_some() || self.service.sending()
    }

    /// Runs the device alone (the host sends no tokens) for `us` of simulated time.
    pub fn run_device_for(&mut self, us: u64) {
        let until = self.now_us + us;
        while self.now_us < until {
            self.step();
            assert!(self.steps < 50_000_000, "simulation ran away");
        }
    }
}
