//! What is wrong in a vehicle configuration file, and where: the checks'
//! own errors and toml's, placed by `toml_report`.

use std::fmt;
use std::ops::Range;
use std::path::PathBuf;

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigError {
    /// Set by [`load`]; [`parse`] has no file name.
    pub file: Option<PathBuf>,
    /// 1-based; `None` when the error is about the file as a whole (a missing
    /// section, an unreadable file).
    pub line: Option<usize>,
    pub column: Option<usize>,
    /// Dotted key path (`gnss.baud`, `scanner[1].address`); empty for syntax
    /// errors that are not about one key.
    pub key: String,
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.file {
            Some(file) => write!(f, "{}", file.display())?,
            None => write!(f, "config")?,
        }
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
            if let Some(column) = self.column {
                write!(f, ":{column}")?;
            }
        }
        if !self.key.is_empty() {
            write!(f, ": {}", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ConfigError {}

impl ConfigError {
    /// An error about the whole file (unreadable, a missing section).
    pub(super) fn whole_file(key: &str, message: impl Into<String>) -> ConfigError {
        ConfigError {
            file: None,
            line: None,
            column: None,
            key: key.to_string(),
            message: message.into(),
        }
    }

    /// An error about the key or value at `span` of `text`.
    pub(super) fn at(text: &str, key: &str, span: Range<usize>, message: impl Into<String>) -> ConfigError {
        let place = toml_report::place(text, span.start);
        ConfigError {
            file: None,
            line: Some(place.line),
            column: Some(place.column),
            key: key.to_string(),
            message: message.into(),
        }
    }

    /// toml's own error (syntax, unknown key, wrong type, missing key).
    pub(super) fn from_toml(text: &str, error: &toml::de::Error) -> ConfigError {
        let problem = toml_report::problem(text, error);
        ConfigError {
            file: None,
            line: problem.place.map(|p| p.line),
            column: problem.place.map(|p| p.column),
            key: problem.key,
            message: problem.message,
        }
    }
}
