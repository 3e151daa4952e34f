//! `cargo xtask`: builds firmware images and runs the QEMU end-to-end test.

fn main() {
    eprintln!("usage: cargo xtask firmware --board qemu|stm32f411 | qemu-e2e");
    std::process::exit(2);
}
