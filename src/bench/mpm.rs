//! The MPM family: one grain between two plates, its force curve against Johnson's 2D
//! contact solution (METHODS §5) and against the finest run of the same knob; and the
//! stability map (largest accurate plate travel per step against resolution and material:
//! Newmark's trapezoidal rule is unconditionally stable, so "stable" means Newton converged
//! and "accurate" that the force curve stays within `accuracy` (RMS) of the smallest step's).

use super::spec::{MpmFamily, MpmSetting, MpmStability, Shape};
use crate::mpm::analytic::johnson_force;
use crate::mpm::{Control, Row, ShapeKind, SingleGrainParams, force_at, run_single_grain};

/// What one run measured.
pub struct Measured {
    /// F/F_Johnson - 1 at ε = 0.02 and 0.05.
    pub johnson: [f64; 2],
    /// (strain, mean plate force in N/m) at every recorded step.
    pub curve: Vec<[f64; 2]>,
}

pub fn params(f: &MpmFamily, s: &MpmSetting) -> SingleGrainParams {
    let mut p = SingleGrainParams::paper();
    p.radius = f.radius;
    p.material.young = f.young;
    p.material.poisson = f.poisson;
    p.material.density = f.density;
    p.wall_velocity = f.wall_velocity;
    p.final_strain = f.final_strain;
    p.resolution = s.resolution;
    p.travel_per_step = s.travel_per_step;
    // the defaults keep tol_increment = 10 tol_residual
    p.solver.newton.tol_residual = s.newton_tolerance;
    p.solver.newton.tol_increment = 10.0 * s.newton_tolerance;
    p.solver.shape = match s.shape {
        Shape::Bilinear => ShapeKind::Bilinear,
        Shape::Bspline => ShapeKind::BSpline2,
        Shape::Gimp => ShapeKind::Gimp,
    };
    p
}

pub fn measure(f: &MpmFamily, s: &MpmSetting) -> Result<Measured, String> {
    let p = params(f, s);
    let out = run_single_grain(p, |_| Control::Continue).map_err(|e| e.to_string())?;
    let rel = |eps: f64| {
        let j = johnson_force(f.young, f.poisson, f.radius, eps).unwrap_or(f64::NAN);
        force_at(&out.rows, eps) / j - 1.0
    };
    let curve = curve(&out.rows);
    Ok(Measured {
        johnson: [rel(0.02), rel(0.05)],
        curve,
    })
}

/// (strain, mean plate force) of every recorded step.
fn curve(rows: &[Row]) -> Vec<[f64; 2]> {
    rows.iter()
        .map(|r| [r.strain, 0.5 * (r.force_top + r.force_bottom)])
        .collect()
}

fn interpolate(curve: &[[f64; 2]], strain: f64) -> f64 {
    let mut prev = [0.0, 0.0];
    for &next in curve {
        if prev[0] <= strain && strain <= next[0] {
            let t = (strain - prev[0]) / (next[0] - prev[0]);
            return prev[1] + t * (next[1] - prev[1]);
        }
        prev = next;
    }
    f64::NAN
}

/// RMS difference between a run's forces and the reference curve interpolated at the run's
/// own recorded strains, over the reference's RMS there: it compares the integration, not
/// how densely a coarse step samples the curve. Strains past the reference are skipped.
pub fn rms_difference(curve: &[[f64; 2]], reference: &[[f64; 2]]) -> f64 {
    let (mut diff, mut norm) = (0.0, 0.0);
    for &[e, f] in curve {
        let r = interpolate(reference, e);
        if r.is_finite() {
            diff += (f - r).powi(2);
            norm += r * r;
        }
    }
    (diff / norm).sqrt()
}

/// One run of the stability map.
pub struct StabilityRun {
    pub resolution: f64,
    pub young: f64,
    pub poisson: f64,
    pub travel_per_step: f64,
    /// Time step (s) and its ratio to the explicit limit h_g/c_p.
    pub dt: f64,
    pub dt_over_cfl: f64,
    /// The error that stopped the run, if one did.
    pub failure: Option<String>,
    pub halvings: u64,
    pub newton_per_step: f64,
    /// `rms_difference` to the smallest travel of the same material and resolution.
    pub error: f64,
    pub wall_s: f64,
    /// The largest travel of its material and resolution that completed within accuracy.
    pub largest_accurate: bool,
}

/// Runs the whole map (in this process: the map reports steps, not memory).
pub fn stability(m: &MpmStability, mut progress: impl FnMut(&StabilityRun)) -> Vec<StabilityRun> {
    let mut travels = m.travel_per_step.clone();
    travels.sort_by(f64::total_cmp);
    let mut all = Vec::new();
    for &resolution in &m.resolution {
        for &young in &m.young {
            for &poisson in &m.poisson {
                let mut group: Vec<StabilityRun> = Vec::new();
                let mut reference: Option<Vec<[f64; 2]>> = None;
                for &travel in &travels {
                    let mut p = SingleGrainParams::paper();
                    p.radius = m.radius;
                    p.material.young = young;
                    p.material.poisson = poisson;
                    p.material.density = m.density;
                    p.wall_velocity = m.wall_velocity;
                    p.final_strain = m.final_strain;
                    p.resolution = resolution;
                    p.travel_per_step = travel;
                    let t = std::time::Instant::now();
                    let out = run_single_grain(p, |_| Control::Continue);
                    let wall_s = t.elapsed().as_secs_f64();
                    let mut run = StabilityRun {
                        resolution,
                        young,
                        poisson,
                        travel_per_step: travel,
                        dt: f64::NAN,
                        dt_over_cfl: f64::NAN,
                        failure: None,
                        halvings: 0,
                        newton_per_step: f64::NAN,
                        error: f64::NAN,
                        wall_s,
                        largest_accurate: false,
                    };
                    match out {
                        Ok(out) => {
                            let s = &out.stats;
                            run.dt = s.dt;
                            run.dt_over_cfl = s.dt / s.dt_cfl;
                            run.halvings = s.halvings;
                            run.newton_per_step =
                                s.newton_iterations as f64 / s.steps.max(1) as f64;
                            let c = curve(&out.rows);
                            run.error = rms_difference(&c, reference.get_or_insert(c.clone()));
                        }
                        Err(e) => run.failure = Some(e.to_string()),
                    }
                    progress(&run);
                    group.push(run);
                }
                let ok = |r: &StabilityRun| r.failure.is_none() && r.error <= m.accuracy;
                if let Some(best) = group.iter_mut().rev().find(|r| ok(r)) {
                    best.largest_accurate = true;
                }
                all.extend(group);
            }
        }
    }
    all
}
