//! Talking to a goniometer: the framed [`link`] over a byte [`Transport`], the
//! [`serial`] port, the [`simulated`] devices (in-process and on a pseudo-terminal) and
//! [`ports`] discovery. A [`Connector`] opens (and re-opens) the link to one device.

pub mod link;
pub mod ports;
pub mod serial;
pub mod simulated;

pub use link::{FramedLink, LinkError, Transport};
pub use serial::{SerialConnector, SerialTransport};
pub use simulated::{
    InProcessConnector, InProcessDevice, PtyDevice, SharedInProcessConnector, SimConfig,
};

/// Opens (and re-opens) the link to a device.
pub trait Connector {
    /// The transport it yields.
    type T: Transport;
    /// Opens the link; does not handshake.
    fn connect(&mut self) -> Result<FramedLink<Self::T>, LinkError>;
    /// Whether trying again after a lost link can help (a serial device may come back;
    /// an in-process one cannot get lost).
    fn can_reconnect(&self) -> bool;
}
