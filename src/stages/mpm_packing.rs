//! MPM packings in the pipeline. Discretise keeps the deposited disks and the grain
//! material and grid (the points are seeded by the engine, deterministically); compact
//! places the disks at the unjammed layout of `compact.initial_phi` (which belongs to the
//! compact node's parameters), seeds one MPM grain per disk and runs
//! `crate::mpm::packing::Packing` with the top wall moving down to `compact.final_strain`.
//!
//! Recorded at ε = 0 and every `output.every` steps (`crate::compaction::Row`): wall stresses are the
//! means over the interval (bottom and top over `L`, sides over the current height), Z and
//! Z* from the grain pairs with a loaded contact node at the recording step (rattlers with
//! fewer than 2 contacts with friction, 3 without, wall contacts counted), the overlap the
//! worst inter-grain node gap of the interval over `h_g`, the area under two grains at the
//! recording step (`crate::mpm::overlap`), and the kinetic ratio `E_k / (E_el + 1e-30 J/m)`.

use super::frames::FrameLog;
use super::prepare::Prepared;
use crate::compaction::{
    self, BoxGeometry, ForceLine, OverlapSite, PackingCompacted, PackingFigures, Particle, Row,
    SolveTally,
};
use crate::config::{Method, Model, Mpm, Pipeline, Shape};
use crate::geom::V2;
use crate::io::vtk::{Data, Frame};
use crate::mpm::material::{Material, MaterialKind};
use crate::mpm::node_contact::{ContactKind, NlgsParams, Partner};
use crate::mpm::overlap;
use crate::mpm::packing::{COUPLING_TOLERANCE, Packing, PackingParams, TOP};
use crate::mpm::shape::ShapeKind;
use crate::mpm::solve::SolverParams;
use crate::pipeline::StageCtx;
use crate::timing::lap;
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Top wall travel per step over the cell size when `compact.time_step` is not given
/// (METHODS §6: 0.05–0.1 h_g).
pub const TRAVEL_PER_STEP: f64 = 0.05;

/// The disks of a deposit ready to become MPM grains.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MpmPackingGrains {
    pub centres: Vec<[f64; 2]>,
    pub radii: Vec<f64>,
    pub box_width: f64,
    pub material: Material,
    /// Δr/R with R the mean grain radius.
    pub resolution: f64,
    /// Cell size of the common grid, `h_g = 2 Δr` (m).
    pub cell: f64,
    pub shape: ShapeKind,
    pub bbar: bool,
    pub contact: ContactKind,
    /// Points seeded at the deposit's positions (the compact stage reports its own count).
    pub points: usize,
}

pub fn discretise(m: &Mpm, prep: &Prepared) -> Result<(MpmPackingGrains, String), String> {
    let b = &prep.bodies;
    let n = b.len();
    if n == 0 {
        return Err("the deposit holds no grain".into());
    }
    let mean_r = b.radius.iter().sum::<f64>() / n as f64;
    // Decision (METHODS §7): one grid for all grains, sized on the mean radius.
    let cell = 2.0 * m.resolution * mean_r;
    let material = Material {
        kind: match m.model {
            Model::LinearElastic => MaterialKind::LinearElastic,
            Model::NeoHookean => MaterialKind::NeoHookean,
        },
        young: m.young,
        poisson: m.poisson,
        density: m.density,
    };
    let centres: Vec<[f64; 2]> = b.pos.iter().map(|p| [p.x, p.y]).collect();
    let mut g = MpmPackingGrains {
        centres,
        radii: b.radius.clone(),
        box_width: prep.box_width,
        material,
        resolution: m.resolution,
        cell,
        shape: match m.shape {
            Shape::Bspline => ShapeKind::BSpline2,
            Shape::Bilinear => ShapeKind::Bilinear,
            Shape::Gimp => ShapeKind::Gimp,
        },
        bbar: m.bbar,
        contact: m.contact,
        points: 0,
    };
    let top = b
        .pos
        .iter()
        .zip(&b.radius)
        .map(|(p, r)| p.y + r)
        .fold(0.0, f64::max);
    let probe = packing(
        &g,
        &params(&g, 0.0, 0.0, 0.0, 1.0, None, None),
        &g.centres,
        top,
    )?;
    g.points = probe.point_count();
    let summary = format!(
        "{n} grains, {} material points, h_g = {:.3e} m (Δr/R = {} of the mean radius)",
        g.points, g.cell, g.resolution
    );
    Ok((g, summary))
}

fn params(
    g: &MpmPackingGrains,
    friction: f64,
    wall_friction: f64,
    gravity: f64,
    wall_velocity: f64,
    time_step: Option<f64>,
    newton_tolerance: Option<f64>,
) -> PackingParams {
    let mut solver = SolverParams {
        shape: g.shape,
        bbar: g.bbar,
        ..SolverParams::default()
    };
    solver.newton.tol_residual = newton_tolerance.unwrap_or(COUPLING_TOLERANCE);
    PackingParams {
        material: g.material,
        solver,
        cell: g.cell,
        friction,
        contact: g.contact,
        wall_friction,
        gravity,
        wall_velocity,
        travel_per_step: time_step.map_or(TRAVEL_PER_STEP, |dt| dt * wall_velocity / g.cell),
        nlgs: NlgsParams::for_packing(g.contact, friction),
    }
}

fn packing(
    g: &MpmPackingGrains,
    p: &PackingParams,
    centres: &[[f64; 2]],
    h0: f64,
) -> Result<Packing, String> {
    let c: Vec<Vector2<f64>> = centres.iter().map(|c| Vector2::new(c[0], c[1])).collect();
    Packing::new(p.clone(), &c, &g.radii, g.box_width, h0).map_err(|e| e.to_string())
}

/// What a snapshot holds: everything needed to continue bit for bit.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Running {
    pk: Packing,
    geometry: BoxGeometry,
    frames: FrameLog,
    rows: Vec<Row>,
    figures: PackingFigures,
    mass0: f64,
    /// Σ v_p at the start (m²).
    area0: f64,
    /// Sums over the current recording interval: wall forces (bottom, top, left, right),
    /// coupling iterations, steps; the worst gap, the contact solves, and the grains' stress
    /// and the pairs' moment over the box (`Row::sigma_box`, `Row::sigma_lever`).
    forces: [f64; 4],
    iterations: u64,
    since: u64,
    min_gap: f64,
    /// Where `min_gap` was (its `overlap` and `strain` filled at the row).
    deepest: OverlapSite,
    solves: SolveTally,
    stress: f64,
    lever: f64,
    touched_top: bool,
}

pub fn compact(
    p: &Pipeline,
    mu: f64,
    g: &MpmPackingGrains,
    ctx: &StageCtx,
) -> Result<(PackingCompacted, String), String> {
    let c = p.compact.as_ref().expect("planned with a compact section");
    let mut continued = None;
    let mut st = match ctx.load_snapshot::<Running>() {
        Some(st) => st,
        None => match ctx.load_continuation::<Running>() {
            Some(st) if st.pk.strain() < c.final_strain - 1e-12 => {
                continued = Some(st.pk.strain());
                st
            }
            _ => {
                let centres: Vec<V2> = g.centres.iter().map(|c| V2::new(c[0], c[1])).collect();
                // MPM seeding gives Σ v_p = π R² per grain exactly: the nominal areas are Φ's
                let area: f64 = g.radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
                let (moved, geometry) = compaction::unjammed_layout(
                    &centres,
                    &g.radii,
                    &g.radii,
                    area,
                    g.box_width,
                    c.initial_phi,
                )?;
                let moved: Vec<[f64; 2]> = moved.iter().map(|c| [c.x, c.y]).collect();
                let prm = params(
                    g,
                    mu,
                    c.wall_friction,
                    c.gravity,
                    c.wall_velocity,
                    c.time_step,
                    c.newton_tolerance,
                );
                let pk = packing(g, &prm, &moved, geometry.h0)?;
                Running {
                    mass0: pk.total_mass(),
                    area0: pk.grain_area(),
                    figures: PackingFigures {
                        time_step: pk.dt,
                        ..PackingFigures::default()
                    },
                    pk,
                    geometry,
                    frames: FrameLog::particles(),
                    rows: Vec::new(),
                    forces: [0.0; 4],
                    iterations: 0,
                    since: 0,
                    min_gap: 0.0,
                    deepest: OverlapSite::default(),
                    solves: SolveTally::default(),
                    stress: 0.0,
                    lever: 0.0,
                    touched_top: false,
                }
            }
        },
    };
    let io = |e: std::io::Error| format!("writing output in {}: {e}", ctx.dir.display());
    let bar = ctx.progress("compact", (c.final_strain * 1e4) as u64);
    let every = p.output.every_for(Method::Mpm).max(1);
    // wall seconds of this run outside the steps: the per-step measures, the rows and
    // frames, the snapshots (`stage.json`'s `timings_s`, with the steps' own parts)
    let (mut measures, mut rows, mut snapshots) = (0.0, 0.0, 0.0);
    let mut clock = Instant::now();
    // the state at ε = 0 is the first row, as in the BPM stage (its Φ is Φ0 to round-off)
    if st.rows.is_empty() {
        record(p, ctx, &mut st, mu).map_err(io)?;
    }
    rows += lap(&mut clock);
    while st.pk.strain() < c.final_strain - 1e-12 {
        let report = st.pk.step().map_err(|e| e.to_string())?;
        clock = Instant::now(); // the step times its own parts (`Packing::phases`)
        let walls = &st.pk.walls;
        for (k, w) in [0, TOP, 1, 2].into_iter().enumerate() {
            st.forces[k] += walls[w].normal_force();
        }
        st.iterations += report.iterations as u64;
        // over this step's box: -Σ v_p σ_yy,p and the pairs' moment, per unit area
        let area = st.pk.width * st.pk.height();
        st.stress -= st.pk.stress_integral()[(1, 1)] / area;
        st.lever += st.pk.contact_moments().1[(1, 1)] / area;
        measures += lap(&mut clock);
        st.since += 1;
        if report.min_gap < st.min_gap {
            st.min_gap = report.min_gap;
            let [a, b] = report.min_gap_grains;
            st.deepest = OverlapSite {
                at: report.min_gap_at,
                grains: [a as u32, b as u32],
                ..OverlapSite::default()
            };
        }
        let f = &mut st.figures;
        f.steps += 1;
        // summed here, over the steps at the end (the rows' means would count the ε = 0 row)
        f.iterations_mean += report.iterations as f64;
        f.iterations_max = f.iterations_max.max(report.iterations as u64);
        let kept_converged = report.kept_unconverged == 0;
        st.solves.add(report.residual, kept_converged);
        f.unconverged_steps += u64::from(!kept_converged);
        f.stopped_solves += report.nlgs_unconverged as u64;
        f.splits += report.splits;
        f.halvings += report.halvings;
        f.factorisations += report.factorisations as u64;
        f.indefinite += report.indefinite as u64;
        f.sweeps += report.sweeps as u64;
        st.touched_top |= walls[TOP].contacts > 0;
        let strain = st.pk.strain();
        bar.set((strain * 1e4) as u64, format!("ε = {strain:.3}"));
        let steps = st.pk.steps;
        if steps % every == 0 {
            record(p, ctx, &mut st, mu).map_err(io)?;
        }
        rows += lap(&mut clock);
        if p.output.snapshot_every > 0 && steps % p.output.snapshot_every == 0 {
            ctx.save_snapshot(&st, &bar).map_err(io)?;
            // the rows so far, readable while the run goes on (as the BPM stage does)
            ctx.write("timeseries.csv", compaction::csv(&st.rows).as_bytes())
                .map_err(io)?;
        }
        snapshots += lap(&mut clock);
        if ctx.interrupted() {
            ctx.save_snapshot(&st, &bar).map_err(io)?;
            return Err(crate::pipeline::INTERRUPTED.into());
        }
    }
    ctx.save_continuation(&st, |s: &Running| s.pk.strain())
        .map_err(io)?;
    snapshots += lap(&mut clock);
    if st.since > 0 {
        record(p, ctx, &mut st, mu).map_err(io)?;
    }
    rows += lap(&mut clock);
    ctx.note_times(
        &st.pk.phases().named(),
        &[
            ("measures", measures),
            ("rows", rows),
            ("snapshots", snapshots),
        ],
    );
    bar.finish();
    ctx.write("timeseries.csv", compaction::csv(&st.rows).as_bytes())
        .map_err(io)?;
    let f = &mut st.figures;
    let steps = f.steps.max(1);
    f.iterations_mean /= steps as f64;
    f.mass_change = Some((st.pk.total_mass() - st.mass0).abs() / st.mass0);
    f.inertial_max = compaction::max_after_jamming(&st.rows, |r| r.inertial);
    f.overlap_max_loaded = compaction::max_after_jamming(&st.rows, |r| r.overlap);
    f.point_overlap_max_loaded = Some(compaction::max_after_jamming(&st.rows, |r| r.point_overlap));
    let last = st.rows.last().cloned().unwrap_or_default();
    let summary = format!(
        "{} grains, {} points, {} steps of {:.2e} s, {:.1} coupling iterations/step, {}, worst overlap {:.2} h_g{} ({:.2} once loaded), area under two grains {:.2}% (at most {:.2}%), points inside another grain {:.2}% (at most {:.2}%), deepest point pair {:.2} h_g{} ({:.2} once loaded), grain area within {:.2}%{}",
        st.pk.grains.len(),
        st.pk.point_count(),
        steps,
        st.pk.dt,
        f.iterations_mean,
        last.state(),
        f.overlap_max,
        f.overlap_site.note(),
        f.overlap_max_loaded,
        100.0 * last.overlap_area,
        100.0 * f.overlap_area_max,
        100.0 * last.points_inside,
        100.0 * f.points_inside_max,
        f.point_overlap_max.unwrap_or(0.0),
        f.point_overlap_site.map_or(String::new(), |s| s.note()),
        f.point_overlap_max_loaded.unwrap_or(0.0),
        100.0 * f.area_change,
        f.unconverged_note()
    );
    let h = st.pk.grid.h;
    let particles = st
        .pk
        .grains
        .iter()
        .enumerate()
        .flat_map(|(k, gr)| {
            gr.x.iter().map(move |x| Particle {
                pos: [x.x, x.y],
                size: gr.half_size,
                grain: k as u32,
            })
        })
        .collect();
    let network = st
        .pk
        .contacts
        .iter()
        .map(|c| {
            let (a, b) = (
                c.position - c.normal * (0.5 * h),
                c.position + c.normal * (0.5 * h),
            );
            ForceLine {
                a: [a.x, a.y],
                b: [b.x, b.y],
                force: c.force_n,
                between_grains: matches!(c.partner, Partner::Grain(_)),
            }
        })
        .collect();
    Ok((
        PackingCompacted {
            method: Method::Mpm,
            friction: mu,
            geometry: st.geometry,
            grains: st.pk.grains.len(),
            rows: st.rows,
            particles,
            network,
            figures: st.figures,
        },
        compaction::continued(summary, continued),
    ))
}

/// Closes the recording interval: one row, and one frame of the points.
fn record(p: &Pipeline, ctx: &StageCtx, st: &mut Running, mu: f64) -> std::io::Result<()> {
    let pk = &st.pk;
    let n = st.since.max(1) as f64;
    let (pairs, walls) = pk.contact_pairs();
    let z = compaction::coordination(
        pk.grains.len(),
        &pairs,
        &walls,
        if mu > 0.0 { 2 } else { 3 },
    );
    let (width, height) = (pk.width, pk.height());
    let ke = pk.kinetic_energy();
    let scale = compaction::GrainScale::new(pk.grains.len(), st.area0, st.mass0);
    let strain_rate = pk.params.wall_velocity / height;
    let pair = overlap::deepest_pair(&pk.grains);
    let mut row = Row {
        time: pk.time,
        strain: pk.strain(),
        phi: pk.phi(),
        z: z.z,
        z_star: z.z_star,
        sigma: st.forces[0] / n / width,
        sigma_top: st.forces[1] / n / width,
        sigma_left: st.forces[2] / n / height,
        sigma_right: st.forces[3] / n / height,
        grain_contacts: z.pairs,
        rattlers: z.rattlers,
        iterations: st.iterations as f64 / n,
        kinetic_ratio: ke / (pk.elastic_energy() + 1e-30),
        overlap: (-st.min_gap).max(0.0) / pk.grid.h,
        overlap_area: overlap::shared_area(&pk.grains),
        points_inside: overlap::points_inside(&pk.grains) as f64 / pk.point_count() as f64,
        point_overlap: pair.depth / pk.grid.h,
        inertial: f64::NAN,
        sigma_box: st.stress / n,
        sigma_lever: st.lever / n,
        residual: st.solves.residual,
        unconverged: st.solves.unconverged,
    };
    row.inertial = scale.inertial_number(strain_rate, row.pressure());
    let pair = OverlapSite {
        at: [pair.at.x, pair.at.y],
        grains: pair.grains.map(|g| g as u32),
        ..OverlapSite::default()
    };
    st.figures
        .fold(&row, st.deepest, Some(pair), pk.grain_area() / st.area0);
    if st.touched_top {
        st.figures.kinetic_ratio_max = st.figures.kinetic_ratio_max.max(row.kinetic_ratio);
    }
    st.rows.push(row);
    (st.forces, st.iterations, st.since, st.min_gap) = ([0.0; 4], 0, 0, 0.0);
    st.deepest = OverlapSite::default();
    st.solves = SolveTally::default();
    (st.stress, st.lever) = (0.0, 0.0);
    if p.output.vtk {
        write_frame(ctx, st)?;
    }
    Ok(())
}

/// A frame of the points: `grain_id`, `volume`, `velocity`, `stress` (3x3 with σzz) and
/// `von_mises`.
fn write_frame(ctx: &StageCtx, st: &mut Running) -> std::io::Result<()> {
    let gs = &st.pk.grains;
    let points: Vec<[f64; 2]> = gs
        .iter()
        .flat_map(|g| g.x.iter().map(|p| [p.x, p.y]))
        .collect();
    let vel: Vec<[f64; 2]> = gs
        .iter()
        .flat_map(|g| g.v.iter().map(|v| [v.x, v.y]))
        .collect();
    let volume: Vec<f64> = gs.iter().flat_map(|g| g.vol.iter().copied()).collect();
    let stress: Vec<[f64; 4]> = gs
        .iter()
        .flat_map(|g| g.stress.iter().map(|t| [t.xx, t.xy, t.xy, t.yy]))
        .collect();
    let zz: Vec<f64> = gs
        .iter()
        .flat_map(|g| g.stress.iter().map(|t| t.zz))
        .collect();
    let grain: Vec<i32> = gs
        .iter()
        .enumerate()
        .flat_map(|(k, g)| std::iter::repeat_n(k as i32, g.len()))
        .collect();
    let frame = Frame::new(&points)
        .with("grain_id", Data::Int(&grain))
        .with("volume", Data::Scalar(&volume))
        .with("velocity", Data::Vector(&vel))
        .with("stress", Data::tensor_zz(&stress, &zz));
    st.frames.write(&ctx.dir, st.pk.time, &frame)
}
