//! One error type for the whole tool.
//!
//! Every error caused by user input carries where it came from (file, line,
//! element or column), so the message can point the user at the exact place.
//! [`Error::Input`] maps to exit status 2, [`Error::Internal`] to 1.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in the user's input an error was found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Location {
    pub file: Option<PathBuf>,
    /// 1-based line number.
    pub line: Option<usize>,
    /// XML element (`<Body name="femur_r">`) or table column.
    pub element: Option<String>,
}

impl Location {
    pub fn file(file: impl AsRef<Path>) -> Self {
        Location {
            file: Some(file.as_ref().to_path_buf()),
            ..Default::default()
        }
    }
    pub fn with_line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }
    pub fn with_element(mut self, element: impl Into<String>) -> Self {
        self.element = Some(element.into());
        self
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut wrote = false;
        if let Some(file) = &self.file {
            write!(f, "{}", file.display())?;
            wrote = true;
        }
        if let Some(line) = self.line {
            write!(f, "{}line {}", if wrote { ", " } else { "" }, line)?;
            wrote = true;
        }
        if let Some(el) = &self.element {
            write!(f, "{}{}", if wrote { ", " } else { "" }, el)?;
        }
        Ok(())
    }
}

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The user's input (a file, a setting, a command-line option) is wrong.
    #[error("{}{msg}", loc_prefix(loc))]
    Input { loc: Box<Location>, msg: String },
    /// Something the tool itself failed at (a bug, or a numerical failure that input did not cause).
    #[error("internal error: {0}")]
    Internal(String),
}

impl Error {
    pub fn input(loc: Location, msg: impl Into<String>) -> Self {
        Error::Input {
            loc: Box::new(loc),
            msg: msg.into(),
        }
    }
    /// An input error with no location (e.g. a command-line option).
    pub fn msg(msg: impl Into<String>) -> Self {
        Error::Input {
            loc: Box::default(),
            msg: msg.into(),
        }
    }
    pub fn io(file: impl AsRef<Path>, err: std::io::Error) -> Self {
        Error::input(
            Location::file(file),
            format!("cannot read or write file: {err}"),
        )
    }
    pub fn internal(msg: impl Into<String>) -> Self {
        Error::Internal(msg.into())
    }
    /// Process exit status for this error: 2 for bad input, 1 for internal failures.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input { .. } => 2,
            Error::Internal(_) => 1,
        }
    }
    /// Add a note on a line of its own after the message (what may have
    /// caused it), keeping the location.
    pub fn with_note(self, note: impl fmt::Display) -> Self {
        match self {
            Error::Input { loc, msg } => Error::Input {
                loc,
                msg: format!("{msg}\nnote: {note}"),
            },
            Error::Internal(m) => Error::Internal(format!("{m}\nnote: {note}")),
        }
    }
    /// Prefix the message with context, keeping the location.
    pub fn context(self, ctx: impl fmt::Display) -> Self {
        match self {
            Error::Input { loc, msg } => Error::Input {
                loc,
                msg: format!("{ctx}: {msg}"),
            },
            Error::Internal(m) => Error::Internal(format!("{ctx}: {m}")),
        }
    }
}

fn loc_prefix(loc: &Location) -> String {
    if *loc == Location::default() {
        String::new()
    } else {
        format!("{loc}: ")
    }
}

pub type Result<T> = std::result::Result<T, Error>;
