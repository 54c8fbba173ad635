//! Linear time-invariant systems in state-space form, ẋ = A x + B u,
//! y = C x + D u, and what a control engineer asks of them.
//!
//! Owns: a small dense matrix type ([`Matrix`], row-major, real), diagonal
//! balancing ([`balance`]), modes — eigenvalues with natural frequency,
//! damping ratio and the states that take part in each ([`modal`]) — the
//! minimal realisation of one input–output pair ([`realization`]), its poles,
//! transmission zeros and gain ([`zeros`]), frequency responses and Bode data
//! ([`frequency`]), step responses by the exact discretisation of the
//! system ([`time`]), and rank-revealing least squares ([`lstsq`], used by
//! trim solves). The eigenvalue, generalised-eigenvalue and singular-value
//! decompositions are faer's (already the sparse LU of `crates/ode`).
//!
//! Never knows: pneumatics, models, files. Inputs must be finite: every
//! function that takes matrices checks that and returns
//! [`LinearError::NonFinite`] otherwise (faer's iterations would not
//! converge on NaN).

pub mod balance;
pub mod frequency;
pub mod lstsq;
pub mod matrix;
pub mod modal;
pub mod realization;
pub mod time;
pub mod zeros;

pub use matrix::Matrix;

/// A complex number (faer's, which is num-complex's).
pub type Complex = faer::c64;

/// What a linear-algebra step could not do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LinearError {
    #[error("{what} has a non-finite entry")]
    NonFinite { what: &'static str },
    #[error("{what}: the decomposition did not converge")]
    NoConvergence { what: &'static str },
    #[error("{0}")]
    Shape(String),
}
