//! Goniometer controller on a WeAct "Black Pill" STM32F411CEU6 (25 MHz HSE crystal):
//! USB CDC-ACM link to the host, two step/dir arms, a laser enable and a photodiode
//! amplifier on ADC1. Logs go out over RTT (defmt); panics print there too.
//!
//! # Faults
//!
//! A panic or HardFault first drives the laser pin low and both drivers' enable pins
//! high (disabled) by raw register writes ([`SAFE_PINS`], `firmware::safety`), then logs
//! and restarts the chip (the next boot reports `ResetCause::Software`). The
//! independent watchdog ([`WATCHDOG_MS`]) is fed only by the main loop after each
//! service iteration: a hang anywhere restarts the chip (`ResetCause::Watchdog`). The
//! reset cause is read from RCC_CSR at boot and reported by `GetStatus`; the
//! brown-out level is set to 2.7 V in the option bytes at the first boot that finds
//! it otherwise.
//!
//! # Run-time settings
//!
//! Mechanics, switch wiring and detector integration (`brdf_core::controller::settings`)
//! are kept in flash sector 4 ([`settings_flash`], 64 KiB at 0x0801_0000, just past the
//! 64 KiB the image may take), read at boot (defaults when the record is erased,
//! damaged or of another version) and rewritten after each `SetSettings`. The erase
//! stalls the main loop for up to about 2.4 s, so the watchdog is stretched to its
//! longest (4.1 s nominal) meanwhile; the controller has turned the laser off and
//! released the drivers before the board stores.
//!
//! Build and flash: `cargo run --release --bin stm32f411 --features stm32f411`
//! (from `firmware/`, with a debug probe on SWD).
//!
//! # Pins
//!
//! This table, [`Board::take`] and [`SAFE_PINS`] are the only places that name pins;
//! keep them in step.
//!
//! | Pin  | Function                  | Notes                                                      |
//! |------|---------------------------|------------------------------------------------------------|
//! | PB12 | source arm STEP           | push-pull, idle low, ~2 us high pulse                      |
//! | PB13 | source arm DIR            | push-pull; 1 us settle after every change                  |
//! | PB14 | source arm ENABLE         | push-pull, active low (driver `EN`); driven high at boot   |
//! | PB15 | source arm HOME switch    | input, pull-up; NC switch to GND: low at rest, high pressed or a cut wire |
//! | PB6  | detector arm STEP         | push-pull, idle low, ~2 us high pulse                      |
//! | PB7  | detector arm DIR          | push-pull; 1 us settle after every change                  |
//! | PB8  | detector arm ENABLE       | push-pull, active low (driver `EN`); driven high at boot   |
//! | PB9  | detector arm HOME switch  | input, pull-up; NC switch to GND: low at rest, high pressed or a cut wire |
//! | PB10 | laser enable              | push-pull, active high; driven low (off) at boot           |
//! | PA1  | photodiode amplifier out  | analog, ADC1_IN1, 0..3.3 V; keep the amp output <= VDDA    |
//! | PA0  | interlock input           | pull-up; loop closed to GND = closed, high = open (a cut wire) |
//! | PA9  | USB VBUS sense (optional) | OTG_FS_VBUS, 5 V tolerant; used only with [`VBUS_SENSE`]    |
//! | PC13 | status LED (on board)     | push-pull, active low; lit once the firmware is running    |
//! | PA11 | USB D-                    | OTG_FS (on board USB-C)                                    |
//! | PA12 | USB D+                    | OTG_FS (on board USB-C)                                    |
//! | PA13 | SWDIO                     | debug probe, not reassigned                                |
//! | PA14 | SWCLK                     | debug probe, not reassigned                                |
//!
//! The interlock on PA0 shares the pin with the on-board KEY button (to GND): pressing
//! KEY holds the loop "closed", so leave it alone. Left free on purpose: PB2 (BOOT1,
//! has a resistor on the board), PA15/PB3/PB4 (JTAG; PB3 is SWO), PC14/PC15 (32 kHz
//! crystal), PA10 (USART1 RX, the ROM bootloader's UART; PA9, its TX, is free unless
//! VBUS is sensed). The F411CE package has no PB11. Both arms are on one header row
//! (PB12..PB15, PB6..PB9); the laser and the analog input are on the other, away from
//! the step lines.
//!
//! During reset and until `Board::take` runs, all pins float: a driver whose `EN` has
//! no pull-up of its own (A4988, DRV8825 boards pull it down) holds torque then, and a
//! laser driver needs its own pull-down to stay off.
//!
//! # Detector units
//!
//! [`Photodiode::sample`] returns raw ADC counts (12 bit, 0..=4095 for 0..VDDA), the
//! mean of the conversions of a whole number of mains periods (20 ms by default) as
//! `f32`, so it carries fractional counts. A sample blocks the main loop for its span
//! (the controller takes one per loop iteration; the run-time settings cap it at
//! 100 ms), which conversions by timer and DMA would not. Counts
//! are not converted to volts: readings are relative anyway (dark-subtracted, then
//! normalised on the host), and counts do not depend on an estimate of VDDA.
//!
//! # Time
//!
//! TIM5 (32 bit) counts microseconds; [`MicrosClock`] extends it to 64 bits by noticing
//! wrap-arounds (every 71.6 minutes), which only needs `now_us` to be called more
//! often than that — the main loop calls it continuously.

#![no_std]
#![no_main]

use brdf_core::axis::{StepDirPins, SwitchWiring};
use brdf_core::controller::{Controller, ControllerConfig, Detector, DetectorError, settings};
use brdf_core::mechanics;
use brdf_core::protocol::IntegrationSettings;
use brdf_core::service::Service;
use cortex_m_rt::entry;
use defmt_rtt as _;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorType, OutputPin, PinState};
use firmware::safety::{self, SafePins, Watchdog};
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::adc::config::{AdcConfig, Clock, Resolution, SampleTime};
use stm32f4xx_hal::dwt::{Delay, DwtExt};
use stm32f4xx_hal::gpio::PinState as Level;
use stm32f4xx_hal::gpio::{
    Analog, Input, Output, PA0, PA1, PB6, PB7, PB8, PB9, PB10, PB12, PB13, PB14, PB15, PC13,
};
use stm32f4xx_hal::otg_fs::{USB, UsbBus, UsbBusType};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Config, Rcc};
use stm32f4xx_hal::timer::FTimerUs;
use usb_device::bus::UsbBusAllocator;
use usb_link::UsbLink;

/// Board name reported in the handshake.
const BOARD: &str = "stm32f411";
/// The pins a panic or fault forces: port B, laser enable PB10 low, the drivers' enable
/// inputs PB14 (source) and PB8 (detector) high (active low: disabled).
const SAFE_PINS: SafePins = SafePins {
    port: 1,
    low: 1 << 10,
    high: (1 << 14) | (1 << 8),
};
/// The independent watchdog's timeout (milliseconds, at the LSI's nominal 32 kHz).
const WATCHDOG_MS: u16 = 500;
/// How the home switches are wired until the run-time settings say otherwise
/// ([`SwitchWiring`]): normally closed, so a cut wire reads "pressed" and stops the arm
/// (homing fails "stuck or its wire broken", a move stops at `LimitSwitch`) instead of
/// driving it into the hard stop. A rig wired normally open says so with
/// `gonio config set` (the settings' `home_switch`).
const HOME_SWITCH_WIRING: SwitchWiring = SwitchWiring::NormallyClosed;
/// Sense VBUS on PA9 (the OTG core's B-session comparator): set it on a rig whose board
/// is powered apart from USB, with the USB connector's VBUS wired to PA9, so that
/// pulling the cable stops everything at once (`usb_link::UsbLink::set_vbus`). Off by
/// default: the Black Pill does not wire PA9 to VBUS, and with sensing on and PA9
/// unwired the device never connects. A bus-powered board needs no sensing (unplugged,
/// it is off); a self-powered one without it still stops when the bus is seen
/// suspended (3 ms of idle bus).
const VBUS_SENSE: bool = false;
/// Step pulse width (A4988 >= 1 us, DRV8825 >= 1.9 us, TMC2209 >= 0.1 us).
const STEP_PULSE_NS: u32 = 2_000;
/// Direction setup time before the next step edge (DRV8825 >= 650 ns, A4988 >= 200 ns).
const DIR_SETUP_NS: u32 = 1_000;
/// ADC sample time: 144 ADC clocks (6 us at 24 MHz) is ample for an op-amp output.
const ADC_SAMPLE_TIME: SampleTime = SampleTime::Cycles_144;
/// Words of RAM for the USB OTG endpoint buffers (OUT packets of EP0 and the CDC data
/// endpoint; 64 bytes each, with room to spare).
const USB_EP_MEMORY_WORDS: usize = 320;

/// A direction output that waits [`DIR_SETUP_NS`] after every level change, so the
/// driver has latched the direction before the step edge that follows at once.
struct DirPin<P> {
    pin: P,
    delay: Delay,
}

impl<P: OutputPin> ErrorType for DirPin<P> {
    type Error = P::Error;
}

impl<P: OutputPin> OutputPin for DirPin<P> {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.set_state(PinState::Low)
    }

    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.set_state(PinState::High)
    }

    fn set_state(&mut self, state: PinState) -> Result<(), Self::Error> {
        self.pin.set_state(state)?;
        self.delay.delay_ns(DIR_SETUP_NS);
        Ok(())
    }
}

/// Pins of the source (laser) arm.
type SourcePins = StepDirPins<PB12<Output>, DirPin<PB13<Output>>, PB14<Output>, PB15<Input>, Delay>;
/// Pins of the detector arm.
type DetectorPins = StepDirPins<PB6<Output>, DirPin<PB7<Output>>, PB8<Output>, PB9<Input>, Delay>;

/// A step/dir driver with the settings common to both arms.
fn step_dir<STEP, DIR, EN, HOME>(
    step: STEP,
    dir: DIR,
    enable: EN,
    home: HOME,
    delay: Delay,
) -> StepDirPins<STEP, DirPin<DIR>, EN, HOME, Delay> {
    StepDirPins {
        step,
        dir: DirPin { pin: dir, delay },
        enable,
        home,
        delay,
        pulse_ns: STEP_PULSE_NS,
        enable_active_low: true,
        home_wiring: HOME_SWITCH_WIRING,
    }
}

/// The photodiode amplifier on ADC1: each sample is the mean of back-to-back
/// conversions over a whole number of mains periods (the run-time settings' `mains_hz`
/// and `periods`; 20 ms by default), timed by TIM5, so mains pick-up averages out. In
/// raw ADC counts (0..=4095).
struct Photodiode {
    adc: Adc<pac::ADC1>,
    pin: PA1<Analog>,
    /// How long one sample integrates (microseconds).
    span_us: u32,
    /// Conversions at full scale (4095) not yet reported.
    saturated: u32,
}

/// A 12-bit conversion at full scale: the input was at or above VDDA (clipped).
const ADC_FULL_SCALE: u16 = 4095;
/// TIM5's counter ([`MicrosClock`], microseconds), read by the detector to time its
/// samples.
const TIM5_CNT: *const u32 = 0x4000_0C24 as *const u32;

fn tim5_us() -> u32 {
    // SAFETY: a read of TIM5's counter, which MicrosClock keeps running.
    unsafe { core::ptr::read_volatile(TIM5_CNT) }
}

impl Detector for Photodiode {
    fn sample(
        &mut self,
        _theta_i: f32,
        _theta_r: f32,
        _laser_on: bool,
    ) -> Result<f32, DetectorError> {
        // About 3,000 conversions of ~7 us in 20 ms: the span is whole to one of them.
        let (mut sum, mut n) = (0u32, 0u32);
        let start = tim5_us();
        loop {
            let x = self.adc.convert(&self.pin, ADC_SAMPLE_TIME);
            if x >= ADC_FULL_SCALE {
                self.saturated += 1;
            }
            sum += u32::from(x);
            n += 1;
            if tim5_us().wrapping_sub(start) >= self.span_us {
                break;
            }
        }
        // The mean in integer parts: the sum exceeds f32's exact integers.
        Ok((sum / n) as f32 + (sum % n) as f32 / n as f32)
    }

    fn set_integration(&mut self, integration: &IntegrationSettings) {
        self.span_us = (settings::sample_ms(integration) * 1000.0) as u32;
    }

    fn sample_us(&self) -> u32 {
        self.span_us
    }

    fn take_saturated(&mut self) -> u32 {
        core::mem::take(&mut self.saturated)
    }
}

/// TIM5 free-running at 1 MHz, extended to 64 bits.
struct MicrosClock {
    tim: pac::TIM5,
    last: u32,
    wraps: u32,
}

impl MicrosClock {
    /// Starts TIM5 counting microseconds from 0 over the full 32-bit range.
    fn start(tim: pac::TIM5, rcc: &mut Rcc) -> Self {
        // Enables and resets TIM5 and sets the prescaler for 1 MHz.
        let tim = FTimerUs::new(tim, rcc).release();
        tim.arr().write(|w| w.arr().set(u32::MAX));
        // Load the prescaler and restart from 0, then run.
        tim.egr().write(|w| w.ug().set_bit());
        tim.cr1().modify(|_, w| w.cen().set_bit());
        MicrosClock {
            tim,
            last: 0,
            wraps: 0,
        }
    }

    /// Microseconds since `start`; must be called at least once per 71 minutes.
    fn now_us(&mut self) -> u64 {
        let now = self.tim.cnt().read().bits();
        if now < self.last {
            self.wraps += 1;
        }
        self.last = now;
        (u64::from(self.wraps) << 32) | u64::from(now)
    }
}

/// The chip's 96-bit unique ID as 24 upper-case hex digits: the three 32-bit words at
/// 0x1FFF_7A10 in address order, each most significant digit first (as a debugger
/// shows them).
fn unique_id_hex() -> [u8; 24] {
    const UID_BASE: *const u32 = 0x1FFF_7A10 as *const u32;
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    let mut out = [0u8; 24];
    for (i, chunk) in out.chunks_exact_mut(8).enumerate() {
        // SAFETY: the unique ID is three read-only words of system memory, always
        // mapped on the STM32F411 (RM0383 section 24.2).
        let word = unsafe { core::ptr::read_volatile(UID_BASE.add(i)) };
        for (j, c) in chunk.iter_mut().enumerate() {
            *c = HEX[((word >> (28 - 4 * j)) & 0xF) as usize];
        }
    }
    out
}

/// Everything on the board the firmware uses, set up. The pin assignment here follows
/// the table at the top of this file.
struct Board {
    source: SourcePins,
    detector: DetectorPins,
    laser: PB10<Output>,
    interlock: PA0<Input>,
    photodiode: Photodiode,
    led: PC13<Output>,
    clock: MicrosClock,
    usb_bus: UsbBusAllocator<UsbBusType>,
    flash: pac::FLASH,
}

impl Board {
    fn take() -> Board {
        let dp = pac::Peripherals::take().unwrap();
        let cp = cortex_m::Peripherals::take().unwrap();

        // 25 MHz HSE -> PLL: sysclk 96 MHz and exactly 48 MHz for USB (the HAL picks
        // M = 25, N = 384, P = 4, Q = 8). APB1 48 MHz (timers 96 MHz), APB2 96 MHz.
        let mut rcc = dp
            .RCC
            .freeze(Config::hse(25.MHz()).sysclk(96.MHz()).require_pll48clk());
        let clocks = rcc.clocks;
        defmt::info!(
            "clocks: sysclk {} Hz, hclk {} Hz, pclk1 {} Hz, pclk2 {} Hz, usb {} Hz",
            clocks.sysclk().raw(),
            clocks.hclk().raw(),
            clocks.pclk1().raw(),
            clocks.pclk2().raw(),
            clocks.pll48clk().map_or(0, |f| f.raw())
        );
        assert!(clocks.is_pll48clk_valid(), "no valid 48 MHz USB clock");

        // The DWT cycle counter times the step pulses and the direction setup.
        let delay = cp.DWT.constrain(cp.DCB, &clocks).delay();

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);

        let source = step_dir(
            gpiob.pb12.into_push_pull_output_in_state(Level::Low),
            gpiob.pb13.into_push_pull_output_in_state(Level::Low),
            gpiob.pb14.into_push_pull_output_in_state(Level::High),
            gpiob.pb15.into_pull_up_input(),
            delay,
        );
        let detector = step_dir(
            gpiob.pb6.into_push_pull_output_in_state(Level::Low),
            gpiob.pb7.into_push_pull_output_in_state(Level::Low),
            gpiob.pb8.into_push_pull_output_in_state(Level::High),
            gpiob.pb9.into_pull_up_input(),
            delay,
        );
        let laser = gpiob.pb10.into_push_pull_output_in_state(Level::Low);
        let interlock = gpioa.pa0.into_pull_up_input();
        interlock::listen();
        let led = gpioc.pc13.into_push_pull_output_in_state(Level::High);

        // ADC clock = APB2 / 4 = 24 MHz (the F411 allows at most 36 MHz).
        let adc = Adc::new(
            dp.ADC1,
            true,
            AdcConfig::default()
                .clock(Clock::Pclk2_div_4)
                .resolution(Resolution::Twelve)
                .default_sample_time(ADC_SAMPLE_TIME),
            &mut rcc,
        );
        let photodiode = Photodiode {
            adc,
            pin: gpioa.pa1.into_analog(),
            // Until the controller passes the settings on (at once, in `new`).
            span_us: 20_000,
            saturated: 0,
        };

        let clock = MicrosClock::start(dp.TIM5, &mut rcc);

        let ep_memory =
            cortex_m::singleton!(: [u32; USB_EP_MEMORY_WORDS] = [0; USB_EP_MEMORY_WORDS]).unwrap();
        let usb = USB::new(
            (dp.OTG_FS_GLOBAL, dp.OTG_FS_DEVICE, dp.OTG_FS_PWRCLK),
            (gpioa.pa11, gpioa.pa12),
            &clocks,
        );
        let usb_bus = UsbBus::new(usb, ep_memory);

        Board {
            source,
            detector,
            laser,
            interlock,
            photodiode,
            led,
            clock,
            usb_bus,
            flash: dp.FLASH,
        }
    }
}

/// The interlock's interrupt: EXTI line 0 (PA0, the reset default of SYSCFG_EXTICR1)
/// on its rising edge, the loop opening. The handler forces the safe pins at once;
/// the main loop then reads the level and puts the controller in its safe state.
mod interlock {
    use core::ptr::write_volatile;
    use core::sync::atomic::{AtomicBool, Ordering};
    use stm32f4xx_hal::pac::interrupt;

    /// Set by the interrupt: the loop opened, if only for a glitch. The pins were
    /// forced, so the controller must hear of it even if the loop reads closed again.
    static TRIPPED: AtomicBool = AtomicBool::new(false);

    /// Whether the interrupt fired since the last call.
    pub fn tripped() -> bool {
        TRIPPED.swap(false, Ordering::AcqRel)
    }

    const EXTI_IMR: *mut u32 = 0x4001_3C00 as *mut u32;
    const EXTI_RTSR: *mut u32 = 0x4001_3C08 as *mut u32;
    const EXTI_PR: *mut u32 = 0x4001_3C14 as *mut u32;
    /// EXTI0 is IRQ 6.
    const NVIC_ISER0: *mut u32 = 0xE000_E100 as *mut u32;

    /// Unmasks EXTI0 on a rising edge and enables its interrupt.
    pub fn listen() {
        // SAFETY: EXTI line 0's mask and trigger bits and EXTI0's NVIC enable bit;
        // nothing else uses them.
        unsafe {
            write_volatile(EXTI_RTSR, 1);
            write_volatile(EXTI_IMR, 1);
            write_volatile(NVIC_ISER0, 1 << 6);
        }
    }

    #[interrupt]
    fn EXTI0() {
        // SAFETY: clearing line 0's pending bit (write 1).
        unsafe { write_volatile(EXTI_PR, 1) };
        firmware::safety::force_safe_pins(super::SAFE_PINS);
        TRIPPED.store(true, Ordering::Release);
    }
}

/// The run-time settings' record in flash sector 4 (see the file's docs).
mod settings_flash {
    use brdf_core::controller::settings::RECORD_LEN;
    use stm32f4xx_hal::flash::{Error, FlashExt};
    use stm32f4xx_hal::pac::FLASH;

    /// Sector 4: 64 KiB at 0x0801_0000 (RM0383 table 4).
    const SECTOR: u8 = 4;
    /// Its offset from the start of flash.
    const OFFSET: usize = 0x1_0000;
    const ADDRESS: usize = 0x0800_0000 + OFFSET;

    /// The stored record (erased flash reads 0xFF).
    pub fn read() -> [u8; RECORD_LEN] {
        // SAFETY: RECORD_LEN bytes of on-chip flash, always mapped and readable.
        unsafe { core::ptr::read_volatile(ADDRESS as *const [u8; RECORD_LEN]) }
    }

    /// Whether the image (code, read-only data and the initial values of .data) lies
    /// wholly below the sector: never erase our own code, whatever the size budget.
    pub fn image_clear() -> bool {
        unsafe extern "C" {
            static __sidata: u32;
            static __sdata: u32;
            static __edata: u32;
        }
        // Addresses of cortex-m-rt's linker symbols; nothing is read through them.
        let (lma, start, end) = (
            &raw const __sidata as usize,
            &raw const __sdata as usize,
            &raw const __edata as usize,
        );
        lma + (end - start) <= ADDRESS
    }

    /// Erases the sector and writes `record`.
    pub fn write(flash: &mut FLASH, record: &[u8; RECORD_LEN]) -> Result<(), Error> {
        let mut unlocked = flash.unlocked();
        unlocked.erase(SECTOR)?;
        unlocked.program(OFFSET, record.iter())
    }
}

/// VBUS sensing of the OTG FS core by its registers (RM0383 section 22.16): the HAL's
/// bus (synopsys-usb-otg) turns sensing off (GCCFG.NOVBUSSENS) when usb-device enables
/// it, so [`enable`](vbus::enable) turns it back on afterwards, as embassy's stm32f4
/// examples do with their `vbus_detection` setting.
mod vbus {
    use core::ptr::{read_volatile, write_volatile};

    const OTG_FS: usize = 0x5000_0000;
    const GOTGCTL: *const u32 = OTG_FS as *const u32;
    const GCCFG: *mut u32 = (OTG_FS + 0x38) as *mut u32;
    /// GOTGCTL.BSVLD: B-session valid (VBUS above the B-device threshold, ~4.4 V).
    const BSVLD: u32 = 1 << 19;
    /// GCCFG.NOVBUSSENS: sensing off (pull-up always on).
    const NOVBUSSENS: u32 = 1 << 21;
    /// GCCFG.VBUSBSEN: sensing of VBUS on PA9 for a B-device (ours).
    const VBUSBSEN: u32 = 1 << 19;

    /// Turns sensing on: from here the D+ pull-up follows VBUS on PA9, and
    /// [`present`] reads it. Call once the USB device is built (the core enabled).
    pub fn enable() {
        // SAFETY: GCCFG of the OTG FS core, which usb-device has enabled; the bus code
        // writes it only in its enable(), which has run.
        unsafe {
            let v = read_volatile(GCCFG);
            write_volatile(GCCFG, (v & !NOVBUSSENS) | VBUSBSEN);
        }
    }

    /// Whether VBUS is present (with [`enable`]d sensing).
    pub fn present() -> bool {
        // SAFETY: a read of the OTG FS core's status register.
        unsafe { read_volatile(GOTGCTL) & BSVLD != 0 }
    }
}

#[entry]
fn main() -> ! {
    let reset_cause = safety::take_reset_cause();
    let bor = safety::ensure_bor_level3();
    let Board {
        source,
        detector,
        laser,
        interlock,
        photodiode,
        mut led,
        mut clock,
        usb_bus,
        mut flash,
    } = Board::take();

    let serial_hex = unique_id_hex();
    let serial_number = core::str::from_utf8(&serial_hex).unwrap_or("0");
    defmt::info!("serial number {}", serial_number);

    // Descriptors (VID:PID, strings) and the link's behaviour live in usb-link, which
    // the host tests run against a simulated bus.
    let mut link = UsbLink::new(&usb_bus, serial_number);
    if VBUS_SENSE {
        vbus::enable();
    }

    let cfg = ControllerConfig {
        board: BOARD,
        firmware: firmware::FIRMWARE_VERSION,
        source: mechanics::SOURCE,
        detector: mechanics::DETECTOR,
    };
    let mut service = Service::new(Controller::new(cfg, source, detector, laser, photodiode));
    service.ctrl.set_reset_cause(reset_cause);
    match service.ctrl.load_settings(&settings_flash::read()) {
        Ok(()) => defmt::info!("settings: the stored record"),
        Err(e) => defmt::warn!("settings: defaults ({=str})", e.describe()),
    }

    led.set_low();
    defmt::info!(
        "gonio {} ready; reset cause {}, brown-out level before boot {}",
        BOARD,
        defmt::Debug2Format(&reset_cause),
        defmt::Debug2Format(&bor)
    );
    // From here on a main loop that stops making progress restarts the chip.
    let mut watchdog = Watchdog::start(WATCHDOG_MS);

    let (mut errors, mut open, mut interlock_open) = (0, false, false);
    loop {
        let now = clock.now_us();
        // Open (high: the loop broken or a wire cut) is a fault; the interrupt has
        // already forced the pins.
        let cut = interlock.is_high();
        if interlock::tripped() && !cut {
            // A glitch the interrupt saw: the pins were forced, so the controller
            // goes to its safe state as well before the loop reads closed.
            service.ctrl.set_interlock(true, now);
            interlock_open = true;
        }
        if cut != interlock_open {
            interlock_open = cut;
            service.ctrl.set_interlock(cut, now);
            defmt::warn!(
                "interlock {}",
                if cut { "open: safe state" } else { "closed" }
            );
        }
        if VBUS_SENSE {
            let present = vbus::present();
            if present != link.vbus() {
                defmt::warn!(
                    "usb: VBUS {}",
                    if present { "back" } else { "lost: safe state" }
                );
            }
            link.set_vbus(present);
        }
        service.poll(&mut link, now);
        watchdog.feed();
        if let Some(record) = service.ctrl.take_settings_record() {
            if settings_flash::image_clear() {
                // The erase stalls the loop: the longest timeout meanwhile (the IWDG
                // takes new values while running), then the usual one again.
                Watchdog::start(4095);
                let stored = settings_flash::write(&mut flash, &record);
                Watchdog::start(WATCHDOG_MS);
                match stored {
                    Ok(()) => defmt::info!("settings stored"),
                    // The record stays as it was, or erased: the next boot says which.
                    Err(_) => defmt::error!("settings not stored: flash error"),
                }
            } else {
                defmt::error!("settings not stored: the image reaches their flash sector");
            }
        }
        if link.host_open() != open {
            open = link.host_open();
            if open {
                defmt::info!("usb: host opened the port (DTR on)");
            } else {
                defmt::info!("usb: host closed the port (DTR off): safe state, output discarded");
            }
        }
        if link.errors() != errors {
            errors = link.errors();
            defmt::warn!("usb: {} read/write errors so far", errors);
        }
    }
}

/// Makes the pins safe before anything else, then logs and restarts the chip.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    safety::force_safe_pins(SAFE_PINS);
    defmt::error!(
        "panic: {}; laser off, drivers disabled; restarting",
        defmt::Display2Format(info)
    );
    cortex_m::peripheral::SCB::sys_reset()
}

/// A HardFault (any fault, escalated): the same as a panic.
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    safety::force_safe_pins(SAFE_PINS);
    defmt::error!(
        "HardFault at pc={:#010x}; laser off, drivers disabled; restarting",
        frame.pc()
    );
    cortex_m::peripheral::SCB::sys_reset()
}
