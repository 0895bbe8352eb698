//! The CD family: a small deposit under gravity (the floor must carry the weight, contacts
//! must not overlap) and a disk on an incline (rolling a = (2/3) g sin θ, sliding
//! a = g (sin θ - μ cos θ)), each with the knob's NLGS tolerance, time step and alert distance.

use super::spec::{CdFamily, CdSetting};
use crate::cd::{Bodies, CdParams, Coulomb, LawTable, NlgsParams, Scene};
use crate::config::defaults;
use crate::geom::{V2, Wall};
use crate::packing::{self, Distribution};
use crate::rng::Rng;

const G: f64 = 9.81;

/// What one setting measured (all relative).
pub struct Measured {
    /// |floor force / weight - 1| at rest.
    pub floor_balance: f64,
    /// Deepest overlap of an active contact at rest, over the mean radius.
    pub max_overlap: f64,
    /// Largest relative error of the incline accelerations (rolling and sliding).
    pub incline: f64,
}

fn params(s: &CdSetting, dt: f64, d_min: f64) -> CdParams {
    CdParams {
        dt,
        theta: defaults::THETA,
        gravity: V2::new(0.0, -G),
        alert: s.alert * d_min,
        skin: defaults::SKIN * d_min,
        nlgs: NlgsParams {
            tol: s.tolerance,
            check_every: defaults::NLGS_CHECK_EVERY,
            max_iter: defaults::NLGS_MAX_ITERATIONS,
            relax: defaults::NLGS_RELAXATION,
            anderson: 0,
            islands: false,
        },
        sleep: None,
    }
}

pub fn measure(f: &CdFamily, s: &CdSetting) -> Result<Measured, String> {
    let (floor_balance, max_overlap) = deposit(f, s)?;
    let rolling = {
        let th = 25f64.to_radians();
        incline(s, th, th.tan() / 3.0 * 1.2)? / (2.0 / 3.0 * G * th.sin()) - 1.0
    };
    let sliding = {
        let (th, mu) = (35f64.to_radians(), 0.1);
        incline(s, th, mu)? / (G * (th.sin() - mu * th.cos())) - 1.0
    };
    Ok(Measured {
        floor_balance,
        max_overlap,
        incline: rolling.abs().max(sliding.abs()),
    })
}

/// Deposits `grains` disks in a box about as high as wide, as the prepare stage does, until
/// at rest (the stage's criterion) or `max_time`; returns the floor balance and max overlap.
fn deposit(f: &CdFamily, s: &CdSetting) -> Result<(f64, f64), String> {
    let dist = Distribution::EqualAreaPerSize;
    let mut rng = Rng::stream(defaults::SEED, "prepare-sizes");
    let d = packing::diameters(dist, f.diameter, f.grains, &mut rng);
    let width = packing::square_box_width(dist, f.diameter, f.grains, defaults::SQUARE_BOX_PHI);
    let (pos, height) = packing::loose_layout(&d, width, &mut rng);
    let mut bodies = Bodies::default();
    for (k, (x, dk)) in pos.iter().zip(&d).enumerate() {
        bodies.push(*x, 0.5 * dk, defaults::DENSITY, k as u32);
    }
    let d_mean = d.iter().sum::<f64>() / d.len() as f64;
    let d_min = d.iter().cloned().fold(f64::INFINITY, f64::min);
    let walls = packing::box_walls(width, 2.0 * height, f.diameter[1]);
    let wall_laws = vec![Coulomb { mu: 0.0 }; walls.len()];
    let disk = Coulomb { mu: f.friction };
    let dt = s.time_step * (d_mean / G).sqrt();
    let mut scene = Scene::new(
        bodies,
        walls,
        LawTable::new(disk, disk, wall_laws),
        params(s, dt, d_min),
        defaults::SEED,
    );
    let settle = (2.0 * height / G).sqrt();
    let scale = scene.bodies.total_mass() * G * d_mean;
    let (mut quiet, mut floor) = (0, Vec::new());
    while quiet < defaults::REST_STEPS && scene.time < f.max_time {
        scene.step().map_err(|e| format!("deposit: {e}"))?;
        let rest = scene.bodies.translational_energy() / scale < defaults::REST_TOLERANCE;
        quiet = if scene.time > settle && rest {
            quiet + 1
        } else {
            0
        };
        floor.push(scene.wall_force[0].y);
    }
    // the floor force averaged over the last 20 steps, as the prepare stage reports it
    let tail = &floor[floor.len().saturating_sub(20)..];
    let floor_force = tail.iter().sum::<f64>() / tail.len() as f64;
    let weight = scene.bodies.total_mass() * G;
    let gaps = scene.current_gaps();
    let deepest = (scene.contacts.iter().zip(&gaps))
        .filter(|(c, _)| c.p_n > 0.0)
        .map(|(_, g)| (-g).max(0.0))
        .fold(0.0, f64::max);
    Ok((
        (floor_force / weight - 1.0).abs(),
        deepest / scene.bodies.mean_radius(),
    ))
}

/// A disk of radius 1 cm released on a wall at `angle` (rad) with friction `mu`, for 0.2 s:
/// its acceleration along the slope (θ = 1 integrates a constant one exactly in velocity).
fn incline(s: &CdSetting, angle: f64, mu: f64) -> Result<f64, String> {
    let r = 0.01;
    let dir = V2::new(angle.cos(), -angle.sin());
    let a = V2::new(0.0, 1.0);
    let wall = Wall::new(a, a + 2.0 * dir);
    let n = wall.normal();
    let mut bodies = Bodies::default();
    bodies.push(a + 0.1 * dir + r * n, r, defaults::DENSITY, 0);
    let law = Coulomb { mu };
    let dt = s.time_step * (2.0 * r / G).sqrt();
    let mut scene = Scene::new(
        bodies,
        vec![wall],
        LawTable::new(law, law, vec![law]),
        params(s, dt, 2.0 * r),
        defaults::SEED,
    );
    let steps = (0.2 / dt).ceil() as usize;
    for _ in 0..steps {
        scene.step().map_err(|e| format!("incline: {e}"))?;
    }
    Ok(scene.bodies.vel[0].dot(&dir) / scene.time)
}
