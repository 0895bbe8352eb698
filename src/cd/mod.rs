//! Nonsmooth contact dynamics (Moreau-Jean) for rigid disks and straight walls in 2D.
//!
//! One time step (METHODS.md §1.1, θ-scheme):
//! 1. smooth forces F = gravity + the laws' explicit forces (BPM attraction) at t⁻;
//! 2. free velocity V_free = V⁻ + h M⁻¹ F;
//! 3. geometry at q_TT = q⁻ + (1-θ) h V⁻ (normals and gaps frozen for the step);
//! 4. impulses P by nonlinear Gauss-Seidel on velocity-Signorini + Coulomb with gap
//!    anticipation (zero restitution), warm-started from the previous step;
//! 5. q⁺ = q⁻ + h [(1-θ) V⁻ + θ V⁺].
//!
//! Geometry is explicit and velocities implicit, so the scheme is stable for any step; the
//! step is chosen for accuracy (a small displacement per step keeps frozen normals right).
//! The engine takes plain structs and reports progress through callbacks; it never reads
//! files or prints.

pub(crate) mod anderson;
mod bodies;
mod contact;
mod detect;
mod guard;
mod law;
mod nlgs;
mod scene;
mod separate;
mod sleep;

pub use bodies::Bodies;
pub use contact::{Contact, Partner};
pub use detect::Neighbours;
pub use law::{Coulomb, InteractionLaw, LawTable};
pub use nlgs::{COLOURED_MIN, NlgsParams, NlgsReport};
pub use scene::{CdError, CdParams, Scene, StepReport};
pub use separate::{Separation, separate};
pub use sleep::SleepParams;

/// Loops over fewer items than this run on the calling thread. Handing a loop to rayon's
/// pool wakes its threads and waits for them (the scheduler's share was 40% of a 300-disk
/// deposit's profile, more than the NLGS's), while a loop this short takes microseconds.
const PAR_MIN: usize = 4096;

/// Root of `x` in a union-find forest over bodies (path halving): the contact graph's
/// islands (`nlgs.rs`) and sleeping groups (`sleep.rs`).
fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        parent[x as usize] = parent[parent[x as usize] as usize];
        x = parent[x as usize];
    }
    x
}
