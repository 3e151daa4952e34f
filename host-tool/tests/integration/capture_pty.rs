//! `gonio info` and `gonio capture` as a user runs them, against simulated devices on
//! pseudo-terminals: a full capture, Ctrl-C and --resume, a device that goes away and
//! comes back, one that never comes back, and a device of another protocol version.

use std::os::fd::{AsRawFd, FromRawFd};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use brdf_core::Preset;
use brdf_core::protocol::PROTOCOL_VERSION as V;
use gonio::device::{PtyDevice, SimConfig};
use gonio::sweep_file::read_sweep;

use crate::util::{Run, gonio_command, scratch};

/// The pty tests run one at a time. Pty numbers are reused: a capture reconnecting to
/// the path of a device that was dropped could open another test's new device (as
/// root, the tty's exclusive mode does not stop it), send it Abort, and end that test's
/// capture early. Ports are now also `flock`ed (`SerialTransport::open`), which binds
/// root, across test binaries and worktrees too.
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static PTYS: std::sync::Mutex<()> = std::sync::Mutex::new(());
    PTYS.lock().unwrap_or_else(|e| e.into_inner())
}

fn device(speed: Option<f64>) -> PtyDevice {
    let mut cfg = SimConfig::new(Preset::by_name("fe-0.115").unwrap(), 0.005, 5);
    cfg.speed = speed;
    PtyDevice::start(&cfg).unwrap()
}

/// The simulated device's pace (times real time) in the tests that unplug it after a few
/// readings: [`small_plan`]'s 200 ms settle is then 25 ms a reading, so the rest of the
/// sweep takes far longer than the test needs to notice the rows and unplug it, even on
/// a loaded machine (at 40x a loaded run once saw the capture finish first).
const PACE_MID_SWEEP: f64 = 8.0;

/// A small plan: 2 incidences x 17 detector angles.
fn small_plan(d: &Path) -> PathBuf {
    let p = d.join("plan.toml");
    std::fs::write(&p, "incidences = [20, 60]\ndetector = { start = -80, stop = 80, step = 10 }\nsettle_ms = 200\n").unwrap();
    p
}

fn rows_in(path: &Path) -> usize {
    std::fs::read(path)
        .map(|b| {
            gonio::sweep_file::parse_sweep(&b)
                .map(|d| d.rows.len())
                .unwrap_or(0)
        })
        .unwrap_or(0)
}

fn wait_rows(child: &mut Child, path: &Path, n: usize) {
    let deadline = Instant::now() + Duration::from_secs(60);
    while rows_in(path) < n {
        if child.try_wait().unwrap().is_some() {
            // Say why: the capture's own last words.
            let mut err = String::new();
            if let Some(mut e) = child.stderr.take() {
                let _ = std::io::Read::read_to_string(&mut e, &mut err);
            }
            panic!("capture ended early: {err}");
        }
        assert!(Instant::now() < deadline, "no {n} rows in time");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn finish(child: Child) -> Run {
    child.wait_with_output().unwrap().into()
}

fn seqs(path: &Path) -> Vec<u32> {
    read_sweep(path)
        .unwrap()
        .rows
        .iter()
        .map(|r| r.seq.unwrap())
        .collect()
}

/// `gonio config set` and `get` over a pty against the simulated device (brdf-core's
/// controller), and `gonio info` printing what it now uses.
#[test]
fn config_set_get_and_info_over_a_pty() {
    let _one = one_at_a_time();
    let dev = device(None);
    let port = dev.path().to_str().unwrap();
    let run = |args: &[&str]| -> Run { gonio_command().args(args).output().unwrap().into() };
    let set = run(&[
        "config",
        "set",
        "--port",
        port,
        "detector.microsteps=8",
        "source.home_switch=no",
    ]);
    assert!(set.ok(), "{}", set.stderr);
    for said in [
        "detector.microsteps = 8\n",
        "# detector: 40 microsteps/degree\n",
        "source.home_switch = no\n",
        "# source: 80 microsteps/degree\n",
    ] {
        assert!(set.stdout.contains(said), "{said}: {}", set.stdout);
    }
    let get = run(&["config", "get", "--port", port]);
    assert!(get.ok(), "{}", get.stderr);
    assert_eq!(get.stdout, set.stdout);
    let info = run(&["info", "--port", port]);
    assert!(info.ok(), "{}", info.stderr);
    assert!(
        info.stdout
            .contains("detector:  -90 .. 90 degrees, 40 microsteps/degree")
            && info.stdout.contains("settings (gonio config):\n")
            && info.stdout.contains("detector.microsteps = 8\n"),
        "{}",
        info.stdout
    );
    // Refused by the device (out of range): exit 1, one line, nothing changed.
    let bad = run(&["config", "set", "--port", port, "source.microsteps=3"]);
    assert_eq!(bad.code, 1, "{}", bad.stderr);
    assert!(
        bad.stderr.contains("refused the settings: microsteps"),
        "{}",
        bad.stderr
    );
    // A typo is bad usage, caught before anything is sent.
    let typo = run(&["config", "set", "--port", port, "source.microstep=3"]);
    assert_eq!(typo.code, 2, "{}", typo.stderr);
    assert!(
        typo.stderr.contains("unknown key 'source.microstep'"),
        "{}",
        typo.stderr
    );
    assert_eq!(run(&["config", "get", "--port", port]).stdout, set.stdout);
}

#[test]
fn info_and_a_full_capture_over_a_pty() {
    let _one = one_at_a_time();
    let dev = device(None);
    let port = dev.path().to_str().unwrap();
    let out: Run = gonio_command()
        .args(["info", "--port", port])
        .output()
        .unwrap()
        .into();
    assert!(out.ok(), "{}", out.last_line());
    let text = out.stdout.clone();
    assert!(
        text.contains(&format!("protocol:  {V} (this gonio: {V})"))
            && text.contains("-90 .. 90 degrees"),
        "{text}"
    );
    let d = scratch("full");
    let file = d.join("fe.csv");
    let raw = d.join("fe.raw");
    let out: Run = gonio_command()
        .args([
            "capture",
            "--port",
            port,
            "--out",
            file.to_str().unwrap(),
            "--raw",
            raw.to_str().unwrap(),
        ])
        .output()
        .unwrap()
        .into();
    assert!(out.ok(), "{}", out.last_line());
    assert!(
        out.last_line().contains("153/153 readings"),
        "{}",
        out.last_line()
    );
    assert_eq!(seqs(&file), (0..153).collect::<Vec<_>>());
    // The raw log holds every frame received: decoding it gives the 153 readings again.
    let bytes = std::fs::read(&raw).unwrap();
    let mut dec = brdf_core::frame::FrameDecoder::<{ brdf_core::frame::MAX_FRAME_LEN }>::new();
    let readings = bytes
        .iter()
        .filter_map(|&b| dec.push::<brdf_core::protocol::Event>(b))
        .filter(|r| matches!(r, Ok(brdf_core::protocol::Event::Reading(_))))
        .count();
    assert_eq!(readings, 153);
}

#[test]
fn ctrl_c_leaves_a_valid_file_and_resume_completes_it() {
    let _one = one_at_a_time();
    let dev = device(Some(40.0));
    let d = scratch("ctrlc");
    let file = d.join("s.csv");
    let plan = small_plan(&d);
    let mut child = gonio_command()
        .args([
            "capture",
            "--port",
            dev.path().to_str().unwrap(),
            "--plan",
            plan.to_str().unwrap(),
        ])
        .args(["--out", file.to_str().unwrap()])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_rows(&mut child, &file, 8);
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = finish(child);
    assert_eq!(out.code, 1, "{}", out.last_line());
    assert!(
        out.last_line().contains("interrupted:") && out.last_line().contains("--resume"),
        "{}",
        out.last_line()
    );
    let data = read_sweep(&file).unwrap();
    let got = data.rows.len();
    assert!((8..34).contains(&got), "{got}");
    assert!(
        data.meta["status"].starts_with("interrupted"),
        "{:?}",
        data.meta["status"]
    );
    let out: Run = gonio_command()
        .args([
            "capture",
            "--port",
            dev.path().to_str().unwrap(),
            "--resume",
            "--out",
            file.to_str().unwrap(),
        ])
        .output()
        .unwrap()
        .into();
    assert!(out.ok(), "{}", out.last_line());
    assert_eq!(
        seqs(&file),
        (0..34).collect::<Vec<_>>(),
        "each point once, none lost"
    );
}

#[test]
fn sigterm_and_sighup_stop_a_capture_like_ctrl_c() {
    let _one = one_at_a_time();
    for signal in ["-TERM", "-HUP"] {
        // Real time: the 34 points take about 10 s, so a device not sent Abort would
        // still be sweeping when gonio has exited.
        let dev = device(Some(1.0));
        let d = scratch("sigterm");
        let file = d.join("s.csv");
        let plan = small_plan(&d);
        let mut child = gonio_command()
            .args([
                "capture",
                "--port",
                dev.path().to_str().unwrap(),
                "--plan",
                plan.to_str().unwrap(),
            ])
            .args(["--out", file.to_str().unwrap()])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        wait_rows(&mut child, &file, 8);
        let status = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
        let out = finish(child);
        assert_eq!(out.code, 1, "{signal}: {}", out.last_line());
        assert!(
            out.last_line().contains("interrupted:"),
            "{}",
            out.last_line()
        );
        let data = read_sweep(&file).unwrap();
        assert!(
            data.meta["status"].starts_with("interrupted"),
            "{signal}: {:?}",
            data.meta["status"]
        );
        assert!((8..34).contains(&data.rows.len()));
        // Abort was sent: the device is idle at once, its laser off.
        assert_eq!(device_state(dev.path()), Ok(false), "{signal}: laser");
    }
}

/// Whether a device is idle (`Ok(laser on)`) or was still sweeping (`Err`), asked
/// with `Abort`: an idle device answers with its Status (laser as it is), a sweeping
/// one with the SweepDone of the sweep it was running.
fn device_state(port: &Path) -> Result<bool, String> {
    use brdf_core::protocol::{Command as Cmd, Event};
    use gonio::device::Connector;
    let mut link = gonio::device::SerialConnector::new(port.to_str().unwrap())
        .connect()
        .unwrap();
    link.send(&Cmd::Abort).unwrap();
    let deadline = Instant::now() + Duration::from_secs(3);
    while Instant::now() < deadline {
        match link.recv(Duration::from_millis(100)).unwrap() {
            Some(Event::Status(s)) => return Ok(s.laser),
            Some(Event::SweepDone(d)) => return Err(format!("still sweeping: {d:?}")),
            _ => {}
        }
    }
    Err("no answer".into())
}

#[test]
fn a_device_that_goes_away_and_comes_back_is_reconnected() {
    let _one = one_at_a_time();
    let d = scratch("reconnect");
    let link = d.join("port");
    let file = d.join("s.csv");
    let plan = small_plan(&d);
    let point = |dev: &PtyDevice| {
        let tmp = d.join("port.new");
        let _ = std::fs::remove_file(&tmp);
        std::os::unix::fs::symlink(dev.path(), &tmp).unwrap();
        std::fs::rename(&tmp, &link).unwrap(); // atomic re-point, like udev's by-id links
    };
    // Paced (PACE_MID_SWEEP) so that the unplug comes mid-sweep even under load.
    let first = device(Some(PACE_MID_SWEEP));
    point(&first);
    let mut child = gonio_command()
        .args([
            "capture",
            "--port",
            link.to_str().unwrap(),
            "--plan",
            plan.to_str().unwrap(),
        ])
        .args(["--out", file.to_str().unwrap(), "--reconnect", "20"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_rows(&mut child, &file, 10);
    drop(first); // unplugged
    std::thread::sleep(Duration::from_millis(700));
    let second = device(Some(40.0)); // plugged in again (fresh, not homed)
    point(&second);
    let out = finish(child);
    let err = out.stderr.clone();
    assert!(out.ok(), "{err}");
    assert!(
        err.contains("device lost") && err.contains("device is back"),
        "{err}"
    );
    // At least one reconnect: under load the capture may lose and regain the device
    // more than once before the second device answers (scheduling decides how often);
    // what matters is that it came back and lost nothing.
    let reconnects = out
        .last_line()
        .split_whitespace()
        .collect::<Vec<_>>()
        .windows(2)
        .find(|w| w[1].starts_with("reconnect"))
        .and_then(|w| w[0].parse::<u32>().ok());
    assert!(
        out.last_line().contains("34/34 readings") && reconnects.is_some_and(|n| n >= 1),
        "{err}"
    );
    assert_eq!(seqs(&file), (0..34).collect::<Vec<_>>());
    drop(second);
}

#[test]
fn a_device_that_does_not_come_back_ends_with_a_clear_message() {
    let _one = one_at_a_time();
    let d = scratch("gone");
    let file = d.join("s.csv");
    let plan = small_plan(&d);
    let dev = device(Some(PACE_MID_SWEEP));
    let mut child = gonio_command()
        .args([
            "capture",
            "--port",
            dev.path().to_str().unwrap(),
            "--plan",
            plan.to_str().unwrap(),
        ])
        .args(["--out", file.to_str().unwrap(), "--reconnect", "1"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_rows(&mut child, &file, 5);
    drop(dev);
    let out = finish(child);
    assert_eq!(out.code, 1);
    let last = out.last_line();
    assert!(
        last.contains("device lost")
            && last.contains("not back within 1 s")
            && last.contains("--resume"),
        "{last}"
    );
    let data = read_sweep(&file).unwrap();
    assert!(
        data.rows.len() >= 5 && data.meta["status"].starts_with("failed"),
        "{:?}",
        data.meta
    );
}

/// A fake device that answers Ping and GetInfo like a device of protocol `version`
/// whose Info has fields this gonio does not know.
fn foreign_device(version: u16) -> (PathBuf, std::thread::JoinHandle<()>) {
    let mut out = [0u8; 256];
    let n = brdf_core::frame::encode(
        &(0u8, version, [1u8, 2, 3], "v-next board", 42u64),
        &mut out,
    )
    .unwrap();
    device_answering_info_with(out[..n].to_vec())
}

/// A device on a pty that answers Ping and, to GetInfo, the frame `info`.
fn device_answering_info_with(info: Vec<u8>) -> (PathBuf, std::thread::JoinHandle<()>) {
    use brdf_core::frame::{FrameDecoder, MAX_FRAME_LEN, encode};
    use brdf_core::protocol::{Command as Cmd, Event};
    use std::io::{Read, Write};
    let pty = nix::pty::openpty(None, None).unwrap();
    let mut t = nix::sys::termios::tcgetattr(pty.slave).unwrap();
    nix::sys::termios::cfmakeraw(&mut t);
    nix::sys::termios::tcsetattr(pty.slave, nix::sys::termios::SetArg::TCSANOW, &t).unwrap();
    let path = nix::unistd::ttyname(pty.slave).unwrap();
    for fd in [pty.master, pty.slave] {
        nix::fcntl::fcntl(
            fd,
            nix::fcntl::FcntlArg::F_SETFD(nix::fcntl::FdFlag::FD_CLOEXEC),
        )
        .unwrap();
    }
    // SAFETY: fresh descriptors from openpty, owned here only.
    let (mut master, slave) = unsafe {
        (
            std::fs::File::from_raw_fd(pty.master),
            std::fs::File::from_raw_fd(pty.slave),
        )
    };
    let h = std::thread::spawn(move || {
        let _slave = slave;
        let mut dec = FrameDecoder::<MAX_FRAME_LEN>::new();
        let mut buf = [0u8; 256];
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut out = [0u8; 256];
        while Instant::now() < deadline {
            let mut fds = [nix::poll::PollFd::new(
                master.as_raw_fd(),
                nix::poll::PollFlags::POLLIN,
            )];
            if nix::poll::poll(&mut fds, 50).unwrap_or(0) == 0 {
                continue;
            }
            let Ok(n) = master.read(&mut buf) else { return };
            for &b in &buf[..n] {
                match dec.push::<Cmd>(b) {
                    Some(Ok(Cmd::Ping(t))) => {
                        let n = encode(&Event::Pong(t), &mut out).unwrap();
                        let _ = master.write_all(&out[..n]);
                    }
                    Some(Ok(Cmd::GetInfo)) => {
                        let _ = master.write_all(&info);
                    }
                    _ => {}
                }
            }
        }
    });
    (path, h)
}

#[test]
fn protocol_mismatch_says_which_side_to_update() {
    let _one = one_at_a_time();
    for (version, advice) in [
        (V + 1, "update gonio"),
        (V - 1, "update the firmware (gonio flash)"),
    ] {
        let (path, h) = foreign_device(version);
        let out: Run = gonio_command()
            .args(["info", "--port", path.to_str().unwrap(), "--timeout", "5"])
            .output()
            .unwrap()
            .into();
        assert_eq!(out.code, 1);
        let err = out.stderr.clone();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.contains(&format!(
                "device speaks protocol v{version}, this gonio speaks v{V}: {advice}"
            )),
            "{err}"
        );
        drop(h);
    }
}

#[test]
fn an_info_of_this_version_that_does_not_decode_gets_no_version_advice() {
    let _one = one_at_a_time();
    // The foreign device's Info body after the version is not this protocol's Info.
    let (path, h) = foreign_device(V);
    let t0 = Instant::now();
    let out: Run = gonio_command()
        .args(["info", "--port", path.to_str().unwrap(), "--timeout", "2"])
        .output()
        .unwrap()
        .into();
    assert!(
        t0.elapsed() < Duration::from_secs(6),
        "bounded by --timeout"
    );
    assert_eq!(out.code, 1);
    let err = out.stderr.clone();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("does not decode"), "{err}");
    assert!(
        !err.contains("update"),
        "no version advice when versions agree: {err}"
    );
    drop(h);
}

#[test]
fn info_prints_device_text_escaped() {
    use brdf_core::protocol::{ArmLimits, Event, Info, MAX_SWEEP_POINTS, PROTOCOL_VERSION};
    let _one = one_at_a_time();
    let limits = ArmLimits {
        min_deg: 0.0,
        max_deg: 90.0,
        steps_per_deg: 80.0,
    };
    let info = Event::Info(Info {
        protocol: PROTOCOL_VERSION,
        firmware: [0, 1, 0],
        board: heapless::String::try_from("x\n0,0,1\u{1b}[2J").unwrap(),
        source: limits,
        detector: ArmLimits {
            min_deg: -90.0,
            ..limits
        },
        max_points: MAX_SWEEP_POINTS,
        homed: true,
    });
    let mut buf = [0u8; 256];
    let n = brdf_core::frame::encode(&info, &mut buf).unwrap();
    let (path, h) = device_answering_info_with(buf[..n].to_vec());
    let out: Run = gonio_command()
        .args(["info", "--port", path.to_str().unwrap(), "--timeout", "5"])
        .output()
        .unwrap()
        .into();
    assert!(out.ok(), "{}", out.stderr);
    let text = out.stdout.clone();
    assert!(!text.contains('\u{1b}'), "{text:?}");
    let device = text.lines().next().unwrap();
    assert!(device.starts_with("device:    x\\n0,0,1"), "{device:?}");
    // Seven lines of Info, then the status and settings lines: this fake device
    // answers only Info.
    assert_eq!(text.lines().count(), 9, "{text}");
    assert_eq!(
        text.lines().skip(7).collect::<Vec<_>>(),
        [
            "status:    no answer to GetStatus",
            "settings:  the device did not answer with its settings in time"
        ],
        "{text}"
    );
    drop(h);
}
