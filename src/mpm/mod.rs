//! Implicit material point method (MPM) for soft grains in 2D plane strain, after
//! Nezamabadi et al. (2017) §2.2 and Guilkey & Weiss (2003); see METHODS.md §3–§6.
//!
//! Pure library: plain structs in, plain structs out, progress through a callback.
//!
//! # Decisions the paper leaves open
//! * **Seeding.** 2×2 points per square cell at the quarter-cell centres, kept when inside
//!   the circle; the cell size is `h_g = 2Δr` with `n = round(R/Δr)` whole cells across
//!   the diameter, so the disk touches both plates exactly (Δr/R = 0.029 gives n = 34,
//!   3,640 points). Every point gets the area `π R²/N`, so `Σ V_p = π R²` exactly.
//! * **Surface of the point cloud.** Each point's extents toward ±x and ±y are its
//!   half-width `l_p = Δr/2` clipped by the seeded circle; its face along a direction `n`
//!   is the support of the ellipse on those extents along `Fᵀn` (`Points::support`, with
//!   the point's rotation since session 35). Gaps to the plates and between grains, and
//!   the width `L`, use it. With the plain `l_p` the Cartesian seeding has a flat of width
//!   ≈ 2√(R h_g/2) at each pole (half the diameter at Δr/R = 0.08) that acts as a flat
//!   punch: the force was 1.8 × Johnson's at ε = 0.02.
//! * **Small-mass nodes.** Nodes lighter than `LIGHT_NODE` = 1e-4 of the mean nodal mass
//!   are dropped and the points' weights renormalised (partition of unity and `Σ ∇S = 0`
//!   kept, so momentum stays exact); the Newton matrix gets a diagonal shift of 1e-10 of
//!   its largest diagonal (the residual does not, so the converged state is unaffected).
//! * **Wall contact** (`contact.rs`). Rigid plates of infinite mass, frictionless by default
//!   (`SingleGrainParams::wall_friction` adds Coulomb friction), applied at
//!   the nodes behind the plate or less than half a cell in front of it, with the gap
//!   measured from the points; the wall normal is the contact normal. Signorini on the
//!   end-of-step gap without pushing existing overlaps apart, solved exactly inside Newton
//!   by a primal–dual active set (warm-started from the previous step).
//! * **Shape functions.** Quadratic B-spline by default; bilinear (the paper's) and uGIMP
//!   are options. Bilinear agrees at the paper's resolution for small strain but drifts
//!   with refinement and at large strain (cell crossing: F/Johnson at ε = 0.05 falls from
//!   0.94 at Δr/R = 0.029 to 0.89 at 0.01, and at 30 % its force is 28 % below the smooth
//!   bases, which agree with each other).
//! * **Locking.** B-bar on the 2D dilatation, averaged (volume-weighted, start-of-step) over
//!   the points of a grid cell — for B-splines the cell centred on a node, so the group
//!   shares one stencil — on by default; `SolverParams::bbar = false` gives the plain
//!   formulation. The internal force is the exact derivative of the B-bar kinematics and
//!   the tangent includes the B-bar geometric terms. At ν = 0.45 with 2×2 points per cell
//!   the small-strain locking is mild (bilinear: secant slope to ε = 0.02 is 8.7 % stiffer
//!   without B-bar at Δr/R = 0.08, 5.3 % at 0.04, 1.8 % at 0.029) but without it the force
//!   at 30 % strain is far higher.
//! * **Newmark.** β = 1/4, γ = 1/2 by default (Guilkey & Weiss); `Newmark::damped(γ)`
//!   for numerical damping. Point velocities use the FLIP-type Newmark update (no PIC
//!   blend). The single-grain driver starts from the quasi-static velocity field.
//! * **Tangent.** Material plus geometric stiffness in the current configuration. For the
//!   Hughes–Winget linear-elastic law the material part is `C` corrected for the Jaumann
//!   rate (symmetrised); with `C` alone Newton's convergence rate fell to 0.6 once contact
//!   stresses reached ~0.1 E. If the tangent is not positive definite (pre-stressed grain),
//!   the iteration is redone with the initial elastic matrix; an iterate that inverts a
//!   point is pulled back by halving. About 5 Newton iterations per step to 30 % strain.
//! * **Plate force.** `σ = F/L` uses the mean of the two plate forces; both are recorded.
//! * **Packings** (`packing`, `node_contact`): one nodal field per grain on windows of a
//!   common grid, contact between grains (on their surface layers at the contact nodes by
//!   default, or at the nodes) and with the walls (at the nodes) by contact dynamics on
//!   the condensed compliance (METHODS §4.4B); their decisions are listed in `packing`.
//! * **Time step.** Chosen from the plate travel per step (default 0.05 h_g), not from CFL.
//!   A step whose Newton solve fails is redone as two half steps (at most 3 halvings,
//!   counted in `RunStats::halvings`) before the error is returned.

pub mod analytic;
pub mod colour;
pub mod connect;
pub mod contact;
pub mod driver;
pub mod error;
pub mod grid;
pub mod material;
pub mod newmark;
pub mod node_contact;
pub mod overlap;
pub mod packing;
pub mod points;
pub mod shape;
pub mod solve;
pub mod sparse;

pub use driver::{
    Control, PointState, Progress, Row, RunStats, SingleGrain, SingleGrainParams,
    SingleGrainResult, force_at, run_single_grain, window_mean_over_johnson,
};
pub use error::MpmError;
pub use material::{Material, MaterialKind};
pub use newmark::Newmark;
pub use shape::ShapeKind;
pub use solve::{NewtonParams, Solver, SolverParams, StepStats};
