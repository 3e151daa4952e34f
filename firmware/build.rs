//! Hands the repository's `memory.x` to the linker and picks the linker scripts per
//! binary (defmt's only for the stm32f411 board).

use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap());
    let memory = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap()).join("../memory.x");
    fs::copy(&memory, out.join("memory.x")).expect("copy ../memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    if env::var_os("CARGO_FEATURE_STM32F411").is_some() {
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
