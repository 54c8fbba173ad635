//! The error of every use case: everything that can stop one, as one line,
//! with the exit status a command-line front end gives it.

#[derive(Debug, thiserror::Error)]
pub enum AppError {
    #[error(transparent)]
    Graph(Box<graph::GraphError>),
    #[error(transparent)]
    Solve(Box<solve::SolveError>),
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    #[error("{0}")]
    Usage(String),
    #[error("{0}")]
    Data(String),
    /// The run reached its end time before doing what it was asked (its
    /// outputs were written); exit status [`AppError::EXIT_INCOMPLETE`].
    #[error("{0}")]
    Incomplete(String),
}

/// A message as one line: control characters (newlines, terminal escapes)
/// from any input it quotes are shown escaped.
pub fn one_line(message: &str) -> String {
    units::show::line(message)
}

/// A path for a one-line message: control characters escaped.
pub fn shown_path(path: &std::path::Path) -> String {
    graph::escape(&path.display().to_string())
}

impl AppError {
    /// Exit status of a run that ended before completing its cycles.
    pub const EXIT_INCOMPLETE: u8 = 3;

    /// Process exit status for this error: 3 for an incomplete run, 1 otherwise
    /// (2 is the command line's, for arguments it cannot parse).
    pub fn exit_code(&self) -> u8 {
        match self {
            AppError::Incomplete(_) => Self::EXIT_INCOMPLETE,
            _ => 1,
        }
    }

    pub fn io(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        AppError::Io { path: shown_path(path), message: units::show::line(&e.to_string()) }
    }
}

impl From<graph::GraphError> for AppError {
    fn from(e: graph::GraphError) -> Self {
        AppError::Graph(Box::new(e))
    }
}

impl From<draw::DrawError> for AppError {
    fn from(e: draw::DrawError) -> Self {
        match e {
            draw::DrawError::Graph(g) => AppError::Graph(g),
            other => AppError::Data(other.to_string()),
        }
    }
}

impl From<solve::SolveError> for AppError {
    fn from(e: solve::SolveError) -> Self {
        AppError::Solve(Box::new(e))
    }
}
