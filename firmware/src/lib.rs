//! Board-independent part of the goniometer firmware: the mechanics of our goniometer
//! and the service loop that connects a link (USB CDC or USART) to the brdf-core
//! controller. The boards in `src/bin/` only provide pins, a link and a clock.
#![no_std]
#![deny(missing_docs)]

pub mod mechanics;
pub mod service;
