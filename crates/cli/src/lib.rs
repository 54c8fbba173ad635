//! The `pneumo` command line as a library: argument parsing and dispatch
//! ([`command::run`]), which the binary (`src/main.rs`) and `python -m
//! pneumo` call. A thin shell over the use-case layer `pneumo_app`: each
//! subcommand's module (`src/args/`) turns its arguments into the app's
//! options, calls one use case and prints what it returns.
//!
//! The only crate that parses arguments, prints to the terminal and chooses
//! exit statuses.

mod args;
pub mod command;
