//! The CLI's error type: everything that can stop a command, as one line.

#[derive(Debug, thiserror::Error)]
pub enum CliError {
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
    /// outputs were written); exit status [`CliError::EXIT_INCOMPLETE`].
    #[error("{0}")]
    Incomplete(String),
}

/// A path for a one-line message: control characters escaped.
pub fn shown_path(path: &std::path::Path) -> String {
    graph::escape(&path.display().to_string())
}

impl CliError {
    /// Exit status of a run that ended before completing its cycles.
    pub const EXIT_INCOMPLETE: u8 = 3;

    /// Process exit status for this error: 3 for an incomplete run, 1 otherwise
    /// (2 is clap's, for usage errors).
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Incomplete(_) => Self::EXIT_INCOMPLETE,
            _ => 1,
        }
    }

    pub fn io(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        CliError::Io { path: shown_path(path), message: graph::escape(&e.to_string()) }
    }
}

impl From<graph::GraphError> for CliError {
    fn from(e: graph::GraphError) -> Self {
        CliError::Graph(Box::new(e))
    }
}

impl From<draw::DrawError> for CliError {
    fn from(e: draw::DrawError) -> Self {
        match e {
            draw::DrawError::Graph(g) => CliError::Graph(g),
            other => CliError::Data(other.to_string()),
        }
    }
}

impl From<solve::SolveError> for CliError {
    fn from(e: solve::SolveError) -> Self {
        CliError::Solve(Box::new(e))
    }
}
