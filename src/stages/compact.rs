//! The compact stage for one BPM grain: a top plate moves down at constant speed onto the
//! grain until the cumulative
//! strain ε = ln(h0/h) reaches `compact.final_strain`. Plate forces are impulses summed over
//! each recording interval divided by its duration (mean forces: single CD steps are noisy).

use super::discretise::BpmGrains;
use super::frames::FrameLog;
use crate::bpm::{BpmLaw, measure};
use crate::cd::{LawTable, Scene};
use crate::config::{Compact, Pipeline, defaults};
use crate::geom::{V2, Wall};
use crate::pipeline::StageCtx;
use crate::timing::lap;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::time::Instant;

/// One recorded row.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub time: f64,
    pub strain: f64,
    /// Mean force on the bottom plate over the interval (N/m, compression positive).
    pub force: f64,
    pub force_top: f64,
    /// Largest horizontal width of the grains (m).
    pub width: f64,
    /// force / width (Pa) for a single grain, force / box width for a packing.
    pub sigma: f64,
    /// Grain area by closing (single grain; m²).
    pub area: f64,
    pub escaped: usize,
    pub nlgs_iterations: f64,
    /// Cohesive prestress σ_c of the grain (single grain; Pa): `GrainStress::prestress`.
    pub sigma_c: f64,
    /// Mobilised friction of its contact network: `GrainStress::mobilised_friction`.
    pub sin_phi: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Compacted {
    pub rows: Vec<Row>,
    pub final_particles: crate::cd::Bodies,
    pub figures: CompactFigures,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompactFigures {
    pub steps: u64,
    pub time_step: f64,
    pub t0: f64,
    pub mean_a0: f64,
    pub f0: f64,
    pub nlgs_iterations: u64,
    pub unconverged_steps: u64,
    pub contact_updates: u64,
    /// Mean σ <a0>/F0 over ε in [0.1, final] (single grain: the plastic plateau).
    pub plateau: f64,
    /// Means over the same rows of σ_c <a0>/F0 and of the mobilised friction (single grain).
    pub plateau_prestress: f64,
    pub plateau_sin_phi: f64,
    /// Slope dσ/dε below ε = 0.02 (Pa).
    pub small_strain_slope: f64,
    /// Largest relative change of the grain area during the test (single grain).
    pub area_change: f64,
    pub escaped_max: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct Running {
    scene: Scene<BpmLaw>,
    h0: f64,
    top: usize,
    rows: Vec<Row>,
    frames: FrameLog,
    contact_frames: FrameLog,
    impulse_bottom: f64,
    impulse_top: f64,
    since_record: u64,
    iterations_since: u64,
    figures: CompactFigures,
}

fn new_run(
    p: &Pipeline,
    c: &Compact,
    mu: f64,
    g: &BpmGrains,
    beyond_step_limit: bool,
) -> Result<Running, String> {
    let b = &g.bodies;
    let top_y = (0..b.len())
        .map(|i| b.pos[i].y + b.radius[i])
        .fold(f64::NEG_INFINITY, f64::max);
    let bot_y = (0..b.len())
        .map(|i| b.pos[i].y - b.radius[i])
        .fold(f64::INFINITY, f64::min);
    let (lo_x, hi_x) = (
        (0..b.len())
            .map(|i| b.pos[i].x)
            .fold(f64::INFINITY, f64::min),
        (0..b.len())
            .map(|i| b.pos[i].x)
            .fold(f64::NEG_INFINITY, f64::max),
    );
    let span = hi_x - lo_x + top_y - bot_y;
    // plates far wider than the grain will ever get
    let walls = vec![
        Wall::new(
            V2::new(lo_x - 2.0 * span, bot_y),
            V2::new(hi_x + 2.0 * span, bot_y),
        ),
        Wall {
            a: V2::new(hi_x + 2.0 * span, top_y),
            b: V2::new(lo_x - 2.0 * span, top_y),
            velocity: V2::new(0.0, -c.wall_velocity),
        },
    ];
    let (f0, t0) = match g.law {
        BpmLaw::Cohesive { f0, .. } => (f0, super::discretise::t0(b, f0)),
        BpmLaw::Coulomb { .. } => return Err("the grains carry no cohesive law".into()),
    };
    let dt = c.time_step.unwrap_or(defaults::BPM_STEP * t0);
    if dt > 0.5 * t0 && !beyond_step_limit {
        return Err(format!(
            "compact.time_step = {dt:e} s is above the stability limit of the explicit attraction, 0.5 t0 = {:e} s",
            0.5 * t0
        ));
    }
    let d_min = 2.0 * b.radius.iter().cloned().fold(f64::INFINITY, f64::min);
    let params = super::cd_params(&p.compact_solver(), dt, c.gravity, d_min);
    let top = walls.len() - 1;
    let wall_laws = vec![
        BpmLaw::Coulomb {
            mu: c.wall_friction
        };
        walls.len()
    ];
    let laws = LawTable::new(g.law, BpmLaw::Coulomb { mu }, wall_laws);
    let scene = Scene::new(b.clone(), walls, laws, params, p.seed);
    Ok(Running {
        scene,
        h0: top_y - bot_y,
        top,
        rows: Vec::new(),
        frames: FrameLog::particles(),
        contact_frames: FrameLog::new("contacts", "contacts.pvd"),
        impulse_bottom: 0.0,
        impulse_top: 0.0,
        since_record: 0,
        iterations_since: 0,
        figures: CompactFigures {
            time_step: dt,
            t0,
            mean_a0: g.figures.mean_a0,
            f0,
            ..Default::default()
        },
    })
}

fn gap(st: &Running) -> f64 {
    st.scene.walls[st.top].a.y - st.scene.walls[0].a.y
}

pub fn run_bpm(
    p: &Pipeline,
    mu: f64,
    g: &BpmGrains,
    ctx: &StageCtx,
) -> Result<(Compacted, String), String> {
    let c = p.compact.as_ref().expect("planned with a compact section");
    let mut st = match ctx.load_snapshot::<Running>() {
        Some(st) => st,
        None => new_run(p, c, mu, g, ctx.beyond_step_limit)?,
    };
    let cutoff = match g.law {
        BpmLaw::Cohesive { cutoff, .. } => cutoff,
        BpmLaw::Coulomb { .. } => 0.0,
    };
    let io = |e: std::io::Error| format!("writing output in {}: {e}", ctx.dir.display());
    let bar = ctx.progress("compact", (c.final_strain * 1e4) as u64);
    let every = p.output.every.max(1);
    // where the time goes, for stage.json (the step times its own parts, `Scene::phases`)
    let (mut rows, mut snapshots) = (0.0, 0.0);
    let mut clock = Instant::now();
    if st.rows.is_empty() {
        record(p, ctx, &mut st, cutoff).map_err(io)?;
    }
    rows += lap(&mut clock);
    while (st.h0 / gap(&st)).ln() < c.final_strain {
        let r = st.scene.step().map_err(|e| e.to_string())?;
        clock = Instant::now();
        let h = st.scene.params.dt;
        st.impulse_bottom += st.scene.wall_force[0].y * h;
        st.impulse_top -= st.scene.wall_force[st.top].y * h;
        st.since_record += 1;
        st.iterations_since += r.nlgs.iterations as u64;
        let f = &mut st.figures;
        f.steps += 1;
        f.nlgs_iterations += r.nlgs.iterations as u64;
        f.unconverged_steps += u64::from(!r.nlgs.converged);
        f.contact_updates += r.updates;
        if st.scene.steps % every == 0 {
            record(p, ctx, &mut st, cutoff).map_err(io)?;
            let strain = st.rows.last().map_or(0.0, |r| r.strain);
            bar.set((strain * 1e4) as u64, format!("ε = {strain:.3}"));
        }
        rows += lap(&mut clock);
        if p.output.snapshot_every > 0 && st.scene.steps % p.output.snapshot_every == 0 {
            ctx.save_snapshot(&st, &bar).map_err(io)?;
            // the rows so far, for a look at a long run while it goes on
            ctx.write("timeseries.csv", csv(&st.rows).as_bytes())
                .map_err(io)?;
        }
        snapshots += lap(&mut clock);
        if ctx.interrupted() {
            ctx.save_snapshot(&st, &bar).map_err(io)?;
            return Err(crate::pipeline::INTERRUPTED.into());
        }
    }
    if st.since_record > 0 {
        record(p, ctx, &mut st, cutoff).map_err(io)?;
    }
    rows += lap(&mut clock);
    ctx.note_times(
        &st.scene.phases().named(),
        &[("rows", rows), ("snapshots", snapshots)],
    );
    bar.finish();
    finish(ctx, st)
}

/// Closes a recording interval: a row of the time series, a VTK frame of the particles and
/// one of the contact-force network.
fn record(p: &Pipeline, ctx: &StageCtx, st: &mut Running, cutoff: f64) -> std::io::Result<()> {
    let b = &st.scene.bodies;
    let dt = st.since_record as f64 * st.scene.params.dt;
    let (force, force_top) = if dt > 0.0 {
        (st.impulse_bottom / dt, st.impulse_top / dt)
    } else {
        (0.0, 0.0)
    };
    let width = measure::width(&b.pos, &b.radius);
    let r_max = b.max_radius();
    let area = measure::closed_area(
        &b.pos,
        &b.radius,
        r_max,
        2.0 * b.radius.iter().cloned().fold(f64::INFINITY, f64::min) / 8.0,
    );
    let internal = measure::GrainStress::of(&st.scene, area);
    let row = Row {
        time: st.scene.time,
        strain: (st.h0 / gap(st)).ln(),
        force,
        force_top,
        width,
        sigma: force / width,
        area,
        escaped: measure::escaped(b, cutoff),
        nlgs_iterations: st.iterations_since as f64 / st.since_record.max(1) as f64,
        sigma_c: internal.prestress(),
        sin_phi: internal.mobilised_friction(),
    };
    st.rows.push(row);
    st.impulse_bottom = 0.0;
    st.impulse_top = 0.0;
    st.since_record = 0;
    st.iterations_since = 0;
    if p.output.vtk {
        st.frames.write_disks(&ctx.dir, st.scene.time, b)?;
        st.contact_frames.write_network(&ctx.dir, &st.scene)?;
    }
    Ok(())
}

fn csv(rows: &[Row]) -> String {
    let mut csv = String::from(
        "time,strain,force,width,sigma,force_top,area,escaped,nlgs_iterations,sigma_c,sin_phi\n",
    );
    for r in rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{}",
            r.time,
            r.strain,
            r.force,
            r.width,
            r.sigma,
            r.force_top,
            r.area,
            r.escaped,
            r.nlgs_iterations,
            r.sigma_c,
            r.sin_phi
        );
    }
    csv
}

fn finish(ctx: &StageCtx, st: Running) -> Result<(Compacted, String), String> {
    let mut f = st.figures;
    let rows = st.rows;
    let plateau: Vec<&Row> = rows.iter().filter(|r| r.strain >= 0.1).collect();
    let mean = |v: fn(&Row) -> f64| {
        plateau.iter().map(|r| v(r)).sum::<f64>() / plateau.len().max(1) as f64
    };
    f.plateau = mean(|r| r.sigma) * f.mean_a0 / f.f0;
    f.plateau_prestress = mean(|r| r.sigma_c) * f.mean_a0 / f.f0;
    f.plateau_sin_phi = mean(|r| r.sin_phi);
    // least-squares slope through the origin of σ(ε) below 2% strain
    let small: Vec<&Row> = rows
        .iter()
        .filter(|r| r.strain > 0.0 && r.strain <= 0.02)
        .collect();
    let sxx: f64 = small.iter().map(|r| r.strain * r.strain).sum();
    f.small_strain_slope =
        small.iter().map(|r| r.strain * r.sigma).sum::<f64>() / sxx.max(f64::MIN_POSITIVE);
    let a0 = rows.first().map_or(0.0, |r| r.area);
    f.area_change = rows
        .iter()
        .map(|r| (r.area / a0 - 1.0).abs())
        .fold(0.0, f64::max);
    f.escaped_max = rows.iter().map(|r| r.escaped).max().unwrap_or(0);
    ctx.write("timeseries.csv", csv(&rows).as_bytes())
        .map_err(|e| format!("writing output in {}: {e}", ctx.dir.display()))?;
    let summary = format!(
        "{} steps, {:.1} NLGS sweeps/step, plateau σ<a0>/F0 = {:.3} (prestress {:.3}, mobilised friction {:.3}), area change {:.1}%, {} escaped",
        f.steps,
        f.nlgs_iterations as f64 / f.steps.max(1) as f64,
        f.plateau,
        f.plateau_prestress,
        f.plateau_sin_phi,
        100.0 * f.area_change,
        f.escaped_max
    );
    Ok((
        Compacted {
            rows,
            final_particles: st.scene.bodies,
            figures: f,
        },
        summary,
    ))
}
