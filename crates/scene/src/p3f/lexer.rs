//! Tokens of p3f and NFF text: words and numbers separated by whitespace, `#` comments to the end
//! of the line. Lines end with LF, CR LF or a lone CR (classic Mac OS text). Positions are counted
//! as they are scanned, so lexing is linear in the text's length however long its lines are.

/// A token and where it starts.
#[derive(Clone, Copy, Debug)]
pub(super) struct Token<'a> {
    pub text: &'a str,
    /// Line, from 1.
    pub line: u32,
    /// Column in characters, from 1.
    pub column: u32,
    /// Byte offset of the token in the text.
    pub offset: usize,
    /// Whether no other token precedes it on its line.
    pub first_on_line: bool,
}

impl Token<'_> {
    /// Whether the token reads as a number (a tag never does).
    pub fn is_number(&self) -> bool {
        self.text.parse::<f64>().is_ok()
    }

    /// The token as it is printed in messages: characters that a terminal would not show as
    /// themselves (controls, non-breaking and other unusual spaces) are escaped.
    pub fn shown(&self) -> String {
        shown(self.text)
    }
}

/// Most characters of a text a message quotes; a longer one is cut, saying how much is left out.
const SHOWN_CHARS: usize = 120;

/// `text` with its invisible or look-alike characters escaped (`\u{a0}`), cut after [`SHOWN_CHARS`]
/// characters.
pub(crate) fn shown(text: &str) -> String {
    let count = text.chars().count();
    let mut out = escaped(text.chars().take(SHOWN_CHARS));
    if count > SHOWN_CHARS {
        out += &format!("… ({} more characters)", count - SHOWN_CHARS);
    }
    out
}

fn escaped(text: impl Iterator<Item = char>) -> String {
    text.map(|c| {
        if c.is_control() || (c.is_whitespace() && c != ' ') || matches!(c, '\u{200b}'..='\u{200f}' | '\u{feff}') {
            c.escape_unicode().to_string()
        } else {
            c.to_string()
        }
    })
    .collect()
}

/// Whether the byte at `pos` ends a line: an LF, or a CR that no LF follows.
pub(super) fn ends_line(bytes: &[u8], pos: usize) -> bool {
    match bytes[pos] {
        b'\n' => true,
        b'\r' => bytes.get(pos + 1) != Some(&b'\n'),
        _ => false,
    }
}

#[derive(Clone)]
pub(super) struct Lexer<'a> {
    text: &'a str,
    pos: usize,
    line: u32,
    line_start: usize,
    /// Characters between `line_start` and `counted`.
    column_chars: u32,
    counted: usize,
    /// Whether a token was already read on the current line.
    seen_on_line: bool,
    /// Characters counted for columns so far, over all lines (at most the text's length).
    chars_counted: usize,
    peeked: Option<Option<Token<'a>>>,
}

impl<'a> Lexer<'a> {
    pub fn new(text: &'a str) -> Self {
        Self {
            text,
            pos: 0,
            line: 1,
            line_start: 0,
            column_chars: 0,
            counted: 0,
            seen_on_line: false,
            chars_counted: 0,
            peeked: None,
        }
    }

    fn newline_at(&mut self, pos: usize) {
        self.line += 1;
        self.line_start = pos + 1;
        self.counted = pos + 1;
        self.column_chars = 0;
        self.seen_on_line = false;
    }

    /// The column of byte offset `at` on the current line (counting only what was not counted yet).
    fn column_of(&mut self, at: usize) -> u32 {
        let chars = self.text[self.counted..at].chars().count();
        self.chars_counted += chars;
        self.column_chars += chars as u32;
        self.counted = at;
        self.column_chars + 1
    }

    fn scan(&mut self) -> Option<Token<'a>> {
        let bytes = self.text.as_bytes();
        loop {
            while self.pos < bytes.len() && bytes[self.pos].is_ascii_whitespace() {
                if ends_line(bytes, self.pos) {
                    self.newline_at(self.pos);
                }
                self.pos += 1;
            }
            if self.pos < bytes.len() && bytes[self.pos] == b'#' {
                while self.pos < bytes.len() && !matches!(bytes[self.pos], b'\n' | b'\r') {
                    self.pos += 1;
                }
                continue;
            }
            break;
        }
        if self.pos >= bytes.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < bytes.len() && !bytes[self.pos].is_ascii_whitespace() && bytes[self.pos] != b'#' {
            self.pos += 1;
        }
        let column = self.column_of(start);
        let first_on_line = !self.seen_on_line;
        self.seen_on_line = true;
        Some(Token { text: &self.text[start..self.pos], line: self.line, column, offset: start, first_on_line })
    }

    pub fn next(&mut self) -> Option<Token<'a>> {
        match self.peeked.take() {
            Some(t) => t,
            None => self.scan(),
        }
    }

    pub fn peek(&mut self) -> Option<Token<'a>> {
        if self.peeked.is_none() {
            self.peeked = Some(self.scan());
        }
        self.peeked.unwrap()
    }

    /// How many of the next tokens (at most `limit`) are numbers.
    pub fn numbers_ahead(&self, limit: usize) -> usize {
        let mut ahead = self.clone();
        (0..limit).take_while(|_| ahead.next().is_some_and(|t| t.is_number())).count()
    }

    /// How many of the next tokens (at most `limit`) are numbers on line `line`.
    pub fn numbers_on_line(&self, line: u32, limit: usize) -> usize {
        let mut ahead = self.clone();
        (0..limit).take_while(|_| ahead.next().is_some_and(|t| t.is_number() && t.line == line)).count()
    }

    /// Skips the rest of `token`'s line; returns the text skipped from `token` on (its comment
    /// excluded).
    pub fn skip_line(&mut self, token: &Token<'a>) -> &'a str {
        let end = self.text[token.offset..].find(['\n', '\r']).map_or(self.text.len(), |i| token.offset + i);
        let line = self.text[token.offset..end].split('#').next().unwrap_or("").trim();
        // A peeked token on the same line is skipped with it; one on a later line is kept.
        if self.peeked.is_some_and(|p| p.is_some_and(|p| p.offset < end)) {
            self.peeked = None;
        }
        if self.peeked.is_none() && self.pos < end {
            self.pos = end;
        }
        line
    }

    /// Where the end of the text is, for errors at end of file.
    pub fn eof_position(&mut self) -> (u32, u32) {
        let mut end = self.clone();
        end.peeked = None;
        while end.scan().is_some() {}
        let at = end.text.len();
        (end.line, end.column_of(at))
    }

    /// The number of bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.text.len() - self.pos
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_count_characters_and_lines() {
        let mut lex = Lexer::new("a  bé c\n  #x\n dd # e\nf");
        let toks: Vec<_> =
            std::iter::from_fn(|| lex.next()).map(|t| (t.text, t.line, t.column, t.first_on_line)).collect();
        assert_eq!(
            toks,
            [("a", 1, 1, true), ("bé", 1, 4, false), ("c", 1, 7, false), ("dd", 3, 2, true), ("f", 4, 1, true)]
        );
    }

    #[test]
    fn skipping_a_line_keeps_the_next_lines_tokens() {
        let mut lex = Lexer::new("Floor of the box\ns 1 2 3 4\n");
        let floor = lex.next().unwrap();
        assert_eq!(lex.peek().unwrap().text, "of");
        assert_eq!(lex.skip_line(&floor), "Floor of the box");
        assert_eq!(lex.next().unwrap().text, "s");
        let mut lex = Lexer::new("junk\ns 1");
        let junk = lex.next().unwrap();
        lex.peek();
        assert_eq!(lex.skip_line(&junk), "junk");
        assert_eq!(lex.next().unwrap().text, "s");
    }

    #[test]
    fn a_lone_carriage_return_ends_a_line() {
        let mut lex = Lexer::new("# old Mac\rFloor 1\rs 1 # r\r2\r\nv");
        let floor = lex.next().unwrap();
        assert_eq!((floor.text, floor.line, floor.first_on_line), ("Floor", 2, true));
        assert_eq!(lex.skip_line(&floor), "Floor 1");
        let toks: Vec<_> = std::iter::from_fn(|| lex.next()).map(|t| (t.text, t.line, t.column)).collect();
        assert_eq!(toks, [("s", 3, 1), ("1", 3, 3), ("2", 4, 1), ("v", 5, 1)]);
    }

    #[test]
    fn long_lines_lex_in_linear_time() {
        // 400 000 numbers on one line: every character is counted once for the columns.
        let line = "1.5 ".repeat(400_000);
        let mut lex = Lexer::new(&line);
        let mut last = 0;
        while let Some(t) = lex.next() {
            last = t.column;
        }
        assert_eq!(last, 4 * 399_999 + 1);
        assert!(lex.chars_counted <= line.len(), "{} characters counted for {}", lex.chars_counted, line.len());
    }
}
