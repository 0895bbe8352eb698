//! Stages: thin glue from a config section and the upstream states to an engine call and a
//! new state. Each stage's output is one variant of `StageState`, the checkpoint payload.

pub mod analyse;
pub mod bpm_packing;
pub mod compact;
pub mod discretise;
pub mod frames;
pub mod mpm_packing;
pub mod mpm_single;
pub mod prepare;

use crate::cd::{CdParams, NlgsParams};
use crate::config::{Layout, Method, Pipeline, Solver};
use crate::geom::V2;
use crate::pipeline::{Node, Stage, StageCtx};
use serde::{Deserialize, Serialize};

/// The state a stage node produces (what its checkpoint holds).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum StageState {
    Prepared(prepare::Prepared),
    Bpm(discretise::BpmGrains),
    Compacted(compact::Compacted),
    Mpm(mpm_single::MpmGrain),
    MpmCompacted(mpm_single::MpmCompacted),
    /// A compacted packing, either method.
    Packing(crate::compaction::PackingCompacted),
    /// The disks of a packing to become MPM grains (last: checkpoints keep their variant
    /// numbers).
    MpmPacking(mpm_packing::MpmPackingGrains),
    /// The analysis of every case (its files are under `analyse/`).
    Analysed(analyse::Analysed),
}

impl StageState {
    /// The state's key figures, for `stage.json`.
    pub fn figures(&self) -> serde_json::Value {
        match self {
            StageState::Prepared(p) => serde_json::to_value(&p.figures).unwrap_or_default(),
            StageState::Bpm(g) => serde_json::to_value(&g.figures).unwrap_or_default(),
            StageState::Compacted(c) => serde_json::to_value(&c.figures).unwrap_or_default(),
            StageState::Mpm(g) => serde_json::to_value(g).unwrap_or_default(),
            StageState::MpmPacking(g) => serde_json::json!({
                "grains": g.radii.len(),
                "points": g.points,
                "cell": g.cell,
                "resolution": g.resolution,
            }),
            StageState::Packing(c) => serde_json::to_value(&c.figures).unwrap_or_default(),
            StageState::MpmCompacted(c) => {
                serde_json::json!({"stats": c.stats, "small_strain": c.small_strain})
            }
            StageState::Analysed(a) => serde_json::json!({
                "summary": serde_json::from_str::<serde_json::Value>(&a.summary_json).unwrap_or_default(),
                "files": a.files,
            }),
        }
    }
}

/// Contact-dynamics settings from the solver section: lengths in units of the smallest
/// diameter `d_min`, gravity along -y.
pub(crate) fn cd_params(solver: &Solver, dt: f64, gravity: f64, d_min: f64) -> CdParams {
    CdParams {
        dt,
        theta: solver.theta,
        gravity: V2::new(0.0, -gravity),
        alert: solver.alert * d_min,
        skin: solver.skin * d_min,
        nlgs: NlgsParams {
            tol: solver.tolerance,
            check_every: solver.check_every,
            max_iter: solver.max_iterations,
            relax: solver.relaxation,
            anderson: solver.anderson,
            islands: solver.islands,
        },
        sleep: None,
    }
}

/// Whether this build can run a node; a node it cannot is refused before any work starts,
/// never faked.
pub fn supported(p: &Pipeline, node: &Node) -> Result<(), String> {
    match node.stage {
        Stage::Prepare | Stage::Analyse => Ok(()),
        Stage::Discretise | Stage::Compact if p.prepare.layout == Layout::Explicit => Err(format!(
            "the {} stage needs grains (prepare.layout packing or single); an explicit scene holds rigid disks only",
            node.stage.name()
        )),
        Stage::Discretise | Stage::Compact => Ok(()),
    }
}

/// Runs one node; returns its state and a one-line summary, or why it failed.
pub fn run(
    p: &Pipeline,
    node: &Node,
    upstream: &[&StageState],
    ctx: &StageCtx,
) -> Result<(StageState, String), String> {
    match (node.stage, upstream) {
        (Stage::Prepare, _) => {
            let (state, summary) = prepare::run(p, ctx)?;
            Ok((StageState::Prepared(state), summary))
        }
        (Stage::Discretise, [StageState::Prepared(prep)])
            if node.method == Some(Method::Mpm) && prep.layout == Layout::Packing =>
        {
            let m = p
                .discretise
                .as_ref()
                .and_then(|d| d.mpm.as_ref())
                .expect("validated");
            let (g, summary) = mpm_packing::discretise(m, prep)?;
            Ok((StageState::MpmPacking(g), summary))
        }
        (Stage::Discretise, [StageState::Prepared(prep)]) if node.method == Some(Method::Mpm) => {
            let m = p
                .discretise
                .as_ref()
                .and_then(|d| d.mpm.as_ref())
                .expect("validated");
            let (g, summary) = mpm_single::discretise(m, prep.bodies.radius[0])?;
            Ok((StageState::Mpm(g), summary))
        }
        (Stage::Discretise, [StageState::Prepared(prep)]) => {
            let d = p
                .discretise
                .as_ref()
                .expect("planned from the discretise section");
            let bpm = d.bpm.as_ref().expect("validated");
            let range: [f64; 2] =
                serde_json::from_value(node.params["bpm"]["particle_diameter"].clone())
                    .map_err(|e| format!("bad planned parameters: {e}"))?;
            let (g, summary) = discretise::run_bpm(p, bpm, range, prep, ctx)?;
            Ok((StageState::Bpm(g), summary))
        }
        (Stage::Compact, [StageState::Bpm(g)]) if g.layout == Layout::Packing => {
            let mu = node.friction().expect("a compact node has its friction");
            let (c, summary) = bpm_packing::run(p, mu, g, ctx)?;
            Ok((StageState::Packing(c), summary))
        }
        (Stage::Compact, [StageState::Bpm(g)]) => {
            let mu = node.friction().expect("a compact node has its friction");
            let (c, summary) = compact::run_bpm(p, mu, g, ctx)?;
            Ok((StageState::Compacted(c), summary))
        }
        (Stage::Compact, [StageState::MpmPacking(g)]) => {
            let mu = node.friction().expect("a compact node has its friction");
            let (c, summary) = mpm_packing::compact(p, mu, g, ctx)?;
            Ok((StageState::Packing(c), summary))
        }
        (Stage::Compact, [StageState::Mpm(g)]) => {
            let (c, summary) = mpm_single::compact(p, g, ctx)?;
            Ok((StageState::MpmCompacted(c), summary))
        }
        (Stage::Analyse, states) => {
            let a = p
                .analyse
                .as_ref()
                .expect("planned from the analyse section");
            let (s, summary) = analyse::run(p, a, &analyse::inputs(ctx, states), &ctx.dir)?;
            Ok((StageState::Analysed(s), summary))
        }
        (stage, _) => Err(format!(
            "the {} stage cannot run on this upstream state",
            stage.name()
        )),
    }
}
