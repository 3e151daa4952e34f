//! The one way gonio writes an output file: the target checked first, a private
//! temporary file beside it, fsync, rename; nothing half-written is ever left under the
//! name asked for, nor a temporary file after an error or Ctrl-C.
//!
//! Rules every writer (exports, plots, the sweep file's creation, `bench`, `demo`) gets:
//! - a target whose directory does not exist is refused, naming the directory (unless
//!   the command creates that directory itself: [`Target::in_made_dir`]);
//! - a target that exists and is not a regular file (a device such as `/dev/null` or
//!   `/dev/stdout`, a symlink, a directory) is refused: gonio writes only regular files;
//! - a target that is one of the command's input files is refused
//!   (`gonio fit mine.csv --export csv=mine.csv`);
//! - an existing regular target is refused unless the command was given `--force`;
//! - the temporary file is created in the target's directory with a random name,
//!   `O_CREAT|O_EXCL|O_NOFOLLOW` and mode 0600 (the `tempfile` crate), synced, then
//!   renamed over the target (without `--force`: linked, so a file that appeared
//!   meanwhile is never replaced); the finished file then gets the mode a plain
//!   create would give it (0666 less the umask), so a lab's shared group or world
//!   read applies to plots, exports and sweeps, while nothing half-written is readable;
//! - it is removed on any error, and on SIGINT/SIGTERM in commands that do not handle
//!   Ctrl-C themselves.

use std::fmt;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use tempfile::NamedTempFile;

/// Why an output file was not written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum OutError {
    /// The target is not one gonio may write (bad input: not a regular file, an input
    /// file, or existing without `--force`). One line naming it.
    Refused(String),
    /// Creating, writing, syncing or renaming failed. One line naming the target.
    Io(String),
}

impl fmt::Display for OutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OutError::Refused(m) | OutError::Io(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for OutError {}

/// Where an output may go: the path, whether an existing file may be replaced, and the
/// command's input files (never overwritten).
#[derive(Debug, Clone, Copy)]
pub struct Target<'a> {
    /// The file to write.
    pub path: &'a Path,
    /// Replace an existing regular file.
    pub force: bool,
    /// The command's input files.
    pub inputs: &'a [&'a Path],
    /// The command creates the target's directory itself (`--plot DIR`,
    /// `mitsuba=DIR`, a campaign's `--out DIR`): a missing one is not refused.
    pub in_made_dir: bool,
}

impl<'a> Target<'a> {
    /// A target without inputs.
    pub fn new(path: &'a Path, force: bool) -> Self {
        Target {
            path,
            force,
            inputs: &[],
            in_made_dir: false,
        }
    }

    /// The same target, never one of `inputs`.
    pub fn inputs(self, inputs: &'a [&'a Path]) -> Self {
        Target { inputs, ..self }
    }

    /// The same target in a directory the command creates before writing it.
    pub fn in_made_dir(self) -> Self {
        Target {
            in_made_dir: true,
            ..self
        }
    }
}

/// The directory `path` is written into (`.` for a bare name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Checks `t` without writing anything: see the module rules. Commands call this for
/// every output before any work (before touching a device).
pub fn check(t: Target<'_>) -> Result<(), OutError> {
    let path = t.path;
    if path.as_os_str().is_empty() || path.as_os_str() == "-" {
        return Err(OutError::Refused(format!(
            "'{}' is not a file name (gonio writes files; reports go to stdout)",
            path.display()
        )));
    }
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        // (Not a directory: a file stands where the target's directory should be.)
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::NotFound | io::ErrorKind::NotADirectory
            ) =>
        {
            return check_dir(t);
        }
        Err(e) => return Err(OutError::Io(format!("{}: {e}", path.display()))),
    };
    if !meta.file_type().is_file() {
        let what = if meta.file_type().is_symlink() {
            "a symbolic link"
        } else if meta.is_dir() {
            "a directory"
        } else {
            "a device or special file"
        };
        return Err(OutError::Refused(format!(
            "{} is {what}, not a regular file: gonio writes only regular files (for stdout use the command's \
             own output, e.g. fit --json)",
            path.display()
        )));
    }
    for input in t.inputs {
        if let Ok(im) = std::fs::metadata(input)
            && im.dev() == meta.dev()
            && im.ino() == meta.ino()
        {
            return Err(OutError::Refused(format!(
                "{} is the input file {}: choose another output name",
                path.display(),
                input.display()
            )));
        }
    }
    // A sweep file a capture is writing (it holds the file's lock) is never replaced,
    // --force or not: the capture would go on writing into the replaced file's inode.
    if let Some(pid) = locked_by(path, &meta) {
        let who = pid.map_or("a running capture".to_string(), |p| {
            format!("a running capture (process {p})")
        });
        return Err(OutError::Refused(format!(
            "{} is being written by {who}: wait for it to end, or choose another output name",
            path.display()
        )));
    }
    if !t.force {
        return Err(OutError::Refused(format!(
            "{} exists: use --force to overwrite it",
            path.display()
        )));
    }
    Ok(())
}

/// Whether a process holds the lock a capture takes on the regular file `path`
/// (`Some`), and which when /proc/locks says (`Some(Some(pid))`).
fn locked_by(path: &Path, meta: &std::fs::Metadata) -> Option<Option<u32>> {
    use nix::fcntl::{FlockArg, flock};
    use std::os::fd::AsRawFd;
    let file = File::open(path).ok()?;
    match flock(file.as_raw_fd(), FlockArg::LockSharedNonblock) {
        // Ours for a moment; closing the file releases it.
        Ok(()) => None,
        Err(nix::errno::Errno::EWOULDBLOCK) => Some(lock_holder(meta.ino())),
        Err(_) => None,
    }
}

/// Why an exclusive lock was not taken ([`lock_exclusive`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LockError {
    /// Another process holds it: its PID, when /proc/locks says.
    Held(Option<u32>),
    /// The lock call itself failed.
    Failed(nix::errno::Errno),
}

impl LockError {
    /// "another process (process N)" style words for the holder: `what` names it.
    pub fn holder(self, what: &str) -> String {
        match self {
            LockError::Held(Some(pid)) => format!("{what} (process {pid})"),
            _ => what.to_string(),
        }
    }
}

/// Takes the exclusive, non-blocking `flock` of `file` (a sweep file a capture writes,
/// a campaign's output directory), held until `file` is closed; says who holds it
/// otherwise. The one lock of writers that must not run twice on one target.
pub fn lock_exclusive(file: &File) -> Result<(), LockError> {
    use nix::fcntl::{FlockArg, flock};
    use std::os::fd::AsRawFd;
    match flock(file.as_raw_fd(), FlockArg::LockExclusiveNonblock) {
        Ok(()) => Ok(()),
        Err(nix::errno::Errno::EWOULDBLOCK) => Err(LockError::Held(
            file.metadata().ok().and_then(|m| lock_holder(m.ino())),
        )),
        Err(e) => Err(LockError::Failed(e)),
    }
}

/// The process holding an flock on inode `ino`, from /proc/locks (Linux): lines such
/// as `1: FLOCK  ADVISORY  WRITE 4242 fd:01:1234567 0 EOF`.
fn lock_holder(ino: u64) -> Option<u32> {
    let text = std::fs::read_to_string("/proc/locks").ok()?;
    text.lines().find_map(|line| {
        let f: Vec<&str> = line.split_whitespace().collect();
        // Waiting requests are marked "->" and shift the fields: skip them.
        if f.len() < 6 || f[1] != "FLOCK" {
            return None;
        }
        let inode = f[5].rsplit(':').next()?.parse::<u64>().ok()?;
        (inode == ino).then(|| f[4].parse().ok()).flatten()
    })
}

/// A new target's directory must exist (and be one) unless the command makes it.
fn check_dir(t: Target<'_>) -> Result<(), OutError> {
    if t.in_made_dir {
        return Ok(());
    }
    let dir = parent_dir(t.path);
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => Err(OutError::Refused(format!(
            "cannot write {}: {} is not a directory",
            t.path.display(),
            dir.display()
        ))),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Err(OutError::Refused(format!(
            "cannot write {}: the directory {} does not exist (create it with mkdir -p {}, or choose another path)",
            t.path.display(),
            dir.display(),
            dir.display()
        ))),
        Err(e) => Err(OutError::Io(format!(
            "cannot write {}: {}: {e}",
            t.path.display(),
            dir.display()
        ))),
    }
}

/// Writes `t` through a buffered writer given to `body` (see the module rules).
pub fn write(
    t: Target<'_>,
    body: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), OutError> {
    write_with(t, "", |tmp| {
        let mut w = BufWriter::new(tmp.as_file_mut());
        body(&mut w)?;
        w.flush()
    })
    .map(drop)
}

/// Writes `t` by letting `fill` write the temporary file (by its handle, or by its
/// path, which ends in `.tmp` and `suffix`: for libraries that pick a format from the
/// extension),
/// then syncs and renames it. Returns the target, open, positioned at its end.
pub fn write_with(
    t: Target<'_>,
    suffix: &str,
    fill: impl FnOnce(&mut NamedTempFile) -> io::Result<()>,
) -> Result<File, OutError> {
    check(t)?;
    let path = t.path;
    let fail = |e: io::Error| write_error(path, e);
    let (mut tmp, guard) = temp_beside(path, suffix)?;
    let result = fill(&mut tmp).and_then(|()| tmp.as_file().sync_all());
    if let Err(e) = result {
        drop(tmp); // removes the file
        drop(guard);
        return Err(fail(e));
    }
    // Private while written; the user's umask once complete (see the module rules).
    tmp.as_file()
        .set_permissions(finished_mode())
        .map_err(fail)?;
    let persisted = if t.force {
        tmp.persist(path)
    } else {
        tmp.persist_noclobber(path)
    };
    drop(guard);
    let mut file = persisted.map_err(|e| rename_error(path, e.error))?;
    // The rename itself is durable once the directory is synced.
    if let Ok(d) = File::open(parent_dir(path)) {
        let _ = d.sync_all();
    }
    io::Seek::seek(&mut file, io::SeekFrom::End(0)).map_err(fail)?;
    Ok(file)
}

/// The one-line error of a failed write of `path`.
fn write_error(path: &Path, e: io::Error) -> OutError {
    OutError::Io(format!("cannot write {}: {e}", path.display()))
}

/// The error of a failed rename onto `path`: a file that appeared meanwhile is refused.
fn rename_error(path: &Path, e: io::Error) -> OutError {
    if e.kind() == io::ErrorKind::AlreadyExists {
        OutError::Refused(format!(
            "{} exists: use --force to overwrite it",
            path.display()
        ))
    } else {
        write_error(path, e)
    }
}

/// The mode a finished file gets: what a plain create would give it.
fn finished_mode() -> std::fs::Permissions {
    std::fs::Permissions::from_mode(0o666 & !umask())
}

/// A new private temporary file beside `path` (see the module rules), registered for
/// removal on a signal.
fn temp_beside(path: &Path, suffix: &str) -> Result<(NamedTempFile, Pending), OutError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Created and listed under the list's lock, which the signal handler holds while
    // it removes the files and exits: no temporary file is made that it misses.
    let mut list = pending().lock().unwrap_or_else(|p| p.into_inner());
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(&format!(".tmp{suffix}"))
        .tempfile_in(parent_dir(path))
        .map_err(|e| write_error(path, e))?;
    list.push(tmp.path().to_path_buf());
    let guard = Pending(tmp.path().to_path_buf());
    Ok((tmp, guard))
}

/// Many files written as one batch: each lands whole under its name, as with
/// [`write`], but the syncs are shared. Each file is written to its private temporary
/// file and closed; every `size` files (or at [`Batch::finish`]) the batch's contents
/// are made durable together (Linux: one `syncfs` of the filesystem holding them;
/// elsewhere an fsync per file), only then renamed to their names, and then each
/// directory synced once. So a name never shows a file half-written, not even after a
/// crash; an interrupted batch leaves nothing under its names (the temporary files are
/// removed, as [`write`]'s are), and once [`Batch::finish`] returns every file is durable.
/// A campaign of 400 reports syncs a few times instead of 800.
pub struct Batch {
    size: usize,
    staged: Mutex<Vec<Staged>>,
    failed: Mutex<Vec<(usize, OutError)>>,
}

/// A file of a [`Batch`] written to its temporary file, not yet renamed.
struct Staged {
    key: usize,
    tmp: tempfile::TempPath,
    path: PathBuf,
    force: bool,
    _pending: Pending,
}

impl Batch {
    /// A batch synced every `size` files (at least 1).
    pub fn new(size: usize) -> Self {
        Batch {
            size: size.max(1),
            staged: Mutex::new(Vec::new()),
            failed: Mutex::new(Vec::new()),
        }
    }

    /// Checks `t` (the module rules) and writes it through `body` into its temporary
    /// file; it is renamed when its part of the batch is synced. A rename refused
    /// then (a file that appeared meanwhile) or a failed sync is returned by
    /// [`Batch::finish`] under `key`. Callable from many threads.
    pub fn write(
        &self,
        key: usize,
        t: Target<'_>,
        body: impl FnOnce(&mut dyn Write) -> io::Result<()>,
    ) -> Result<(), OutError> {
        check(t)?;
        let (tmp, guard) = temp_beside(t.path, "")?;
        let written = {
            let mut w = BufWriter::new(tmp.as_file());
            body(&mut w).and_then(|()| w.flush())
        };
        if let Err(e) = written {
            return Err(write_error(t.path, e)); // (dropping tmp removes the file)
        }
        let staged = Staged {
            key,
            tmp: tmp.into_temp_path(),
            path: t.path.to_path_buf(),
            force: t.force,
            _pending: guard,
        };
        let full = {
            let mut s = self.staged.lock().unwrap_or_else(|p| p.into_inner());
            s.push(staged);
            (s.len() >= self.size).then(|| std::mem::take(&mut *s))
        };
        if let Some(files) = full {
            self.commit(files);
        }
        Ok(())
    }

    /// Syncs, renames and syncs the directories of the files not yet committed; the
    /// files that could not be committed, by key.
    pub fn finish(self) -> Vec<(usize, OutError)> {
        let rest = std::mem::take(&mut *self.staged.lock().unwrap_or_else(|p| p.into_inner()));
        self.commit(rest);
        std::mem::take(&mut *self.failed.lock().unwrap_or_else(|p| p.into_inner()))
    }

    /// The contents made durable, then the renames, then each directory synced once.
    fn commit(&self, files: Vec<Staged>) {
        if files.is_empty() {
            return;
        }
        let mut failed = Vec::new();
        let mut dirs: Vec<PathBuf> = Vec::new();
        for f in &files {
            let d = parent_dir(&f.path);
            if !dirs.iter().any(|x| x == d) {
                dirs.push(d.to_path_buf());
            }
        }
        let synced = sync_contents(&files, &dirs);
        for f in files {
            let path = f.path.clone();
            let done = synced
                .as_ref()
                .map_err(|e| write_error(&path, io::Error::new(e.kind(), e.to_string())))
                .and_then(|()| {
                    std::fs::set_permissions(&f.tmp, finished_mode())
                        .map_err(|e| write_error(&path, e))?;
                    let renamed = if f.force {
                        f.tmp.persist(&path)
                    } else {
                        f.tmp.persist_noclobber(&path)
                    };
                    renamed.map_err(|e| rename_error(&path, e.error))
                });
            if let Err(e) = done {
                failed.push((f.key, e));
            }
        }
        for d in &dirs {
            if let Ok(d) = File::open(d) {
                let _ = d.sync_all();
            }
        }
        if !failed.is_empty() {
            let mut all = self.failed.lock().unwrap_or_else(|p| p.into_inner());
            all.extend(failed);
        }
    }
}

/// Makes the staged files' contents durable: one `syncfs` per directory's filesystem
/// on Linux (one call for the batch), an fsync per file elsewhere.
fn sync_contents(files: &[Staged], dirs: &[PathBuf]) -> io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        let _ = files;
        let mut devices = Vec::new();
        for d in dirs {
            let dir = File::open(d)?;
            let dev = dir.metadata()?.dev();
            if !devices.contains(&dev) {
                devices.push(dev);
                nix::unistd::syncfs(dir.as_raw_fd()).map_err(io::Error::from)?;
            }
        }
        Ok(())
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = dirs;
        files
            .iter()
            .try_for_each(|f| File::open(&f.tmp)?.sync_all())
    }
}

/// The process's file-mode creation mask, read once: from /proc (which leaves it
/// alone), else by setting it to the strictest mask for the instant it is read back.
fn umask() -> u32 {
    static MASK: OnceLock<u32> = OnceLock::new();
    *MASK.get_or_init(|| {
        std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find_map(|l| l.strip_prefix("Umask:"))
                    .and_then(|v| u32::from_str_radix(v.trim(), 8).ok())
            })
            .unwrap_or_else(|| {
                use nix::sys::stat::{Mode, umask};
                let old = umask(Mode::from_bits_truncate(0o077));
                umask(old);
                old.bits()
            })
    })
}

/// Temporary files being written, removed by the signal handler.
fn pending() -> &'static Mutex<Vec<PathBuf>> {
    static PENDING: OnceLock<Mutex<Vec<PathBuf>>> = OnceLock::new();
    PENDING.get_or_init(|| {
        // Commands that handle Ctrl-C themselves (capture, simulate) installed their
        // handler first; then this one is not installed and their temporaries are
        // removed when the stopped command unwinds normally.
        let _ = ctrlc::set_handler(|| {
            // Exits holding the lock: no temporary file is created after these.
            let list = pending().lock().unwrap_or_else(|p| p.into_inner());
            for p in list.iter() {
                let _ = std::fs::remove_file(p);
            }
            eprintln!("gonio: interrupted; no partial output left");
            std::process::exit(130);
        });
        Mutex::new(Vec::new())
    })
}

/// A registered temporary file, unregistered when dropped.
struct Pending(PathBuf);

impl Drop for Pending {
    fn drop(&mut self) {
        if let Ok(mut list) = pending().lock() {
            list.retain(|p| p != &self.0);
        }
    }
}

/// A private scratch directory for unit tests (random name, mode 0700), kept until the
/// test removes it: never a predictable `/tmp` path.
#[cfg(test)]
pub(crate) fn test_dir(prefix: &str) -> PathBuf {
    tempfile::Builder::new()
        .prefix(&format!("gonio-{prefix}-"))
        .tempdir()
        .expect("a scratch directory")
        .keep()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp"))
            .collect()
    }

    #[test]
    fn a_file_a_capture_holds_is_never_replaced_even_with_force() {
        use nix::fcntl::{FlockArg, flock};
        use std::os::fd::AsRawFd;
        let dir = test_dir("locked");
        let path = dir.join("fe.csv");
        std::fs::write(&path, "theta_i,theta_r,brdf\n").unwrap();
        // The lock a capture's SweepWriter holds (another open file description).
        let holder = File::open(&path).unwrap();
        flock(holder.as_raw_fd(), FlockArg::LockExclusiveNonblock).unwrap();
        for force in [false, true] {
            let e = check(Target::new(&path, force)).unwrap_err().to_string();
            assert!(
                e.contains("being written by a running capture")
                    && e.contains(&format!("process {}", std::process::id())),
                "{e}"
            );
            let w = write(Target::new(&path, force), |w| w.write_all(b"x"));
            assert!(w.is_err());
        }
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "theta_i,theta_r,brdf\n"
        );
        drop(holder);
        write(Target::new(&path, true), |w| w.write_all(b"x")).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_batch_renames_only_synced_files_and_an_unfinished_one_leaves_nothing() {
        let d = tempfile::tempdir().unwrap();
        let name = |k: usize| d.path().join(format!("r{k}.txt"));
        let batch = Batch::new(3);
        for k in 0..5 {
            let body = format!("report {k}\n");
            batch
                .write(k, Target::new(&name(k), false), |w| {
                    w.write_all(body.as_bytes())
                })
                .unwrap();
        }
        // The first three were committed together; the last two wait, unnamed.
        assert!((0..3).all(|k| name(k).is_file()));
        assert!(!name(3).exists() && !name(4).exists());
        assert_eq!(leftovers(d.path()).len(), 2);
        // One appears meanwhile under a batch file's name: refused, left alone.
        std::fs::write(name(4), b"theirs").unwrap();
        let failed = batch.finish();
        assert_eq!(failed.len(), 1, "{failed:?}");
        assert_eq!(failed[0].0, 4);
        assert!(matches!(&failed[0].1, OutError::Refused(m) if m.contains("exists")));
        assert_eq!(std::fs::read(name(4)).unwrap(), b"theirs");
        for k in 0..4 {
            assert_eq!(
                std::fs::read_to_string(name(k)).unwrap(),
                format!("report {k}\n")
            );
            let mode = std::fs::metadata(name(k)).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o666 & !umask());
        }
        assert!(leftovers(d.path()).is_empty());
        // Interrupted (dropped before finish): nothing under any name, no temporary file.
        let e = tempfile::tempdir().unwrap();
        let batch = Batch::new(10);
        batch
            .write(0, Target::new(&e.path().join("a.txt"), false), |w| {
                w.write_all(b"a")
            })
            .unwrap();
        let e2 = batch.write(1, Target::new(&e.path().join("b.txt"), false), |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("disk full"))
        });
        assert!(matches!(e2, Err(OutError::Io(m)) if m.contains("disk full")));
        drop(batch);
        assert_eq!(std::fs::read_dir(e.path()).unwrap().count(), 0);
    }

    #[test]
    fn writes_refuses_existing_and_forces() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a.txt");
        write(Target::new(&p, false), |w| w.write_all(b"one")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"one");
        let e = write(Target::new(&p, false), |w| w.write_all(b"two")).unwrap_err();
        assert!(
            matches!(&e, OutError::Refused(m) if m.contains("--force")),
            "{e}"
        );
        assert_eq!(std::fs::read(&p).unwrap(), b"one");
        write(Target::new(&p, true), |w| w.write_all(b"two")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert!(leftovers(d.path()).is_empty());
    }

    #[test]
    fn refuses_special_files_symlinks_dirs_and_inputs() {
        let d = tempfile::tempdir().unwrap();
        let victim = d.path().join("victim");
        std::fs::write(&victim, b"keep").unwrap();
        let link = d.path().join("link");
        std::os::unix::fs::symlink(&victim, &link).unwrap();
        for (p, says) in [
            (Path::new("/dev/null"), "device"),
            (Path::new("/dev/stdout"), "not a regular file"),
            (link.as_path(), "symbolic link"),
            (d.path(), "directory"),
            (Path::new("-"), "not a file name"),
        ] {
            let e = write(Target::new(p, true), |w| w.write_all(b"x")).unwrap_err();
            assert!(
                matches!(&e, OutError::Refused(m) if m.contains(says)),
                "{}: {e}",
                p.display()
            );
        }
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
        let inputs = [victim.as_path()];
        let e = write(Target::new(&victim, true).inputs(&inputs), |w| {
            w.write_all(b"x")
        })
        .unwrap_err();
        assert!(e.to_string().contains("is the input file"), "{e}");
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
        assert!(leftovers(d.path()).is_empty());
    }

    #[test]
    fn a_failed_body_leaves_nothing() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("b.bin");
        let e = write(Target::new(&p, false), |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("disk full"))
        })
        .unwrap_err();
        assert!(
            matches!(&e, OutError::Io(m) if m.contains("disk full")),
            "{e}"
        );
        assert!(!p.exists());
        assert!(leftovers(d.path()).is_empty());
        // A predictable name planted beside the target is neither used nor touched.
        let planted = d.path().join("b.bin.tmp");
        std::os::unix::fs::symlink("/nonexistent-victim", &planted).unwrap();
        write(Target::new(&p, false), |w| w.write_all(b"ok")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"ok");
        assert!(std::fs::symlink_metadata(&planted).unwrap().is_symlink());
    }

    #[test]
    fn a_missing_directory_is_named_unless_the_command_makes_it() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("nodir").join("x.csv");
        let e = write(Target::new(&p, false), |w| w.write_all(b"x")).unwrap_err();
        let m = e.to_string();
        assert!(matches!(e, OutError::Refused(_)), "{m}");
        assert!(
            m.contains("directory") && m.contains("nodir") && m.contains("mkdir"),
            "{m}"
        );
        assert!(!m.contains(".x.csv."), "names gonio's temporary file: {m}");
        check(Target::new(&p, false).in_made_dir()).unwrap();
        let file = d.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        let e = check(Target::new(&file.join("x.csv"), false)).unwrap_err();
        assert!(e.to_string().contains("not a directory"), "{e}");
    }

    #[test]
    fn the_temporary_file_is_private_and_the_result_follows_the_umask() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("shared.csv");
        write_with(Target::new(&p, false), "", |tmp| {
            let mode = tmp.as_file().metadata()?.permissions().mode() & 0o777;
            assert_eq!(mode, 0o600, "the temporary file while written");
            tmp.as_file_mut().write_all(b"x")
        })
        .unwrap();
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        // What File::create would have given, whatever this process's umask is.
        let plain = d.path().join("plain");
        File::create(&plain).unwrap();
        let want = std::fs::metadata(&plain).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, want, "{mode:o} vs {want:o}");
        assert_eq!(mode, 0o666 & !umask());
    }
}
