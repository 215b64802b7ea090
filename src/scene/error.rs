//! Scene errors name the file, the line and the field.

use serde_saphyr::Spanned;
use std::fmt;

/// The 1-based source line of a parsed value, if known.
pub(crate) fn line<T>(s: &Spanned<T>) -> Option<u64> {
    Some(s.referenced.line()).filter(|&l| l > 0)
}

#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    pub file: Option<String>,
    pub line: Option<u64>,
    /// Path of the offending field, e.g. `bodies[0].mass`.
    pub field: String,
    pub message: String,
}

impl SceneError {
    pub(crate) fn at(
        line: Option<u64>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        SceneError {
            file: None,
            line,
            field: field.into(),
            message: message.into(),
        }
    }

    pub(crate) fn in_file(mut self, file: &str) -> Self {
        self.file = Some(file.to_string());
        self
    }

    pub(crate) fn from_yaml(file: &str, e: &serde_saphyr::Error) -> Self {
        let line = e.location().map(|l| l.line()).filter(|&l| l > 0);
        // the first line of saphyr's rendering is the message; the rest is a source snippet
        let text = e.to_string();
        let text = text.trim().trim_start_matches("error: ");
        SceneError {
            file: Some(file.to_string()),
            line,
            field: String::new(),
            message: text.trim().to_string(),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(file) = &self.file {
            write!(f, "{file}")?;
            if let Some(l) = self.line {
                write!(f, ":{l}")?;
            }
            write!(f, ": ")?;
        } else if let Some(l) = self.line {
            write!(f, "line {l}: ")?;
        }
        if !self.field.is_empty() {
            write!(f, "`{}` ", self.field)?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for SceneError {}
