//! The discretise stage: every prepared disk becomes a soft grain. BPM: an aggregate of
//! primary particles built by the advancing front, then relaxed under its own attraction.

use super::prepare::Prepared;
use crate::bpm::{self, BpmLaw};
use crate::cd::{Bodies, LawTable};
use crate::config::{Bpm, Layout, Pipeline, defaults};
use crate::geom::{V2, Wall};
use crate::pipeline::StageCtx;
use crate::rng::Rng;
use serde::{Deserialize, Serialize};

/// BPM grains: all primary particles (group = grain id) and what the compaction needs.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BpmGrains {
    pub layout: Layout,
    pub bodies: Bodies,
    /// Radius of each grain as prepared (m).
    pub grain_radius: Vec<f64>,
    /// The prepare stage's walls and box width (packings).
    pub walls: Vec<Wall>,
    pub box_width: f64,
    pub law: BpmLaw,
    pub figures: BpmFigures,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BpmFigures {
    pub grains: usize,
    pub particles: usize,
    pub particles_per_grain_min: usize,
    pub particles_per_grain_max: usize,
    /// Solid fraction inside the grains' circles, Σ A_p / Σ π R².
    pub phi_in: f64,
    /// Mean a0 = r_i + r_j over touching same-grain pairs after relaxation (m).
    pub mean_a0: f64,
    /// t0 = sqrt(m a0 / F0) of the smallest particle (s).
    pub t0: f64,
    /// Kinetic energy at the end of the relaxation (J/m).
    pub kinetic_energy: f64,
}

/// Version of the BPM discretisation (`plan::version`), hashed into its nodes' names so that
/// checkpoints made by an earlier version are not reused. 1 (before session 17) relaxed all aggregates in one
/// scene, whose one convergence test waited for the slowest grain; 2 (commit c58d3ca only)
/// relaxed each alone, which let touching aggregates bulge into each other; 3 relaxes each
/// against its neighbours held fixed (`bpm::relax`); 4 also holds them inside the deposit's
/// box walls.
pub const BPM_VERSION: u32 = 4;

/// Time scale of the attraction: t0 = sqrt(m a0 / F0) for the smallest particle.
pub fn t0(b: &Bodies, f0: f64) -> f64 {
    let (k, r) =
        b.radius.iter().enumerate().fold(
            (0, f64::INFINITY),
            |acc, (k, &r)| if r < acc.1 { (k, r) } else { acc },
        );
    (b.mass(k) * 2.0 * r / f0).sqrt()
}

pub fn run_bpm(
    p: &Pipeline,
    bpm: &Bpm,
    range: [f64; 2],
    prep: &Prepared,
    ctx: &StageCtx,
) -> Result<(BpmGrains, String), String> {
    let mut rng = Rng::stream(p.seed, "discretise-bpm");
    let mut bodies = Bodies::default();
    let mut counts = Vec::new();
    let mut grain_area = 0.0;
    for g in 0..prep.bodies.len() {
        let (centre, radius) = (prep.bodies.pos[g], prep.bodies.radius[g]);
        if radius < 2.0 * range[1] {
            return Err(format!(
                "grain {g} of radius {radius} m is too small for particles up to {} m: need radius >= 2 d_max",
                range[1]
            ));
        }
        let (pos, rad) = bpm::build_grain(radius, range, &mut rng);
        counts.push(pos.len());
        grain_area += std::f64::consts::PI * radius * radius;
        for (x, r) in pos.iter().zip(&rad) {
            bodies.push(centre + x, *r, bpm.density, g as u32);
        }
    }
    let law = BpmLaw::Cohesive {
        f0: bpm.f0,
        gamma: bpm.gamma,
        cutoff: bpm.cutoff,
        rolling: bpm.rolling_resistance,
    };
    let t0 = t0(&bodies, bpm.f0);
    let d_min = range[0];
    let params = super::cd_params(&p.solver, defaults::BPM_STEP * t0, 0.0, d_min);
    // the deposit's walls hold the aggregates in the box, frictionless as in the compaction
    let wall_laws = vec![BpmLaw::Coulomb { mu: 0.0 }; prep.walls.len()];
    let laws = LawTable::new(law, BpmLaw::Coulomb { mu: 0.0 }, wall_laws);
    let circles: Vec<(V2, f64)> = (prep.bodies.pos.iter().copied())
        .zip(prep.bodies.radius.iter().copied())
        .collect();
    let bar = ctx.progress("discretise", counts.len() as u64);
    let grains = bpm::relax::Grains {
        bodies: &bodies,
        counts: &counts,
        circles: &circles,
        walls: &prep.walls,
    };
    let relaxed = bpm::relax::relax_grains(
        grains,
        &laws,
        &params,
        defaults::BPM_RELAX_STEPS,
        p.seed,
        &|done| bar.set(done, "relaxing grains"),
    )?;
    bar.finish();
    let (bodies, touching) = (relaxed.bodies, relaxed.touching_a0);
    let solid: f64 = bodies
        .radius
        .iter()
        .map(|r| std::f64::consts::PI * r * r)
        .sum();
    let figures = BpmFigures {
        grains: counts.len(),
        particles: bodies.len(),
        particles_per_grain_min: counts.iter().cloned().min().unwrap_or(0),
        particles_per_grain_max: counts.iter().cloned().max().unwrap_or(0),
        phi_in: solid / grain_area,
        mean_a0: touching.iter().sum::<f64>() / touching.len().max(1) as f64,
        t0,
        kinetic_energy: relaxed.kinetic_energy,
    };
    super::frames::FrameLog::particles()
        .write_disks(&ctx.dir, 0.0, &bodies)
        .map_err(|e| format!("writing output in {}: {e}", ctx.dir.display()))?;
    let summary = format!(
        "{} grains, {} particles ({}-{} per grain), phi_in {:.3}, <a0> {:.3e} m",
        figures.grains,
        figures.particles,
        figures.particles_per_grain_min,
        figures.particles_per_grain_max,
        figures.phi_in,
        figures.mean_a0
    );
    Ok((
        BpmGrains {
            layout: prep.layout,
            bodies,
            grain_radius: prep.bodies.radius.clone(),
            walls: prep.walls.clone(),
            box_width: prep.box_width,
            law,
            figures,
        },
        summary,
    ))
}
