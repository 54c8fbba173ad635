//! One module per subcommand: its clap arguments, their conversion into the
//! options of a `pneumo_app` use case, and what the command prints.

pub mod check;
pub mod conductance;
pub mod discrepancy;
pub mod draw;
pub mod fmu;
pub mod linearize;
pub mod plot;
pub mod report;
pub mod simulate;
pub mod sweep;

/// A count that must be at least 1 (`--cycles`, `--jobs`): zero cycles is
/// not a run and zero workers run nothing, so 0 is refused as a usage error
/// (exit status 2) rather than run as an empty success.
pub fn at_least_one<T: std::str::FromStr + PartialEq + From<u8>>(text: &str) -> Result<T, String> {
    let n: T = text.trim().parse().map_err(|_| "expected a whole number >= 1".to_string())?;
    if n == T::from(0) {
        return Err("must be at least 1".into());
    }
    Ok(n)
}

/// Print warnings, one line each on stderr, without repeating a line.
pub fn print_warnings(warnings: &[graph::Warning]) {
    let mut seen = std::collections::BTreeSet::new();
    for w in warnings {
        if seen.insert(w) {
            // file and message shortened apart, so that a long path does not cut the message
            let file = if w.file.is_empty() { String::new() } else { format!("{}: ", pneumo_app::error::one_line(&w.file)) };
            eprintln!("warning: {file}{}", pneumo_app::error::one_line(&w.message));
        }
    }
}
