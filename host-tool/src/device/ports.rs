//! Port discovery: which serial ports the system lists, with their USB details, and
//! how much each looks like the goniometer firmware.

use brdf_core::identity::{USB_PID, USB_PRODUCT, USB_VID};
use serialport::{SerialPortInfo, SerialPortType};

/// How much a port looks like the goniometer firmware.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Likeness {
    /// The product string is the firmware's (marker `*`).
    Yes,
    /// The firmware's VID:PID, but no product string was reported (marker `?`).
    Maybe,
    /// Anything else.
    No,
}

impl Likeness {
    /// The one-character marker shown in the table.
    pub fn marker(self) -> &'static str {
        match self {
            Likeness::Yes => "*",
            Likeness::Maybe => "?",
            Likeness::No => " ",
        }
    }

    /// The word used in the JSON output.
    pub fn word(self) -> &'static str {
        match self {
            Likeness::Yes => "yes",
            Likeness::Maybe => "maybe",
            Likeness::No => "no",
        }
    }
}

/// Decides whether a USB serial port looks like the goniometer firmware.
///
/// The product string decides: `"gonio goniometer"` (compared without case, surrounding
/// blanks, and with `_` taken as a space, since udev may report `gonio_goniometer`) is
/// [`Likeness::Yes`], whatever the VID:PID. VID:PID 16c0:27dd with no (or an empty)
/// product string is [`Likeness::Maybe`]; with another product string it is someone
/// else's device on the shared VID:PID, [`Likeness::No`].
pub fn looks_like_gonio(vid: u16, pid: u16, product: Option<&str>) -> Likeness {
    let product = product
        .map(|p| p.trim().replace('_', " "))
        .unwrap_or_default();
    if product.eq_ignore_ascii_case(USB_PRODUCT) {
        Likeness::Yes
    } else if (vid, pid) == (USB_VID, USB_PID) && product.is_empty() {
        Likeness::Maybe
    } else {
        Likeness::No
    }
}

/// One listed port, ready to print.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortRow {
    /// Device path or name (`/dev/ttyACM0`, `COM3`).
    pub port: String,
    /// `usb`, `pci`, `bluetooth` or `unknown`.
    pub kind: &'static str,
    /// USB vendor and product ID, for USB ports.
    pub vid_pid: Option<(u16, u16)>,
    /// USB manufacturer string.
    pub manufacturer: Option<String>,
    /// USB product string.
    pub product: Option<String>,
    /// USB serial number.
    pub serial_number: Option<String>,
    /// Whether it looks like the goniometer.
    pub gonio: Likeness,
}

impl PortRow {
    /// Converts what `serialport` reports.
    pub fn from_info(info: &SerialPortInfo) -> Self {
        let mut row = PortRow {
            port: info.port_name.clone(),
            kind: "unknown",
            vid_pid: None,
            manufacturer: None,
            product: None,
            serial_number: None,
            gonio: Likeness::No,
        };
        match &info.port_type {
            SerialPortType::UsbPort(usb) => {
                row.kind = "usb";
                row.vid_pid = Some((usb.vid, usb.pid));
                row.manufacturer = usb.manufacturer.clone();
                row.product = usb.product.clone();
                row.serial_number = usb.serial_number.clone();
                row.gonio = looks_like_gonio(usb.vid, usb.pid, usb.product.as_deref());
            }
            SerialPortType::PciPort => row.kind = "pci",
            SerialPortType::BluetoothPort => row.kind = "bluetooth",
            SerialPortType::Unknown => {}
        }
        row
    }
}

/// The serial ports the system lists, sorted by name.
pub fn list() -> Result<Vec<PortRow>, serialport::Error> {
    let mut infos = serialport::available_ports()?;
    infos.sort_by(|a, b| a.port_name.cmp(&b.port_name));
    Ok(infos.iter().map(PortRow::from_info).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn firmware_identity_is_ours() {
        assert_eq!(
            looks_like_gonio(0x16c0, 0x27dd, Some("gonio goniometer")),
            Likeness::Yes
        );
    }

    #[test]
    fn product_string_alone_is_enough() {
        assert_eq!(
            looks_like_gonio(0x1234, 0x5678, Some("gonio goniometer")),
            Likeness::Yes
        );
        // udev's ID_MODEL form, case and blanks do not matter.
        assert_eq!(
            looks_like_gonio(0x16c0, 0x27dd, Some(" Gonio_Goniometer ")),
            Likeness::Yes
        );
    }

    #[test]
    fn shared_vid_pid_needs_the_product_string() {
        assert_eq!(
            looks_like_gonio(0x16c0, 0x27dd, Some("Some Other Gadget")),
            Likeness::No
        );
        assert_eq!(looks_like_gonio(0x16c0, 0x27dd, None), Likeness::Maybe);
        assert_eq!(
            looks_like_gonio(0x16c0, 0x27dd, Some("  ")),
            Likeness::Maybe
        );
    }

    #[test]
    fn other_devices_are_not_ours() {
        assert_eq!(
            looks_like_gonio(0x0483, 0x374b, Some("STM32 STLink")),
            Likeness::No
        );
        assert_eq!(looks_like_gonio(0x0403, 0x6001, None), Likeness::No);
        assert_eq!(
            looks_like_gonio(0x16c0, 0x27dd, Some("gonio goniometer v2")),
            Likeness::No
        );
    }
}
