//! Talking to a goniometer: the framed [`link`] over a byte [`Transport`], the
//! [`serial`] port, the [`simulated`] devices (in-process and on a pseudo-terminal; the
//! sample a preset's model or a [`replay`]ed sweep) and [`ports`] discovery. A [`Connector`] opens (and re-opens) the link to one device.

pub mod link;
pub mod ports;
pub mod replay;
pub mod serial;
pub mod simulated;

pub use link::{Connector, FramedLink, LinkError, Transport};
pub use serial::{SerialConnector, SerialTransport};
pub use simulated::{
    InProcessConnector, InProcessDevice, OtherSample, PtyDevice, Sample, SharedInProcessConnector,
    SimConfig,
};
