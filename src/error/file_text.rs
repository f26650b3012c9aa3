//! Text that came from outside the program (a file, a caller's option),
//! made safe to print.
//!
//! A file is chosen by whoever wrote it: a glTF `uri`, a PLY keyword or a
//! JSON key can hold terminal escape sequences that clear the screen, fake
//! a result or set the clipboard (OSC 52), or be megabytes long. Every such
//! string reaches an [`Error`](super::Error) as a [`FileText`], which is
//! escaped and bounded when it is made, so no surface (the CLI, `Display`,
//! a JavaScript error) can print it raw.

use std::fmt;

/// Escaped, bounded text for a message: control characters and the
/// invisible characters that reorder or hide text appear as `\u{..}`
/// escapes, and anything past the bound is cut with a note of the length.
#[derive(Clone, PartialEq, Eq, Hash, Default)]
pub struct FileText(String);

impl FileText {
    /// The most characters a message part from a file may show: enough
    /// for any sensible name or parser message, short of a flood.
    pub const MAX_CHARS: usize = 400;

    /// The most characters a single word from a file may show: a keyword
    /// or number that failed to parse is recognizable in this many.
    pub const WORD_CHARS: usize = 32;

    /// `text`, escaped and cut to [`FileText::MAX_CHARS`].
    pub fn new(text: &str) -> FileText {
        FileText(escape(text, Self::MAX_CHARS))
    }

    /// Bytes from a file as one word: decoded as UTF-8 where they are
    /// (invalid bytes become `\x..` escapes), escaped and cut to
    /// [`FileText::WORD_CHARS`].
    pub fn word(bytes: &[u8]) -> FileText {
        FileText(escape_bytes(bytes, Self::WORD_CHARS))
    }

    /// The escaped text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl From<&str> for FileText {
    fn from(text: &str) -> FileText {
        FileText::new(text)
    }
}

impl From<String> for FileText {
    fn from(text: String) -> FileText {
        FileText::new(&text)
    }
}

impl From<&String> for FileText {
    fn from(text: &String) -> FileText {
        FileText::new(text)
    }
}

impl fmt::Display for FileText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl fmt::Debug for FileText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&self.0, f)
    }
}

impl PartialEq<str> for FileText {
    fn eq(&self, other: &str) -> bool {
        self.0 == other
    }
}

impl PartialEq<&str> for FileText {
    fn eq(&self, other: &&str) -> bool {
        self.0 == *other
    }
}

impl std::ops::Deref for FileText {
    type Target = str;
    fn deref(&self) -> &str {
        &self.0
    }
}

/// Whether `c` must not reach a terminal as itself: C0 and C1 controls and
/// DEL (escape sequences start with them), and the format characters that
/// reorder or hide what is shown (bidirectional overrides and isolates,
/// zero-width characters, the byte-order mark, the line and paragraph
/// separators).
fn is_unsafe(c: char) -> bool {
    c.is_control()
        || matches!(c,
            '\u{200B}'..='\u{200F}'
            | '\u{2028}'..='\u{202E}'
            | '\u{2060}'..='\u{2069}'
            | '\u{FEFF}'
            | '\u{FFF9}'..='\u{FFFB}')
}

/// `text` with every unsafe character escaped, cut to `max_chars`
/// characters of output (escapes counted as what they print).
pub fn escape(text: &str, max_chars: usize) -> String {
    let mut out = Shown::new(max_chars);
    for c in text.chars() {
        if !out.push(c) {
            break;
        }
    }
    out.finish(text.len())
}

/// Like [`escape`], for bytes that may not be UTF-8: each invalid byte is
/// shown as `\x..`.
pub fn escape_bytes(bytes: &[u8], max_chars: usize) -> String {
    let mut out = Shown::new(max_chars);
    'chunks: for chunk in bytes.utf8_chunks() {
        for c in chunk.valid().chars() {
            if !out.push(c) {
                break 'chunks;
            }
        }
        for b in chunk.invalid() {
            if !out.push_escape(&format!("\\x{b:02x}")) {
                break 'chunks;
            }
        }
    }
    out.finish(bytes.len())
}

/// Output under construction, counting what it shows.
struct Shown {
    text: String,
    shown: usize,
    max: usize,
    cut: bool,
}

impl Shown {
    fn new(max: usize) -> Shown {
        Shown {
            text: String::new(),
            shown: 0,
            max,
            cut: false,
        }
    }

    /// Adds `c`, escaped if unsafe; false once the bound is reached.
    fn push(&mut self, c: char) -> bool {
        if is_unsafe(c) {
            let escaped: String = match c {
                '\n' => "\\n".into(),
                '\r' => "\\r".into(),
                '\t' => "\\t".into(),
                c => format!("\\u{{{:x}}}", c as u32),
            };
            return self.push_escape(&escaped);
        }
        if self.shown + 1 > self.max {
            self.cut = true;
            return false;
        }
        self.text.push(c);
        self.shown += 1;
        true
    }

    fn push_escape(&mut self, escaped: &str) -> bool {
        if self.shown + escaped.len() > self.max {
            self.cut = true;
            return false;
        }
        self.text.push_str(escaped);
        self.shown += escaped.len();
        true
    }

    fn finish(mut self, total_bytes: usize) -> String {
        if self.cut {
            self.text
                .push_str(&format!("... ({total_bytes} bytes in all)"));
        }
        self.text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_sequences_are_shown_not_sent() {
        let osc52 = "\u{1b}]52;c;ZWNobyBoaQ==\u{7}";
        let shown = FileText::new(osc52);
        assert!(!shown.chars().any(is_unsafe), "{shown:?}");
        assert_eq!(shown.as_str(), "\\u{1b}]52;c;ZWNobyBoaQ==\\u{7}");
        let csi = FileText::new("a\u{9b}2Jb\u{7f}");
        assert_eq!(csi.as_str(), "a\\u{9b}2Jb\\u{7f}");
        let bidi = FileText::new("evil\u{202e}txt.exe\u{200b}");
        assert_eq!(bidi.as_str(), "evil\\u{202e}txt.exe\\u{200b}");
        assert_eq!(FileText::new("line\nnext\r").as_str(), "line\\nnext\\r");
    }

    #[test]
    fn plain_text_is_kept_as_it_is() {
        for text in ["tri.bin", "buffers/été 2.bin", "unknown field `foo`", ""] {
            assert_eq!(FileText::new(text).as_str(), text);
        }
    }

    #[test]
    fn long_text_is_cut_and_says_how_long_it_was() {
        let long = "a".repeat(1 << 20);
        let shown = FileText::new(&long);
        assert!(shown.len() < FileText::MAX_CHARS + 40, "{}", shown.len());
        assert!(shown.ends_with("... (1048576 bytes in all)"), "{shown}");
        // An escape is never cut in half.
        let escapes = "\u{1b}".repeat(1000);
        let shown = FileText::new(&escapes);
        assert!(shown.starts_with("\\u{1b}"));
        let body = shown.split("...").next().unwrap();
        assert_eq!(body.len() % "\\u{1b}".len(), 0, "{shown}");
    }

    #[test]
    fn words_show_invalid_bytes_as_escapes() {
        assert_eq!(FileText::word(b"ab\xffc").as_str(), "ab\\xffc");
        assert_eq!(FileText::word(b"\x1b[2J").as_str(), "\\u{1b}[2J");
        let long = FileText::word(&[b'x'; 100]);
        assert!(long.starts_with(&"x".repeat(FileText::WORD_CHARS)));
        assert!(long.ends_with("(100 bytes in all)"), "{long}");
    }
}
