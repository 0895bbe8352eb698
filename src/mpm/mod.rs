//! Implicit material point method (MPM) for soft grains in 2D plane strain, after
//! Nezamabadi et al. (2017) §2.2 and Guilkey & Weiss (2003); see METHODS.md §3–§6.
//!
//! Pure library: plain structs in, plain structs out, progress through a callback.
//!
//! # Decisions the paper leaves open
//! * **Seeding.** 2×2 points per square cell at the quarter-cell centres, kept when inside
//!   the circle; the cell size is `h_g = 2Δr` with `n = round(R/Δr)` whole cells across
//!   the diameter, so the disk touches both plates exactly. Every point gets the area
//!   `π R²/N`, so `Σ V_p = π R²` exactly.
//! * **Small-mass nodes.** No cut: every node a point reaches with a positive weight is
//!   active; the lumped mass term `M/(β Δt²)` keeps the effective stiffness positive
//!   definite. The smooth bases (uGIMP, B-spline) remove the gradient jumps that make
//!   cell crossing noisy.
//! * **Wall contact** (`contact.rs`). Frictionless rigid plates of infinite mass, applied at
//!   the nodes on or behind the plate plane with the gap measured from the points; the wall
//!   normal is used (no mass-gradient normal is needed for a plane). Signorini on the
//!   end-of-step gap, solved exactly inside Newton by an active set.
//! * **Locking.** B-bar on the 2D dilatation, averaged over the points of a grid cell
//!   (volume-weighted), on by default; `SolverParams::bbar = false` gives the plain
//!   (locking-prone at ν = 0.45) formulation.
//! * **Newmark.** β = 1/4, γ = 1/2 by default (Guilkey & Weiss); `Newmark::damped(γ)`
//!   for numerical damping. Point velocities use the FLIP-type Newmark update (no PIC blend).
//! * **Tangent.** Material (B̄ᵀ D B̄) plus geometric stiffness in the current configuration;
//!   with the Hughes–Winget update `D = C`, so Newton converges fast but not quadratically.
//! * **Plate force.** `σ = F/L` uses the mean of the two plate forces; both are recorded.
//! * **Time step.** Chosen from the plate travel per step (default 0.05 h_g), not from CFL.

pub mod analytic;
pub mod contact;
pub mod driver;
pub mod error;
pub mod grid;
pub mod material;
pub mod newmark;
pub mod points;
pub mod shape;
pub mod solve;
pub mod sparse;

pub use driver::{
    Control, PointState, Progress, Row, RunStats, SingleGrain, SingleGrainParams,
    SingleGrainResult, run_single_grain,
};
pub use error::MpmError;
pub use material::{Material, MaterialKind};
pub use newmark::Newmark;
pub use shape::ShapeKind;
pub use solve::{NewtonParams, Solver, SolverParams, StepStats};
