//! `pneumo`: the command-line front end. The command itself lives in the
//! library ([`pneumo_cli::command`]); every failure reaches the user as one
//! line on stderr and a non-zero exit; output files are written whole or not
//! at all.

use std::process::ExitCode;

fn main() -> ExitCode {
    restore_default_sigpipe();
    ExitCode::from(pneumo_cli::command::run(std::env::args_os()))
}

/// Die quietly on a closed pipe (`pneumo blocks | head`), as Unix tools do,
/// instead of panicking inside `println!`.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread exists; only
    // resets the disposition of SIGPIPE to its default.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
