//! Stages: thin glue from a config section and the upstream states to an engine call and a
//! new state. Each stage's output is one variant of `StageState`, the checkpoint payload.

pub mod frames;
pub mod prepare;

use crate::config::Pipeline;
use crate::pipeline::{Node, Stage, StageCtx};
use serde::{Deserialize, Serialize};

/// The state a stage node produces (what its checkpoint holds).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum StageState {
    Prepared(prepare::Prepared),
}

impl StageState {
    /// The state's key figures, for `stage.json`.
    pub fn figures(&self) -> serde_json::Value {
        match self {
            StageState::Prepared(p) => serde_json::to_value(&p.figures).unwrap_or_default(),
        }
    }
}

/// Runs one node; returns its state and a one-line summary, or why it failed.
pub fn run(
    p: &Pipeline,
    node: &Node,
    _upstream: &[&StageState],
    ctx: &StageCtx,
) -> Result<(StageState, String), String> {
    match node.stage {
        Stage::Prepare => {
            let (state, summary) = prepare::run(p, ctx)?;
            Ok((StageState::Prepared(state), summary))
        }
        other => Err(format!("the {} stage is not built", other.name())),
    }
}
