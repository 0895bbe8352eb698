//! The compaction family: a reduced packing (by default 16 grains of 1.4-2.4 mm made of
//! coarse particles, 0.2-0.34 mm, about 40 per grain) compacted from Φ0 to `final_strain`,
//! through the prepare, discretise and compact stage functions in a scratch folder (no
//! checkpoints). Its σ(ε) and Φ(ε) are compared with the knob's finest value's.

use super::spec::{CompactionFamily, CompactionSetting};
use crate::config::Pipeline;
use crate::pipeline::StageCtx;
use crate::stages::{bpm_packing, discretise, prepare};
use std::path::Path;

/// σ(ε) (Pa) and Φ(ε) as recorded.
pub struct Measured {
    pub sigma: Vec<[f64; 2]>,
    pub phi: Vec<[f64; 2]>,
}

pub fn measure(
    f: &CompactionFamily,
    s: &CompactionSetting,
    scratch: &Path,
) -> Result<Measured, String> {
    let [d0, d1] = f.particle_diameter;
    let yaml = format!(
        "name: bench-compaction\nseed: 7\nprepare:\n  grains: {}\n  diameter: [1.4e-3, 2.4e-3]\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [{d0:e}, {d1:e}]\n    f0: 100.0\ncompact:\n  wall_velocity: {:e}\n  final_strain: {:e}\n  initial_phi: {:e}\nsolver:\n  tolerance: {:e}\noutput:\n  every: 50\n  snapshot_every: 0\n  vtk: false\n",
        f.grains, s.wall_velocity, f.final_strain, f.initial_phi, s.tolerance
    );
    let mut p: Pipeline = serde_saphyr::from_str(&yaml).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
    let ctx = StageCtx::scratch(scratch.to_path_buf());
    let (prep, _) = prepare::run(&p, &ctx)?;
    let bpm = p
        .discretise
        .as_ref()
        .and_then(|d| d.bpm.clone())
        .expect("written above");
    let (grains, _) = discretise::run_bpm(&p, &bpm, [d0, d1], &prep, &ctx)?;
    if let Some(c) = p.compact.as_mut() {
        c.time_step = Some(s.time_step * grains.figures.t0);
    }
    let (c, _) = bpm_packing::run(&p, f.friction, &grains, &ctx)?;
    Ok(Measured {
        sigma: c.rows.iter().map(|r| [r.strain, r.sigma]).collect(),
        phi: c.rows.iter().map(|r| [r.strain, r.phi]).collect(),
    })
}
