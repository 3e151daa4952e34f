//! Instruction counts of the f32 evaluation variants on the Cortex-M4, under QEMU
//! (`cargo xtask firmware-bench`). QEMU's DWT cycle counter reads 0, so: with
//! `-icount shift=0` SysTick advances with executed instructions; it is calibrated
//! against a block of exactly 4096 `nop`s, then each variant evaluates the paper grid
//! (153 points) 20 times. Counts are instructions, not cycles. Results go out through
//! semihosting; the program exits with status 0.
#![no_std]
#![no_main]

use brdf_core::fast::FastModel;
use brdf_core::{Model, Params};
use cortex_m::peripheral::{SYST, syst::SystClkSource};
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};

const REPS: u32 = 20;

fn ticks(syst: &SYST, f: impl FnOnce()) -> u32 {
    let start = SYST::get_current();
    f();
    let end = SYST::get_current();
    let _ = syst;
    // SysTick counts down, 24 bits.
    start.wrapping_sub(end) & 0x00FF_FFFF
}

#[inline(never)]
fn nops() {
    // SAFETY: no operands, no side effects: 4096 nop instructions.
    unsafe { core::arch::asm!(".rept 4096", "nop", ".endr") };
}

#[inline(never)]
fn eval_libm(m: &Model<f32>, ti: f32, tr: f32) -> f32 {
    m.eval_in_plane(ti, tr).map_or(0.0, |e| e.f)
}

#[inline(never)]
fn eval_fast(m: &FastModel, ti: f32, tr: f32) -> f32 {
    m.eval_in_plane(ti, tr)
}

fn grid(mut f: impl FnMut(f32, f32) -> f32) -> f32 {
    let mut s = 0.0;
    for _ in 0..REPS {
        for i in 0..9 {
            for r in 0..17 {
                s += f(
                    core::hint::black_box(10.0 * i as f32),
                    -80.0 + 10.0 * r as f32,
                );
            }
        }
    }
    s
}

#[entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap();
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(0x00FF_FFFF);
    cp.SYST.clear_current();
    cp.SYST.enable_counter();
    let syst = &cp.SYST;
    // Calibration: ticks per instruction (the call adds a handful of instructions).
    let cal = ticks(syst, || {
        for _ in 0..8 {
            nops();
        }
    });
    let per_instr = cal as f32 / (8.0 * 4096.0);
    let m = Model::three_component(Params {
        ks: 215.0f32,
        sigma: 0.115,
        kdd: 900.0,
        sigma_m: 0.7,
        kid: 25.0,
    })
    .unwrap();
    let fast = FastModel::new(&m, 0.0);
    let cull = FastModel::new(&m, 1e-3);
    let loop_only = ticks(syst, || {
        core::hint::black_box(grid(|a, b| a + b));
    });
    let n = (REPS * 153) as f32;
    let report = |name: &str, t: u32| {
        let instr = (t.saturating_sub(loop_only)) as f32 / per_instr / n;
        hprintln!("variant {} instructions_per_eval {}", name, instr as u32);
    };
    hprintln!("calibration ticks_per_instruction {}", per_instr);
    report(
        "f32-libm",
        ticks(syst, || {
            core::hint::black_box(grid(|a, b| eval_libm(&m, a, b)));
        }),
    );
    report(
        "f32-fast",
        ticks(syst, || {
            core::hint::black_box(grid(|a, b| eval_fast(&fast, a, b)));
        }),
    );
    report(
        "f32-fast-cull-1e-3",
        ticks(syst, || {
            core::hint::black_box(grid(|a, b| eval_fast(&cull, a, b)));
        }),
    );
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::bkpt();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("bench panic: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    hprintln!("bench HardFault at pc={:#010x}", frame.pc());
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}
