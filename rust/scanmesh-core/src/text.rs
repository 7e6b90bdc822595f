//! Numeric text tables: rows of whitespace- or comma-separated floats parsed from bytes.
//!
//! The text readers (XYZ, CSV) hand this module one chunk of whole lines at a time, so a
//! 10-million-point file is parsed without a Python step per point and the caller can
//! honour Ctrl-C between chunks. The rules are those of the readers' numpy path, which
//! stays the reference and the error reporter:
//!
//! - a line is the bytes up to `\n`; tokens are maximal runs of bytes other than space,
//!   tab, CR, LF (and, in comma mode, `,`);
//! - a line without tokens is blank (in comma mode it must hold no comma either);
//! - a line whose first token starts with `#` is a comment;
//! - every other line is a data row of exactly `ncols` numbers (in comma mode with exactly
//!   `ncols - 1` commas, so an empty field is an error, not a skipped column);
//! - a number is `[+-]?(digits[.digits]|.digits)([eE][+-]?digits)?`, `nan`, `inf` or
//!   `infinity` (any case, optional sign): what numpy's text parser accepts.
//!
//! Numbers are converted by `fast_float2` (Eisel-Lemire with an exact fallback: correctly
//! rounded, so `%.17g` text reads back bit for bit).

use rayon::prelude::*;

/// Why a chunk was refused: the first offending line (0-based within the chunk) and the
/// byte offset (within the chunk) of the offending token or line start. The caller turns
/// it into a message naming the file, line and text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TextError {
    /// 0-based line index within the chunk
    pub line: usize,
    /// byte offset within the chunk where the problem starts
    pub offset: usize,
}

/// A parsed chunk: `values` row-major (rows × ncols), the line of every row and the blank
/// lines (the readers split scan lines at blank lines).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// row-major values, `ncols` per data row
    pub values: Vec<f64>,
    /// 0-based line index (within the chunk) of each data row
    pub row_lines: Vec<i64>,
    /// 0-based line indices (within the chunk) of the blank lines, ascending
    pub blank_lines: Vec<i64>,
    /// number of lines in the chunk (a last line without `\n` counts)
    pub n_lines: usize,
}

/// Separator bytes: bit 0 = whitespace separator, bit 1 = comma.
const fn separator_table() -> [u8; 256] {
    let mut t = [0u8; 256];
    t[b' ' as usize] = 1;
    t[b'\t' as usize] = 1;
    t[b'\r' as usize] = 1;
    t[b'\n' as usize] = 1;
    t[b',' as usize] = 2;
    t
}
const SEPARATORS: [u8; 256] = separator_table();

/// One number token, or None when it is not entirely a number in the accepted grammar.
fn number(token: &[u8]) -> Option<f64> {
    // fast_float2 takes the same grammar (sign, digits, dot, exponent, nan/inf/infinity in
    // any case) but stops early on trailing junk: require the whole token to be consumed.
    match fast_float2::parse_partial::<f64, _>(token) {
        Ok((value, used)) if used == token.len() => Some(value),
        _ => None,
    }
}

/// Chunks at least this long are split at line breaks into one piece per rayon thread and
/// parsed in parallel (smaller ones are not worth a thread hand-off).
pub const PARALLEL_MIN_BYTES: usize = 1 << 18;

/// Parses `buf`, a chunk of whole lines, as rows of `ncols` numbers (see the module rules).
///
/// `comma` selects comma mode (commas separate too, and count). Returns the first bad line
/// as a [`TextError`]; never panics on any input. Long chunks are parsed in parallel pieces
/// (same result as one piece: tested). O(len) work.
pub fn parse_table(buf: &[u8], ncols: usize, comma: bool) -> Result<Table, TextError> {
    let threads = rayon::current_num_threads();
    if buf.len() < PARALLEL_MIN_BYTES || threads < 2 {
        return parse_piece(buf, ncols, comma);
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
        .map(|w| parse_piece(&buf[w[0]..w[1]], ncols, comma))
        .collect();
    let mut out = Table::default();
    for (piece, &offset) in pieces.into_iter().zip(&cuts) {
        let lines = out.n_lines as i64;
        let piece = piece.map_err(|e| TextError {
            line: e.line + out.n_lines,
            offset: e.offset + offset,
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

/// [`parse_table`] on one thread.
fn parse_piece(buf: &[u8], ncols: usize, comma: bool) -> Result<Table, TextError> {
    let mask = if comma { 3u8 } else { 1u8 };
    // A row costs at least 2 bytes per value: reserve for the densest plausible chunk /4
    // (about what real scans hold) and let the vector grow past it if needed.
    let mut table = Table {
        values: Vec::with_capacity(buf.len() / 4),
        ..Table::default()
    };
    let mut start = 0usize;
    let mut line = 0usize;
    while start < buf.len() {
        let end = buf[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(buf.len(), |k| start + k);
        parse_line(buf, start, end, line, ncols, comma, mask, &mut table)?;
        line += 1;
        start = end + 1;
    }
    table.n_lines = line;
    Ok(table)
}

/// Parses line `line` (bytes `start..end`, without its `\n`) into `table`.
#[allow(clippy::too_many_arguments)]
fn parse_line(
    buf: &[u8],
    start: usize,
    end: usize,
    line: usize,
    ncols: usize,
    comma: bool,
    mask: u8,
    table: &mut Table,
) -> Result<(), TextError> {
    let text = &buf[start..end];
    let bad = |offset: usize| TextError { line, offset };
    let mut tokens = 0usize;
    let mut commas = 0usize;
    let mut i = 0usize;
    let row_start = table.values.len();
    while i < text.len() {
        let kind = SEPARATORS[text[i] as usize] & mask;
        if kind != 0 {
            commas += usize::from(kind == 2);
            i += 1;
            continue;
        }
        let t0 = i;
        while i < text.len() && SEPARATORS[text[i] as usize] & mask == 0 {
            i += 1;
        }
        let token = &text[t0..i];
        if tokens == 0 && token[0] == b'#' {
            table.values.truncate(row_start);
            return Ok(()); // a comment line: its commas do not count
        }
        tokens += 1;
        if tokens > ncols {
            table.values.truncate(row_start);
            return Err(bad(start));
        }
        match number(token) {
            Some(v) => table.values.push(v),
            None => {
                table.values.truncate(row_start);
                return Err(bad(start + t0));
            }
        }
    }
    if tokens == 0 {
        if commas > 0 {
            return Err(bad(start));
        }
        table.blank_lines.push(line as i64);
        return Ok(());
    }
    if tokens != ncols || (comma && commas != ncols - 1) {
        table.values.truncate(row_start);
        return Err(bad(start));
    }
    table.row_lines.push(line as i64);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_comments_and_blank_lines() {
        let t = parse_table(b"1 2 3\n# note, here\n\n4\t5 6\r\n  \n7 8 9", 3, false).unwrap();
        assert_eq!(t.values, vec![1., 2., 3., 4., 5., 6., 7., 8., 9.]);
        assert_eq!(t.row_lines, vec![0, 3, 5]);
        assert_eq!(t.blank_lines, vec![2, 4]);
        assert_eq!(t.n_lines, 6);
        // a chunk that ends with a line break has no extra empty line
        assert_eq!(parse_table(b"1 2\n", 2, false).unwrap().n_lines, 1);
    }

    #[test]
    fn comma_mode_counts_fields() {
        let t = parse_table(b"1,2,3\n4, 5 ,6\n", 3, true).unwrap();
        assert_eq!(t.values, vec![1., 2., 3., 4., 5., 6.]);
        // an empty field is refused, not skipped; a line of commas is not blank
        assert_eq!(
            parse_table(b"1,2,3\n1,,2,3\n", 3, true),
            Err(TextError { line: 1, offset: 6 })
        );
        assert_eq!(
            parse_table(b"1,2,3\n,,\n", 3, true),
            Err(TextError { line: 1, offset: 6 })
        );
        // without comma mode a comma is part of a token, and so not a number
        assert!(parse_table(b"1,2,3\n", 3, false).is_err());
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
            parse_table(b"1 2 3\n4 x 6\n", 3, false),
            Err(TextError { line: 1, offset: 8 })
        );
        assert_eq!(
            parse_table(b"1 2 3\n4 5\n", 3, false),
            Err(TextError { line: 1, offset: 6 })
        );
        assert_eq!(
            parse_table(b"1 2 3\n4 5 6 7\n", 3, false),
            Err(TextError { line: 1, offset: 6 })
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
        let t = parse_table(text.as_bytes(), 1, false).unwrap();
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
            .install(|| parse_table(text.as_bytes(), 3, false))
            .unwrap();
        assert_eq!(parallel, parse_piece(text.as_bytes(), 3, false).unwrap());
        // an error in a later piece names its line and offset in the whole chunk
        let bad_at = text.len() - 20;
        let line_start = text[..bad_at].rfind('\n').unwrap() + 1;
        let mut broken = text.clone().into_bytes();
        broken[line_start] = b'x';
        let line = text[..line_start].matches('\n').count();
        let e = pool.install(|| parse_table(&broken, 3, false)).unwrap_err();
        assert_eq!(
            e,
            TextError {
                line,
                offset: line_start
            }
        );
    }

    #[test]
    fn any_bytes_never_panic() {
        let samples: [&[u8]; 6] = [b"", b"\n\n", b"#", b"\xff\xfe 1 2", b"1 2 3\n\x00", b",,,"];
        for s in samples {
            for comma in [false, true] {
                let _ = parse_table(s, 3, comma);
            }
        }
    }
}
