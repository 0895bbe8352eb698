//! The relaxation of freshly built aggregates under their own attraction (discretise stage),
//! grain by grain.
//!
//! One scene with every aggregate would solve all of them as one NLGS problem, whose
//! convergence test waits for the slowest grain at every step: its cost grows faster than
//! the number of grains. Here each grain relaxes in a scene of its own, where the particles of
//! the grains whose circles come near it are fixed obstacles (1/m = 0, the inter-grain law),
//! so that no aggregate can move into a neighbour. Grains are coloured so that no two
//! neighbours share a colour; the colours relax one after another, the grains of a colour in
//! parallel, each against its neighbours as they stand (relaxed if their colour came first).
//! A grain relaxed later never overlaps one relaxed earlier, whatever the thread count, and
//! the result does not depend on it. The walls of the deposit's box bound every grain's scene:
//! boundary particles pushed outward by the relaxation would otherwise start the compaction
//! past the floor or a side wall (by up to 0.36 particle diameters on the paper's 300 grains).

use super::BpmLaw;
use crate::cd::{Bodies, CdParams, LawTable, Neighbours, Partner, Scene};
use crate::geom::{V2, Wall};
use rayon::prelude::*;

/// What the relaxation returns: every particle relaxed, in the input's order, and two
/// figures of the relaxed aggregates.
pub struct Relaxed {
    pub bodies: Bodies,
    /// a0 = r_i + r_j of every same-grain pair in contact (p_n > 0) at the last step.
    pub touching_a0: Vec<f64>,
    /// Kinetic energy of the particles at the end (J/m).
    pub kinetic_energy: f64,
}

/// Freshly built aggregates: grain g's particles are `counts[g]` consecutive `bodies`, built
/// inside the circle `circles[g]` (centre, radius), among fixed `walls`.
pub struct Grains<'a> {
    pub bodies: &'a Bodies,
    pub counts: &'a [usize],
    pub circles: &'a [(V2, f64)],
    pub walls: &'a [Wall],
}

/// Relaxes each grain for `steps` steps (`laws` has one wall law per wall). Grain g's scene
/// shuffles its contacts with the stream of `seed + g`, so a single grain (no neighbours)
/// relaxes exactly as in a scene of its own. `progress` is told how many grains are done.
pub fn relax_grains(
    grains: Grains,
    laws: &LawTable<BpmLaw>,
    params: &CdParams,
    steps: u64,
    seed: u64,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Relaxed, String> {
    let Grains {
        bodies,
        counts,
        circles,
        walls,
    } = grains;
    let mut ranges = Vec::with_capacity(counts.len());
    let mut start = 0;
    for &n in counts {
        ranges.push(start..start + n);
        start += n;
    }
    // Obstacles are taken within two particle diameters of a grain's own particles. Built
    // aggregates lie inside their circles; the relaxation moved boundary particles out by at
    // most 0.063 mm (7.5% of R) on the paper's 300 grains, against a margin of 0.26 mm there.
    let margin = 4.0 * bodies.max_radius();
    let near = neighbours(circles, margin);
    let colour = colours(&near);
    let mut state = bodies.clone();
    let mut touching_a0 = vec![Vec::new(); counts.len()];
    let mut kinetic = vec![0.0; counts.len()];
    let mut done = 0;
    for c in 0..colour.iter().max().map_or(0, |m| m + 1) {
        let grains: Vec<usize> = (0..counts.len()).filter(|&g| colour[g] == c).collect();
        let relaxed: Vec<Result<Scene<BpmLaw>, String>> = grains
            .par_iter()
            .map(|&g| {
                let obstacles = near[g].iter().map(|&j| ranges[j].clone());
                let mut scene = Scene::new(
                    with_obstacles(&state, ranges[g].clone(), obstacles, circles[g].0, margin),
                    walls.to_vec(),
                    laws.clone(),
                    params.clone(),
                    seed.wrapping_add(g as u64),
                );
                for _ in 0..steps {
                    scene
                        .step()
                        .map_err(|e| format!("relaxing the aggregate of grain {g}: {e}"))?;
                }
                Ok(scene)
            })
            .collect();
        for (&g, scene) in grains.iter().zip(relaxed) {
            let scene = scene?;
            let own = ranges[g].len();
            let b = &scene.bodies;
            for (k, i) in ranges[g].clone().enumerate() {
                state.pos[i] = b.pos[k];
                state.angle[i] = b.angle[k];
                state.vel[i] = b.vel[k];
                state.omega[i] = b.omega[k];
            }
            touching_a0[g] = (scene.contacts.iter())
                .filter(|c| c.p_n > 0.0)
                .filter_map(|c| match c.j {
                    Partner::Body(j) if (j as usize) < own => {
                        Some(b.radius[c.i as usize] + b.radius[j as usize])
                    }
                    _ => None,
                })
                .collect();
            kinetic[g] = b.kinetic_energy();
        }
        done += grains.len();
        progress(done as u64);
    }
    Ok(Relaxed {
        bodies: state,
        touching_a0: touching_a0.concat(),
        kinetic_energy: kinetic.iter().sum(),
    })
}

/// For each grain, the other grains whose circles come within `margin` of its own, in
/// increasing order (the contact engine's broad phase, over the circles).
fn neighbours(circles: &[(V2, f64)], margin: f64) -> Vec<Vec<usize>> {
    let (centres, radii): (Vec<V2>, Vec<f64>) = circles.iter().copied().unzip();
    let mut list = Neighbours::default();
    list.update(&centres, &radii, margin, 0.0);
    let mut near = vec![Vec::new(); circles.len()];
    for &(a, b) in &list.pairs {
        near[a as usize].push(b as usize);
        near[b as usize].push(a as usize);
    }
    near.iter_mut().for_each(|n| n.sort_unstable());
    near
}

/// Greedy colouring in grain order: each grain takes the smallest colour none of its
/// lower-numbered neighbours has.
fn colours(near: &[Vec<usize>]) -> Vec<usize> {
    let mut colour = vec![0; near.len()];
    for g in 0..near.len() {
        let taken: Vec<usize> = near[g]
            .iter()
            .filter(|&&j| j < g)
            .map(|&j| colour[j])
            .collect();
        colour[g] = (0..).find(|c| !taken.contains(c)).expect("a free colour");
    }
    colour
}

/// Grain `own`'s particles, followed by the particles of the `others` that lie within
/// `margin` of its reach from `centre`, fixed (1/m = 1/I = 0, at rest).
fn with_obstacles(
    b: &Bodies,
    own: std::ops::Range<usize>,
    others: impl Iterator<Item = std::ops::Range<usize>>,
    centre: V2,
    margin: f64,
) -> Bodies {
    let reach = own
        .clone()
        .map(|i| (b.pos[i] - centre).norm() + b.radius[i])
        .fold(0.0, f64::max);
    let mut scene = Bodies::default();
    let mut copy = |i: usize, fixed: bool| {
        scene.pos.push(b.pos[i]);
        scene.angle.push(b.angle[i]);
        scene.radius.push(b.radius[i]);
        scene.group.push(b.group[i]);
        scene.force.push(b.force[i]);
        if fixed {
            scene.vel.push(V2::zeros());
            scene.omega.push(0.0);
            scene.inv_mass.push(0.0);
            scene.inv_inertia.push(0.0);
        } else {
            scene.vel.push(b.vel[i]);
            scene.omega.push(b.omega[i]);
            scene.inv_mass.push(b.inv_mass[i]);
            scene.inv_inertia.push(b.inv_inertia[i]);
        }
    };
    for i in own {
        copy(i, false);
    }
    for i in others.flatten() {
        if (b.pos[i] - centre).norm() - b.radius[i] <= reach + margin {
            copy(i, true);
        }
    }
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    const R: f64 = 1.0e-3;

    /// Aggregates of radius R built in circles centred at `centres` (seeded so that, relaxed
    /// alone, two of them bulge into each other).
    fn grains(centres: &[V2]) -> (Bodies, Vec<usize>, Vec<(V2, f64)>) {
        let mut rng = Rng::stream(4, "test-grains");
        let mut b = Bodies::default();
        let (mut counts, mut circles) = (Vec::new(), Vec::new());
        for (g, &c) in centres.iter().enumerate() {
            let (pos, rad) = super::super::build_grain(R, [1.0e-4, 1.6e-4], &mut rng);
            counts.push(pos.len());
            circles.push((c, R));
            for (p, r) in pos.iter().zip(&rad) {
                b.push(c + p, *r, 990.0, g as u32);
            }
        }
        (b, counts, circles)
    }

    fn relax(b: &Bodies, counts: &[usize], circles: &[(V2, f64)], threads: usize) -> Relaxed {
        relax_in(b, counts, circles, &[], threads)
    }

    fn relax_in(
        b: &Bodies,
        counts: &[usize],
        circles: &[(V2, f64)],
        walls: &[Wall],
        threads: usize,
    ) -> Relaxed {
        let law = BpmLaw::Cohesive {
            f0: 100.0,
            gamma: 7.0,
            cutoff: 1.0,
            rolling: 0.0,
        };
        let frictionless = vec![BpmLaw::Coulomb { mu: 0.0 }; walls.len()];
        let laws = LawTable::new(law, BpmLaw::Coulomb { mu: 0.0 }, frictionless);
        let t0 = crate::stages::discretise::t0(b, 100.0);
        let params =
            crate::stages::cd_params(&crate::config::Solver::default(), 0.1 * t0, 0.0, 1.0e-4);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        let grains = Grains {
            bodies: b,
            counts,
            circles,
            walls,
        };
        pool.install(|| relax_grains(grains, &laws, &params, 400, 7, &|_| ()))
            .expect("relaxed")
    }

    /// Worst overlap between particles of different grains, over the smallest diameter.
    fn worst_inter_grain_overlap(b: &Bodies) -> f64 {
        let d_min = 2.0 * b.radius.iter().cloned().fold(f64::INFINITY, f64::min);
        let mut worst = 0.0f64;
        for i in 0..b.len() {
            for j in i + 1..b.len() {
                if b.group[i] != b.group[j] {
                    let gap = (b.pos[i] - b.pos[j]).norm() - b.radius[i] - b.radius[j];
                    worst = worst.max(-gap);
                }
            }
        }
        worst / d_min
    }

    #[test]
    fn touching_aggregates_relax_without_entering_each_other() {
        // A grain and its six touching neighbours, as a deposit leaves them.
        let centres: Vec<V2> = (0..7)
            .map(|k| {
                let a = std::f64::consts::FRAC_PI_3 * k as f64;
                if k == 0 {
                    V2::zeros()
                } else {
                    2.0 * R * V2::new(a.cos(), a.sin())
                }
            })
            .collect();
        let (b, counts, circles) = grains(&centres);
        let two = relax(&b, &counts, &circles, 2);
        // The particles moved, and no particle of one grain entered another grain's.
        assert_ne!(two.bodies.pos, b.pos);
        assert_eq!(worst_inter_grain_overlap(&two.bodies), 0.0);
        // Relaxed alone (ten times further apart), the same aggregates put back in place
        // overlap by a few hundredths of a particle: the obstacles are what prevents it.
        let apart: Vec<V2> = centres.iter().map(|c| 10.0 * c).collect();
        let (far, _, far_circles) = grains(&apart);
        let alone = relax(&far, &counts, &far_circles, 2);
        let mut put_back = alone.bodies.clone();
        for i in 0..put_back.len() {
            let g = put_back.group[i] as usize;
            put_back.pos[i] -= apart[g] - centres[g];
        }
        assert!(worst_inter_grain_overlap(&put_back) > 1e-2);
        // One thread or two, the same bits.
        let one = relax(&b, &counts, &circles, 1);
        assert_eq!(one.bodies, two.bodies);
        assert_eq!(one.kinetic_energy, two.kinetic_energy);
    }

    /// How far the particles reach past the walls, over the smallest particle diameter
    /// (negative: all inside).
    fn past_walls(b: &Bodies, walls: &[Wall]) -> f64 {
        let d_min = 2.0 * b.radius.iter().cloned().fold(f64::INFINITY, f64::min);
        let gaps = (0..b.len()).flat_map(|i| {
            let centre = b.pos[i];
            let gap = move |w: &Wall| w.gap(V2::zeros(), centre, b.radius[i]).map(|(g, _)| g);
            walls.iter().filter_map(gap)
        });
        -gaps.fold(f64::INFINITY, f64::min) / d_min
    }

    #[test]
    fn an_aggregate_relaxes_inside_the_walls_around_it() {
        // A grain in a 24-sided box whose sides touch its circle, as a deposit's walls touch
        // the grains beside them.
        let (b, counts, circles) = grains(&[V2::zeros()]);
        let sides = 24;
        let half = std::f64::consts::PI / sides as f64;
        let walls: Vec<Wall> = (0..sides)
            .map(|k| {
                let n = V2::new((2.0 * half * k as f64).cos(), (2.0 * half * k as f64).sin());
                let (foot, along) = (R * n, 1.2 * R * half.tan() * V2::new(-n.y, n.x));
                // counter-clockwise: the grain is on each wall's left
                Wall::new(foot - along, foot + along)
            })
            .collect();
        assert!(past_walls(&b, &walls) <= 0.0);
        // Relaxed alone, boundary particles bulge out of the circle and through the walls.
        let free = relax(&b, &counts, &circles, 1);
        assert!(past_walls(&free.bodies, &walls) > 1e-2);
        let held = relax_in(&b, &counts, &circles, &walls, 1);
        assert!(past_walls(&held.bodies, &walls) < 1e-6);
    }

    #[test]
    fn grains_are_coloured_apart_from_their_neighbours() {
        let circles: Vec<(V2, f64)> = (0..6)
            .map(|k| {
                (
                    V2::new(2.0 * R * (k % 3) as f64, 2.0 * R * (k / 3) as f64),
                    R,
                )
            })
            .collect();
        let near = neighbours(&circles, 0.1 * R);
        assert_eq!(near[0], vec![1, 3]);
        assert_eq!(near[4], vec![1, 3, 5]);
        let colour = colours(&near);
        for (g, n) in near.iter().enumerate() {
            assert!(n.iter().all(|&j| colour[j] != colour[g]));
        }
    }
}
