//! What the firmware does when it can no longer trust itself (panic, HardFault): drive
//! the laser and the stepper drivers' enable pins to their safe levels by raw register
//! writes, before anything else; and the reset cause read at the next boot.
//!
//! The pins are named by the board (its pin table); this module only knows the STM32F4
//! GPIO and RCC registers (RM0383 sections 6.3 and 8.4), which are the same on the
//! F405 QEMU models and on the F411 of the Black Pill.

use brdf_core::protocol::ResetCause;
use core::ptr::{read_volatile, write_volatile};

/// Pins of one GPIO port to force: `low` driven low, `high` driven high (bit masks).
#[derive(Debug, Clone, Copy)]
pub struct SafePins {
    /// The port's index (0 = GPIOA, 1 = GPIOB, ...).
    pub port: u8,
    /// Pins driven low (the laser enable, active high).
    pub low: u16,
    /// Pins driven high (the drivers' enable inputs, active low).
    pub high: u16,
}

const RCC_AHB1ENR: *mut u32 = 0x4002_3830 as *mut u32;
const RCC_CSR: *mut u32 = 0x4002_3874 as *mut u32;
const GPIO_BASE: usize = 0x4002_0000;
const GPIO_STRIDE: usize = 0x400;

/// Drives `pins` to their safe levels and makes them push-pull outputs, whatever state
/// the program was in: safe to call from a panic or fault handler (no locks, no HAL,
/// BSRR writes are atomic). Idempotent.
pub fn force_safe_pins(pins: SafePins) {
    let base = GPIO_BASE + pins.port as usize * GPIO_STRIDE;
    let moder = base as *mut u32;
    let otyper = (base + 0x04) as *mut u32;
    let bsrr = (base + 0x18) as *mut u32;
    let all = pins.low | pins.high;
    // SAFETY: the documented RCC and GPIO registers of the STM32F4. A pin already
    // configured by the HAL is only set to the level it should have; the clock enable
    // and mode writes change nothing for a port that was set up.
    unsafe {
        write_volatile(RCC_AHB1ENR, read_volatile(RCC_AHB1ENR) | (1 << pins.port));
        // Levels first, then the mode: a pin that was an input starts at its safe level.
        write_volatile(bsrr, (u32::from(pins.low) << 16) | u32::from(pins.high));
        let mut mode = read_volatile(moder);
        let mut push_pull = read_volatile(otyper);
        for pin in 0..16 {
            if all & (1 << pin) != 0 {
                mode = (mode & !(0b11 << (2 * pin))) | (0b01 << (2 * pin));
                push_pull &= !(1 << pin);
            }
        }
        write_volatile(otyper, push_pull);
        write_volatile(moder, mode);
    }
}

/// What reset the chip, from RCC_CSR's flags; clears them so that the next boot reads
/// only its own. Power-on sets the pin and brown-out flags too, so it is tested first
/// after the watchdogs and a software reset. A board whose RCC reads 0 (QEMU) gives
/// [`ResetCause::Unknown`].
pub fn take_reset_cause() -> ResetCause {
    // SAFETY: RCC_CSR's flags are read, then cleared with RMVF (bit 24).
    let csr = unsafe {
        let csr = read_volatile(RCC_CSR);
        write_volatile(RCC_CSR, csr | (1 << 24));
        csr
    };
    reset_cause_of(csr)
}

/// [`take_reset_cause`]'s decoding of an RCC_CSR value (RM0383 section 6.3.21).
pub fn reset_cause_of(csr: u32) -> ResetCause {
    const BORRSTF: u32 = 1 << 25;
    const PINRSTF: u32 = 1 << 26;
    const PORRSTF: u32 = 1 << 27;
    const SFTRSTF: u32 = 1 << 28;
    const IWDGRSTF: u32 = 1 << 29;
    const WWDGRSTF: u32 = 1 << 30;
    if csr & (IWDGRSTF | WWDGRSTF) != 0 {
        ResetCause::Watchdog
    } else if csr & SFTRSTF != 0 {
        ResetCause::Software
    } else if csr & PORRSTF != 0 {
        ResetCause::PowerOn
    } else if csr & BORRSTF != 0 {
        ResetCause::BrownOut
    } else if csr & PINRSTF != 0 {
        ResetCause::Pin
    } else {
        ResetCause::Unknown
    }
}

/// The independent watchdog (IWDG), by its registers (RM0383 section 17): clocked by
/// the ~32 kHz LSI, it resets the chip unless fed in time; once started nothing stops
/// it. QEMU's netduinoplus2 does not model it (accesses are "unimplemented device"
/// writes that do nothing).
pub struct Watchdog;

impl Watchdog {
    const KR: *mut u32 = 0x4000_3000 as *mut u32;
    const PR: *mut u32 = 0x4000_3004 as *mut u32;
    const RLR: *mut u32 = 0x4000_3008 as *mut u32;
    const SR: *const u32 = 0x4000_300C as *const u32;

    /// Starts the IWDG with a timeout of `ms` milliseconds (1..=4095) at LSI / 32 =
    /// 1 kHz nominal (the LSI may run at 17 to 47 kHz, so the real timeout lies
    /// between 0.68 and 1.9 times `ms`).
    pub fn start(ms: u16) -> Watchdog {
        // SAFETY: the IWDG's key, prescaler and reload registers, in the documented
        // order: start (enables the LSI), unlock, configure, wait for the update, feed.
        unsafe {
            write_volatile(Self::KR, 0xCCCC);
            write_volatile(Self::KR, 0x5555);
            write_volatile(Self::PR, 0b011); // divide by 32
            write_volatile(Self::RLR, u32::from(ms.clamp(1, 4095)));
            // PVU/RVU clear once the LSI domain took the values (a few LSI cycles).
            let mut tries = 0u32;
            while read_volatile(Self::SR) & 0b11 != 0 && tries < 100_000 {
                tries += 1;
            }
            write_volatile(Self::KR, 0xAAAA);
        }
        Watchdog
    }

    /// Reloads the counter; call only where the main loop has made progress.
    pub fn feed(&mut self) {
        // SAFETY: the reload key.
        unsafe { write_volatile(Self::KR, 0xAAAA) };
    }
}

/// Brown-out reset level from the option bytes (FLASH_OPTCR, BOR_LEV bits 3:2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BorLevel {
    /// BOR level 3: reset below about 2.70 V.
    Level3,
    /// BOR level 2: about 2.40 V.
    Level2,
    /// BOR level 1: about 2.10 V.
    Level1,
    /// BOR off: only the power-on/power-down reset (about 1.8 V), the factory setting.
    Off,
}

const FLASH_KEYR_OPT: *mut u32 = 0x4002_3C08 as *mut u32;
const FLASH_SR: *const u32 = 0x4002_3C0C as *const u32;
const FLASH_OPTCR: *mut u32 = 0x4002_3C14 as *mut u32;

/// The brown-out level the option bytes hold now.
pub fn bor_level() -> BorLevel {
    // SAFETY: a read of FLASH_OPTCR.
    match (unsafe { read_volatile(FLASH_OPTCR) } >> 2) & 0b11 {
        0b00 => BorLevel::Level3,
        0b01 => BorLevel::Level2,
        0b10 => BorLevel::Level1,
        _ => BorLevel::Off,
    }
}

/// Programs BOR level 3 (2.7 V: below it the chip is held in reset, so a sagging
/// supply cannot leave the laser pin in an undefined state of a half-running program)
/// if the option bytes hold another level. Writes the option bytes only when needed
/// (their flash wears); returns the level found before.
pub fn ensure_bor_level3() -> BorLevel {
    let before = bor_level();
    if before == BorLevel::Level3 {
        return before;
    }
    // SAFETY: the documented option-byte sequence (RM0383 section 3.6.2): unlock with
    // the two keys, write OPTCR with BOR_LEV = 00, set OPTSTRT, wait for BSY to
    // clear, lock again (OPTLOCK). Other option bits are kept.
    unsafe {
        write_volatile(FLASH_KEYR_OPT, 0x0819_2A3B);
        write_volatile(FLASH_KEYR_OPT, 0x4C5D_6E7F);
        let optcr = read_volatile(FLASH_OPTCR) & !(0b11 << 2);
        write_volatile(FLASH_OPTCR, optcr);
        write_volatile(FLASH_OPTCR, optcr | (1 << 1));
        while read_volatile(FLASH_SR) & (1 << 16) != 0 {}
        write_volatile(FLASH_OPTCR, read_volatile(FLASH_OPTCR) | 1);
    }
    before
}
