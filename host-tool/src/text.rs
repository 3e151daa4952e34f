//! Text for messages: [`escape_line`] makes any string that quotes input one bounded,
//! printable line; [`count`] puts a number before a noun in the right number;
//! [`angle`] prints an angle in a label or a note.

/// `s` as one line of at most `max_chars` characters (plus `...` and the count left
/// out when cut): control characters (NUL, CR, LF, ESC, DEL, C1...) escaped as `\0`,
/// `\r`, `\n`, `\t` or `\u{..}`, a backslash doubled; printable characters, non-ASCII
/// included, kept. Runs in time linear in what it keeps, whatever the input's size.
pub fn escape_line(s: &str, max_chars: usize) -> String {
    let mut out = String::new();
    let mut used = 0usize;
    for (at, c) in s.char_indices() {
        let esc = match c {
            '\0' => "\\0".to_string(),
            '\n' => "\\n".to_string(),
            '\r' => "\\r".to_string(),
            '\t' => "\\t".to_string(),
            '\\' => "\\\\".to_string(),
            c if c.is_control() || c == '\u{feff}' || c == '\u{2028}' || c == '\u{2029}' => {
                format!("\\u{{{:x}}}", c as u32)
            }
            c => c.to_string(),
        };
        let n = esc.chars().count();
        if used + n > max_chars {
            let left = s[at..].chars().count();
            out.push_str(&format!("... ({left} more characters)"));
            return out;
        }
        used += n;
        out.push_str(&esc);
    }
    out
}

/// `n noun`, with an `s` unless `n` is 1: "1 free parameter", "13 free parameters".
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// An angle (degrees) as labels and notes print it: rounded to 0.01 degree in its
/// shortest form (`20`, `22.5`, `30.16`, never `-0`), so an incidence read from a file
/// (30.15640533663018) or an angle corrected by `--offset` (29.98826066030085) reads
/// as a person would write it. Only for text people read: JSON, exports and file names
/// keep every digit.
pub fn angle(t: f64) -> String {
    let r = (t * 100.0).round() / 100.0;
    // -0.004 rounds to -0: printed as 0.
    let r = if r == 0.0 { 0.0 } else { r };
    if r.is_finite() {
        format!("{r}")
    } else {
        format!("{t}")
    }
}

/// A number for notes people read, to `digits` significant digits in
/// [`brdf_core::error::Short`]'s form (`637.4`, `2.7e27`), never 17 digits of noise.
pub fn sig(x: f64, digits: usize) -> String {
    let p = digits.max(1) - 1;
    let rounded = format!("{x:.p$e}").parse::<f64>().unwrap_or(x);
    brdf_core::error::Short(rounded).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_print_to_a_hundredth_of_a_degree() {
        for (t, s) in [
            (20.0, "20"),
            (22.5, "22.5"),
            (41.4, "41.4"),
            (30.15640533663018, "30.16"),
            (29.98826066030085, "29.99"),
            (-0.004, "0"),
            (-12.345678, "-12.35"),
            (89.999996, "90"),
        ] {
            assert_eq!(angle(t), s, "{t}");
        }
    }

    #[test]
    fn counts_in_the_right_number() {
        assert_eq!(count(1, "free parameter"), "1 free parameter");
        assert_eq!(count(0, "file"), "0 files");
        assert_eq!(count(13, "free parameter"), "13 free parameters");
    }

    #[test]
    fn escapes_controls_and_bounds_length() {
        assert_eq!(escape_line("plain é", 80), "plain é");
        assert_eq!(
            escape_line("a\0b\r\nc\x1b[2J\\", 80),
            "a\\0b\\r\\nc\\u{1b}[2J\\\\"
        );
        assert_eq!(escape_line("\u{feff}x\u{7f}", 80), "\\u{feff}x\\u{7f}");
        let big = "x".repeat(10_000_000);
        let e = escape_line(&big, 40);
        assert!(e.starts_with(&"x".repeat(40)));
        assert!(e.ends_with("(9999960 more characters)"), "{e}");
        assert!(!e.contains('\n'));
        assert_eq!(escape_line("abc", 0), "... (3 more characters)");
        // An escape is never cut in half.
        assert_eq!(escape_line("ab\0", 3), "ab... (1 more characters)");
    }
}
