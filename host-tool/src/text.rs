//! Text from outside (a device, a file) made safe to print or write on one line.

/// `s` on one line of at most `max_chars` characters: control characters (newlines,
/// escape sequences, DEL, C1 controls) escaped as `\n`, `\t`, `\r`, `\\` or `\u{..}`;
/// a longer text is cut and ends with `...`.
pub fn escape_line(s: &str, max_chars: usize) -> String {
    let mut out = String::new();
    let mut n = 0;
    for c in s.chars() {
        let piece: String = match c {
            '\n' => "\\n".into(),
            '\r' => "\\r".into(),
            '\t' => "\\t".into(),
            '\\' => "\\\\".into(),
            c if c.is_control() => format!("\\u{{{:x}}}", c as u32),
            c => c.to_string(),
        };
        let len = piece.chars().count();
        if n + len > max_chars {
            // Room for the ellipsis: drop what no longer fits.
            while n + 3 > max_chars && out.pop().is_some() {
                n -= 1;
            }
            if max_chars >= 3 {
                out.push_str("...");
            }
            return out;
        }
        out.push_str(&piece);
        n += len;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::escape_line;

    #[test]
    fn control_characters_are_escaped_and_length_bounded() {
        assert_eq!(escape_line("plain", 80), "plain");
        assert_eq!(escape_line("x\n0,0,1\nZ", 80), "x\\n0,0,1\\nZ");
        assert_eq!(escape_line("\u{1b}[31mred", 80), "\\u{1b}[31mred");
        assert_eq!(escape_line("a\\b", 80), "a\\\\b");
        let long = escape_line(&"é".repeat(100), 10);
        assert_eq!(long.chars().count(), 10);
        assert!(long.ends_with("..."));
        assert!(!escape_line(&"\u{7f}".repeat(50), 20).contains('\u{7f}'));
        assert!(escape_line(&"\u{7f}".repeat(50), 20).chars().count() <= 20);
    }
}
