//! The NFF reader's token cursor: it walks the text once, token by token, without building
//! a token list.
//!
//! Tokens are what `text.lines()`, then `split('#')`, then `split_whitespace()` would give,
//! in the same order and with the same 1-based lines: a token is a run of characters that
//! are neither whitespace ([`char::is_whitespace`], so Unicode spaces separate too) nor `#`,
//! and `#` starts a comment that runs to the end of its line. Lines end at `\n` (a `\r`
//! before it is whitespace anyway). ASCII bytes are classified by a table; only the bytes
//! of non-ASCII characters are decoded, to ask whether they are whitespace.

use super::number::plain_decimal;

/// A token and where it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Token<'a> {
    pub text: &'a str,
    /// 1-based line number.
    pub line: usize,
    /// Byte offset of the token in the text.
    pub start: usize,
}

/// What an ASCII byte is to the tokenizer.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Class {
    /// Part of a token.
    Token,
    /// Whitespace other than `\n`.
    Space,
    Newline,
    /// `#`: a comment to the end of the line.
    Hash,
    /// The first byte of a non-ASCII character (or a continuation byte, never met here).
    Other,
}

const fn class_table() -> [Class; 256] {
    let mut table = [Class::Token; 256];
    let mut b = 0x80;
    while b < 256 {
        table[b] = Class::Other;
        b += 1;
    }
    // The ASCII characters of `char::is_whitespace`: tab, LF, VT, FF, CR and space.
    table[b'\t' as usize] = Class::Space;
    table[0x0b] = Class::Space;
    table[0x0c] = Class::Space;
    table[b'\r' as usize] = Class::Space;
    table[b' ' as usize] = Class::Space;
    table[b'\n' as usize] = Class::Newline;
    table[b'#' as usize] = Class::Hash;
    table
}

static CLASS: [Class; 256] = class_table();

/// Whether the byte, following ASCII token characters, surely ends the token: ASCII
/// whitespace or `#`. (A non-ASCII space ends it too; this answers no for it, and a caller
/// that must know decodes the character.)
pub(super) fn ends_token(byte: u8) -> bool {
    CLASS[byte as usize] != Class::Token && CLASS[byte as usize] != Class::Other
}

/// A position in the text, with its line.
#[derive(Clone, Copy)]
pub(super) struct Cursor<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
}

impl<'a> Cursor<'a> {
    /// A cursor at byte `pos` of `text`, which must be the start of a line (or of the
    /// text) on 1-based line `line`.
    pub fn new(text: &'a str, pos: usize, line: usize) -> Cursor<'a> {
        Cursor { text, pos, line }
    }

    /// The next token without consuming it.
    pub fn peek(&self) -> Option<Token<'a>> {
        let mut ahead = *self;
        ahead.next()
    }

    /// The non-ASCII character at byte `i`, and whether it is whitespace.
    fn wide(&self, i: usize) -> (bool, usize) {
        let c = self.text[i..].chars().next().unwrap_or('\0');
        (c.is_whitespace(), c.len_utf8())
    }

    /// Skips whitespace and comments; returns where the next token starts, or `None` at the
    /// end of the text.
    #[inline]
    fn skip(&mut self) -> Option<usize> {
        let bytes = self.text.as_bytes();
        let mut i = self.pos;
        loop {
            let Some(&b) = bytes.get(i) else {
                self.pos = i;
                return None;
            };
            match CLASS[b as usize] {
                Class::Token => break,
                Class::Space => i += 1,
                Class::Newline => {
                    i += 1;
                    self.line += 1;
                }
                Class::Hash => {
                    i += bytes[i..].iter().position(|&b| b == b'\n').unwrap_or(bytes.len() - i);
                }
                Class::Other => match self.wide(i) {
                    (true, len) => i += len,
                    (false, _) => break,
                },
            }
        }
        self.pos = i;
        Some(i)
    }

    /// Consumes the token that starts at byte `start`, or goes on from byte `from` within
    /// it.
    #[inline]
    fn take(&mut self, start: usize, from: usize) -> Token<'a> {
        let bytes = self.text.as_bytes();
        let mut i = from;
        while let Some(&b) = bytes.get(i) {
            match CLASS[b as usize] {
                Class::Token => i += 1,
                Class::Other => match self.wide(i) {
                    (false, len) => i += len,
                    (true, _) => break,
                },
                Class::Space | Class::Newline | Class::Hash => break,
            }
        }
        self.pos = i;
        Token { text: &self.text[start..i], line: self.line, start }
    }

    /// The next token, or `None` at the end of the text.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Option<Token<'a>> {
        let start = self.skip()?;
        Some(self.take(start, start))
    }

    /// The next token and, when it is a plain decimal ([`plain_decimal`]), its value: the
    /// value `str::parse::<f64>` gives, read in the same pass. `None` for the value means
    /// the caller is to parse the token.
    #[inline]
    pub fn next_number(&mut self) -> Option<(Token<'a>, Option<f64>)> {
        let start = self.skip()?;
        let bytes = self.text.as_bytes();
        if let Some((value, len)) = plain_decimal(&bytes[start..]) {
            let end = start + len;
            let ends = bytes.get(end).is_none_or(|&b| ends_token(b));
            if ends {
                self.pos = end;
                return Some((Token { text: &self.text[start..end], line: self.line, start }, Some(value)));
            }
        }
        Some((self.take(start, start), None))
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// The tokens as the reader first split them: lines, comments, then whitespace.
    fn reference(text: &str) -> Vec<(&str, usize)> {
        let mut tokens = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let code = line.split('#').next().unwrap_or("");
            tokens.extend(code.split_whitespace().map(|t| (t, i + 1)));
        }
        tokens
    }

    fn streamed(text: &str) -> Vec<(&str, usize)> {
        let mut cursor = Cursor::new(text, 0, 1);
        let mut tokens = Vec::new();
        while let Some(t) = cursor.next() {
            assert_eq!(&text[t.start..t.start + t.text.len()], t.text);
            tokens.push((t.text, t.line));
        }
        tokens
    }

    #[test]
    fn tokens_and_lines_match_the_line_split() {
        for text in [
            "",
            "\n\n",
            "v\nfrom 0 0 1 # eye\n#\n# all comment\r\nat 0 0 0\r\n",
            "a#b c\nd",
            "x\u{a0}y\u{85}z\u{2028}w\u{3000}v\x0bu\x0ct\x1cs",
            "é ü\t\u{2009}ñ#\u{a0}\nq",
            "p 3\r1 2 3\r\n4",
            "  trailing  ",
        ] {
            assert_eq!(streamed(text), reference(text), "{text:?}");
        }
    }

    #[test]
    fn every_ascii_byte_is_classified_like_char_is_whitespace() {
        for b in 0u8..128 {
            let c = b as char;
            let class = CLASS[b as usize];
            let space = class == Class::Space || class == Class::Newline;
            assert_eq!(space, c.is_whitespace(), "byte {b:#x}");
            assert_eq!(class == Class::Hash, c == '#');
        }
    }

    proptest! {
        #[test]
        fn random_text_tokenizes_like_the_line_split(
            parts in prop::collection::vec(
                prop::sample::select(vec![
                    "p", "pp", "1.5", "-2", " ", "\t", "\n", "\r\n", "\r", "#", "# note\n", "\u{a0}",
                    "\u{85}", "\u{2028}", "\u{3000}", "é", "\x0b", "\x0c", "\x1f", "\0", "x",
                ]),
                0..40,
            )
        ) {
            let text: String = parts.concat();
            prop_assert_eq!(streamed(&text), reference(&text));
        }
    }
}
