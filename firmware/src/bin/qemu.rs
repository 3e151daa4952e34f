//! Board `qemu`: the goniometer firmware on QEMU's `netduinoplus2` (an STM32F405 with
//! the same memory map as our STM32F411), so the real controller, protocol and framing
//! run in tests on any machine.
//!
//! - Link: USART1 (0x40011000), connected by QEMU to a pseudo-terminal with
//!   `-serial pty`. QEMU models neither the RCC nor baud rates: bytes move as fast as
//!   the emulator runs.
//! - Arms: simulated (`brdf_core::sim::SimArm`): steps are counted, a home switch sits
//!   at each arm's `home_deg`; the shafts start at 45 (source) and 10 (detector)
//!   degrees, unknown to the controller until it homes.
//! - Detector: a virtual sample, the `fe-0.115` preset evaluated with brdf-core in
//!   f32, times `1 + 0.005 * n` with `n` deterministic pseudo-random standard-normal
//!   noise (xorshift32, fixed seed), so every run of the image gives the same numbers.
//!   Beside it a Lambertian reference standard of reflectance factor
//!   [`REFERENCE_R`], read after `Mount(Reference)` as K R / pi (K =
//!   `brdf_core::sim::SIM_K`), so a capture can calibrate against it.
//! - Time: simulated. When the controller asks to be called again in N microseconds
//!   the clock jumps there, so motion and settle times cost no wall time; readings'
//!   `t_ms` are simulated milliseconds. The host lease runs on wall time instead
//!   ([`WallClock`], TIM2, which QEMU models on its virtual clock), since the host keeps
//!   it in wall time.
//! - Faults: a panic or HardFault first forces the STM32F411 board's safe pins
//!   ([`SAFE_PINS`]: laser low, drivers disabled; QEMU does not model the GPIO, so the
//!   writes are only seen with `-d unimp`), then says so over semihosting and exits QEMU
//!   with status 1. For the tests, the byte sequences [`TEST_PANIC`] and [`TEST_FAULT`]
//!   on the link make the firmware panic or take a HardFault (an undefined
//!   instruction); they exist only in this image.
//! - Watchdog and reset cause: the IWDG is started and fed as on the STM32F411, but
//!   QEMU does not model it (nor RCC_CSR, which reads 0: reset cause `Unknown`).
#![no_std]
#![no_main]

use core::ptr::{read_volatile, write_volatile};

use brdf_core::presets::Preset;
use brdf_core::service::{Link, Service};
use brdf_core::sim::{VirtualSample, simulated_controller};
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use firmware::FIRMWARE_VERSION;
use firmware::safety::{self, SafePins, Watchdog};

/// The STM32F411 board's safe pins (see its pin table): PB10 low, PB14 and PB8 high.
const SAFE_PINS: SafePins = SafePins {
    port: 1,
    low: 1 << 10,
    high: (1 << 14) | (1 << 8),
};
/// Bytes that make this image panic (test-only): a 0x00-delimited "frame" that is no
/// valid COBS frame of a command.
pub const TEST_PANIC: &[u8] = b"\0gonio-test:panic\0";
/// Bytes that make this image take a HardFault (test-only).
pub const TEST_FAULT: &[u8] = b"\0gonio-test:fault\0";

/// The reflectance factor of the board's simulated reference standard.
const REFERENCE_R: f32 = 0.99;

/// USART1 of the STM32F4 family, by its registers (RM0383 section 19.6), with the
/// test-only fault triggers watched in what it receives.
struct Usart1 {
    panic: Matcher,
    fault: Matcher,
}

/// Finds a fixed byte sequence in a stream.
struct Matcher {
    want: &'static [u8],
    at: usize,
}

impl Matcher {
    const fn new(want: &'static [u8]) -> Self {
        Matcher { want, at: 0 }
    }

    /// Takes one byte; true when it completes the sequence.
    fn push(&mut self, b: u8) -> bool {
        if b == self.want[self.at] {
            self.at += 1;
        } else {
            // 0x00 appears only at both ends of a sequence: a 0x00 may start one.
            self.at = usize::from(b == self.want[0]);
        }
        if self.at == self.want.len() {
            self.at = 0;
            return true;
        }
        false
    }
}

impl Usart1 {
    const BASE: usize = 0x4001_1000;
    const SR: *mut u32 = Self::BASE as *mut u32;
    const DR: *mut u32 = (Self::BASE + 0x04) as *mut u32;
    const BRR: *mut u32 = (Self::BASE + 0x08) as *mut u32;
    const CR1: *mut u32 = (Self::BASE + 0x0C) as *mut u32;
    const SR_RXNE: u32 = 1 << 5;
    const SR_TXE: u32 = 1 << 7;
    const CR1_UE_TE_RE: u32 = (1 << 13) | (1 << 3) | (1 << 2);
    /// CR1 RXNEIE: a received byte raises USART1's interrupt line (used to wake, not
    /// handled: PRIMASK stays set).
    const CR1_RXNEIE: u32 = 1 << 5;
    /// USART1 is IRQ 37: bit 5 of the NVIC's second enable / clear-pending words.
    const NVIC_ISER1: *mut u32 = 0xE000_E104 as *mut u32;
    const NVIC_ICPR1: *mut u32 = 0xE000_E284 as *mut u32;
    const IRQ_BIT: u32 = 1 << (37 - 32);
    /// RCC APB2ENR, bit 4: USART1 clock (ignored by QEMU, needed on silicon).
    const RCC_APB2ENR: *mut u32 = 0x4002_3844 as *mut u32;

    fn init() -> Self {
        // SAFETY: single-threaded start-up; these are the documented USART1/RCC
        // registers and nothing else uses them.
        unsafe {
            write_volatile(
                Self::RCC_APB2ENR,
                read_volatile(Self::RCC_APB2ENR) | (1 << 4),
            );
            // 115200 baud from a 16 MHz HSI (ignored by QEMU).
            write_volatile(Self::BRR, 0x8B);
            write_volatile(Self::CR1, Self::CR1_UE_TE_RE | Self::CR1_RXNEIE);
            // Interrupts stay masked (PRIMASK): an enabled, pending IRQ still ends WFI
            // (ARMv7-M B1.5.19), so no handler is needed.
            cortex_m::interrupt::disable();
            write_volatile(Self::NVIC_ISER1, Self::IRQ_BIT);
        }
        Usart1 {
            panic: Matcher::new(TEST_PANIC),
            fault: Matcher::new(TEST_FAULT),
        }
    }

    /// Sleeps (WFI) until a byte arrives, unless one is already waiting. Without it the
    /// idle loop spins on the status register, keeping a host core busy and, in QEMU,
    /// taking the emulator's lock the receive path needs for every byte.
    fn wait_for_input(&mut self) {
        // SAFETY: the NVIC clear-pending word and USART1's status register. Clearing
        // first, then checking RXNE, leaves no window: a byte arriving after the check
        // pends the IRQ again, which ends the WFI at once.
        unsafe {
            write_volatile(Self::NVIC_ICPR1, Self::IRQ_BIT);
            if read_volatile(Self::SR) & Self::SR_RXNE == 0 {
                cortex_m::asm::wfi();
            }
        }
    }
}

impl Link for Usart1 {
    fn read(&mut self, buf: &mut [u8]) -> usize {
        let mut n = 0;
        // SAFETY: reads of USART1 status/data registers; reading DR clears RXNE.
        while n < buf.len() && unsafe { read_volatile(Self::SR) } & Self::SR_RXNE != 0 {
            let b = unsafe { read_volatile(Self::DR) } as u8;
            if self.panic.push(b) {
                panic!("test-only panic requested over the link");
            }
            if self.fault.push(b) {
                cortex_m::asm::udf();
            }
            buf[n] = b;
            n += 1;
        }
        n
    }

    fn write(&mut self, bytes: &[u8]) -> usize {
        for &b in bytes {
            // SAFETY: USART1 status/data registers; TXE means DR may be written.
            while unsafe { read_volatile(Self::SR) } & Self::SR_TXE == 0 {}
            unsafe { write_volatile(Self::DR, b as u32) };
        }
        bytes.len()
    }
}

/// TIM2 counting microseconds of QEMU's virtual clock (wall time without `-icount`),
/// extended to 64 bits. QEMU clocks its STM32 timers at 1 GHz whatever the RCC says
/// (measured: PSC = 999 gives 1 MHz); silicon would count at its APB1 timer clock.
struct WallClock {
    last: u32,
    wraps: u32,
}

impl WallClock {
    const BASE: usize = 0x4000_0000;
    const CR1: *mut u32 = Self::BASE as *mut u32;
    const CNT: *const u32 = (Self::BASE + 0x24) as *const u32;
    const PSC: *mut u32 = (Self::BASE + 0x28) as *mut u32;
    const ARR: *mut u32 = (Self::BASE + 0x2C) as *mut u32;
    /// RCC APB1ENR, bit 0: TIM2 clock.
    const RCC_APB1ENR: *mut u32 = 0x4002_3840 as *mut u32;

    fn start() -> Self {
        // SAFETY: TIM2's and RCC's documented registers, used by nothing else.
        unsafe {
            write_volatile(Self::RCC_APB1ENR, read_volatile(Self::RCC_APB1ENR) | 1);
            write_volatile(Self::PSC, 999);
            write_volatile(Self::ARR, u32::MAX);
            write_volatile(Self::CR1, 1);
        }
        WallClock { last: 0, wraps: 0 }
    }

    /// Microseconds; a wrap-around (71.6 minutes) missed while asleep only makes the
    /// clock lag, and the board never sleeps while the lease matters.
    fn now_us(&mut self) -> u64 {
        // SAFETY: a read of TIM2's counter.
        let now = unsafe { read_volatile(Self::CNT) };
        if now < self.last {
            self.wraps += 1;
        }
        self.last = now;
        (u64::from(self.wraps) << 32) | u64::from(now)
    }
}

#[entry]
fn main() -> ! {
    let reset_cause = safety::take_reset_cause();
    let mut link = Usart1::init();
    let mut wall = WallClock::start();
    let sample = Preset::by_name("fe-0.115").unwrap_or(&brdf_core::presets::PRESETS[4]);
    let ctrl = simulated_controller(
        "qemu",
        FIRMWARE_VERSION,
        VirtualSample::new(sample, 0.005, 0x6F6E_6F67).with_reference(REFERENCE_R),
    );
    let mut service = Service::new(ctrl);
    service.ctrl.set_reset_cause(reset_cause);
    let mut watchdog = Watchdog::start(500);
    let mut now_us: u64 = 0;
    loop {
        service.ctrl.set_lease_clock(wall.now_us());
        let next = service.poll(&mut link, now_us);
        watchdog.feed();
        // QEMU keeps the run-time settings in RAM (in the controller) until it exits:
        // there is no flash to store their record in.
        let _ = service.ctrl.take_settings_record();
        match next {
            // Simulated time: jump to the next deadline.
            Some(at) => now_us = now_us.max(at),
            // Nothing to do until the host sends something.
            None if !service.sending() => link.wait_for_input(),
            None => {}
        }
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    safety::force_safe_pins(SAFE_PINS);
    hprintln!("safe state: laser pin low, drivers disabled");
    hprintln!("firmware panic: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    safety::force_safe_pins(SAFE_PINS);
    hprintln!("safe state: laser pin low, drivers disabled");
    hprintln!("firmware HardFault at pc={:#010x}", frame.pc());
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}
