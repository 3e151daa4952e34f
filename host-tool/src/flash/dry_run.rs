//! `gonio flash` as far as it goes without a board: probe-rs's fake probe (a mocked
//! Cortex-M core) stands in for the debug probe, so the chip lookup, the attach
//! sequence, the ELF checks against the chip's memory map and the download plan (flash
//! algorithm, sectors) run exactly as when flashing; the dry run stops before the flash
//! algorithm would be loaded and run on the core, which a mocked core cannot do.
//!
//! For tests only (feature `testing`): the mocked core prints every register access
//! on stdout, so `gonio flash` cannot run it as a preflight check.

use std::ops::Range;
use std::path::Path;

use probe_rs::integration::FakeProbe;

use super::error::FlashError;
use super::probe::{attach, download, target};

/// What flashing an ELF into a chip would do, as probe-rs plans it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FlashPlan {
    /// The chip, as probe-rs names its target.
    pub chip: String,
    /// The image's data: (address, length in bytes), in address order.
    pub ranges: Vec<(u64, u64)>,
    /// The chip's flash region that holds the data (addresses).
    pub region: Range<u64>,
    /// The flash algorithm probe-rs uses for that region.
    pub algorithm: String,
    /// The algorithm's sector layout: (offset from the start of its range, sector size
    /// in bytes), each entry repeating until the next.
    pub sectors: Vec<(u64, u64)>,
}

impl FlashPlan {
    /// Bytes the image programs.
    pub fn bytes(&self) -> u64 {
        self.ranges.iter().map(|r| r.1).sum()
    }
}

/// Plans flashing `elf` into `chip` without a board (see the module docs); errors are
/// those `gonio flash` would give for the same chip and ELF before touching the flash,
/// after its own ELF header check (`read_elf`), which this leaves to probe-rs.
pub fn dry_run(chip: &str, elf: &Path) -> Result<FlashPlan, FlashError> {
    let target = target(chip)?;
    let probe = FakeProbe::with_mocked_core().into_probe();
    let mut session = attach(probe, target, "probe-rs's fake probe")?;
    let (ranges, _) = download(&mut session, elf, true)?;
    let target = session.target();
    let start = ranges.first().map_or(0, |r| r.0);
    let region = target
        .memory_map
        .iter()
        .filter_map(|m| m.as_nvm_region())
        .find(|r| r.range.contains(&start))
        .map(|r| r.range.clone())
        .ok_or_else(|| FlashError::Failed(format!("no flash region of {chip} holds {start:#x}")))?;
    // The dry run succeeded, so probe-rs found an algorithm for the region; say which
    // (an only candidate is the one it takes, else the default among them).
    let candidates: Vec<_> = target
        .flash_algorithms
        .iter()
        .filter(|a| {
            let r = &a.flash_properties.address_range;
            r.start <= region.start && region.end <= r.end
        })
        .collect();
    let algo = match candidates.as_slice() {
        [one] => *one,
        many => many.iter().copied().find(|a| a.default).ok_or_else(|| {
            FlashError::Failed(format!(
                "{chip}: no default flash algorithm for {region:x?}"
            ))
        })?,
    };
    Ok(FlashPlan {
        chip: target.name.clone(),
        ranges,
        region,
        algorithm: algo.name.clone(),
        sectors: algo
            .flash_properties
            .sectors
            .iter()
            .map(|s| (s.address, s.size))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flash::DEFAULT_CHIP;

    /// The STM32F411CE's flash (RM0383 section 3.3): 512 KiB at 0x0800_0000.
    const F411_FLASH: Range<u64> = 0x0800_0000..0x0808_0000;

    #[test]
    fn a_host_executable_is_refused_as_built_for_another_chip() {
        // This test binary is an ELF whose data lies nowhere near the chip's flash.
        let exe = std::env::current_exe().unwrap();
        let e = dry_run(DEFAULT_CHIP, &exe).unwrap_err();
        assert!(matches!(e, FlashError::Input(_)), "bad input: {e}");
        assert!(e.to_string().contains("is it built for STM32F411CE"), "{e}");
        assert!(!e.to_string().contains('\n'), "{e}");
    }

    #[test]
    fn an_unknown_chip_is_bad_input_before_any_probe() {
        let exe = std::env::current_exe().unwrap();
        let e = dry_run("STM32F999", &exe).unwrap_err();
        assert!(matches!(e, FlashError::Input(_)), "bad input: {e}");
        assert!(e.to_string().contains("knows no such chip"), "{e}");
    }

    #[test]
    fn the_f411_target_and_its_flash_algorithm_match_the_reference_manual() {
        let t = target(DEFAULT_CHIP).unwrap();
        assert!(
            t.memory_map
                .iter()
                .filter_map(|m| m.as_nvm_region())
                .any(|r| r.range == F411_FLASH),
            "512 KiB of flash at 0x0800_0000"
        );
        assert!(
            t.memory_map
                .iter()
                .filter_map(|m| m.as_ram_region())
                .any(|r| r.range == (0x2000_0000..0x2002_0000)),
            "128 KiB of SRAM at 0x2000_0000 (memory.x)"
        );
    }
}
