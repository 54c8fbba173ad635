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
}

impl CliError {
    pub fn io(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        CliError::Io { path: path.display().to_string(), message: e.to_string() }
    }
}

impl From<graph::GraphError> for CliError {
    fn from(e: graph::GraphError) -> Self {
        CliError::Graph(Box::new(e))
    }
}

impl From<solve::SolveError> for CliError {
    fn from(e: solve::SolveError) -> Self {
        CliError::Solve(Box::new(e))
    }
}
