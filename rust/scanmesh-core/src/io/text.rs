//! Numeric text tables: rows of floats separated by whitespace or one delimiter byte.
//!
//! The text readers (XYZ, CSV, PLY and VTK bodies) hand this module one chunk of whole
//! lines at a time, so a 10-million-point file is parsed without a Python step per point
//! and the caller can honour Ctrl-C between chunks. The rules:
//!
//! - a line is the bytes up to `\n`; tokens are maximal runs of bytes other than space,
//!   tab, CR, LF (and, with a delimiter such as `,` or `;`, the delimiter);
//! - a line without tokens is blank (with a delimiter it must hold none either);
//! - a line whose first token starts with `#` is a comment;
//! - every other line is a data row of exactly `ncols` numbers (with a delimiter, exactly
//!   `ncols - 1` delimiters, so an empty field is an error, not a skipped column); with
//!   `ncols == 0` a row may hold any number of values (free layout: VTK blocks, PLY lists);
//! - a number is `[+-]?(digits[.digits]|.digits)([eE][+-]?digits)?`, `nan`, `inf` or
//!   `infinity` (any case, optional sign): what numpy's text parser accepts.
//!
//! A refused chunk is reported as the first bad line with the byte offset of the offending
//! token (or of the line) and why, so the caller names file, line and text without
//! parsing again. Numbers are converted by `fast_float2` (Eisel-Lemire with an exact
//! fallback: correctly rounded, so `%.17g` text reads back bit for bit).

use rayon::prelude::*;

/// Why a line was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextErrorKind {
    /// the token at the offset is not a number
    NotANumber,
    /// the line holds another number of values (or delimiters) than `ncols`
    WrongCount,
    /// the values read so far and this line's could not be given memory (the allocation
    /// failed: an error, never an abort)
    OutOfMemory,
}

/// Why a chunk was refused: the first offending line (0-based within the chunk), the byte
/// offset (within the chunk) of the offending token or, for a wrong count, of the line
/// start, and the kind of problem.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TextError {
    /// 0-based line index within the chunk
    pub line: usize,
    /// byte offset within the chunk where the problem starts
    pub offset: usize,
    /// what is wrong there
    pub kind: TextErrorKind,
}

/// A parsed chunk: `values` row-major (rows × ncols), the line of every row and the blank
/// lines (the readers split scan lines at blank lines).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// row-major values, `ncols` per data row (any number per row in free layout)
    pub values: Vec<f64>,
    /// 0-based line index (within the chunk) of each data row
    pub row_lines: Vec<i64>,
    /// 0-based line indices (within the chunk) of the blank lines, ascending
    pub blank_lines: Vec<i64>,
    /// number of lines in the chunk (a last line without `\n` counts)
    pub n_lines: usize,
}

/// Whitespace separator bytes: space, tab, CR, LF.
const fn whitespace_table() -> [bool; 256] {
    let mut t = [false; 256];
    t[b' ' as usize] = true;
    t[b'\t' as usize] = true;
    t[b'\r' as usize] = true;
    t[b'\n' as usize] = true;
    t
}
const WHITESPACE: [bool; 256] = whitespace_table();

/// What separates tokens: whitespace, and the delimiter byte when there is one.
#[derive(Clone, Copy)]
struct Separators {
    delimiter: Option<u8>,
}

impl Separators {
    /// 0 for a token byte, 1 for whitespace, 2 for the delimiter.
    #[inline]
    fn kind(self, b: u8) -> u8 {
        if WHITESPACE[b as usize] {
            1
        } else if Some(b) == self.delimiter {
            2
        } else {
            0
        }
    }
}

/// Chunks at least this long are split at line breaks into one piece per rayon thread and
/// parsed in parallel (smaller ones are not worth a thread hand-off).
pub const PARALLEL_MIN_BYTES: usize = 1 << 18;

/// Parses `buf`, a chunk of whole lines, as rows of `ncols` numbers (see the module rules;
/// `ncols == 0` for a free layout).
///
/// `delimiter` (e.g. `Some(b',')`, `Some(b';')`) separates too, and counts; whitespace
/// always separates. Returns the first bad line as a [`TextError`]; never panics on any
/// input. Long chunks are parsed in parallel pieces (same result as one piece: tested).
/// O(len) work; the values take at most 4 × len bytes (a value needs 2 bytes of text).
pub fn parse_table(buf: &[u8], ncols: usize, delimiter: Option<u8>) -> Result<Table, TextError> {
    let threads = rayon::current_num_threads();
    if buf.len() < PARALLEL_MIN_BYTES || threads < 2 {
        return parse_piece(buf, ncols, delimiter);
    }
    // cut points: just after the first line break at or past each k/threads of the chunk
    let mut cuts = vec![0usize];
    for k in 1..threads {
        let at = (buf.len() * k / threads).max(*cuts.last().expect("starts with 0"));
        match buf[at..].iter().position(|&b| b == b'\n') {
            Some(p) if at + p + 1 < buf.len() => cuts.push(at + p + 1),
            _ => break,
        }
    }
    cuts.push(buf.len());
    cuts.dedup();
    let pieces: Vec<Result<Table, TextError>> = cuts
        .par_windows(2)
        .map(|w| parse_piece(&buf[w[0]..w[1]], ncols, delimiter))
        .collect();
    let mut out = Table::default();
    // The pieces' values copied into one vector: an allocation of the whole input's size.
    let total: usize = pieces.iter().flatten().map(|p| p.values.len()).sum();
    out.values.try_reserve_exact(total).map_err(|_| TextError {
        line: 0,
        offset: 0,
        kind: TextErrorKind::OutOfMemory,
    })?;
    for (piece, &offset) in pieces.into_iter().zip(&cuts) {
        let lines = out.n_lines as i64;
        let piece = piece.map_err(|e| TextError {
            line: e.line + out.n_lines,
            offset: e.offset + offset,
            kind: e.kind,
        })?;
        out.values.extend_from_slice(&piece.values);
        out.row_lines
            .extend(piece.row_lines.iter().map(|l| l + lines));
        out.blank_lines
            .extend(piece.blank_lines.iter().map(|l| l + lines));
        out.n_lines += piece.n_lines;
    }
    Ok(out)
}

/// [`parse_table`] on one thread: one forward pass, each number parsed where it starts
/// (its end is where the parser stops, which must be a separator, the line end or the end
/// of the chunk: the same tokens as splitting at separators first, read once).
fn parse_piece(buf: &[u8], ncols: usize, delimiter: Option<u8>) -> Result<Table, TextError> {
    let seps = Separators { delimiter };
    // A value costs at least 2 bytes of text: reserve for a plausible density (about what
    // real scans hold) and let the vector grow, by what was read, past it if needed.
    let mut table = Table::default();
    let out_of_memory = |line: usize, offset: usize| TextError {
        line,
        offset,
        kind: TextErrorKind::OutOfMemory,
    };
    table
        .values
        .try_reserve(buf.len() / 4)
        .map_err(|_| out_of_memory(0, 0))?;
    let free = ncols == 0;
    let n = buf.len();
    let mut pos = 0usize;
    let mut line = 0usize;
    while pos < n {
        let start = pos;
        let bad = |offset: usize, kind: TextErrorKind| TextError { line, offset, kind };
        let row_start = table.values.len();
        let mut tokens = 0usize;
        let mut delimiters = 0usize;
        let mut comment = false;
        loop {
            while pos < n && buf[pos] != b'\n' {
                match seps.kind(buf[pos]) {
                    0 => break,
                    kind => delimiters += usize::from(kind == 2),
                }
                pos += 1;
            }
            if pos == n || buf[pos] == b'\n' {
                break;
            }
            if tokens == 0 && buf[pos] == b'#' {
                comment = true; // a comment line: its delimiters do not count
                pos = buf[pos..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(n, |k| pos + k);
                break;
            }
            tokens += 1;
            if !free && tokens > ncols {
                table.values.truncate(row_start);
                return Err(bad(start, TextErrorKind::WrongCount));
            }
            if table.values.len() == table.values.capacity() {
                // Past the plausible density reserved above: grow, fallibly.
                let more = table.values.len().max(1024);
                table
                    .values
                    .try_reserve(more)
                    .map_err(|_| out_of_memory(line, pos))?;
            }
            match fast_float2::parse_partial::<f64, _>(&buf[pos..]) {
                Ok((value, used)) if pos + used == n || seps.kind(buf[pos + used]) != 0 => {
                    table.values.push(value);
                    pos += used;
                }
                _ => {
                    table.values.truncate(row_start);
                    return Err(bad(pos, TextErrorKind::NotANumber));
                }
            }
        }
        if comment {
            // neither a row nor a blank line
        } else if tokens == 0 {
            if delimiters > 0 {
                return Err(bad(start, TextErrorKind::WrongCount));
            }
            table.blank_lines.push(line as i64);
        } else {
            let wrong_delimiters = seps.delimiter.is_some() && delimiters + 1 != tokens;
            if (!free && tokens != ncols) || wrong_delimiters {
                table.values.truncate(row_start);
                return Err(bad(start, TextErrorKind::WrongCount));
            }
            table.row_lines.push(line as i64);
        }
        line += 1;
        pos += 1; // past the line break (or the end)
    }
    table.n_lines = line;
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_comments_and_blank_lines() {
        let t = parse_table(b"1 2 3\n# note, here\n\n4\t5 6\r\n  \n7 8 9", 3, None).unwrap();
        assert_eq!(t.values, vec![1., 2., 3., 4., 5., 6., 7., 8., 9.]);
        assert_eq!(t.row_lines, vec![0, 3, 5]);
        assert_eq!(t.blank_lines, vec![2, 4]);
        assert_eq!(t.n_lines, 6);
        // a chunk that ends with a line break has no extra empty line
        assert_eq!(parse_table(b"1 2\n", 2, None).unwrap().n_lines, 1);
    }

    #[test]
    fn comma_mode_counts_fields() {
        let t = parse_table(b"1,2,3\n4, 5 ,6\n", 3, Some(b',')).unwrap();
        assert_eq!(t.values, vec![1., 2., 3., 4., 5., 6.]);
        // an empty field is refused, not skipped; a line of commas is not blank
        assert_eq!(
            parse_table(b"1,2,3\n1,,2,3\n", 3, Some(b',')),
            Err(TextError {
                line: 1,
                offset: 6,
                kind: TextErrorKind::WrongCount
            })
        );
        assert_eq!(
            parse_table(b"1,2,3\n,,\n", 3, Some(b',')),
            Err(TextError {
                line: 1,
                offset: 6,
                kind: TextErrorKind::WrongCount
            })
        );
        // without comma mode a comma is part of a token, and so not a number
        assert!(parse_table(b"1,2,3\n", 3, None).is_err());
    }

    #[test]
    fn free_layout_and_other_delimiters() {
        // ncols 0: any number of values per row, rows still listed
        let t = parse_table(b"3 1 2 3\n\n1 7\n", 0, None).unwrap();
        assert_eq!(t.values, vec![3., 1., 2., 3., 1., 7.]);
        assert_eq!(t.row_lines, vec![0, 2]);
        assert_eq!(t.blank_lines, vec![1]);
        // a semicolon delimiter counts like a comma; a comma is then part of a token
        let t = parse_table(b"1;2;3\n4 ; 5;6\n", 3, Some(b';')).unwrap();
        assert_eq!(t.values, vec![1., 2., 3., 4., 5., 6.]);
        assert_eq!(
            parse_table(b"1,5;2;3\n", 3, Some(b';')),
            Err(TextError {
                line: 0,
                offset: 0,
                kind: TextErrorKind::NotANumber
            })
        );
        assert_eq!(
            parse_table(b"1;2;;3\n", 0, Some(b';')).unwrap_err().kind,
            TextErrorKind::WrongCount
        );
    }

    /// One token alone on a line, parsed as a one-column table.
    fn number(token: &[u8]) -> Option<f64> {
        parse_table(token, 1, None).ok().map(|t| t.values[0])
    }

    #[test]
    fn grammar_matches_the_readers() {
        let good: &[(&str, f64)] = &[
            ("1", 1.0),
            ("-2.5", -2.5),
            ("+.5", 0.5),
            ("5.", 5.0),
            ("1e3", 1000.0),
            ("1.5E-2", 0.015),
            ("0.1", 0.1),
            ("1.7976931348623157e308", f64::MAX),
            ("4.9406564584124654e-324", 5e-324),
        ];
        for (text, value) in good {
            assert_eq!(number(text.as_bytes()), Some(*value), "{text}");
        }
        for text in ["nan", "-NaN", "inf", "-Infinity", "+INF"] {
            assert!(number(text.as_bytes()).is_some(), "{text}");
        }
        for text in [
            "e5", "1e", "1e+", ".", "-", "+", "1.2.3", "0x10", "1_0", "abc", "infin", "1d3",
        ] {
            assert_eq!(number(text.as_bytes()), None, "{text}");
        }
    }

    #[test]
    fn errors_name_the_first_bad_line() {
        assert_eq!(
            parse_table(b"1 2 3\n4 x 6\n", 3, None),
            Err(TextError {
                line: 1,
                offset: 8,
                kind: TextErrorKind::NotANumber
            })
        );
        assert_eq!(
            parse_table(b"1 2 3\n4 5\n", 3, None),
            Err(TextError {
                line: 1,
                offset: 6,
                kind: TextErrorKind::WrongCount
            })
        );
        assert_eq!(
            parse_table(b"1 2 3\n4 5 6 7\n", 3, None),
            Err(TextError {
                line: 1,
                offset: 6,
                kind: TextErrorKind::WrongCount
            })
        );
    }

    #[test]
    fn round_trips_17_digits() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut text = String::new();
        let mut want = Vec::new();
        for _ in 0..3000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let v = f64::from_bits(state);
            if v.is_finite() {
                text.push_str(&format!("{v:e}\n"));
                want.push(v);
            }
        }
        let t = parse_table(text.as_bytes(), 1, None).unwrap();
        assert_eq!(t.values, want);
    }

    #[test]
    fn parallel_pieces_equal_one_piece() {
        let mut text = String::new();
        for i in 0..60_000 {
            match i % 97 {
                0 => text.push('\n'),
                1 => text.push_str("# comment\n"),
                _ => text.push_str(&format!("{} {}.5 -{}e-3\n", i, i % 13, i * 7)),
            }
        }
        assert!(text.len() > 2 * PARALLEL_MIN_BYTES);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let parallel = pool
            .install(|| parse_table(text.as_bytes(), 3, None))
            .unwrap();
        assert_eq!(parallel, parse_piece(text.as_bytes(), 3, None).unwrap());
        // an error in a later piece names its line and offset in the whole chunk
        let bad_at = text.len() - 20;
        let line_start = text[..bad_at].rfind('\n').unwrap() + 1;
        let mut broken = text.clone().into_bytes();
        broken[line_start] = b'x';
        let line = text[..line_start].matches('\n').count();
        let e = pool.install(|| parse_table(&broken, 3, None)).unwrap_err();
        assert_eq!(
            e,
            TextError {
                line,
                offset: line_start,
                kind: TextErrorKind::NotANumber,
            }
        );
    }

    #[test]
    fn any_bytes_never_panic() {
        let samples: [&[u8]; 6] = [b"", b"\n\n", b"#", b"\xff\xfe 1 2", b"1 2 3\n\x00", b",,,"];
        for s in samples {
            for delimiter in [None, Some(b','), Some(b';')] {
                for ncols in [0, 3] {
                    let _ = parse_table(s, ncols, delimiter);
                }
            }
        }
    }
}
