//! Board-independent part of the goniometer firmware. The controller, the service loop
//! and the arms' mechanics live in brdf-core (shared with the host's simulated
//! devices); the boards in `src/bin/` only provide pins, a link and a clock.
#![no_std]
#![deny(missing_docs)]

pub mod safety;

/// Firmware version reported in the handshake (major, minor, patch), from Cargo.
pub use brdf_core::identity::FIRMWARE_VERSION;
