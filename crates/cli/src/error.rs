//! The CLI's error type: everything that can stop a command, as one line.

#[derive(Debug, thiserror::Error)]
pub enum CliError {
    #[error(transparent)]
    Graph(#[from] graph::GraphError),
    #[error(transparent)]
    Solve(#[from] solve::SolveError),
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
