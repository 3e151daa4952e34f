//! `gonio ports`: lists the serial ports and marks the ones that look like our firmware.

use std::fmt::Write as _;
use std::path::Path;

use clap::Args;
use serialport::{SerialPortInfo, SerialPortType};

use crate::error::{CliError, CliResult};
use crate::output::write_stdout;

/// USB vendor ID of the goniometer firmware (the shared V-USB/pid.codes range).
pub const GONIO_VID: u16 = 0x16c0;
/// USB product ID of the goniometer firmware (CDC-ACM).
pub const GONIO_PID: u16 = 0x27dd;
/// USB product string of the goniometer firmware.
pub const GONIO_PRODUCT: &str = "gonio goniometer";

/// Arguments of `gonio ports`.
#[derive(Debug, Args)]
#[command(
    about = "List serial ports and mark the ones that look like the goniometer",
    long_about = "List serial ports, with USB details (VID:PID, manufacturer, product, \
serial number), and mark the ones that look like the goniometer firmware.\n\n\
Marker '*': the USB product string is \"gonio goniometer\" (the firmware's; normally with \
VID:PID 16c0:27dd). Marker '?': VID:PID 16c0:27dd but the system reported no product \
string, so it may be ours. 16c0:27dd alone is not enough: other hobby CDC-ACM devices \
share it. The firmware's serial number is the chip's 96-bit unique ID in hex.\n\n\
Pseudo-terminals (such as the /dev/pts/N that QEMU prints) are not listed: the system \
does not enumerate them as serial ports.\n\n\
Output: a table on stdout, or with --json a JSON array of objects with the keys port, \
type (usb, pci, bluetooth, unknown), vid and pid (4 hex digits, or null), manufacturer, \
product, serial_number (string or null) and gonio (\"yes\", \"maybe\" or \"no\").",
    after_help = "Examples:\n  gonio ports\n  gonio ports --json"
)]
pub struct PortsArgs {
    /// Print a JSON array instead of a table.
    #[arg(long)]
    pub json: bool,
}

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
    if product.eq_ignore_ascii_case(GONIO_PRODUCT) {
        Likeness::Yes
    } else if (vid, pid) == (GONIO_VID, GONIO_PID) && product.is_empty() {
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

/// The line printed when no port was found.
pub const NO_PORTS: &str = "no serial ports found (pseudo-terminals such as QEMU's \
/dev/pts/N are not listed: the system does not enumerate them)";

/// Formats the rows as a table with a header and, when anything is marked, a legend.
pub fn table(rows: &[PortRow]) -> String {
    let cells: Vec<[String; 6]> = rows
        .iter()
        .map(|r| {
            [
                r.port.clone(),
                r.kind.to_string(),
                r.vid_pid
                    .map(|(v, p)| format!("{v:04x}:{p:04x}"))
                    .unwrap_or_else(|| "-".into()),
                r.manufacturer.clone().unwrap_or_else(|| "-".into()),
                r.product.clone().unwrap_or_else(|| "-".into()),
                r.serial_number.clone().unwrap_or_else(|| "-".into()),
            ]
        })
        .collect();
    let header = [
        "PORT",
        "TYPE",
        "VID:PID",
        "MANUFACTURER",
        "PRODUCT",
        "SERIAL",
    ];
    let mut width = header.map(|h| h.chars().count());
    for row in &cells {
        for (w, c) in width.iter_mut().zip(row) {
            *w = (*w).max(c.chars().count());
        }
    }
    let mut out = String::new();
    let mut line = |marker: &str, fields: &[&str]| {
        let mut l = format!("{marker} ");
        for (i, (f, w)) in fields.iter().zip(width).enumerate() {
            if i + 1 == fields.len() {
                l.push_str(f);
            } else {
                let _ = write!(l, "{f:<w$}  ");
            }
        }
        out.push_str(l.trim_end());
        out.push('\n');
    };
    line(" ", &header);
    for (r, c) in rows.iter().zip(&cells) {
        let fields: Vec<&str> = c.iter().map(String::as_str).collect();
        line(r.gonio.marker(), &fields);
    }
    if rows.iter().any(|r| r.gonio == Likeness::Yes) {
        out.push_str("* looks like the gonio firmware (product \"gonio goniometer\")\n");
    }
    if rows.iter().any(|r| r.gonio == Likeness::Maybe) {
        out.push_str("? VID:PID 16c0:27dd without a product string: may be the gonio firmware\n");
    }
    out
}

/// Writes `s` as a JSON string literal (quotes included).
pub fn json_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 || c == '\u{7f}' => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn json_opt(s: Option<&str>) -> String {
    s.map(json_string).unwrap_or_else(|| "null".into())
}

/// Formats the rows as a JSON array, one object per line.
pub fn json(rows: &[PortRow]) -> String {
    if rows.is_empty() {
        return "[]\n".into();
    }
    let mut out = String::from("[\n");
    for (i, r) in rows.iter().enumerate() {
        let (vid, pid) = match r.vid_pid {
            Some((v, p)) => (format!("\"{v:04x}\""), format!("\"{p:04x}\"")),
            None => ("null".into(), "null".into()),
        };
        let _ = write!(
            out,
            "  {{\"port\": {}, \"type\": {}, \"vid\": {vid}, \"pid\": {pid}, \
\"manufacturer\": {}, \"product\": {}, \"serial_number\": {}, \"gonio\": {}}}",
            json_string(&r.port),
            json_string(r.kind),
            json_opt(r.manufacturer.as_deref()),
            json_opt(r.product.as_deref()),
            json_opt(r.serial_number.as_deref()),
            json_string(r.gonio.word()),
        );
        out.push_str(if i + 1 < rows.len() { ",\n" } else { "\n" });
    }
    out.push_str("]\n");
    out
}

/// Runs `gonio ports`.
pub fn run(args: &PortsArgs) -> CliResult {
    let mut infos = available_ports()
        .map_err(|e| CliError::failed(format!("cannot list serial ports: {e}")))?;
    infos.sort_by(|a, b| a.port_name.cmp(&b.port_name));
    let rows: Vec<PortRow> = infos.iter().map(PortRow::from_info).collect();
    if args.json {
        if rows.is_empty() {
            eprintln!("gonio: {NO_PORTS}");
        }
        write_stdout(json(&rows).as_bytes())
    } else if rows.is_empty() {
        write_stdout(format!("{NO_PORTS}\n").as_bytes())
    } else {
        write_stdout(table(&rows).as_bytes())
    }
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
        let dir = std::env::temp_dir().join(format!("gonio-ports-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let dev = dir.join("ttyACM0");
        std::fs::write(&dev, b"").unwrap();
        let by_id = dir.join("usb-gonio_gonio_goniometer_3F0041-if00");
        let _ = std::fs::remove_file(&by_id);
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
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn row(port: &str, product: Option<&str>, gonio: Likeness) -> PortRow {
        PortRow {
            port: port.into(),
            kind: "usb",
            vid_pid: Some((0x16c0, 0x27dd)),
            manufacturer: Some("gonio".into()),
            product: product.map(Into::into),
            serial_number: Some("0123ABCD".into()),
            gonio,
        }
    }

    #[test]
    fn table_marks_ours_and_explains_the_marker() {
        let rows = [
            row("/dev/ttyACM0", Some("gonio goniometer"), Likeness::Yes),
            PortRow {
                port: "/dev/ttyS0".into(),
                kind: "pci",
                vid_pid: None,
                manufacturer: None,
                product: None,
                serial_number: None,
                gonio: Likeness::No,
            },
        ];
        let t = table(&rows);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), 4, "{t}");
        assert!(lines[0].starts_with("  PORT"));
        assert!(lines[1].starts_with("* /dev/ttyACM0"));
        assert!(lines[1].contains("16c0:27dd") && lines[1].ends_with("0123ABCD"));
        assert!(lines[2].starts_with("  /dev/ttyS0") && lines[2].contains(" - "));
        assert!(lines[3].starts_with("* looks like"));
        // Columns line up.
        let col = lines[0].find("TYPE").unwrap();
        assert_eq!(&lines[1][col..col + 3], "usb");
        assert_eq!(&lines[2][col..col + 3], "pci");
    }

    #[test]
    fn json_escapes_and_uses_null() {
        assert_eq!(
            json_string("a\"b\\c\nd\u{1}é"),
            "\"a\\\"b\\\\c\\nd\\u0001é\""
        );
        assert_eq!(json(&[]), "[]\n");
        let j = json(&[row("COM3", None, Likeness::Maybe)]);
        assert_eq!(
            j,
            "[\n  {\"port\": \"COM3\", \"type\": \"usb\", \"vid\": \"16c0\", \"pid\": \"27dd\", \
\"manufacturer\": \"gonio\", \"product\": null, \"serial_number\": \"0123ABCD\", \
\"gonio\": \"maybe\"}\n]\n"
        );
    }
}
