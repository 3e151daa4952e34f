//! Host-side tests of the stm32f411 board's USB link (usb-link over usb-device and
//! usbd-serial, with brdf-core's service loop on top, as the firmware runs them) on a
//! simulated USB bus driven by a modelled host, with gonio's own decoder, capture
//! engine and port matcher on the host side.

mod bus;
mod host;
mod port;
mod rig;

mod descriptors;
mod dtr;
mod frames;
mod suspend;
mod sweep;
