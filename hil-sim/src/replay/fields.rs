//! Whitespace-separated fields of one text line, taken in order with the name each has in
//! its format, so that every failure becomes a [`LogError`] naming file, line and field.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::str::SplitWhitespace;

use super::error::{FieldProblem, LogError};

/// The fields of one line, consumed front to back.
pub(crate) struct Fields<'a> {
    path: &'a Path,
    line: usize,
    record: &'a str,
    words: SplitWhitespace<'a>,
}

impl<'a> Fields<'a> {
    /// The fields of `text`, line `line` of `path`, holding a `record`.
    pub(crate) fn new(path: &'a Path, line: usize, record: &'a str, text: &'a str) -> Self {
        Fields {
            path,
            line,
            record,
            words: text.split_whitespace(),
        }
    }

    /// An error about `field` of this line.
    pub(crate) fn error(&self, field: &str, problem: FieldProblem) -> LogError {
        LogError::Field {
            path: self.path.to_owned(),
            line: self.line,
            record: self.record.to_owned(),
            field: field.to_owned(),
            problem,
        }
    }

    /// The next field as text.
    pub(crate) fn text(&mut self, field: &str) -> Result<&'a str, LogError> {
        self.words
            .next()
            .ok_or_else(|| self.error(field, FieldProblem::Missing))
    }

    /// The next field, if there is one.
    pub(crate) fn optional_text(&mut self) -> Option<&'a str> {
        self.words.next()
    }

    /// The next field as a finite number.
    pub(crate) fn number(&mut self, field: &str) -> Result<f64, LogError> {
        let text = self.text(field)?;
        parse_number(text).ok_or_else(|| self.error(field, FieldProblem::NotANumber(text.into())))
    }

    /// The next field as a finite number, with its text.
    pub(crate) fn number_with_text(&mut self, field: &str) -> Result<(f64, &'a str), LogError> {
        let text = self.text(field)?;
        match parse_number(text) {
            Some(value) => Ok((value, text)),
            None => Err(self.error(field, FieldProblem::NotANumber(text.into()))),
        }
    }

    /// The next field as a finite number, named `field[index]` in an error.
    pub(crate) fn indexed_number(&mut self, field: &str, index: usize) -> Result<f64, LogError> {
        match self.words.next() {
            Some(text) => parse_number(text).ok_or_else(|| {
                self.error(
                    &format!("{field}[{index}]"),
                    FieldProblem::NotANumber(text.into()),
                )
            }),
            None => Err(self.error(&format!("{field}[{index}]"), FieldProblem::Missing)),
        }
    }

    /// The next field as a count.
    pub(crate) fn count(&mut self, field: &str) -> Result<usize, LogError> {
        let text = self.text(field)?;
        text.parse::<usize>()
            .map_err(|_| self.error(field, FieldProblem::NotACount(text.into())))
    }

    /// Fails if any field is left.
    pub(crate) fn end(&mut self) -> Result<(), LogError> {
        match self.words.next() {
            None => Ok(()),
            Some(extra) => Err(self.error("end of line", FieldProblem::Unexpected(extra.into()))),
        }
    }
}

/// `text` as a finite `f64`.
pub(crate) fn parse_number(text: &str) -> Option<f64> {
    text.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Whether a line holds nothing to read: blank, or a `#` comment.
pub(crate) fn is_blank_or_comment(line: &str) -> bool {
    let line = line.trim_start();
    line.is_empty() || line.starts_with('#')
}

/// Opens `path` for reading line by line, through a gzip decoder when its name ends in `.gz`.
///
/// # Errors
/// [`LogError::Io`] when the file cannot be opened.
pub(crate) fn open_lines(path: &Path) -> Result<Box<dyn BufRead + Send>, LogError> {
    let file = File::open(path).map_err(|e| LogError::io(path, e))?;
    let gzipped = path
        .extension()
        .is_some_and(|ext| ext.eq_ignore_ascii_case("gz"));
    Ok(if gzipped {
        Box::new(BufReader::new(flate2::read::MultiGzDecoder::new(file)))
    } else {
        Box::new(BufReader::new(file))
    })
}

/// Calls `parse` on every line of `reader` (numbered from 1) that is neither blank nor a `#`
/// comment, and collects what it returns.
///
/// # Errors
/// The first error of `parse`, or [`LogError::Io`] when reading fails.
pub(crate) fn parse_lines<T>(
    mut reader: impl BufRead,
    path: &Path,
    mut parse: impl FnMut(usize, &str) -> Result<T, LogError>,
) -> Result<Vec<T>, LogError> {
    let mut out = Vec::new();
    let mut text = String::new();
    let mut line = 0;
    loop {
        text.clear();
        let read = reader
            .read_line(&mut text)
            .map_err(|e| LogError::io(path, e))?;
        if read == 0 {
            return Ok(out);
        }
        line += 1;
        if !is_blank_or_comment(&text) {
            out.push(parse(line, &text)?);
        }
    }
}
