//! softgrain: soft granular materials by the bonded particle model and the implicit
//! material point method (Nezamabadi, Nguyen, Delenne & Radjai, Granular Matter 2017).

pub mod analysis;
pub mod bench;
pub mod bpm;
pub mod cd;
pub mod compaction;
pub mod config;
pub mod geom;
pub mod io;
pub mod mpm;
pub mod packing;
pub mod pipeline;
pub mod rng;
pub mod shortcuts;
pub mod stages;
pub mod timing;
