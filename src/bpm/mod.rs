//! The bonded particle model (paper section 2.1): each soft grain is an aggregate of rigid
//! primary disks, frictionless and cohesive inside a grain (Eq. 1 attraction plus unilateral
//! contact), frictional and non-cohesive between grains, all solved by the contact-dynamics
//! engine of `crate::cd` with the laws of `law`.
//!
//! Decisions the paper leaves open (METHODS.md §7), as implemented:
//! - primary particle diameters: each particle's area uniform in [A_min, A_max];
//! - grains built by an advancing front (`build`), then relaxed under attraction in the
//!   discretise stage, grain by grain against fixed neighbours (`relax`);
//! - attraction explicit (option E), cut-off not shifted, h = 0.1 t0 by default;
//! - grain area: morphological closing with the largest particle radius (`measure`).

pub mod build;
pub mod law;
pub mod measure;
pub mod relax;

pub use build::build_grain;
pub use law::BpmLaw;
