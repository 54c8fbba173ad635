//! No code. A "workspace-hack" package (the pattern cargo-hakari automates):
//! `pneumo-app` depends on it so that the command line, the Python extension
//! and the test build all compile the shared dependencies with one feature
//! set and share `target/release` (see Cargo.toml for which and why).
