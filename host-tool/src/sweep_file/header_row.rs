//! The sweep table's header row: which delimiter the table uses (`,` `;` or tab,
//! sniffed from the header row) and where each of [`COLUMNS`] is (names in any case).

use super::format::COLUMNS;
use crate::text::escape_line;

/// The delimiters a sweep table may use, in the order a tie is settled (comma first).
pub const DELIMITERS: [u8; 3] = [b',', b';', b'\t'];

/// How a delimiter is named in messages.
pub fn delimiter_name(d: u8) -> &'static str {
    match d {
        b';' => "';'",
        b'\t' => "tab",
        _ => "','",
    }
}

/// The delimiter of the table starting at `table`: the one of [`DELIMITERS`] found most
/// often (outside double quotes) in its first line, the header row; a comma when none is.
/// The header row decides because its names hold no decimal commas, which a
/// `;`-separated row of numbers may.
pub fn sniff_delimiter(table: &[u8]) -> u8 {
    let mut counts = [0usize; 3];
    let mut quoted = false;
    for &b in table {
        match b {
            b'"' => quoted = !quoted,
            b'\n' | b'\r' if !quoted => break,
            _ if !quoted => {
                if let Some(k) = DELIMITERS.iter().position(|&d| d == b) {
                    counts[k] += 1;
                }
            }
            _ => {}
        }
    }
    let best = (0..3).fold(0, |best, k| if counts[k] > counts[best] { k } else { best });
    DELIMITERS[best]
}

/// Where each of [`COLUMNS`] is in the header row `fields` (names compared without
/// regard to case: `Theta_i` is `theta_i`). The first three are required and none may
/// appear twice; a header without them is refused with one line listing what it holds.
pub fn header_columns(fields: &[&str], delimiter: u8) -> Result<[Option<usize>; 7], String> {
    let find = |name: &str| fields.iter().position(|c| c.eq_ignore_ascii_case(name));
    let idx = COLUMNS.map(find);
    let missing: Vec<&str> = COLUMNS
        .iter()
        .zip(idx)
        .take(3)
        .filter(|(_, i)| i.is_none())
        .map(|(n, _)| *n)
        .collect();
    if let Some(first) = missing.first() {
        let shown: Vec<String> = fields.iter().map(|f| format!("'{f}'")).collect();
        return Err(format!(
            "missing column '{first}': the header row holds {} column(s) separated by {}: {}; gonio reads theta_i, theta_r, brdf (any case); for other names use gonio import table FILE --columns theta_i=NAME,theta_r=NAME,brdf=NAME",
            fields.len(),
            delimiter_name(delimiter),
            escape_line(&shown.join(" "), 120)
        ));
    }
    for name in COLUMNS {
        if fields
            .iter()
            .filter(|c| c.eq_ignore_ascii_case(name))
            .count()
            > 1
        {
            return Err(format!(
                "column '{name}' appears more than once: which one is meant?"
            ));
        }
    }
    Ok(idx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep_file::parse_sweep;

    #[test]
    fn the_delimiter_is_the_header_rows_most_frequent() {
        assert_eq!(sniff_delimiter(b"theta_i;theta_r;brdf\n0,5;1,5;2\n"), b';');
        assert_eq!(sniff_delimiter(b"theta_i\ttheta_r\tbrdf\n"), b'\t');
        assert_eq!(sniff_delimiter(b"theta_i,theta_r,brdf\r\n"), b',');
        // A quoted name holding another delimiter does not count.
        assert_eq!(sniff_delimiter(b"\"a;b;c\",theta_r,brdf\n"), b',');
        // None at all (one column): a comma, as before.
        assert_eq!(sniff_delimiter(b"brdf\n1\n"), b',');
        assert_eq!(sniff_delimiter(b""), b',');
    }

    #[test]
    fn semicolon_tab_and_any_case_headers_are_read() {
        let expect = [(20.0, -10.0, 1.5), (20.0, 30.0, 2.5)];
        for text in [
            &b"# brdf: 1/sr\ntheta_i;theta_r;brdf\n20;-10;1.5\n20;30;2.5\n"[..],
            b"theta_i\ttheta_r\tbrdf\n20\t-10\t1.5\n20\t30\t2.5\n",
            b"Theta_i,Theta_r,BRDF\n20,-10,1.5\n20,30,2.5\n",
            b"THETA_R ; theta_I ; Brdf ; STD\r\n-10;20;1.5;0.1\r\n30;20;2.5;0.1\r\n",
        ] {
            let data = parse_sweep(text).unwrap();
            let got: Vec<_> = data
                .rows
                .iter()
                .map(|r| (r.theta_i, r.theta_r, r.brdf))
                .collect();
            assert_eq!(got, expect, "{}", String::from_utf8_lossy(text));
        }
        let with_std = parse_sweep(b"THETA_R;theta_I;Brdf;STD\n-10;20;1.5;0.1\n").unwrap();
        assert_eq!(with_std.rows[0].std, Some(0.1));
    }

    #[test]
    fn a_header_not_understood_is_listed_in_one_line() {
        let (line, msg) = parse_sweep(b"# x\nAOI;AOS;BRDF\n10;20;3\n").unwrap_err();
        assert_eq!(line, 2);
        assert!(
            msg.contains("missing column 'theta_i'")
                && msg.contains("3 column(s) separated by ';'")
                && msg.contains("'AOI' 'AOS' 'BRDF'")
                && msg.contains("gonio import table")
                && !msg.contains('\n'),
            "{msg}"
        );
        let (_, msg) = parse_sweep(b"theta_i\tTHETA_I\ttheta_r\tbrdf\n").unwrap_err();
        assert!(msg.contains("'theta_i' appears more than once"), "{msg}");
    }

    #[test]
    fn a_decimal_comma_says_how_to_import_it() {
        let (line, msg) = parse_sweep(b"theta_i;theta_r;brdf\n20;-10;1,5\n").unwrap_err();
        assert_eq!(line, 2);
        assert!(
            msg.contains("brdf '1,5' is not a finite number") && msg.contains("--decimal-comma"),
            "{msg}"
        );
    }
}
