use std::path::PathBuf;

/// Why a scene could not be loaded or rendered. Every parse error names the file, line and column.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The text does not follow the p3f grammar, or a value is out of range.
    #[error("{file}:{line}:{column}: {message}")]
    Syntax {
        /// The file name (as given to the loader).
        file: String,
        /// Line, from 1.
        line: u32,
        /// Column, from 1.
        column: u32,
        /// What was found and what was expected.
        message: String,
        /// What was skipped before the error, in file order: the reasons a user may need to see
        /// first (printed before the error).
        warnings: Vec<Warning>,
    },
    /// A file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// An environment cubemap could not be found or decoded.
    #[error("environment map '{name}': {message}")]
    Environment {
        /// The name given in the scene (`env NAME`).
        name: String,
        /// What went wrong.
        message: String,
    },
    /// The scene or the settings are not renderable (e.g. no camera, absurd size).
    #[error("{0}")]
    Invalid(String),
    /// The render was cancelled before it finished (`raylume_render::CancelToken`).
    #[error("the render was cancelled")]
    Cancelled,
}

impl SceneError {
    /// The warnings found before a syntax error (empty for other errors).
    pub fn warnings(&self) -> &[Warning] {
        match self {
            SceneError::Syntax { warnings, .. } => warnings,
            _ => &[],
        }
    }

    /// The error with `earlier` warnings put before its own.
    pub(crate) fn with_earlier_warnings(mut self, mut earlier: Vec<Warning>) -> Self {
        if let SceneError::Syntax { warnings, .. } = &mut self {
            earlier.append(warnings);
            *warnings = earlier;
        }
        self
    }
}

/// Something in a scene file that was skipped (an error under `--strict`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// The file name.
    pub file: String,
    /// Line, from 1 (0: the warning is about no line of a file).
    pub line: u32,
    /// Column, from 1.
    pub column: u32,
    /// What was skipped.
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.line, self.file.is_empty()) {
            (0, true) => write!(f, "warning: {}", self.message),
            (0, false) => write!(f, "{}: warning: {}", self.file, self.message),
            _ => write!(f, "{}:{}:{}: warning: {}", self.file, self.line, self.column, self.message),
        }
    }
}
