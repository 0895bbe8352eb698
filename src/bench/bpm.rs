//! The BPM family: one small grain between two plates (by default R = 1.5 mm, particles
//! 0.16-0.26 mm, about 150, F0 = 100 N/m) to `final_strain`, through the prepare,
//! discretise and compact stage functions in a scratch folder (no checkpoints); its plastic
//! plateau σ<a0>/F0 (mean over ε ≥ 0.1) is compared with the knob's finest value.

use super::spec::{BpmFamily, BpmSetting};
use crate::config::Pipeline;
use crate::pipeline::StageCtx;
use crate::stages::{compact, discretise, prepare};
use std::path::Path;

/// The plateau σ<a0>/F0 of one run.
pub fn measure(f: &BpmFamily, s: &BpmSetting, scratch: &Path) -> Result<f64, String> {
    let [d0, d1] = f.particle_diameter;
    let yaml = format!(
        "name: bench-bpm\nseed: 1\nprepare:\n  layout: single\n  radius: {:e}\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [{d0:e}, {d1:e}]\n    f0: 100.0\ncompact:\n  wall_velocity: {:e}\n  final_strain: {:e}\nsolver:\n  tolerance: {:e}\noutput:\n  every: 100\n  snapshot_every: 0\n  vtk: false\n",
        f.radius, f.wall_velocity, f.final_strain, s.tolerance
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
    let (c, _) = compact::run_bpm(&p, 0.0, &grains, &ctx)?;
    Ok(c.figures.plateau)
}
