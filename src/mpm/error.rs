//! Typed failures of the MPM engine: a bad state is never returned as `Ok`.

use thiserror::Error;

/// Why a step (or a run) was refused. Every variant names the step.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MpmError {
    /// A parameter is out of range (checked before anything runs).
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter { name: &'static str, reason: String },
    /// A NaN or infinity appeared in a computed quantity.
    #[error("step {step}: non-finite {quantity}")]
    NonFinite { step: u64, quantity: &'static str },
    /// Newton did not meet its tolerances within the iteration limit.
    #[error(
        "step {step}: Newton did not converge in {iterations} iterations \
         (residual {residual:.3e} of tolerance scale, active set changing: {active_set_changing})"
    )]
    NotConverged {
        step: u64,
        iterations: usize,
        residual: f64,
        active_set_changing: bool,
    },
    /// The sparse Cholesky factorisation failed (matrix not positive definite).
    #[error("step {step}: sparse Cholesky failed ({reason})")]
    LinearSolve { step: u64, reason: String },
    /// Kinetic energy grew beyond what the walls supplied.
    #[error(
        "step {step}: kinetic energy {kinetic:.3e} J/m exceeds twice the supplied energy {supplied:.3e} J/m"
    )]
    EnergyGrowth {
        step: u64,
        kinetic: f64,
        supplied: f64,
    },
    /// A material point left the background grid.
    #[error("step {step}: material point {point} left the grid")]
    OutOfGrid { step: u64, point: usize },
    /// A point was crushed or inverted (det F <= 0).
    #[error("step {step}: material point {point} has det F = {det:.3e}")]
    Inverted { step: u64, point: usize, det: f64 },
}
