//! The compact stage of a BPM packing (paper section 4): the deposited grains, discretised
//! into aggregates, are spread to the unjammed Φ0 (`compaction::unjammed_layout`) in a box
//! with a fixed floor and side walls; the top wall moves down at `compact.wall_velocity`
//! until ε = ln(h0/h) reaches `compact.final_strain`. Walls are frictionless by default,
//! inter-grain contacts frictional per case, gravity `compact.gravity` (none by default).
//!
//! Measures (recorded every `output.every` steps, wall forces as interval means):
//! * Φ: Σ grain areas / (L h), each grain's area by morphological closing of its particles
//!   with the largest particle radius (METHODS.md §2.4). The top wall is placed with these
//!   areas, so Φ(0) = Φ0 in the reported convention. They are below the prepared circles'
//!   π R² (the particles lie inside the circle: about 0.9 for the paper's particles, 0.7 for
//!   coarse ones), so a coarse deposit can be looser than 0.65 already (`quick.yaml`).
//! * Z: grain pairs with at least one particle contact carrying a positive impulse in the
//!   last step; Z* after removing rattlers (`compaction::coordination`, wall contacts count
//!   toward holding a grain).
//! * overlap: largest particle-particle overlap between different grains over d_min;
//!   overlap_area: the lens areas of those overlaps over Σ grain areas.
//! * kinetic_ratio: kinetic energy over the work the walls have done so far.
//! * inertial: I = ε̇ d sqrt(ρ/p) with the top wall's ε̇, the walls' mean stress p and the
//!   grains' size and density at ε = 0 (`compaction::GrainScale`).

use super::discretise::BpmGrains;
use super::frames::FrameLog;
use crate::bpm::{BpmLaw, measure};
use crate::cd::{LawTable, Partner, Scene};
use crate::compaction::{
    self, BoxGeometry, ForceLine, OverlapSite, PackingCompacted, PackingFigures, Particle, Row,
    SolveTally,
};
use crate::config::{Compact, Method, Pipeline, defaults};
use crate::geom::{V2, Wall};
use crate::packing;
use crate::pipeline::StageCtx;
use crate::timing::lap;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Wall indices: floor, left, right from `packing::box_walls`, then the moving top.
const FLOOR: usize = 0;
const LEFT: usize = 1;
const RIGHT: usize = 2;
const TOP: usize = 3;

#[derive(Clone, Debug, Serialize, Deserialize)]
struct Running {
    scene: Scene<BpmLaw>,
    geometry: BoxGeometry,
    friction: f64,
    grains: usize,
    /// Σ closed grain areas at the start (m²).
    area0: f64,
    rows: Vec<Row>,
    frames: FrameLog,
    network_frames: FrameLog,
    /// Impulses of each wall on the grains since the last row (N s/m).
    impulse: [V2; 4],
    /// Work done by the walls since the start (J/m).
    wall_work: f64,
    since_record: u64,
    iterations_since: u64,
    solves_since: SolveTally,
    figures: PackingFigures,
}

/// Closed area of every grain (m²), in parallel over grains.
fn grain_areas(b: &crate::cd::Bodies, grains: usize) -> Vec<f64> {
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); grains];
    for (i, &g) in b.group.iter().enumerate() {
        members[g as usize].push(i);
    }
    let r_min = b.radius.iter().cloned().fold(f64::INFINITY, f64::min);
    members
        .par_iter()
        .map(|m| {
            let pos: Vec<V2> = m.iter().map(|&i| b.pos[i]).collect();
            let rad: Vec<f64> = m.iter().map(|&i| b.radius[i]).collect();
            let s = rad.iter().cloned().fold(0.0, f64::max);
            // pixel r_min / 2: the area to about 1% at a few ms per grain
            measure::closed_area(&pos, &rad, s, 0.5 * r_min)
        })
        .collect()
}

fn new_run(p: &Pipeline, c: &Compact, mu: f64, g: &BpmGrains) -> Result<Running, String> {
    let mut b = g.bodies.clone();
    let grains = g.grain_radius.len();
    // each grain's centre: the area-weighted mean of its particles
    let mut centre = vec![V2::zeros(); grains];
    let mut weight = vec![0.0; grains];
    for i in 0..b.len() {
        let (k, a) = (b.group[i] as usize, b.radius[i] * b.radius[i]);
        centre[k] += b.pos[i] * a;
        weight[k] += a;
    }
    for (x, w) in centre.iter_mut().zip(&weight) {
        *x /= *w;
    }
    // how far each aggregate reaches under and over its centre
    let (mut below, mut above) = (vec![0.0f64; grains], vec![0.0f64; grains]);
    for i in 0..b.len() {
        let k = b.group[i] as usize;
        let dy = b.pos[i].y - centre[k].y;
        below[k] = below[k].max(b.radius[i] - dy);
        above[k] = above[k].max(dy + b.radius[i]);
    }
    let area0: f64 = grain_areas(&b, grains).iter().sum();
    let (moved, geometry) =
        compaction::unjammed_layout(&centre, &below, &above, area0, g.box_width, c.initial_phi)?;
    for i in 0..b.len() {
        let k = b.group[i] as usize;
        b.pos[i] += moved[k] - centre[k];
    }
    let t0 = match g.law {
        BpmLaw::Cohesive { f0, .. } => super::discretise::t0(&b, f0),
        BpmLaw::Coulomb { .. } => return Err("the grains carry no cohesive law".into()),
    };
    let dt = c.time_step.unwrap_or(defaults::BPM_STEP * t0);
    if dt > 0.5 * t0 {
        return Err(format!(
            "compact.time_step = {dt:e} s is above the stability limit of the explicit attraction, 0.5 t0 = {:e} s",
            0.5 * t0
        ));
    }
    let r_max = g.grain_radius.iter().cloned().fold(0.0, f64::max);
    let mut walls = packing::box_walls(geometry.width, geometry.h0, r_max);
    walls.push(Wall {
        a: V2::new(geometry.width + r_max, geometry.h0),
        b: V2::new(-r_max, geometry.h0),
        velocity: V2::new(0.0, -c.wall_velocity),
    });
    let d_min = 2.0 * b.radius.iter().cloned().fold(f64::INFINITY, f64::min);
    let params = super::cd_params(&p.compact_solver(), dt, c.gravity, d_min);
    let wall_laws = vec![
        BpmLaw::Coulomb {
            mu: c.wall_friction
        };
        walls.len()
    ];
    let laws = LawTable::new(g.law, BpmLaw::Coulomb { mu }, wall_laws);
    Ok(Running {
        scene: Scene::new(b, walls, laws, params, p.seed),
        geometry,
        friction: mu,
        grains,
        area0,
        rows: Vec::new(),
        frames: FrameLog::particles(),
        network_frames: FrameLog::new("contacts", "contacts.pvd"),
        impulse: [V2::zeros(); 4],
        wall_work: 0.0,
        since_record: 0,
        iterations_since: 0,
        solves_since: SolveTally::default(),
        figures: PackingFigures {
            time_step: dt,
            ..Default::default()
        },
    })
}

fn height(st: &Running) -> f64 {
    st.scene.walls[TOP].a.y - st.scene.walls[FLOOR].a.y
}

pub fn run(
    p: &Pipeline,
    mu: f64,
    g: &BpmGrains,
    ctx: &StageCtx,
) -> Result<(PackingCompacted, String), String> {
    let c = p.compact.as_ref().expect("planned with a compact section");
    let strain = |st: &Running| (st.geometry.h0 / height(st)).ln();
    let mut continued = None;
    let mut st = match ctx.load_snapshot::<Running>() {
        Some(st) => st,
        None => match ctx.load_continuation::<Running>() {
            Some(st) if strain(&st) < c.final_strain => {
                continued = Some(strain(&st));
                st
            }
            _ => new_run(p, c, mu, g)?,
        },
    };
    let io = |e: std::io::Error| format!("writing output in {}: {e}", ctx.dir.display());
    let bar = ctx.progress("compact", (c.final_strain * 1e4) as u64);
    let every = p.output.every.max(1);
    // where the time goes, for stage.json (the step times its own parts, `Scene::phases`)
    let (mut rows, mut snapshots) = (0.0, 0.0);
    let mut clock = Instant::now();
    if st.rows.is_empty() {
        record(p, ctx, &mut st).map_err(io)?;
    }
    rows += lap(&mut clock);
    while strain(&st) < c.final_strain {
        let r = st.scene.step().map_err(|e| e.to_string())?;
        clock = Instant::now();
        let h = st.scene.params.dt;
        for (k, imp) in st.impulse.iter_mut().enumerate() {
            *imp += st.scene.wall_force[k] * h;
        }
        st.wall_work += st.scene.wall_force[TOP].dot(&st.scene.walls[TOP].velocity) * h;
        st.since_record += 1;
        st.iterations_since += r.nlgs.iterations as u64;
        st.solves_since.add(r.nlgs.residual, r.nlgs.converged);
        let f = &mut st.figures;
        f.steps += 1;
        f.iterations_max = f.iterations_max.max(r.nlgs.iterations as u64);
        f.unconverged_steps += u64::from(!r.nlgs.converged);
        f.stopped_solves += u64::from(!r.nlgs.converged);
        f.iterations_mean += r.nlgs.iterations as f64;
        if st.scene.steps % every == 0 {
            record(p, ctx, &mut st).map_err(io)?;
            let strain = st.rows.last().map_or(0.0, |r| r.strain);
            bar.set(
                (strain * 1e4) as u64,
                format!("ε = {strain:.3}, {} sweeps/step", r.nlgs.iterations),
            );
        }
        rows += lap(&mut clock);
        if p.output.snapshot_every > 0 && st.scene.steps % p.output.snapshot_every == 0 {
            ctx.save_snapshot(&st, &bar).map_err(io)?;
            ctx.write("timeseries.csv", compaction::csv(&st.rows).as_bytes())
                .map_err(io)?;
        }
        snapshots += lap(&mut clock);
        if ctx.interrupted() {
            ctx.save_snapshot(&st, &bar).map_err(io)?;
            return Err(crate::pipeline::INTERRUPTED.into());
        }
    }
    ctx.save_continuation(&st, strain).map_err(io)?;
    snapshots += lap(&mut clock);
    if st.since_record > 0 {
        record(p, ctx, &mut st).map_err(io)?;
    }
    rows += lap(&mut clock);
    ctx.note_times(
        &st.scene.phases().named(),
        &[("rows", rows), ("snapshots", snapshots)],
    );
    bar.finish();
    let (done, summary) = finish(ctx, st)?;
    Ok((done, compaction::continued(summary, continued)))
}

/// Closes a recording interval: one row, one particle frame and one force-network frame.
fn record(p: &Pipeline, ctx: &StageCtx, st: &mut Running) -> std::io::Result<()> {
    let scene = &st.scene;
    let b = &scene.bodies;
    let span = st.since_record as f64 * scene.params.dt;
    let mean = |k: usize| {
        if span > 0.0 {
            st.impulse[k] / span
        } else {
            V2::zeros()
        }
    };
    let (width, h) = (st.geometry.width, height(st));
    let area: f64 = grain_areas(b, st.grains).iter().sum();
    let d_min = 2.0 * b.radius.iter().cloned().fold(f64::INFINITY, f64::min);
    let mut pairs = Vec::new();
    // walls touched by each grain, one bit each
    let mut walls = vec![0u8; st.grains];
    let mut overlap: f64 = 0.0;
    let mut site = OverlapSite::default();
    let mut lenses = 0.0;
    let mut inside = vec![false; b.len()];
    for (c, gap) in scene.contacts.iter().zip(scene.current_gaps()) {
        let gi = b.group[c.i as usize] as usize;
        match c.j {
            Partner::Body(j) if b.group[j as usize] as usize != gi => {
                if -gap / d_min > overlap {
                    overlap = -gap / d_min;
                    let mid = 0.5 * (b.pos[c.i as usize] + b.pos[j as usize]);
                    site = OverlapSite {
                        overlap,
                        strain: 0.0,
                        at: [mid.x, mid.y],
                        grains: [gi as u32, b.group[j as usize]],
                    };
                }
                if gap < 0.0 {
                    let (ri, rj) = (b.radius[c.i as usize], b.radius[j as usize]);
                    lenses += measure::lens_area(ri, rj, ri + rj + gap);
                    // a centre lies inside the other disk when the gap passes its own radius
                    inside[c.i as usize] |= gap < -ri;
                    inside[j as usize] |= gap < -rj;
                }
                if c.p_n > 0.0 {
                    pairs.push((gi, b.group[j as usize] as usize));
                }
            }
            Partner::Wall(w) if c.p_n > 0.0 => walls[gi] |= 1 << w,
            _ => {}
        }
    }
    let wall_contacts: Vec<usize> = walls.iter().map(|w| w.count_ones() as usize).collect();
    let min_contacts = if st.friction > 0.0 { 2 } else { 3 };
    let z = compaction::coordination(st.grains, &pairs, &wall_contacts, min_contacts);
    let kinetic = b.kinetic_energy();
    let scale = compaction::GrainScale::new(st.grains, st.area0, b.total_mass());
    let strain_rate = -scene.walls[TOP].velocity.y / h;
    let mut row = Row {
        time: scene.time,
        strain: (st.geometry.h0 / h).ln(),
        phi: area / (width * h),
        z: z.z,
        z_star: z.z_star,
        sigma: mean(FLOOR).y / width,
        sigma_top: -mean(TOP).y / width,
        sigma_left: mean(LEFT).x / h,
        sigma_right: -mean(RIGHT).x / h,
        grain_contacts: z.pairs,
        rattlers: z.rattlers,
        iterations: st.iterations_since as f64 / st.since_record.max(1) as f64,
        // undefined (NaN) before the top wall has done any work
        kinetic_ratio: if st.wall_work > 0.0 {
            kinetic / st.wall_work
        } else {
            f64::NAN
        },
        overlap: overlap.max(0.0),
        overlap_area: lenses / area,
        points_inside: inside.iter().filter(|&&i| i).count() as f64 / inside.len() as f64,
        point_overlap: f64::NAN,
        inertial: f64::NAN,
        sigma_box: f64::NAN,
        sigma_lever: f64::NAN,
        residual: st.solves_since.residual,
        unconverged: st.solves_since.unconverged,
    };
    row.inertial = scale.inertial_number(strain_rate, row.pressure());
    st.figures.fold(&row, site, None, area / st.area0);
    st.rows.push(row);
    st.impulse = [V2::zeros(); 4];
    st.since_record = 0;
    st.iterations_since = 0;
    st.solves_since = SolveTally::default();
    if p.output.vtk {
        st.frames
            .write_disks(&ctx.dir, st.scene.time, &st.scene.bodies)?;
        st.network_frames.write_network(&ctx.dir, &st.scene)?;
    }
    Ok(())
}

fn finish(ctx: &StageCtx, st: Running) -> Result<(PackingCompacted, String), String> {
    let mut f = st.figures;
    f.iterations_mean /= f.steps.max(1) as f64;
    f.kinetic_ratio_max = compaction::max_after_jamming(&st.rows, |r| r.kinetic_ratio);
    f.inertial_max = compaction::max_after_jamming(&st.rows, |r| r.inertial);
    f.overlap_max_loaded = compaction::max_after_jamming(&st.rows, |r| r.overlap);
    ctx.write("timeseries.csv", compaction::csv(&st.rows).as_bytes())
        .map_err(|e| format!("writing output in {}: {e}", ctx.dir.display()))?;
    let b = &st.scene.bodies;
    let h = st.scene.params.dt;
    let network = st
        .scene
        .contacts
        .iter()
        .filter(|c| c.p_n > 0.0)
        .filter_map(|c| match c.j {
            Partner::Body(j) => {
                let (i, j) = (c.i as usize, j as usize);
                Some(ForceLine {
                    a: [b.pos[i].x, b.pos[i].y],
                    b: [b.pos[j].x, b.pos[j].y],
                    force: c.p_n / h,
                    between_grains: b.group[i] != b.group[j],
                })
            }
            Partner::Wall(_) => None,
        })
        .collect();
    let particles = (0..b.len())
        .map(|i| Particle {
            pos: [b.pos[i].x, b.pos[i].y],
            size: b.radius[i],
            grain: b.group[i],
        })
        .collect();
    let last = st.rows.last().cloned().unwrap_or_default();
    let summary = format!(
        "{} steps, {:.0} NLGS sweeps/step, {}, worst overlap {:.1e} d_min{} ({:.1e} once loaded), particles with their centre inside another grain {:.2}% at most{}",
        f.steps,
        f.iterations_mean,
        last.state(),
        f.overlap_max,
        f.overlap_site.note(),
        f.overlap_max_loaded,
        100.0 * f.points_inside_max,
        f.unconverged_note()
    );
    Ok((
        PackingCompacted {
            method: Method::Bpm,
            friction: st.friction,
            geometry: st.geometry,
            grains: st.grains,
            rows: st.rows,
            particles,
            network,
            figures: f,
        },
        summary,
    ))
}
