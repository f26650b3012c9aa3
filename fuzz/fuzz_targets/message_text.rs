//! What a message may show of arbitrary bytes: every loader's error, and
//! the escaping itself, hold no character a terminal would act on and stay
//! bounded, whatever the file says.
#![no_main]

use fast_reject::error::FileText;
use fast_reject::mesh::io::load;
use libfuzzer_sys::fuzz_target;

/// Controls and the characters that reorder or hide text.
fn unsafe_char(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200b}'..='\u{200f}' | '\u{2028}'..='\u{202e}' | '\u{2060}'..='\u{2069}' | '\u{feff}')
}

fuzz_target!(|data: &[u8]| {
    let word = FileText::word(data);
    assert!(!word.chars().any(unsafe_char), "{word:?}");
    assert!(
        word.chars().count() <= FileText::WORD_CHARS + 40,
        "{word:?}"
    );
    let text = FileText::new(&String::from_utf8_lossy(data));
    assert!(!text.chars().any(unsafe_char), "{text:?}");
    assert!(text.chars().count() <= FileText::MAX_CHARS + 40, "{text:?}");
    if let Err(e) = load(data, None) {
        let message = e.to_string();
        assert!(!message.chars().any(unsafe_char), "{message:?}");
        assert!(message.len() < 4_000, "{} bytes of message", message.len());
    }
});
