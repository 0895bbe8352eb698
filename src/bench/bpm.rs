//! The BPM family: one small grain between two plates (by default R = 1.5 mm, particles
//! 0.16-0.26 mm, about 150, F0 = 100 N/m) to `final_strain`, through the prepare,
//! discretise and compact stage functions in a scratch folder (no checkpoints); its plastic
//! plateau σ<a0>/F0 (mean over ε ≥ 0.1) is compared with the knob's finest value. The BPM
//! stability map runs the same grain over particle sizes, F0, plate speeds and time steps.

use super::skips::windowed_difference;
use super::spec::{BpmFamily, BpmSetting, BpmStability};
use crate::config::Pipeline;
use crate::pipeline::StageCtx;
use crate::stages::compact::{self, Compacted};
use crate::stages::{discretise, prepare};
use std::path::Path;

/// What one compression is made of.
struct Grain {
    radius: f64,
    particle_diameter: [f64; 2],
    f0: f64,
    wall_velocity: f64,
    final_strain: f64,
    tolerance: f64,
    /// Time step in units of t0 = sqrt(m a0/F0) of the smallest particle.
    time_step: f64,
    /// Rows to record over the run (about; 0 keeps a row every 100 steps).
    rows: u64,
}

/// Compresses the grain; `beyond_step_limit` lifts the compact stage's own time-step
/// check (≤ 0.5 t0), so that the map can look beyond it.
fn compress(g: &Grain, scratch: &Path, beyond_step_limit: bool) -> Result<Compacted, String> {
    let [d0, d1] = g.particle_diameter;
    let yaml = format!(
        "name: bench-bpm\nseed: 1\nprepare:\n  layout: single\n  radius: {:e}\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [{d0:e}, {d1:e}]\n    f0: {:e}\ncompact:\n  wall_velocity: {:e}\n  final_strain: {:e}\nsolver:\n  tolerance: {:e}\noutput:\n  every: 100\n  snapshot_every: 0\n  vtk: false\n",
        g.radius, g.f0, g.wall_velocity, g.final_strain, g.tolerance
    );
    let mut p: Pipeline = serde_saphyr::from_str(&yaml).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
    let mut ctx = StageCtx::scratch(scratch.to_path_buf());
    ctx.beyond_step_limit = beyond_step_limit;
    let (prep, _) = prepare::run(&p, &ctx)?;
    let bpm = p
        .discretise
        .as_ref()
        .and_then(|d| d.bpm.clone())
        .expect("written above");
    let (grains, _) = discretise::run_bpm(&p, &bpm, [d0, d1], &prep, &ctx)?;
    let dt = g.time_step * grains.figures.t0;
    if let Some(c) = p.compact.as_mut() {
        c.time_step = Some(dt);
    }
    if g.rows > 0 {
        // the plates close by ε (2R) in ε 2R / (v dt) steps
        let steps = g.final_strain * 2.0 * g.radius / (g.wall_velocity * dt);
        p.output.every = ((steps / g.rows as f64) as u64).max(1);
    }
    let (c, _) = compact::run_bpm(&p, 0.0, &grains, &ctx)?;
    Ok(c)
}

/// The plateau σ<a0>/F0 of one run.
pub fn measure(f: &BpmFamily, s: &BpmSetting, scratch: &Path) -> Result<f64, String> {
    let g = Grain {
        radius: f.radius,
        particle_diameter: f.particle_diameter,
        f0: 100.0,
        wall_velocity: f.wall_velocity,
        final_strain: f.final_strain,
        tolerance: s.tolerance,
        time_step: s.time_step,
        rows: 0,
    };
    compress(&g, scratch, false).map(|c| c.figures.plateau)
}

/// One run of the BPM stability map.
pub struct StabilityRun {
    pub particle_diameter: [f64; 2],
    pub f0: f64,
    pub wall_velocity: f64,
    /// Time step in units of t0, and in seconds.
    pub time_step: f64,
    pub dt: f64,
    /// The error that stopped the run (the stage's guards), if one did.
    pub failure: Option<String>,
    /// Most particles outside their grain at once, and the largest change of the grain's area.
    pub escaped: usize,
    pub area_change: f64,
    /// Plate force against the smallest step's (means over five strain windows).
    pub error: f64,
    pub wall_s: f64,
    /// Completed with no more particles lost than at the smallest step, the area change
    /// within 5% of that step's, and the force within `accuracy` of its.
    pub stable: bool,
    /// The largest stable step of its particle size, F0 and speed.
    pub largest_stable: bool,
}

/// Runs the whole map in this process (the map reports steps, not memory).
pub fn stability(
    m: &BpmStability,
    scratch: &Path,
    mut progress: impl FnMut(&StabilityRun),
) -> Vec<StabilityRun> {
    let mut steps = m.time_step.clone();
    steps.sort_by(f64::total_cmp);
    let mut all = Vec::new();
    for &particle_diameter in &m.particle_diameter {
        for &f0 in &m.f0 {
            for &wall_velocity in &m.wall_velocity {
                let mut group: Vec<StabilityRun> = Vec::new();
                let mut reference: Option<(Vec<[f64; 2]>, f64, usize)> = None;
                for &time_step in &steps {
                    let g = Grain {
                        radius: m.radius,
                        particle_diameter,
                        f0,
                        wall_velocity,
                        final_strain: m.final_strain,
                        tolerance: crate::config::defaults::NLGS_TOLERANCE,
                        time_step,
                        // the same rows whatever the step, so that every strain window
                        // of the largest steps has some
                        rows: 100,
                    };
                    let t = std::time::Instant::now();
                    let out = compress(&g, scratch, true);
                    let _ = std::fs::remove_dir_all(scratch);
                    let mut run = StabilityRun {
                        particle_diameter,
                        f0,
                        wall_velocity,
                        time_step,
                        dt: f64::NAN,
                        failure: None,
                        escaped: 0,
                        area_change: f64::NAN,
                        error: f64::NAN,
                        wall_s: t.elapsed().as_secs_f64(),
                        stable: false,
                        largest_stable: false,
                    };
                    match out {
                        Ok(c) => {
                            let f = &c.figures;
                            run.dt = f.time_step;
                            run.escaped = f.escaped_max;
                            run.area_change = f.area_change;
                            let curve: Vec<[f64; 2]> =
                                c.rows.iter().map(|r| [r.strain, r.force]).collect();
                            let (ref_curve, ref_area, ref_escaped) = reference.get_or_insert((
                                curve.clone(),
                                f.area_change,
                                f.escaped_max,
                            ));
                            run.error = windowed_difference(&curve, ref_curve, 5);
                            // judged against the smallest step: a fast hit on a weak grain
                            // breaks it at any step, and that is physics, not the scheme
                            run.stable = run.escaped <= *ref_escaped
                                && (run.area_change - *ref_area).abs() < 0.05
                                && run.error < m.accuracy;
                        }
                        Err(e) => run.failure = Some(e),
                    }
                    progress(&run);
                    group.push(run);
                }
                // the largest step below which every step was stable
                let last = group.iter().take_while(|r| r.stable).count();
                if last > 0 {
                    group[last - 1].largest_stable = true;
                }
                all.extend(group);
            }
        }
    }
    all
}
