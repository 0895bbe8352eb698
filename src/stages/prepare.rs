//! The prepare stage: rigid disks by contact dynamics. A packing is deposited under gravity
//! in an open box until at rest; a single grain is just placed; an explicit scene (listed
//! disks and walls, e.g. the incline check) is run for a given time with its trajectories
//! recorded.

use super::frames::FrameLog;
use crate::cd::{Bodies, CdParams, Coulomb, LawTable, Partner, Scene};
use crate::config::{Layout, Pipeline, Prepare, defaults};
use crate::geom::{V2, Wall};
use crate::packing;
use crate::pipeline::StageCtx;
use crate::rng::Rng;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// The prepared disks: what discretise turns into soft grains.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Prepared {
    pub layout: Layout,
    pub bodies: Bodies,
    pub walls: Vec<Wall>,
    /// Inner width of the box (packings), 0 otherwise (m).
    pub box_width: f64,
    pub figures: Figures,
}

/// Key figures of the run (deterministic: no wall time here, so equal seeds give
/// byte-identical checkpoints; wall time goes to stage.json only).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Figures {
    pub particles: usize,
    pub steps: u64,
    pub time: f64,
    pub time_step: f64,
    pub nlgs_iterations: u64,
    pub nlgs_iterations_max: u32,
    pub unconverged_steps: u64,
    /// Σ over steps of sweeps × contacts in the solve.
    pub contact_updates: u64,
    /// Total weight (N/m).
    pub weight: f64,
    /// Vertical force on the floor, mean of the last steps (N/m).
    pub floor_force: f64,
    /// Overlap of the active contacts at the end, over the mean radius.
    pub mean_overlap: f64,
    pub max_overlap: f64,
    /// Kinetic energy at the end (J/m).
    pub kinetic_energy: f64,
    /// Disks asleep at the end (`prepare.sleep`).
    pub sleeping: usize,
    /// The one separation of `prepare.separation`, if it ran.
    pub separation: Option<Separated>,
}

/// When the deposit's overlaps were moved apart (`cd::separate`), and by how much.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Separated {
    pub step: u64,
    /// Deepest overlap before and after, and the largest displacement, over the mean radius.
    pub deepest_before: f64,
    pub deepest_after: f64,
    pub moved: f64,
    pub sweeps: u32,
}

/// What a snapshot holds: everything needed to continue bit for bit.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Running {
    scene: Scene<Coulomb>,
    box_width: f64,
    figures: Figures,
    frames: FrameLog,
    trajectories: String,
    floor_window: Vec<f64>,
    /// Time after which the rest test applies (all disks had time to fall).
    settle_after: f64,
    /// Consecutive steps the packing has met the rest criterion.
    quiet_steps: u64,
}

impl Running {
    /// A separation `prepare.separation` asks for and that has not run yet.
    fn separation_due(&self, prep: &Prepare) -> bool {
        prep.separation.is_some() && self.figures.separation.is_none()
    }
}

/// Steps over which the floor force is averaged.
const FLOOR_WINDOW: usize = 20;

pub fn run(p: &Pipeline, ctx: &StageCtx) -> Result<(Prepared, String), String> {
    let prep = &p.prepare;
    if prep.layout == Layout::Single {
        return single(prep, ctx);
    }
    let mut st = match ctx.load_snapshot::<Running>() {
        Some(st) => st,
        None => start(p)?,
    };
    let limit = match prep.layout {
        Layout::Explicit => prep.duration.expect("validated"),
        _ => prep.max_time,
    };
    let h = st.scene.params.dt;
    let bar = ctx.progress("prepare", (limit / h).ceil() as u64);
    let every = p.output.every;
    let io = |e: std::io::Error| format!("writing output in {}: {e}", ctx.dir.display());
    if st.scene.steps == 0 {
        output(p, ctx, &mut st).map_err(io)?;
    }
    loop {
        let done = match prep.layout {
            Layout::Explicit => st.scene.time >= limit - 0.5 * h,
            _ => st.quiet_steps >= defaults::REST_STEPS && !st.separation_due(prep),
        };
        if done {
            break;
        }
        if st.scene.time > limit {
            return Err(format!(
                "not at rest after prepare.max_time = {limit} s: translational kinetic energy / (Σ m g <d>) = {:.3e} > prepare.rest_tolerance = {:.1e}",
                rest_ratio(&st.scene, prep.gravity),
                prep.rest_tolerance
            ));
        }
        let r = st.scene.step().map_err(|e| e.to_string())?;
        let f = &mut st.figures;
        f.steps += 1;
        f.nlgs_iterations += r.nlgs.iterations as u64;
        f.nlgs_iterations_max = f.nlgs_iterations_max.max(r.nlgs.iterations);
        f.unconverged_steps += u64::from(!r.nlgs.converged);
        f.contact_updates += r.updates;
        if prep.layout == Layout::Packing {
            let ratio = rest_ratio(&st.scene, prep.gravity);
            let settling = st.scene.time > st.settle_after;
            let quiet = settling && ratio < prep.rest_tolerance;
            st.quiet_steps = if quiet { st.quiet_steps + 1 } else { 0 };
            if settling
                && st.separation_due(prep)
                && (prep.separation.is_some_and(|s| ratio < s.at)
                    || st.quiet_steps >= defaults::REST_STEPS)
            {
                separate(&mut st, prep.separation.and_then(|s| s.tolerance));
            }
            st.floor_window.push(st.scene.wall_force[0].y);
            if st.floor_window.len() > FLOOR_WINDOW {
                st.floor_window.remove(0);
            }
        }
        if every > 0 && st.scene.steps % every == 0 {
            output(p, ctx, &mut st).map_err(io)?;
        }
        if p.output.snapshot_every > 0 && st.scene.steps % p.output.snapshot_every == 0 {
            ctx.save_snapshot(&st, &bar).map_err(io)?;
        }
        if ctx.interrupted() {
            ctx.save_snapshot(&st, &bar).map_err(io)?;
            return Err(crate::pipeline::INTERRUPTED.into());
        }
        if st.scene.steps % 50 == 0 {
            bar.set(
                st.scene.steps,
                format!("t = {:.3} s, {} contacts", st.scene.time, r.contacts),
            );
        }
    }
    bar.finish();
    if every == 0 || st.scene.steps % every != 0 {
        output(p, ctx, &mut st).map_err(io)?;
    }
    finish(p, ctx, st)
}

/// Moves the packing's overlapping disks apart once; the rest test then starts over, since
/// disks lifted off a support settle again, at the NLGS `tolerance` if one is given.
fn separate(st: &mut Running, tolerance: Option<f64>) {
    let r = st.scene.bodies.mean_radius();
    let s = crate::cd::separate(
        &mut st.scene.bodies,
        &st.scene.walls,
        &st.scene.contacts,
        defaults::SEPARATION_TOLERANCE * r,
        defaults::SEPARATION_MAX_SWEEPS,
    );
    st.figures.separation = Some(Separated {
        step: st.scene.steps,
        deepest_before: s.deepest_before / r,
        deepest_after: s.deepest_after / r,
        moved: s.moved / r,
        sweeps: s.sweeps,
    });
    st.quiet_steps = 0;
    if let Some(t) = tolerance {
        st.scene.params.nlgs.tol = t;
    }
}

/// Ratio of the translational kinetic energy to Σ m g <d>: the dimensionless rest measure.
/// Rotation is left out: a disk touching only frictionless walls keeps any spin it has
/// forever, at no cost to the structure.
fn rest_ratio(scene: &Scene<Coulomb>, g: f64) -> f64 {
    let b = &scene.bodies;
    b.translational_energy() / (b.total_mass() * g.max(1e-300) * 2.0 * b.mean_radius())
}

fn default_step(prep: &Prepare, d_mean: f64) -> Result<f64, String> {
    match prep.time_step {
        Some(dt) => Ok(dt),
        None if prep.gravity > 0.0 => Ok(defaults::DEPOSIT_STEP * (d_mean / prep.gravity).sqrt()),
        None => Err("prepare.time_step is required when prepare.gravity = 0".into()),
    }
}

/// Builds the initial scene of a packing or explicit layout.
fn start(p: &Pipeline) -> Result<Running, String> {
    let prep = &p.prepare;
    let mut bodies = Bodies::default();
    let (walls, box_width, settle_after) = match prep.layout {
        Layout::Packing => {
            let n = prep.grains.expect("validated");
            let range = prep.diameter.expect("validated");
            let mut rng = Rng::stream(p.seed, "prepare-sizes");
            let d = packing::diameters(prep.distribution, range, n, &mut rng);
            let width = prep.box_width.unwrap_or_else(|| {
                packing::square_box_width(prep.distribution, range, n, defaults::SQUARE_BOX_PHI)
            });
            let (pos, height) = packing::loose_layout(&d, width, &mut rng);
            for (k, (x, dk)) in pos.iter().zip(&d).enumerate() {
                bodies.push(*x, 0.5 * dk, prep.density, k as u32);
            }
            let walls = packing::box_walls(width, 2.0 * height, range[1]);
            (walls, width, (2.0 * height / prep.gravity).sqrt())
        }
        Layout::Explicit => {
            // Tilt clockwise by the incline angle: a wall listed along +x then descends toward +x.
            let rot = nalgebra::Rotation2::new(-prep.incline_angle.to_radians());
            let v = |a: [f64; 2]| rot * V2::new(a[0], a[1]);
            for (k, s) in prep.bodies.iter().enumerate() {
                bodies.push(v(s.position), s.radius, prep.density, k as u32);
                bodies.vel[k] = v(s.velocity);
            }
            let walls = prep
                .walls
                .iter()
                .map(|w| Wall {
                    a: v(w.from),
                    b: v(w.to),
                    velocity: v(w.velocity),
                })
                .collect();
            (walls, 0.0, 0.0)
        }
        Layout::Single => unreachable!("handled by single()"),
    };
    let d_min = 2.0 * bodies.radius.iter().cloned().fold(f64::INFINITY, f64::min);
    let dt = default_step(prep, 2.0 * bodies.mean_radius())?;
    let params = CdParams {
        sleep: prep.sleep,
        ..super::cd_params(&p.solver, dt, prep.gravity, d_min)
    };
    let wall_laws = vec![
        Coulomb {
            mu: prep.wall_friction
        };
        walls.len()
    ];
    let disk = Coulomb { mu: prep.friction };
    let laws = LawTable::new(disk, disk, wall_laws);
    let scene = Scene::new(bodies, walls, laws, params, p.seed);
    let figures = Figures {
        particles: scene.bodies.len(),
        time_step: dt,
        ..Figures::default()
    };
    Ok(Running {
        scene,
        box_width,
        figures,
        frames: FrameLog::particles(),
        trajectories: "time,body,x,y,vx,vy,omega\n".into(),
        floor_window: Vec::new(),
        settle_after,
        quiet_steps: 0,
    })
}

/// A VTK frame, and trajectory rows for explicit scenes.
fn output(p: &Pipeline, ctx: &StageCtx, st: &mut Running) -> std::io::Result<()> {
    let b = &st.scene.bodies;
    if p.prepare.layout == Layout::Explicit {
        for i in 0..b.len() {
            let _ = writeln!(
                st.trajectories,
                "{},{i},{},{},{},{},{}",
                st.scene.time, b.pos[i].x, b.pos[i].y, b.vel[i].x, b.vel[i].y, b.omega[i]
            );
        }
    }
    if p.output.vtk {
        st.frames.write_disks(&ctx.dir, st.scene.time, b)?;
    }
    Ok(())
}

fn overlaps(scene: &Scene<Coulomb>) -> (f64, f64) {
    let gaps = scene.current_gaps();
    let active: Vec<f64> = scene
        .contacts
        .iter()
        .zip(&gaps)
        .filter(|(c, _)| c.p_n > 0.0)
        .map(|(_, g)| (-g).max(0.0))
        .collect();
    let r = scene.bodies.mean_radius();
    if active.is_empty() {
        return (0.0, 0.0);
    }
    let mean = active.iter().sum::<f64>() / active.len() as f64;
    (mean / r, active.iter().cloned().fold(0.0, f64::max) / r)
}

fn finish(p: &Pipeline, ctx: &StageCtx, st: Running) -> Result<(Prepared, String), String> {
    let io = |e: std::io::Error| format!("writing output in {}: {e}", ctx.dir.display());
    let mut f = st.figures;
    let scene = st.scene;
    f.time = scene.time;
    f.weight = scene.bodies.total_mass() * p.prepare.gravity;
    if !st.floor_window.is_empty() {
        f.floor_force = st.floor_window.iter().sum::<f64>() / st.floor_window.len() as f64;
    }
    (f.mean_overlap, f.max_overlap) = overlaps(&scene);
    f.kinetic_energy = scene.bodies.kinetic_energy();
    f.sleeping = scene.sleeping();
    if p.prepare.layout == Layout::Explicit {
        ctx.write("trajectories.csv", st.trajectories.as_bytes())
            .map_err(io)?;
    }
    let wall_contacts = scene
        .contacts
        .iter()
        .filter(|c| matches!(c.j, Partner::Wall(_)) && c.p_n > 0.0)
        .count();
    let mut summary = format!(
        "{} disks, {} steps, {:.1} NLGS sweeps/step, floor {:.4} x weight, mean overlap {:.1e} <r>, {} wall contacts",
        f.particles,
        f.steps,
        f.nlgs_iterations as f64 / f.steps.max(1) as f64,
        if f.weight > 0.0 {
            f.floor_force / f.weight
        } else {
            0.0
        },
        f.mean_overlap,
        wall_contacts
    );
    if let Some(s) = &f.separation {
        let _ = write!(
            summary,
            ", separated at step {} (deepest overlap {:.1e} -> {:.1e} <r>, moved up to {:.1e} <r>)",
            s.step, s.deepest_before, s.deepest_after, s.moved
        );
    }
    let prepared = Prepared {
        layout: p.prepare.layout,
        bodies: scene.bodies,
        walls: scene.walls,
        box_width: st.box_width,
        figures: f,
    };
    Ok((prepared, summary))
}

/// One grain of `radius` resting on the floor (x = 0 at its centre): no dynamics needed.
fn single(prep: &Prepare, ctx: &StageCtx) -> Result<(Prepared, String), String> {
    let r = prep.radius.expect("validated");
    let mut bodies = Bodies::default();
    bodies.push(V2::new(0.0, r), r, prep.density, 0);
    let mut frames = FrameLog::particles();
    frames
        .write_disks(&ctx.dir, 0.0, &bodies)
        .map_err(|e| format!("writing output in {}: {e}", ctx.dir.display()))?;
    let figures = Figures {
        particles: 1,
        ..Figures::default()
    };
    let summary = format!("one grain of radius {r} m");
    Ok((
        Prepared {
            layout: Layout::Single,
            bodies,
            walls: Vec::new(),
            box_width: 0.0,
            figures,
        },
        summary,
    ))
}
