//! MPM grains in the pipeline: discretise records the material and resolution (the points
//! are seeded by the engine, deterministically), compact runs the implicit single-grain
//! compression between two plates (`crate::mpm::SingleGrain`).

use super::frames::FrameLog;
use crate::config::{Compact, Method, Model, Mpm, Pipeline, Shape};
use crate::io::vtk::{Data, Frame};
use crate::mpm::driver::{PointState, Row, RunStats, SingleGrain, SingleGrainParams};
use crate::mpm::material::{Material, MaterialKind};
use crate::mpm::shape::ShapeKind;
use crate::pipeline::StageCtx;
use crate::timing::lap;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// An MPM grain ready to compress.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MpmGrain {
    pub radius: f64,
    pub material: Material,
    pub resolution: f64,
    pub shape: ShapeKind,
    pub bbar: bool,
    pub points: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MpmCompacted {
    pub rows: Vec<Row>,
    pub points: PointState,
    /// Run statistics, with the wall time zeroed (it goes to stage.json) so equal inputs
    /// give equal checkpoints.
    pub stats: RunStats,
    pub small_strain: Vec<SmallStrain>,
}

/// The mean plate force at a small strain against the 2D elastic solution (Johnson §5.6,
/// METHODS.md §5) and its linearisation, the paper's Eq. 13.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SmallStrain {
    pub strain: f64,
    /// N/m, interpolated between recorded rows.
    pub force: f64,
    pub over_johnson: f64,
    pub over_eq13: f64,
}

/// Force/Johnson and force/Eq. 13 at ε = 0.02 and 0.05 (where the run reached them).
fn small_strain(rows: &[Row], g: &MpmGrain) -> Vec<SmallStrain> {
    let (e, nu, r) = (g.material.young, g.material.poisson, g.radius);
    [0.02, 0.05]
        .into_iter()
        .filter_map(|eps| {
            let k = rows.iter().position(|row| row.strain >= eps)?;
            let force_at = |row: &Row| 0.5 * (row.force_top + row.force_bottom);
            let force = if k == 0 {
                force_at(&rows[0]) * eps / rows[0].strain
            } else {
                let (a, b) = (&rows[k - 1], &rows[k]);
                let w = (eps - a.strain) / (b.strain - a.strain);
                (1.0 - w) * force_at(a) + w * force_at(b)
            };
            let johnson = crate::mpm::analytic::johnson_force(e, nu, r, eps)?;
            Some(SmallStrain {
                strain: eps,
                force,
                over_johnson: force / johnson,
                over_eq13: force / crate::mpm::analytic::eq13_force(e, nu, r, eps),
            })
        })
        .collect()
}

fn params(g: &MpmGrain, c: &Compact) -> SingleGrainParams {
    let mut p = SingleGrainParams::paper();
    p.radius = g.radius;
    p.material = g.material;
    p.resolution = g.resolution;
    p.solver.shape = g.shape;
    p.solver.bbar = g.bbar;
    p.wall_velocity = c.wall_velocity;
    p.final_strain = c.final_strain;
    p.wall_friction = c.wall_friction;
    if let Some(t) = c.newton_tolerance {
        p.solver.newton.tol_residual = t;
    }
    p
}

pub fn discretise(m: &Mpm, radius: f64) -> Result<(MpmGrain, String), String> {
    let material = Material {
        kind: match m.model {
            Model::LinearElastic => MaterialKind::LinearElastic,
            Model::NeoHookean => MaterialKind::NeoHookean,
        },
        young: m.young,
        poisson: m.poisson,
        density: m.density,
    };
    let mut g = MpmGrain {
        radius,
        material,
        resolution: m.resolution,
        shape: match m.shape {
            Shape::Bspline => ShapeKind::BSpline2,
            Shape::Bilinear => ShapeKind::Bilinear,
            Shape::Gimp => ShapeKind::Gimp,
        },
        bbar: m.bbar,
        points: 0,
    };
    // seed once to report the count (and fail early on bad parameters)
    let mut probe = SingleGrainParams::paper();
    probe.radius = radius;
    probe.material = material;
    probe.resolution = m.resolution;
    let seeded = SingleGrain::new(probe).map_err(|e| e.to_string())?;
    g.points = seeded.points.len();
    let summary = format!(
        "one grain, {} material points, Δr/R = {}",
        g.points, g.resolution
    );
    Ok((g, summary))
}

pub fn compact(
    p: &Pipeline,
    g: &MpmGrain,
    ctx: &StageCtx,
) -> Result<(MpmCompacted, String), String> {
    let c = p.compact.as_ref().expect("planned with a compact section");
    let mut run = match ctx.load_snapshot::<(SingleGrain, FrameLog)>() {
        Some(s) => s,
        None => (
            SingleGrain::new(params(g, c)).map_err(|e| e.to_string())?,
            FrameLog::particles(),
        ),
    };
    let io = |e: std::io::Error| format!("writing output in {}: {e}", ctx.dir.display());
    let bar = ctx.progress("compact", (c.final_strain * 1e4) as u64);
    let every = p.output.every_for(Method::Mpm).max(1);
    // this run's wall seconds by part (`stage.json`'s `timings_s`)
    let mut clock = std::time::Instant::now();
    let (mut stepping, mut frames, mut snapshots) = (0.0, 0.0, 0.0);
    if run.0.stats.steps == 0 && p.output.vtk {
        write_frame(ctx, &mut run).map_err(io)?;
    }
    frames += lap(&mut clock);
    while !run.0.is_done() {
        run.0.step().map_err(|e| e.to_string())?;
        let steps = run.0.stats.steps;
        bar.set(
            (run.0.strain() * 1e4) as u64,
            format!("ε = {:.3}", run.0.strain()),
        );
        stepping += lap(&mut clock);
        if p.output.vtk && steps % every == 0 {
            write_frame(ctx, &mut run).map_err(io)?;
        }
        frames += lap(&mut clock);
        if p.output.snapshot_every > 0 && steps % p.output.snapshot_every == 0 {
            ctx.save_snapshot(&run, &bar).map_err(io)?;
        }
        snapshots += lap(&mut clock);
        if ctx.interrupted() {
            ctx.save_snapshot(&run, &bar).map_err(io)?;
            return Err(crate::pipeline::INTERRUPTED.into());
        }
    }
    if p.output.vtk && run.0.stats.steps % every != 0 {
        write_frame(ctx, &mut run).map_err(io)?;
    }
    frames += lap(&mut clock);
    bar.finish();
    let mut result = run.0.result(false);
    result.stats.wall_seconds = 0.0;
    let mut csv = String::from("time,strain,force,width,sigma,force_top,newton_iterations\n");
    for r in &result.rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{}",
            r.time, r.strain, r.force_bottom, r.width, r.sigma, r.force_top, r.iterations
        );
    }
    ctx.write("timeseries.csv", csv.as_bytes()).map_err(io)?;
    let small = small_strain(&result.rows, g);
    ctx.note_times(
        &[],
        &[
            ("steps", stepping),
            ("frames", frames),
            ("snapshots", snapshots),
            ("rows", lap(&mut clock)),
        ],
    );
    let s = &result.stats;
    let at = |k: usize| {
        small
            .get(k)
            .map_or(f64::NAN, |x: &SmallStrain| x.over_johnson)
    };
    let summary = format!(
        "{} points, {} steps (Δt = {:.0} x CFL), {:.1} Newton iterations/step, F/Johnson {:.3} at 2% and {:.3} at 5%, σ(ε = {:.2}) = {:.3e} Pa",
        s.points,
        s.steps,
        s.dt / s.dt_cfl,
        s.newton_iterations as f64 / s.steps.max(1) as f64,
        at(0),
        at(1),
        result.rows.last().map_or(0.0, |r| r.strain),
        result.rows.last().map_or(0.0, |r| r.sigma)
    );
    Ok((
        MpmCompacted {
            rows: result.rows,
            points: result.points,
            stats: result.stats,
            small_strain: small,
        },
        summary,
    ))
}

/// A frame of the points: `grain_id`, `volume`, `velocity`, `stress` (3x3 with σzz) and
/// `von_mises` (paper Fig. 5d).
fn write_frame(ctx: &StageCtx, run: &mut (SingleGrain, FrameLog)) -> std::io::Result<()> {
    let s = run.0.point_state();
    let points: Vec<[f64; 2]> = s.position.iter().map(|p| [p.x, p.y]).collect();
    let vel: Vec<[f64; 2]> = s.velocity.iter().map(|v| [v.x, v.y]).collect();
    let stress: Vec<[f64; 4]> = s.stress.iter().map(|t| [t.xx, t.xy, t.xy, t.yy]).collect();
    let zz: Vec<f64> = s.stress.iter().map(|t| t.zz).collect();
    let grain = vec![0i32; points.len()];
    let frame = Frame::new(&points)
        .with("grain_id", Data::Int(&grain))
        .with("volume", Data::Scalar(&s.volume))
        .with("velocity", Data::Vector(&vel))
        .with("stress", Data::tensor_zz(&stress, &zz));
    run.1.write(&ctx.dir, run.0.time, &frame)
}
