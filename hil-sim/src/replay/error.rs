//! The error every log reader of [`super`] returns: which file, which line, which field, and
//! what was wrong with it. Readers never panic on their input; they return one of these.

use std::fmt;
use std::path::{Path, PathBuf};

/// What was wrong with a field.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FieldProblem {
    /// The line ended before the field.
    Missing,
    /// The text is not a (finite) decimal number.
    NotANumber(String),
    /// The text is not a non-negative integer.
    NotACount(String),
    /// The line has more fields than its record holds.
    Unexpected(String),
    /// The value parsed but breaks a rule of the format (the text says which).
    Invalid(String),
}

impl fmt::Display for FieldProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FieldProblem::Missing => write!(f, "missing"),
            FieldProblem::NotANumber(text) => write!(f, "{text:?} is not a number"),
            FieldProblem::NotACount(text) => write!(f, "{text:?} is not a count"),
            FieldProblem::Unexpected(text) => write!(f, "unexpected extra field {text:?}"),
            FieldProblem::Invalid(why) => write!(f, "{why}"),
        }
    }
}

/// Why a log could not be read.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// The file could not be opened or read (or was not valid UTF-8 text).
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A line of the file does not hold a valid record.
    #[error("{}:{line}: {record} field `{field}`: {problem}", path.display())]
    Field {
        /// The file (or the name given to text parsed from memory).
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// The record type (`FLASER`, `ODOM`, `reference pose`, …).
        record: String,
        /// The field's name in the format's documentation.
        field: String,
        /// What was wrong.
        problem: FieldProblem,
    },
}

impl LogError {
    /// An I/O error on `path`.
    pub fn io(path: &Path, source: std::io::Error) -> LogError {
        LogError::Io {
            path: path.to_owned(),
            source,
        }
    }

    /// The line the error is on, if it is about a line.
    pub fn line(&self) -> Option<usize> {
        match self {
            LogError::Io { .. } => None,
            LogError::Field { line, .. } => Some(*line),
        }
    }

    /// The field the error is about, if any.
    pub fn field(&self) -> Option<&str> {
        match self {
            LogError::Io { .. } => None,
            LogError::Field { field, .. } => Some(field),
        }
    }

    /// What was wrong with the field, if the error is about one.
    pub fn problem(&self) -> Option<&FieldProblem> {
        match self {
            LogError::Io { .. } => None,
            LogError::Field { problem, .. } => Some(problem),
        }
    }
}
