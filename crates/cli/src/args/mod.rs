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

/// Limits of a command that loads a netlist: the components it may expand
/// to and the memory it may plan to use.
#[derive(clap::Args, Debug)]
pub struct Limits {
    /// Most components a circuit may expand to (subsystems included).
    #[arg(long = "max-components", value_name = "N", default_value_t = graph::expand::DEFAULT_MAX_COMPONENTS, allow_negative_numbers = true)]
    pub max_components: usize,
    #[command(flatten)]
    pub memory: MemoryLimit,
}

/// The memory limit of a command that reads files or runs simulations.
#[derive(clap::Args, Debug)]
pub struct MemoryLimit {
    /// Memory a run may plan to use [MiB] (result traces, the solver's matrices; input files get a quarter of it);
    /// larger runs and inputs are refused before they start.
    #[arg(long = "max-memory", value_name = "MiB", default_value_t = pneumo_app::load::DEFAULT_MAX_MEMORY_MIB, allow_negative_numbers = true)]
    pub max_memory: u64,
}

impl Limits {
    /// Make these the limits of the use cases this process runs.
    pub fn apply(&self) {
        pneumo_app::load::set_limits(pneumo_app::load::Limits {
            max_components: self.max_components,
            max_memory_mib: self.memory.max_memory,
        });
    }
}

impl MemoryLimit {
    /// Make this the memory limit (the component limit keeps its default: no netlist is loaded).
    pub fn apply(&self) {
        pneumo_app::load::set_limits(pneumo_app::load::Limits {
            max_components: graph::expand::DEFAULT_MAX_COMPONENTS,
            max_memory_mib: self.max_memory,
        });
    }
}

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
