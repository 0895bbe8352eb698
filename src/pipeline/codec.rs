//! The one place that turns states into bytes and back (bincode 2.0.1 with serde, standard
//! configuration). To change the codec (bincode is unmaintained; postcard is the fallback),
//! change these two functions and bump `FORMAT_VERSION`.

use serde::Serialize;
use serde::de::DeserializeOwned;

/// Version of the checkpoint layout and of every stage's state types. Bumping it changes
/// every node's hash, so old checkpoints are recomputed, never misread. Not needed when a
/// `StageState` variant is appended (older payloads decode unchanged): version 4 holds
/// `MpmPacking` and `Analysed` added last; version 5 adds the rolling impulse to contacts;
/// version 7 the NLGS's Anderson depth to the solver settings a scene carries; version 8
/// the inertial number to a packing's rows and figures; version 9 the islands switch to the
/// solver settings a scene carries; version 10 the sleeping settings and state. Version 11
/// changes no layout: the NLGS's local solve multiplies by the inverse diagonal Delassus
/// terms instead of dividing, which moves every result at round-off, so checkpoints of
/// earlier builds are recomputed rather than mixed with this build's. Version 12, likewise:
/// Eq. (1)'s power of a whole γ multiplies instead of calling `powf` (`bpm/law.rs`).
/// Version 13: the deposit's figures and snapshot record its one separation
/// (`prepare.separate_at`). Version 14: a packing's rows and figures record the area under
/// two grains (`overlap_area`). Version 15: they record how close the contact solves came
/// to their tolerance (`residual`, `unconverged`, `SolveTally`) and, MPM, the grains' stress
/// over the box and the grain pairs' moment (`sigma_box`, `sigma_lever`); an MPM packing's
/// contact records keep where their forces act (`applied`). Version 16: a packing's figures
/// say where its worst overlap was (`overlap_site`); version 17 the worst once loaded
/// (`overlap_max_loaded`). Version 18: a packing's rows and figures record the share of
/// particles or points whose centre lies inside another grain (`points_inside`). Version 19:
/// an MPM packing splits a step before trying it when its inertia cannot hold the grains'
/// rotations (`mpm::packing::rotation_ratio`), which changes its results, and its figures
/// count the split and the halved sub-steps. Version 20: they count the grains'
/// factorisations and those whose consistent tangent was indefinite. Version 21: a
/// packing's rows and figures record the deepest overlap of two MPM points
/// (`point_overlap`). Version 22: an MPM packing's figures say where its deepest point pair
/// was (`point_overlap_site`). Version 23: the MPM NLGS settings a packing carries gain
/// `pair_sweeps` (a frictionless surface-contact packing sweeps each grain pair on its own
/// block first, which changes its results; frictional ones recompute to the same bits).
/// Version 24 changes no layout: the MPM stiffness is summed by B-bar group and a packing's
/// contact compliance comes from the forward solve and a Gram product
/// (`mpm::sparse::SymSystem::inverse_gram`), which moves MPM results at round-off.
pub const FORMAT_VERSION: u32 = 24;

pub fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, String> {
    bincode::serde::encode_to_vec(value, bincode::config::standard()).map_err(|e| e.to_string())
}

/// Decodes `bytes`, which must hold exactly one value. A length limit guards against a
/// corrupt length prefix asking for a huge allocation (256 MiB: over ten times the largest
/// state a run writes, a 70,000-particle BPM packing with its contacts).
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    let config = bincode::config::standard().with_limit::<{ 1 << 28 }>();
    let (value, used) =
        bincode::serde::decode_from_slice(bytes, config).map_err(|e| e.to_string())?;
    if used != bytes.len() {
        return Err(format!("{} trailing bytes", bytes.len() - used));
    }
    Ok(value)
}
