//! The discretise stage: every prepared disk becomes a soft grain. BPM: an aggregate of
//! primary particles built by the advancing front, then relaxed under its own attraction.

use super::prepare::Prepared;
use crate::bpm::{self, BpmLaw};
use crate::cd::{Bodies, LawTable, Scene};
use crate::config::{Bpm, Layout, Pipeline, defaults};
use crate::geom::Wall;
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

/// Version of the BPM discretisation, hashed into its nodes' names so that checkpoints made
/// by an earlier version are not reused: 2 relaxes each aggregate alone (`relax_each`; 1,
/// before session 17, relaxed all aggregates in one scene, whose one convergence test waited
/// for the slowest grain, and let touching grains press on each other).
pub const BPM_VERSION: u32 = 2;

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
    let laws = LawTable::new(law, BpmLaw::Coulomb { mu: 0.0 }, vec![]);
    let relaxed = relax_each(&bodies, &counts, &laws, &params, p.seed, ctx)?;
    // Same-grain pairs in contact after relaxation, for <a0>.
    let touching: Vec<f64> = relaxed
        .iter()
        .flat_map(|s| {
            s.contacts
                .iter()
                .filter(|c| c.p_n > 0.0)
                .filter_map(|c| match c.j {
                    crate::cd::Partner::Body(j) => {
                        Some(s.bodies.radius[c.i as usize] + s.bodies.radius[j as usize])
                    }
                    _ => None,
                })
        })
        .collect();
    let kinetic_energy = relaxed.iter().map(|s| s.bodies.kinetic_energy()).sum();
    let bodies = concat(relaxed.into_iter().map(|s| s.bodies));
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
        kinetic_energy,
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

/// Relaxes each aggregate alone, in its own scene (no walls, no gravity, no other grain),
/// under its own attraction for `BPM_RELAX_STEPS` steps of the common time step. Grain g's
/// particles are `counts[g]` consecutive bodies; its scene's NLGS order is seeded with
/// `seed + g` (grain 0 with `seed` itself, so a single grain relaxes as it did in one scene
/// with all grains). Alone, each aggregate stops its solves at its own convergence instead of
/// the slowest grain's, so the cost is linear in the grains, and the grains run in parallel;
/// the result does not depend on the number of threads.
fn relax_each(
    bodies: &Bodies,
    counts: &[usize],
    laws: &LawTable<BpmLaw>,
    params: &crate::cd::CdParams,
    seed: u64,
    ctx: &StageCtx,
) -> Result<Vec<Scene<BpmLaw>>, String> {
    use rayon::prelude::*;
    let mut starts = Vec::with_capacity(counts.len());
    let mut start = 0;
    for &n in counts {
        starts.push(start..start + n);
        start += n;
    }
    let relax = |g: usize| -> Result<Scene<BpmLaw>, String> {
        let grain = slice(bodies, starts[g].clone());
        let mut scene = Scene::new(
            grain,
            vec![],
            laws.clone(),
            params.clone(),
            seed.wrapping_add(g as u64),
        );
        for _ in 0..defaults::BPM_RELAX_STEPS {
            scene
                .step()
                .map_err(|e| format!("relaxing the aggregate of grain {g}: {e}"))?;
        }
        Ok(scene)
    };
    let bar = ctx.progress("discretise", counts.len() as u64);
    // Batches of a few grains per thread, so that the bar moves without a shared counter.
    let batch = 4 * rayon::current_num_threads();
    let mut relaxed = Vec::with_capacity(counts.len());
    for first in (0..counts.len()).step_by(batch) {
        let last = (first + batch).min(counts.len());
        let done: Vec<_> = (first..last).into_par_iter().map(relax).collect();
        for scene in done {
            relaxed.push(scene?);
        }
        bar.set(last as u64, "relaxing grains");
    }
    bar.finish();
    Ok(relaxed)
}

/// Bodies `range` of `b`, as a set of its own.
fn slice(b: &Bodies, range: std::ops::Range<usize>) -> Bodies {
    Bodies {
        pos: b.pos[range.clone()].to_vec(),
        angle: b.angle[range.clone()].to_vec(),
        vel: b.vel[range.clone()].to_vec(),
        omega: b.omega[range.clone()].to_vec(),
        radius: b.radius[range.clone()].to_vec(),
        inv_mass: b.inv_mass[range.clone()].to_vec(),
        inv_inertia: b.inv_inertia[range.clone()].to_vec(),
        group: b.group[range.clone()].to_vec(),
        force: b.force[range].to_vec(),
    }
}

/// The sets one after another, in order.
fn concat(sets: impl Iterator<Item = Bodies>) -> Bodies {
    let mut all = Bodies::default();
    for s in sets {
        all.pos.extend(s.pos);
        all.angle.extend(s.angle);
        all.vel.extend(s.vel);
        all.omega.extend(s.omega);
        all.radius.extend(s.radius);
        all.inv_mass.extend(s.inv_mass);
        all.inv_inertia.extend(s.inv_inertia);
        all.group.extend(s.group);
        all.force.extend(s.force);
    }
    all
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::V2;

    /// Two aggregates of 1 mm radius whose circles touch, as a deposit leaves them.
    fn two_grains() -> (Bodies, Vec<usize>) {
        let mut rng = Rng::stream(7, "test-grains");
        let mut b = Bodies::default();
        let mut counts = Vec::new();
        for (g, x) in [0.0, 2.0e-3].into_iter().enumerate() {
            let (pos, rad) = bpm::build_grain(1.0e-3, [1.0e-4, 1.6e-4], &mut rng);
            counts.push(pos.len());
            for (p, r) in pos.iter().zip(&rad) {
                b.push(V2::new(x, 0.0) + p, *r, 990.0, g as u32);
            }
        }
        (b, counts)
    }

    fn relax(b: &Bodies, counts: &[usize], threads: usize) -> Vec<Scene<BpmLaw>> {
        let law = BpmLaw::Cohesive {
            f0: 100.0,
            gamma: 7.0,
            cutoff: 1.0,
            rolling: 0.0,
        };
        let laws = LawTable::new(law, BpmLaw::Coulomb { mu: 0.0 }, vec![]);
        let params = super::super::cd_params(
            &crate::config::Solver::default(),
            defaults::BPM_STEP * t0(b, 100.0),
            0.0,
            1.0e-4,
        );
        let ctx = StageCtx::scratch(std::env::temp_dir());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| relax_each(b, counts, &laws, &params, 7, &ctx))
            .expect("relaxed")
    }

    #[test]
    fn each_aggregate_relaxes_alone_whatever_the_threads() {
        let (b, counts) = two_grains();
        let both = relax(&b, &counts, 2);
        // Grain 0 relaxed beside grain 1 (their circles touching) is grain 0 relaxed alone.
        let first = slice(&b, 0..counts[0]);
        let alone = relax(&first, &counts[..1], 1);
        assert_eq!(both[0].bodies, alone[0].bodies);
        // The particles did move: the relaxation is not a no-op.
        assert_ne!(both[0].bodies.pos, first.pos);
        // One thread or two, the same bits.
        let serial = relax(&b, &counts, 1);
        for (s, p) in serial.iter().zip(&both) {
            assert_eq!(s.bodies, p.bodies);
        }
        // Concatenated in grain order, every particle keeps its grain.
        let all = concat(both.into_iter().map(|s| s.bodies));
        assert_eq!(all.group, b.group);
    }
}
