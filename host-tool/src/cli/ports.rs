//! `gonio ports`: lists the serial ports as a table or JSON, marking the ones that look
//! like the goniometer firmware.

use std::fmt::Write as _;
use std::io;

use clap::Args;
use serde::Serialize;

use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::device::ports::{self, Likeness, PortRow};

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

/// One port in `--json`: the keys the help text documents, in that order.
#[derive(Serialize)]
struct PortJson<'a> {
    port: &'a str,
    #[serde(rename = "type")]
    kind: &'a str,
    vid: Option<String>,
    pid: Option<String>,
    manufacturer: Option<&'a str>,
    product: Option<&'a str>,
    serial_number: Option<&'a str>,
    gonio: &'a str,
}

/// serde_json's compact form with a space after every `:` and `,` (one object per
/// line, readable and still strict JSON).
struct Spaced;

impl serde_json::ser::Formatter for Spaced {
    fn begin_object_key<W: ?Sized + io::Write>(
        &mut self,
        w: &mut W,
        first: bool,
    ) -> io::Result<()> {
        if first { Ok(()) } else { w.write_all(b", ") }
    }

    fn begin_object_value<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        w.write_all(b": ")
    }
}

fn json_line(r: &PortRow) -> String {
    let row = PortJson {
        port: &r.port,
        kind: r.kind,
        vid: r.vid_pid.map(|(v, _)| format!("{v:04x}")),
        pid: r.vid_pid.map(|(_, p)| format!("{p:04x}")),
        manufacturer: r.manufacturer.as_deref(),
        product: r.product.as_deref(),
        serial_number: r.serial_number.as_deref(),
        gonio: r.gonio.word(),
    };
    let mut out = Vec::new();
    row.serialize(&mut serde_json::Serializer::with_formatter(
        &mut out, Spaced,
    ))
    .expect("JSON of strings");
    String::from_utf8(out).expect("serde_json writes UTF-8")
}

/// Formats the rows as a JSON array, one object per line.
pub fn json(rows: &[PortRow]) -> String {
    if rows.is_empty() {
        return "[]\n".into();
    }
    let lines: Vec<String> = rows.iter().map(json_line).collect();
    format!("[\n  {}\n]\n", lines.join(",\n  "))
}

/// Runs `gonio ports`.
pub fn run(args: &PortsArgs) -> CliResult {
    let rows =
        ports::list().map_err(|e| CliError::failed(format!("cannot list serial ports: {e}")))?;
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
        let odd = PortRow {
            port: "a\"b\\c\nd\u{1}é".into(),
            ..row("x", None, Likeness::No)
        };
        let j = json(&[odd]);
        assert!(j.contains("\"port\": \"a\\\"b\\\\c\\nd\\u0001é\""), "{j}");
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
