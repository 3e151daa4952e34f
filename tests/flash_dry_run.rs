//! `gonio flash` on the real stm32f411 image as far as probe-rs goes without a board:
//! its fake probe attaches as the STM32F411CE, the ELF is loaded against the chip's
//! memory map and the download planned with the flash algorithm probe-rs picks; only
//! running that algorithm on a core (erase, program, verify) and the reset need a
//! board (firmware/README.md, bring-up).

use gonio::flash::{DEFAULT_CHIP, dry_run};
use gonio_e2e::stm32f411_elf;

/// Flash budget of the stm32f411 image (xtask's FLASH_BUDGET).
const FLASH_BUDGET: u64 = 64 * 1024;

#[test]
fn the_stm32f411_image_is_planned_into_the_f411_flash() {
    let plan = dry_run(DEFAULT_CHIP, &stm32f411_elf()).expect("dry run");
    assert_eq!(plan.chip, DEFAULT_CHIP);
    // 512 KiB at 0x0800_0000 (RM0383 section 3.3), the image from its first byte (the
    // vector table the core boots from), all of it inside.
    assert_eq!(plan.region, 0x0800_0000..0x0808_0000);
    assert_eq!(plan.ranges.first().map(|r| r.0), Some(0x0800_0000));
    for &(at, len) in &plan.ranges {
        assert!(
            plan.region.start <= at && at + len <= plan.region.end,
            "{at:#x}+{len}"
        );
    }
    assert!(
        (16 * 1024..=FLASH_BUDGET).contains(&plan.bytes()),
        "{} bytes",
        plan.bytes()
    );
    // The STM32F4 algorithm, with the F411's sectors: 4 x 16 KiB, 64 KiB, then 128 KiB.
    assert_eq!(plan.algorithm, "stm32f4xx_1024");
    assert_eq!(
        plan.sectors,
        [(0, 0x4000), (0x1_0000, 0x1_0000), (0x2_0000, 0x2_0000)]
    );
}
