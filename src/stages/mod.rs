//! Stages: thin glue from a config section and the upstream states to an engine call and a
//! new state. Each stage's output is one variant of `StageState`, the checkpoint payload.

pub mod compact;
pub mod discretise;
pub mod frames;
pub mod prepare;

use crate::config::Pipeline;
use crate::pipeline::{Node, Stage, StageCtx};
use serde::{Deserialize, Serialize};

/// The state a stage node produces (what its checkpoint holds).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum StageState {
    Prepared(prepare::Prepared),
    Bpm(discretise::BpmGrains),
    Compacted(compact::Compacted),
}

impl StageState {
    /// The state's key figures, for `stage.json`.
    pub fn figures(&self) -> serde_json::Value {
        match self {
            StageState::Prepared(p) => serde_json::to_value(&p.figures).unwrap_or_default(),
            StageState::Bpm(g) => serde_json::to_value(&g.figures).unwrap_or_default(),
            StageState::Compacted(c) => serde_json::to_value(&c.figures).unwrap_or_default(),
        }
    }
}

/// Whether this build can run a node; a node it cannot is refused before any work starts,
/// never faked.
pub fn supported(node: &Node) -> Result<(), String> {
    let mpm = node.case.starts_with("mpm");
    match node.stage {
        Stage::Prepare => Ok(()),
        Stage::Discretise | Stage::Compact if !mpm => Ok(()),
        Stage::Discretise | Stage::Compact => Err(format!(
            "the MPM {} stage is not built in this version",
            node.stage.name()
        )),
        Stage::Analyse => Err("the analyse stage is not built in this version".into()),
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
        (Stage::Discretise, [StageState::Prepared(prep)]) => {
            let d = p
                .discretise
                .as_ref()
                .expect("planned from the discretise section");
            let bpm = d.bpm.as_ref().expect("validated");
            let range: [f64; 2] = serde_json::from_value(node.params["particle_diameter"].clone())
                .map_err(|e| format!("bad planned parameters: {e}"))?;
            let (g, summary) = discretise::run_bpm(p, bpm, range, prep, ctx)?;
            Ok((StageState::Bpm(g), summary))
        }
        (Stage::Compact, [StageState::Bpm(g)]) => {
            let mu = node.params["friction"].as_f64().unwrap_or(0.0);
            let (c, summary) = compact::run_bpm(p, mu, g, ctx)?;
            Ok((StageState::Compacted(c), summary))
        }
        (stage, _) => Err(format!(
            "the {} stage cannot run on this upstream state",
            stage.name()
        )),
    }
}
