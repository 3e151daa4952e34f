//! Test harness: builds the firmware images, and runs the `qemu` one under QEMU with
//! its USART on a pseudo-terminal, killing QEMU when the handle drops.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The `qemu` board's ELF: `$GONIO_QEMU_ELF` if set (xtask sets it; a relative path
/// is taken from the repository root, since tests run in their package directory),
/// otherwise built here with the same command `cargo xtask firmware --board qemu` runs.
pub fn qemu_elf() -> PathBuf {
    board_elf("qemu", "GONIO_QEMU_ELF")
}

/// The `stm32f411` board's ELF (what `gonio flash` flashes): `$GONIO_STM32F411_ELF` if
/// set, otherwise built here, as [`qemu_elf`] does.
pub fn stm32f411_elf() -> PathBuf {
    board_elf("stm32f411", "GONIO_STM32F411_ELF")
}

/// A board's release ELF: `$var` if set (relative to the repository root), otherwise
/// built with `cargo xtask firmware --board BOARD`'s command.
fn board_elf(board: &str, var: &str) -> PathBuf {
    if let Some(p) = std::env::var_os(var) {
        let p = root().join(p);
        assert!(p.is_file(), "{var}={} is not a file", p.display());
        return p;
    }
    let fw = root().join("firmware");
    let status = Command::new("cargo")
        .args(["build", "--release", "--bin", board, "--features", board])
        .current_dir(&fw)
        .status()
        .expect("run cargo to build the firmware");
    assert!(
        status.success(),
        "building the {board} firmware failed (`cargo xtask firmware --board {board}` installs the thumb target and flip-link)"
    );
    fw.join("target/thumbv7em-none-eabihf/release").join(board)
}

/// A running QEMU with the firmware; killed on drop.
pub struct Qemu {
    child: Child,
    /// The pseudo-terminal QEMU connected USART1 to.
    pub pty: String,
    /// Lines QEMU printed on stdout/stderr after the pty line (semihosting output).
    pub output: mpsc::Receiver<String>,
}

impl Qemu {
    /// Starts QEMU (`netduinoplus2`) with `elf`, waits for the pty path (10 s at most).
    /// Every QEMU is killed after `limit` even if the test hangs.
    pub fn start(elf: &Path, limit: Duration) -> Qemu {
        // QEMU prints its pty line before it loads the kernel, so check the file first.
        assert!(
            elf.is_file(),
            "firmware image {} does not exist",
            elf.display()
        );
        let mut child = Command::new("timeout")
            .arg("--signal=KILL")
            .arg(format!("{}", limit.as_secs().max(1)))
            .arg("qemu-system-arm")
            .args(["-M", "netduinoplus2", "-display", "none", "-monitor", "none", "-serial", "pty"])
            .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
            .arg(elf)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start qemu-system-arm (install it: apt-get install qemu-system-arm, or cargo xtask setup)");
        let (tx, rx) = mpsc::channel();
        for stream in [
            Box::new(child.stdout.take().unwrap()) as Box<dyn std::io::Read + Send>,
            Box::new(child.stderr.take().unwrap()),
        ] {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(stream).lines().map_while(Result::ok) {
                    if tx.send(line).is_err() {
                        break;
                    }
                }
            });
        }
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut seen = Vec::new();
        while Instant::now() < deadline {
            if let Ok(line) = rx.recv_timeout(Duration::from_millis(100)) {
                // "char device redirected to /dev/pts/N (label serial0)"
                if let Some(rest) = line.split("redirected to ").nth(1) {
                    let pty = rest.split_whitespace().next().unwrap().to_string();
                    return Qemu {
                        child,
                        pty,
                        output: rx,
                    };
                }
                seen.push(line);
            }
            if let Ok(Some(status)) = child.try_wait() {
                panic!("qemu exited ({status}) before giving a pty: {seen:?}");
            }
        }
        let _ = child.kill();
        let _ = child.wait();
        panic!("qemu printed no pty path within 10 s: {seen:?}");
    }

    /// True while QEMU runs.
    pub fn running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        // SIGTERM to `timeout`, which forwards it to QEMU (a SIGKILL would orphan QEMU);
        // SIGKILL only if that did not end it within 2 s.
        let _ = Command::new("kill")
            .arg("-TERM")
            .arg(self.child.id().to_string())
            .status();
        let deadline = Instant::now() + Duration::from_secs(2);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
