//! One module per subcommand: its clap arguments, their conversion into the
//! options of a `pneumo_app` use case, and what the command prints.

pub mod check;
pub mod conductance;
pub mod discrepancy;
pub mod plot;
pub mod simulate;
pub mod sweep;

/// Print warnings, one line each on stderr, without repeating a line.
pub fn print_warnings(warnings: &[graph::Warning]) {
    let mut seen = std::collections::BTreeSet::new();
    for w in warnings {
        if seen.insert(w) {
            eprintln!("warning: {}", graph::escape(&w.to_string()));
        }
    }
}
