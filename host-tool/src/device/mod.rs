//! Talking to a goniometer: the framed [`link`] over a byte [`Transport`], the
//! [`serial`] port, the [`simulated`] devices (in-process and on a pseudo-terminal) and
//! [`ports`] discovery. A [`Connector`] opens (and re-opens) the link to one device.

pub mod link;
pub mod ports;
pub mod serial;
pub mod simulated;

pub use link::{Connector, FramedLink, LinkError, Transport};
pub use serial::{SerialConnector, SerialTransport};
pub use simulated::{
    InProcessConnector, InProcessDevice, PtyDevice, SharedInProcessConnector, SimConfig,
};
