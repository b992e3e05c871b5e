//! Errors of the hair asset loaders: always the file, the line and column, and what is wrong.
//! The fields, limits and header they check are read in [`super::fields`].

/// A hair asset could not be loaded (or built). Displays as `file:line:column: message`,
/// `file: message` when it concerns the whole file, or just the message for a value built in
/// code.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}", self.located())]
pub struct HairAssetError {
    /// The asset path (or file name) that failed; `None` for a value built in code
    /// ([`HairGroom::from_strands`](super::HairGroom::from_strands),
    /// [`HairAnimation::new`](super::HairAnimation::new)).
    pub file: Option<String>,
    /// 1-based line of the offending element or number; `0` when it concerns the whole file.
    pub line: u32,
    /// 1-based column; `0` when it concerns the whole file.
    pub column: u32,
    /// What is wrong, in words.
    pub message: String,
}

impl HairAssetError {
    /// An error in a value built in code, not read from a file.
    pub(crate) fn in_code(message: impl Into<String>) -> Self {
        Self {
            file: None,
            line: 0,
            column: 0,
            message: message.into(),
        }
    }

    fn located(&self) -> String {
        match (&self.file, self.line) {
            (None, _) => self.message.clone(),
            (Some(file), 0) => format!("{file}: {}", self.message),
            (Some(file), line) => format!("{file}:{line}:{}: {}", self.column, self.message),
        }
    }
}

/// An error about the whole file.
pub(crate) fn whole_file(file: &str, message: impl Into<String>) -> HairAssetError {
    HairAssetError {
        file: Some(file.to_string()),
        line: 0,
        column: 0,
        message: message.into(),
    }
}
