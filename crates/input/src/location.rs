//! Where in a user's text a problem is: the 1-based line of a byte offset, and the TOML key
//! whose value starts there, so an error names the file, the line and the key (scenario,
//! candidates and study files).
//!
//! ```
//! use crashrig_input::location::{line_of, toml_value_key};
//! let text = "[grid]\nthreshold_mm = \"5\"\n";
//! let at = text.find('"').unwrap(); // where a parser reports "invalid type: string"
//! assert_eq!((line_of(text, at), toml_value_key(text, at)), (2, Some("threshold_mm")));
//! ```

/// 1-based line of a byte offset of a text (an offset past the end is the last line).
pub fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|b| **b == b'\n')
        .count()
        + 1
}

/// 1-based (line, column) of byte `offset` of `bytes` (text that may not be valid UTF-8); the
/// column counts bytes from the start of the line. An offset past the end is taken as the end.
///
/// ```
/// use crashrig_input::location::line_col_of;
/// assert_eq!(line_col_of(b"ab\ncd", 4), (2, 2));
/// assert_eq!(line_col_of(b"\xff", 0), (1, 1));
/// ```
pub fn line_col_of(bytes: &[u8], offset: usize) -> (usize, usize) {
    let before = &bytes[..offset.min(bytes.len())];
    let line = before.iter().filter(|b| **b == b'\n').count() + 1;
    let start = before
        .iter()
        .rposition(|b| *b == b'\n')
        .map_or(0, |p| p + 1);
    (line, before.len() - start + 1)
}

/// The key whose value starts at byte `offset` of a TOML text (`threshold_mm = "5"` → the
/// offset of `"5"` gives `threshold_mm`), so a parser's type error ("invalid type: string,
/// expected f64", located at the value) can name the key. Looks left on the value's line for
/// `key =`; dotted and quoted keys are returned as written. `None` when the offset is not
/// right after `key =` (a value inside an array, a syntax error).
///
/// ```
/// use crashrig_input::location::toml_value_key;
/// let text = "[grid]\nthreshold_mm = \"5\"\n";
/// assert_eq!(toml_value_key(text, text.find('"').unwrap()), Some("threshold_mm"));
/// let inline = "camera = { model = 3, width = 10 }";
/// assert_eq!(toml_value_key(inline, inline.find('3').unwrap()), Some("model"));
/// assert_eq!(toml_value_key("x = [1, 2]", 8), None);
/// ```
pub fn toml_value_key(text: &str, offset: usize) -> Option<&str> {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |p| p + 1);
    let before = text[line_start..offset]
        .trim_end()
        .strip_suffix('=')?
        .trim_end();
    let start = before
        .rfind(|c: char| !(c.is_ascii_alphanumeric() || "_-.\"'".contains(c)))
        .map_or(0, |p| p + 1);
    let key = &before[start..];
    (!key.is_empty()).then_some(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_count_from_one_and_stop_at_the_end() {
        let text = "a = 1\nb = 2\n\nc = 3";
        assert_eq!(line_of(text, 0), 1);
        assert_eq!(line_of(text, 5), 1); // the newline itself ends line 1
        assert_eq!(line_of(text, 6), 2);
        assert_eq!(line_of(text, text.find('c').unwrap()), 4);
        assert_eq!(line_of(text, 10_000), 4);
        assert_eq!(line_of("", 3), 1);
    }

    #[test]
    fn line_and_column_of_bytes_count_from_one() {
        let bytes = b"a = 1\n\nb = \"\xc3\xa9\xff\"";
        assert_eq!(line_col_of(bytes, 0), (1, 1));
        assert_eq!(line_col_of(bytes, 5), (1, 6)); // the newline ends line 1
        assert_eq!(line_col_of(bytes, 6), (2, 1));
        // The invalid byte after a two-byte character: columns count bytes.
        assert_eq!(line_col_of(bytes, 7 + 7), (3, 8));
        assert_eq!(line_col_of(bytes, 999), (3, 10));
    }

    #[test]
    fn value_keys_are_named_as_written() {
        let text = "[camera]\n  sigma.\"x-y\" =   [1, 2]\nname='a'";
        assert_eq!(
            toml_value_key(text, text.find("[1").unwrap()),
            Some("sigma.\"x-y\"")
        );
        assert_eq!(
            toml_value_key(text, text.find("'a'").unwrap()),
            Some("name")
        );
        // Inside an array, or with no `=` before it, there is no key.
        assert_eq!(toml_value_key(text, text.find('2').unwrap()), None);
        assert_eq!(toml_value_key("= 3", 2), None);
        assert_eq!(toml_value_key("x = 3", 99), None);
    }
}
