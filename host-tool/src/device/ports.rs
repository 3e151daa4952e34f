//! Port discovery: which serial ports the system lists, with their USB details, and
//! how much each looks like the goniometer firmware.

use brdf_core::identity::{USB_PID, USB_PRODUCT, USB_VID};
use std::path::Path;

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

/// The system's serial ports. Without libudev, serialport reads `/sys/class/tty` on
/// Linux and panics when it is absent (a container without sysfs): that is an error here.
pub fn available_ports() -> Result<Vec<SerialPortInfo>, String> {
    if cfg!(target_os = "linux") && !Path::new("/sys/class/tty").is_dir() {
        return Err("/sys/class/tty is missing (sysfs not mounted?)".into());
    }
    serialport::available_ports().map_err(|e| e.to_string())
}

/// The USB serial number of the port at `path`, if `infos` lists it as a USB port.
/// Paths are compared after resolving symlinks, so `/dev/serial/by-id/...` names the
/// same port as the `/dev/ttyACM0` it points to.
pub fn usb_serial_of(infos: &[SerialPortInfo], path: &Path) -> Option<String> {
    let real = std::fs::canonicalize(path).ok()?;
    infos.iter().find_map(|p| match &p.port_type {
        SerialPortType::UsbPort(u) if std::fs::canonicalize(&p.port_name).ok()? == real => {
            u.serial_number.clone()
        }
        _ => None,
    })
}

/// The USB port whose serial number is `serial`: how a device that came back under
/// another name (`/dev/ttyACM1` after `/dev/ttyACM0`) is found again.
pub fn find_by_usb_serial<'a>(
    infos: &'a [SerialPortInfo],
    serial: &str,
) -> Option<&'a SerialPortInfo> {
    infos.iter().find(|p| {
        matches!(&p.port_type, SerialPortType::UsbPort(u) if u.serial_number.as_deref() == Some(serial))
    })
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
pub fn list() -> Result<Vec<PortRow>, String> {
    let mut infos = available_ports()?;
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

    // What serialport reports is tested on constructed `SerialPortInfo`s, not on a fake
    // sysfs tree: without libudev, serialport 4.10.1 enumerates Linux ports in
    // `posix/enumerate.rs` by reading the hard-coded `/sys/class/tty/` (and checking
    // `/dev/NAME` exists), and its sysfs readers (`read_port_type`,
    // `read_usb_port_info`) are private, with no way to give them another root. Only a
    // mount namespace with a bind mount over /sys/class/tty (root only) could fake one.
    // What it reads there: `idVendor`/`idProduct` (hex), `product`, `manufacturer` and
    // `serial` of the USB device, the raw strings, which is what these infos hold.
    fn usb_info(
        port: &str,
        vid: u16,
        pid: u16,
        product: Option<&str>,
        serial: Option<&str>,
    ) -> SerialPortInfo {
        SerialPortInfo {
            port_name: port.into(),
            port_type: SerialPortType::UsbPort(serialport::UsbPortInfo {
                vid,
                pid,
                serial_number: serial.map(Into::into),
                manufacturer: Some("gonio".into()),
                product: product.map(Into::into),
                interface: Some(0),
            }),
        }
    }

    #[test]
    fn rows_from_port_infos_mark_the_board() {
        let infos = [
            usb_info(
                "/dev/ttyACM0",
                0x16c0,
                0x27dd,
                Some("gonio goniometer"),
                Some("3F0041000C51333034353235"),
            ),
            usb_info("/dev/ttyACM1", 0x16c0, 0x27dd, None, Some("1")),
            usb_info(
                "/dev/ttyACM2",
                0x16c0,
                0x27dd,
                Some("Some Other Gadget"),
                None,
            ),
            SerialPortInfo {
                port_name: "/dev/ttyS0".into(),
                port_type: SerialPortType::PciPort,
            },
            SerialPortInfo {
                port_name: "/dev/rfcomm0".into(),
                port_type: SerialPortType::BluetoothPort,
            },
        ];
        let rows: Vec<PortRow> = infos.iter().map(PortRow::from_info).collect();
        let marks: Vec<Likeness> = rows.iter().map(|r| r.gonio).collect();
        assert_eq!(
            marks,
            [
                Likeness::Yes,
                Likeness::Maybe,
                Likeness::No,
                Likeness::No,
                Likeness::No
            ]
        );
        assert_eq!(rows[0].vid_pid, Some((0x16c0, 0x27dd)));
        assert_eq!(
            rows[0].serial_number.as_deref(),
            Some("3F0041000C51333034353235")
        );
        assert_eq!(rows[0].product.as_deref(), Some("gonio goniometer"));
        assert_eq!(
            rows.iter().map(|r| r.kind).collect::<Vec<_>>(),
            ["usb", "usb", "usb", "pci", "bluetooth"]
        );
        assert_eq!(rows[3].vid_pid, None);
    }

    #[test]
    fn a_lost_device_is_found_again_by_usb_serial_number() {
        let infos = [
            SerialPortInfo {
                port_name: "/dev/ttyS0".into(),
                port_type: SerialPortType::PciPort,
            },
            usb_info(
                "/dev/ttyACM0",
                0x0483,
                0x374b,
                Some("STM32 STLink"),
                Some("066DFF"),
            ),
            usb_info(
                "/dev/ttyACM3",
                0x16c0,
                0x27dd,
                Some("gonio goniometer"),
                Some("3F0041"),
            ),
        ];
        let found = find_by_usb_serial(&infos, "3F0041").unwrap();
        assert_eq!(found.port_name, "/dev/ttyACM3");
        assert_eq!(
            find_by_usb_serial(&infos, "066DFF").unwrap().port_name,
            "/dev/ttyACM0"
        );
        // Exact match only: no prefix, no other device, no port without a number.
        assert!(find_by_usb_serial(&infos, "3F00").is_none());
        assert!(find_by_usb_serial(&infos, "").is_none());
        let none = [usb_info("/dev/ttyACM0", 0x16c0, 0x27dd, None, None)];
        assert!(find_by_usb_serial(&none, "3F0041").is_none());
    }

    #[test]
    fn the_serial_number_of_a_path_follows_symlinks() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let dev = dir.join("ttyACM0");
        std::fs::write(&dev, b"").unwrap();
        let by_id = dir.join("usb-gonio_gonio_goniometer_3F0041-if00");
        std::os::unix::fs::symlink(&dev, &by_id).unwrap();
        let other = dir.join("ttyACM1");
        std::fs::write(&other, b"").unwrap();
        let infos = [
            usb_info(other.to_str().unwrap(), 0x16c0, 0x27dd, None, Some("OTHER")),
            usb_info(
                dev.to_str().unwrap(),
                0x16c0,
                0x27dd,
                Some("gonio goniometer"),
                Some("3F0041"),
            ),
        ];
        assert_eq!(usb_serial_of(&infos, &dev).as_deref(), Some("3F0041"));
        assert_eq!(usb_serial_of(&infos, &by_id).as_deref(), Some("3F0041"));
        assert_eq!(usb_serial_of(&infos, &dir.join("missing")), None);
    }
}
