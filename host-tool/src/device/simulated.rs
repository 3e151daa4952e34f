//! Simulated goniometers on the host: the brdf-core controller with simulated arms and
//! a virtual sample, run by the same service loop as the firmware, reachable either
//! in-process (a [`Transport`] and its [`InProcessConnector`], for `gonio simulate` and
//! `gonio demo`) or on a pseudo-terminal (for trying `gonio capture --port` without hardware, and for tests).
//! Time is simulated: waits cost no wall time.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{self, Read, Write};
use std::os::fd::{AsRawFd, FromRawFd};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use brdf_core::controller::{Detector, DetectorError};
use brdf_core::identity::FIRMWARE_VERSION;
use brdf_core::presets::Preset;
use brdf_core::protocol::Specimen;
use brdf_core::service::{Link, Service};
use brdf_core::sim::{SIM_K, SampleSource, SimArm, SimPin, VirtualSample, simulated_controller};

use super::link::{Connector, FramedLink, LinkError, Transport};
use super::replay::Replay;

/// The simulated controller type.
pub type SimService = Service<SimArm, SimArm, SimPin, SimDetector>;

/// How far (degrees) an arm may stop outside a certified table and still read its edge.
const TABLE_EDGE_TOL_DEG: f64 = 0.05;

/// The simulated device's detector: brdf-core's virtual sample (the sample, and a
/// Lambertian standard as on the QEMU board), or, with a certified-table standard
/// mounted, that standard's reflectance factor at the arms' angles: it reads
/// K R(theta_i, theta_r) / pi (K = [`SIM_K`]) times the same noise as the Lambertian
/// standard, so `gonio calibrate --standard table:FILE` on its sweep recovers K.
#[derive(Debug, Clone)]
pub struct SimDetector {
    sample: VirtualSample<Sample>,
    table: Option<Arc<crate::calibrate::Standard>>,
}

impl Detector for SimDetector {
    fn sample(&mut self, theta_i: f32, theta_r: f32, laser_on: bool) -> Result<f32, DetectorError> {
        let s = &mut self.sample;
        match &self.table {
            Some(t) if s.mounted == Specimen::Reference => {
                let clean = if laser_on {
                    let r = t
                        .factor_within(theta_i.into(), theta_r.into(), TABLE_EDGE_TOL_DEG)
                        .ok_or(DetectorError)?;
                    (f64::from(SIM_K) * r / std::f64::consts::PI) as f32 + s.dark
                } else {
                    s.dark
                };
                let x = clean * (1.0 + s.noise * s.reference_rng.normal());
                Ok(s.clip(x))
            }
            _ => s.sample(theta_i, theta_r, laser_on),
        }
    }

    fn take_saturated(&mut self) -> u32 {
        self.sample.take_saturated()
    }

    fn mount(&mut self, specimen: Specimen) -> Result<(), DetectorError> {
        if self.table.is_some() {
            self.sample.mounted = specimen;
            return Ok(());
        }
        self.sample.mount(specimen)
    }
}

/// What the simulated device's sample shows the detector: one virtual sample, two
/// sources.
#[derive(Debug, Clone)]
pub enum Sample {
    /// A preset's model (`gonio simulate --material`).
    Preset(&'static Preset),
    /// A measured sweep, replayed (`gonio simulate --replay`).
    Replay(Arc<Replay>),
    /// Any other source: a sample seen through injected instrument errors
    /// (`gonio simulate --inject`: the uncertainty engine's injection).
    Other(OtherSample),
}

/// A [`SampleSource`] the device module does not know (shared between threads).
#[derive(Clone)]
pub struct OtherSample(pub Arc<dyn SampleSource + Send + Sync>);

impl std::fmt::Debug for OtherSample {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("OtherSample")
    }
}

impl SampleSource for Sample {
    fn reading(&self, theta_i: f32, theta_r: f32) -> Result<f32, DetectorError> {
        match self {
            Sample::Preset(p) => p.reading(theta_i, theta_r),
            Sample::Replay(r) => r.as_ref().reading(theta_i, theta_r),
            Sample::Other(o) => o.0.reading(theta_i, theta_r),
        }
    }

    fn noise(&self, theta_i: f32, theta_r: f32) -> Option<f32> {
        match self {
            Sample::Preset(p) => p.noise(theta_i, theta_r),
            Sample::Replay(r) => r.as_ref().noise(theta_i, theta_r),
            Sample::Other(o) => o.0.noise(theta_i, theta_r),
        }
    }
}

/// What the simulated device measures.
#[derive(Debug, Clone)]
pub struct SimConfig {
    /// The sample.
    pub sample: Sample,
    /// Relative noise of each detector sample (0.005 = 0.5 %).
    pub noise: f32,
    /// Seed of the deterministic noise.
    pub seed: u32,
    /// Firmware version the simulated device reports.
    pub firmware: [u8; 3],
    /// On a pty: run this many times faster than real time, or slower when the machine
    /// cannot keep up (device time never skips ahead of the controller) (`None`: as
    /// fast as possible, waits cost nothing). In-process devices always run as fast as possible.
    pub speed: Option<f64>,
    /// A Lambertian reference standard of this reflectance factor beside the sample
    /// (`Mount(Reference)` puts it in the beam; see `brdf_core::sim::SIM_K`).
    pub reference: Option<f32>,
    /// A standard given by its certified table instead (any [`crate::calibrate::Standard`]:
    /// the device reads K times its stated BRDF; wins over `reference`). Host-side only:
    /// the QEMU board carries the Lambertian standard.
    pub reference_table: Option<Arc<crate::calibrate::Standard>>,
    /// The detector clips at this reading (its conversions at full scale are flagged,
    /// `Event::Saturated`); `None`: it never clips.
    pub full_scale: Option<f32>,
}

impl SimConfig {
    /// A simulated device measuring `preset` with relative `noise`.
    pub fn new(preset: &'static Preset, noise: f32, seed: u32) -> Self {
        Self::of(Sample::Preset(preset), noise, seed)
    }

    /// A simulated device measuring `sample` with relative `noise` (where the sample
    /// states none).
    pub fn of(sample: Sample, noise: f32, seed: u32) -> Self {
        SimConfig {
            sample,
            noise,
            seed,
            firmware: FIRMWARE_VERSION,
            speed: None,
            reference: None,
            reference_table: None,
            full_scale: None,
        }
    }

    fn service(&self) -> SimService {
        let mut sample = VirtualSample::new(self.sample.clone(), self.noise, self.seed);
        if let Some(r) = self.reference {
            sample = sample.with_reference(r);
        }
        sample.full_scale = self.full_scale;
        let detector = SimDetector {
            sample,
            table: self.reference_table.clone(),
        };
        Service::new(simulated_controller("sim", self.firmware, detector))
    }
}

struct Queues<'a> {
    rx: &'a mut VecDeque<u8>,
    tx: &'a mut VecDeque<u8>,
}

impl Link for Queues<'_> {
    fn read(&mut self, buf: &mut [u8]) -> usize {
        let n = buf.len().min(self.rx.len());
        for (b, x) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *b = x;
        }
        n
    }

    fn write(&mut self, bytes: &[u8]) -> usize {
        self.tx.extend(bytes);
        bytes.len()
    }
}

/// A simulated device in this process, on simulated time.
pub struct InProcessDevice {
    service: SimService,
    to_device: VecDeque<u8>,
    from_device: VecDeque<u8>,
    now_us: u64,
}

impl InProcessDevice {
    /// A fresh device (arms not homed).
    pub fn new(cfg: &SimConfig) -> Self {
        let mut service = cfg.service();
        // The device runs only inside the host's `recv`, so it can never outlive a
        // silent host: its lease clock stands still (the lease is tested on the pty
        // device, in brdf-core and on the QEMU board).
        service.ctrl.set_lease_clock(0);
        InProcessDevice {
            service,
            to_device: VecDeque::new(),
            from_device: VecDeque::new(),
            now_us: 0,
        }
    }
}

impl Transport for InProcessDevice {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.to_device.extend(bytes);
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        // Run the device until it has something to say; with nothing to do, wait like
        // a quiet device would (bounded by a millisecond so callers stay responsive).
        for _ in 0..1_000_000 {
            if !self.from_device.is_empty() {
                let n = buf.len().min(self.from_device.len());
                for (b, x) in buf.iter_mut().zip(self.from_device.drain(..n)) {
                    *b = x;
                }
                return Ok(n);
            }
            let mut q = Queues {
                rx: &mut self.to_device,
                tx: &mut self.from_device,
            };
            match self.service.poll(&mut q, self.now_us) {
                Some(at) => self.now_us = self.now_us.max(at),
                None if self.from_device.is_empty() && self.to_device.is_empty() => {
                    std::thread::sleep(timeout.min(Duration::from_millis(1)));
                    return Ok(0);
                }
                None => {}
            }
        }
        Ok(0)
    }
}

/// A simulated device serving a pseudo-terminal from a thread. Dropping it closes the
/// pty, which the other end sees as an unplugged device.
pub struct PtyDevice {
    path: PathBuf,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl PtyDevice {
    /// Opens a pty pair and starts serving it. The slave path is [`PtyDevice::path`].
    pub fn start(cfg: &SimConfig) -> io::Result<Self> {
        use nix::fcntl::{FcntlArg, FdFlag, OFlag, fcntl};
        use nix::sys::termios::{SetArg, cfmakeraw, tcgetattr, tcsetattr};
        let pty = nix::pty::openpty(None, None).map_err(io::Error::from)?;
        // SAFETY: openpty returned two fresh descriptors that nothing else owns.
        let (master, slave) =
            unsafe { (File::from_raw_fd(pty.master), File::from_raw_fd(pty.slave)) };
        let mut t = tcgetattr(slave.as_raw_fd()).map_err(io::Error::from)?;
        cfmakeraw(&mut t);
        tcsetattr(slave.as_raw_fd(), SetArg::TCSANOW, &t).map_err(io::Error::from)?;
        fcntl(master.as_raw_fd(), FcntlArg::F_SETFL(OFlag::O_NONBLOCK)).map_err(io::Error::from)?;
        // Not inherited by child processes: a child holding the master would keep the
        // pty alive after the device is dropped, and clients would never see it go.
        for fd in [master.as_raw_fd(), slave.as_raw_fd()] {
            fcntl(fd, FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).map_err(io::Error::from)?;
        }
        let path = nix::unistd::ttyname(slave.as_raw_fd()).map_err(io::Error::from)?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let mut service = cfg.service();
        let speed = cfg.speed.filter(|s| s.is_finite() && *s > 0.0);
        let thread = std::thread::spawn(move || {
            // The slave stays open here too, so reads of the master do not fail while
            // no client has the port open.
            let _slave = slave;
            let mut port = PtyMaster(master);
            let started = std::time::Instant::now();
            let mut now_us = 0u64;
            // When the controller asked to be called again (None: idle).
            let mut next_at: Option<u64> = None;
            while !flag.load(Ordering::Relaxed) {
                if let Some(speed) = speed {
                    let wall = (started.elapsed().as_secs_f64() * speed * 1e6) as u64;
                    // A thread starved of CPU (a loaded machine) does not skip device
                    // time: the clock goes no further than the controller's next
                    // wake-up, so the device runs slower instead of timing out its
                    // homing with the arms still on their way.
                    now_us = now_us.max(next_at.map_or(wall, |at| wall.min(at)));
                }
                // The host keeps its lease in wall time, whatever the device's clock.
                service
                    .ctrl
                    .set_lease_clock(started.elapsed().as_micros() as u64);
                let poll = service.poll(&mut port, now_us);
                next_at = poll;
                match (poll, speed) {
                    (Some(at), None) => now_us = now_us.max(at),
                    (Some(at), Some(speed)) if at > now_us => {
                        let wall = Duration::from_secs_f64((at - now_us) as f64 / speed / 1e6);
                        port.wait_readable(wall.min(Duration::from_millis(20)));
                    }
                    (Some(_), Some(_)) => {}
                    (None, _) => port.wait_readable(Duration::from_millis(20)),
                }
                if service.sending() {
                    // The client is not reading: do not spin.
                    std::thread::sleep(Duration::from_millis(1));
                }
            }
        });
        Ok(PtyDevice {
            path,
            stop,
            thread: Some(thread),
        })
    }

    /// The pty path to open (e.g. `/dev/pts/3`).
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for PtyDevice {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

struct PtyMaster(File);

impl PtyMaster {
    fn wait_readable(&self, timeout: Duration) {
        use nix::poll::{PollFd, PollFlags, poll};
        let mut fds = [PollFd::new(self.0.as_raw_fd(), PollFlags::POLLIN)];
        let _ = poll(&mut fds, timeout.as_millis() as i32);
    }
}

impl Link for PtyMaster {
    fn read(&mut self, buf: &mut [u8]) -> usize {
        self.0.read(buf).unwrap_or(0)
    }

    fn write(&mut self, bytes: &[u8]) -> usize {
        self.0.write(bytes).unwrap_or(0)
    }
}

/// The in-process simulated device (cannot get lost).
pub struct InProcessConnector(Option<InProcessDevice>);

impl Connector for InProcessConnector {
    type T = InProcessDevice;

    fn connect(&mut self) -> Result<FramedLink<InProcessDevice>, LinkError> {
        self.0
            .take()
            .map(FramedLink::new)
            .ok_or(LinkError::Timeout("the simulated device is gone"))
    }

    fn can_reconnect(&self) -> bool {
        false
    }
}

impl InProcessConnector {
    /// Wraps a simulated device.
    pub fn new(device: InProcessDevice) -> Self {
        InProcessConnector(Some(device))
    }
}

/// An in-process simulated device that several captures connect to in turn (a session:
/// the reference standard, then the sample, on the same device). Each `connect` is a
/// new link to the same device; it cannot get lost, so never reconnects.
pub struct SharedInProcessConnector(Arc<std::sync::Mutex<InProcessDevice>>);

/// A link's handle on a [`SharedInProcessConnector`]'s device.
pub struct SharedInProcessDevice(Arc<std::sync::Mutex<InProcessDevice>>);

impl SharedInProcessConnector {
    /// Wraps a simulated device.
    pub fn new(device: InProcessDevice) -> Self {
        SharedInProcessConnector(Arc::new(std::sync::Mutex::new(device)))
    }
}

impl Transport for SharedInProcessDevice {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.0.lock().map_err(|_| io::ErrorKind::Other)?.send(bytes)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.0
            .lock()
            .map_err(|_| io::ErrorKind::Other)?
            .recv(buf, timeout)
    }
}

impl Connector for SharedInProcessConnector {
    type T = SharedInProcessDevice;

    fn connect(&mut self) -> Result<FramedLink<SharedInProcessDevice>, LinkError> {
        Ok(FramedLink::new(SharedInProcessDevice(self.0.clone())))
    }

    fn can_reconnect(&self) -> bool {
        false
    }
}
