//! The tokenizer: quoted strings, brackets and bare words (directives, numbers, `true`/`false`), each with the
//! line and column where it starts. Comments run from `#` to the end of the line.

use std::path::Path;
use std::sync::Arc;

use scene::Loc;

use crate::error::ParseError;

/// What a token is.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum TokKind {
    /// A double-quoted string, escapes decoded, quotes removed.
    Str(String),
    /// `[`
    Open,
    /// `]`
    Close,
    /// Anything else up to whitespace, a quote, a bracket or `#`: a directive, a number, `true`, `false`.
    Word(String),
}

/// A token and where it starts.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Token {
    pub kind: TokKind,
    pub loc: Loc,
}

impl Token {
    /// The token as the user wrote it, for messages.
    pub fn describe(&self) -> String {
        match &self.kind {
            TokKind::Str(s) => format!("string \"{s}\""),
            TokKind::Open => "'['".to_owned(),
            TokKind::Close => "']'".to_owned(),
            TokKind::Word(w) => format!("'{w}'"),
        }
    }
}

/// Tokenizes one file's text.
pub(crate) struct Lexer {
    text: String,
    pos: usize,
    line: u32,
    column: u32,
    file: Arc<Path>,
}

impl Lexer {
    /// A lexer over `text`, which came from `file`.
    pub fn new(text: String, file: Arc<Path>) -> Self {
        // A UTF-8 byte-order mark is not part of the scene.
        let pos = if text.starts_with('\u{feff}') { 3 } else { 0 };
        Self { text, pos, line: 1, column: 1, file }
    }

    /// The file being read.
    pub fn file(&self) -> &Arc<Path> {
        &self.file
    }

    /// The current position.
    pub fn loc(&self) -> Loc {
        Loc::new(self.file.clone(), self.line, self.column)
    }

    fn peek(&self) -> Option<u8> {
        self.text.as_bytes().get(self.pos).copied()
    }

    fn bump(&mut self) -> Option<u8> {
        let b = self.peek()?;
        self.pos += 1;
        if b == b'\n' {
            self.line += 1;
            self.column = 1;
        } else if b & 0xC0 != 0x80 {
            // Count characters, not bytes: UTF-8 continuation bytes don't start a new column.
            self.column += 1;
        }
        Some(b)
    }

    /// The next token, `None` at the end of the file.
    pub fn next_token(&mut self) -> Result<Option<Token>, ParseError> {
        loop {
            let loc = self.loc();
            let Some(b) = self.peek() else { return Ok(None) };
            match b {
                b' ' | b'\t' | b'\r' | b'\n' | 0x0c | 0x0b => {
                    self.bump();
                }
                b'#' => {
                    while let Some(c) = self.peek() {
                        if c == b'\n' {
                            break;
                        }
                        self.bump();
                    }
                }
                b'[' => {
                    self.bump();
                    return Ok(Some(Token { kind: TokKind::Open, loc }));
                }
                b']' => {
                    self.bump();
                    return Ok(Some(Token { kind: TokKind::Close, loc }));
                }
                b'"' => {
                    self.bump();
                    let s = self.string(&loc)?;
                    return Ok(Some(Token { kind: TokKind::Str(s), loc }));
                }
                _ => {
                    let start = self.pos;
                    while let Some(c) = self.peek() {
                        if matches!(c, b' ' | b'\t' | b'\r' | b'\n' | 0x0c | 0x0b | b'"' | b'[' | b']' | b'#') {
                            break;
                        }
                        self.bump();
                    }
                    let w = self.text[start..self.pos].to_owned();
                    return Ok(Some(Token { kind: TokKind::Word(w), loc }));
                }
            }
        }
    }

    /// The rest of a string whose opening quote was consumed at `start`.
    fn string(&mut self, start: &Loc) -> Result<String, ParseError> {
        let mut out: Vec<u8> = Vec::new();
        loop {
            let esc_loc = self.loc();
            match self.bump() {
                None => {
                    return Err(ParseError::new(
                        start.clone(),
                        "unterminated string: end of file before the closing '\"'",
                    ))
                }
                Some(b'\n') => {
                    return Err(ParseError::new(
                        start.clone(),
                        "unterminated string: end of line before the closing '\"' (strings cannot span lines)",
                    ))
                }
                Some(b'"') => break,
                Some(b'\\') => {
                    let c = match self.bump() {
                        None => return Err(ParseError::new(esc_loc, "end of file after '\\' in a string")),
                        Some(b'n') => b'\n',
                        Some(b't') => b'\t',
                        Some(b'r') => b'\r',
                        Some(b'b') => 0x08,
                        Some(b'f') => 0x0c,
                        Some(b'\\') => b'\\',
                        Some(b'"') => b'"',
                        Some(b'\'') => b'\'',
                        Some(b'\n') => {
                            return Err(ParseError::new(esc_loc, "unterminated string: '\\' at the end of a line"))
                        }
                        Some(other) => {
                            let shown = if other.is_ascii_graphic() {
                                (other as char).to_string()
                            } else {
                                format!("\\x{other:02x}")
                            };
                            return Err(ParseError::new(
                                esc_loc,
                                format!(
                                    "unknown escape '\\{shown}' in a string (known: \\n \\t \\r \\b \\f \\\\ \\\" \\')"
                                ),
                            ));
                        }
                    };
                    out.push(c);
                }
                Some(b) => out.push(b),
            }
        }
        // The text is valid UTF-8 and escapes are ASCII, so this cannot fail; be safe anyway.
        String::from_utf8(out).map_err(|_| ParseError::new(start.clone(), "string is not valid UTF-8"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lex(s: &str) -> Result<Vec<Token>, ParseError> {
        let mut l = Lexer::new(s.to_owned(), Arc::from(Path::new("x.pbrt")));
        let mut v = Vec::new();
        while let Some(t) = l.next_token()? {
            v.push(t);
        }
        Ok(v)
    }

    #[test]
    fn tokens_with_positions() {
        let t = lex("Shape \"sphere\" # comment\n  \"float radius\" [1.5 -2e3]#x\n\"a\\\"b\\n\"").unwrap();
        let kinds: Vec<_> = t.iter().map(|t| t.kind.clone()).collect();
        assert_eq!(
            kinds,
            vec![
                TokKind::Word("Shape".into()),
                TokKind::Str("sphere".into()),
                TokKind::Str("float radius".into()),
                TokKind::Open,
                TokKind::Word("1.5".into()),
                TokKind::Word("-2e3".into()),
                TokKind::Close,
                TokKind::Str("a\"b\n".into()),
            ]
        );
        assert_eq!((t[1].loc.line, t[1].loc.column), (1, 7));
        assert_eq!((t[2].loc.line, t[2].loc.column), (2, 3));
        assert_eq!((t[5].loc.line, t[5].loc.column), (2, 23));
        assert_eq!((t[7].loc.line, t[7].loc.column), (3, 1));
    }

    #[test]
    fn columns_count_characters() {
        let t = lex("\"λλ\" x").unwrap();
        assert_eq!(t[1].loc.column, 6);
    }

    #[test]
    fn string_errors() {
        let e = lex("Shape\n  \"sphere").unwrap_err();
        assert_eq!((e.loc.line, e.loc.column), (2, 3));
        assert!(e.message.contains("unterminated string"));
        let e = lex("\"abc\ndef\"").unwrap_err();
        assert!(e.message.contains("unterminated string"));
        let e = lex("\"a\\qb\"").unwrap_err();
        assert_eq!((e.loc.line, e.loc.column), (1, 3));
        assert!(e.message.contains("unknown escape"));
    }
}
