//! A campaign's checks before any fitting: report names the user did not choose, free
//! space for its reports, and its `--out` directory locked against a concurrent
//! campaign.

use std::fs::File;
use std::path::{Path, PathBuf};

use crate::outfile;

/// Bytes a report takes at most, estimated: a fixed part (the physical checks, the
/// notes) and a part per byte of its sweep (parameters per incidence, residual
/// tables). Measured: a 7 kB paper sweep gives a 9 kB text and a 71 kB JSON report;
/// the golden corpus's largest JSON report is 159 kB.
fn report_estimate(sweep_bytes: u64, ext: &str) -> u64 {
    match ext {
        "json" => (64 << 10) + 8 * sweep_bytes,
        _ => (16 << 10) + 2 * sweep_bytes,
    }
}

/// The estimate is doubled: a campaign must not fill the disk to its last byte.
const SPACE_MARGIN: u64 = 2;

/// The space a campaign's reports of `inputs` (`ext` reports) and summaries need in
/// its output directory, with [`SPACE_MARGIN`] (bytes).
pub fn space_needed(inputs: &[PathBuf], ext: &str) -> u64 {
    let reports: u64 = inputs
        .iter()
        .map(|p| report_estimate(std::fs::metadata(p).map_or(0, |m| m.len()), ext))
        .sum();
    // summary.csv and summary.json: a few hundred bytes a file.
    let summaries = 1024 * inputs.len() as u64;
    SPACE_MARGIN.saturating_mul(reports.saturating_add(summaries))
}

/// Refuses a campaign whose reports need `needed` bytes where `free` are available
/// to the user in `dir`, saying both.
pub fn space_problem(dir: &Path, needed: u64, free: u64) -> Result<(), String> {
    if needed <= free {
        return Ok(());
    }
    let mib = |b: u64| b as f64 / f64::from(1 << 20);
    Err(format!(
        "{}: the reports need about {:.1} MiB (twice their estimated size) but {:.1} MiB are free: free space, or write them elsewhere with --out",
        dir.display(),
        mib(needed),
        mib(free)
    ))
}

/// Bytes free to an unprivileged user on the file system of `dir`, or of its nearest
/// existing ancestor (a campaign creates `--out`); `None` where statvfs cannot say.
pub fn free_bytes(dir: &Path) -> Option<u64> {
    let mut d = dir;
    loop {
        if d.exists() {
            break;
        }
        d = match d.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        if d == Path::new(".") {
            break;
        }
    }
    let s = nix::sys::statvfs::statvfs(d).ok()?;
    Some(s.blocks_available().saturating_mul(s.fragment_size()))
}

/// Checks before any fitting that `dir` has room for the reports of `inputs` (`ext`
/// reports) and the summaries ([`space_needed`]).
pub fn check_space(dir: &Path, inputs: &[PathBuf], ext: &str) -> Result<(), String> {
    match free_bytes(dir) {
        Some(free) => space_problem(dir, space_needed(inputs, ext), free),
        None => Ok(()),
    }
}

/// One line per input whose report name is not its own stem's, because an earlier
/// input has the same stem ([`super::report_names`] numbers them): which two
/// inputs, which names, and what to do. Said before any fitting, so that a report
/// name refused later is one the user was told of.
pub fn renamed_reports(inputs: &[PathBuf], ext: &str) -> Vec<String> {
    let names = super::report_names(inputs, ext);
    let mut first_of: std::collections::HashMap<String, usize> = Default::default();
    let mut out = Vec::new();
    for (k, p) in inputs.iter().enumerate() {
        let stem = p
            .file_stem()
            .map_or("sweep".into(), |s| s.to_string_lossy().into_owned());
        match first_of.get(&stem) {
            Some(&j) => out.push(format!(
                "{} and {} share the name {}: their reports are {} and {} (rename one, or fit them into separate --out directories, to choose)",
                crate::text::escape_line(&inputs[j].display().to_string(), 80),
                crate::text::escape_line(&p.display().to_string(), 80),
                crate::text::escape_line(&stem, 40),
                crate::text::escape_line(&names[j], 80),
                crate::text::escape_line(&names[k], 80),
            )),
            _ => {
                first_of.insert(stem, k);
            }
        }
    }
    out
}

/// A campaign's hold on its output directory: released when dropped.
#[derive(Debug)]
pub struct OutLock(#[allow(dead_code)] File);

/// Creates `dir` if needed and takes its exclusive lock ([`outfile::lock_exclusive`],
/// the lock a capture holds on its sweep file), so that a second campaign into the
/// same `--out` is refused before it fits anything, naming the first's process.
pub fn lock_out_dir(dir: &Path) -> Result<OutLock, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let f = File::open(dir).map_err(|e| format!("cannot open {}: {e}", dir.display()))?;
    match outfile::lock_exclusive(&f) {
        Ok(()) => Ok(OutLock(f)),
        Err(e @ outfile::LockError::Held(_)) => Err(format!(
            "{} is the --out of {}: wait for it to end, or choose another --out",
            dir.display(),
            e.holder("another campaign")
        )),
        Err(outfile::LockError::Failed(e)) => Err(format!("{}: cannot lock: {e}", dir.display())),
    }
}

/// Removes from `dir` the temporary files a campaign killed while writing left there
/// (`.NAME.XXXXXX.tmp`, [`outfile`]'s temporary name, for NAME one of `names`: the
/// reports and summaries this campaign writes), and returns their paths. Called with
/// `dir` locked ([`lock_out_dir`]): no other campaign is writing them. Only regular
/// files are removed.
pub fn remove_leftovers(dir: &Path, names: &[String]) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let names: std::collections::HashSet<&str> = names.iter().map(String::as_str).collect();
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(file) = file.to_str() else {
            continue;
        };
        let ours = file
            .strip_prefix('.')
            .and_then(|f| f.strip_suffix(".tmp"))
            .and_then(|f| f.rsplit_once('.'))
            .is_some_and(|(name, random)| {
                names.contains(name)
                    && !random.is_empty()
                    && random.chars().all(|c| c.is_ascii_alphanumeric())
            });
        let path = entry.path();
        if ours
            && std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_file())
            && std::fs::remove_file(&path).is_ok()
        {
            removed.push(path);
        }
    }
    removed.sort();
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_campaign_needing_more_space_than_is_free_is_refused_saying_both() {
        let d = tempfile::tempdir().unwrap();
        let sweep = d.path().join("fe.csv");
        std::fs::write(&sweep, vec![b'1'; 7000]).unwrap();
        let one = space_needed(std::slice::from_ref(&sweep), "json");
        // 2 x (64 KiB + 8 x 7000 + 1 KiB).
        assert_eq!(one, 2 * ((64 << 10) + 56_000 + 1024));
        let out = d.path().join("reports");
        assert!(check_space(&out, std::slice::from_ref(&sweep), "json").is_ok());
        let e = space_problem(&out, one, one - 1).unwrap_err();
        assert!(
            e.ends_with(
                "reports: the reports need about 0.2 MiB (twice their estimated size) but 0.2 MiB are free: free space, or write them elsewhere with --out"
            ),
            "{e}"
        );
        // A (sparse) sweep of 1 TiB: its report's estimate, 16 TiB, is more than any
        // disk here holds; refused on the real file system.
        let huge = d.path().join("huge.csv");
        File::create(&huge).unwrap().set_len(1 << 40).unwrap();
        let huge = [huge];
        let free = free_bytes(&out).unwrap();
        assert!(space_needed(&huge, "json") > free, "a disk of {free} bytes");
        let e = check_space(&out, &huge, "json").unwrap_err();
        assert!(e.contains("MiB are free"), "{e}");
    }

    #[test]
    fn inputs_sharing_a_name_are_told_before_fitting() {
        let inputs = [
            PathBuf::from("a/fe.csv"),
            PathBuf::from("cu.csv"),
            PathBuf::from("b/fe.csv"),
        ];
        assert_eq!(
            renamed_reports(&inputs, "txt"),
            vec![
                "a/fe.csv and b/fe.csv share the name fe: their reports are fe.txt and fe-2.txt (rename one, or fit them into separate --out directories, to choose)"
                    .to_string()
            ]
        );
        assert!(renamed_reports(&inputs[..2], "txt").is_empty());
    }

    #[test]
    fn a_second_campaign_into_the_same_out_is_refused_naming_the_first() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("out");
        let held = lock_out_dir(&out).unwrap();
        assert!(out.is_dir());
        let e = lock_out_dir(&out).unwrap_err();
        let me = std::process::id();
        assert!(
            e.ends_with(&format!(
                "out is the --out of another campaign (process {me}): wait for it to end, or choose another --out"
            )),
            "{e}"
        );
        drop(held);
        assert!(lock_out_dir(&out).is_ok());
    }

    /// Issue 50 case 12: what a SIGKILLed campaign left (`.NAME.XXXXXX.tmp` of its
    /// reports) is removed at the next run; other files, and other names, are not.
    #[test]
    fn a_killed_campaigns_temporary_files_are_removed() {
        let dir = crate::outfile::test_dir("leftovers");
        for f in [
            ".a.txt.Xy12Zq.tmp",
            ".summary.csv.AbC123.tmp",
            ".b.txt.Q1w2E3.tmp",
            "a.txt",
            ".a.txt.tmp",
        ] {
            std::fs::write(dir.join(f), b"x").unwrap();
        }
        let names = ["a.txt".to_string(), "summary.csv".to_string()];
        let removed = remove_leftovers(&dir, &names);
        assert_eq!(
            removed,
            [
                dir.join(".a.txt.Xy12Zq.tmp"),
                dir.join(".summary.csv.AbC123.tmp")
            ]
        );
        let mut left: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, [".a.txt.tmp", ".b.txt.Q1w2E3.tmp", "a.txt"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
