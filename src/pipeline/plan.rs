//! The stage graph: prepare -> discretise -> compact -> analyse, fanned out into cases
//! (method x particle-size range x friction). Each node's name is blake3 over (stage kind,
//! format version, canonical parameters, upstream hashes; for analyse also its own version)
//! and nothing else, so equal work always has equal names and `--set` hashes exactly like an
//! edited file.

use super::codec::FORMAT_VERSION;
use crate::config::{Layout, Loaded, Method, Output, Pipeline, Solver};
use crate::stages::analyse::ANALYSIS_VERSION;
use serde::Serialize;
use serde_json::json;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Stage {
    Prepare,
    Discretise,
    Compact,
    Analyse,
}

impl Stage {
    pub const ALL: [Stage; 4] = [
        Stage::Prepare,
        Stage::Discretise,
        Stage::Compact,
        Stage::Analyse,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Prepare => "prepare",
            Stage::Discretise => "discretise",
            Stage::Compact => "compact",
            Stage::Analyse => "analyse",
        }
    }

    pub fn parse(s: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|st| st.name() == s)
    }
}

#[derive(Clone, Debug)]
pub struct Node {
    pub stage: Stage,
    pub case: String,
    /// Canonical parameters (JSON with a fixed key order).
    pub params: serde_json::Value,
    /// Indices of the nodes this one reads.
    pub upstream: Vec<usize>,
    pub hash: blake3::Hash,
    /// The soft-grain method of discretise and compact nodes (not part of the hash: it is
    /// in the parameters already).
    pub method: Option<Method>,
    /// The pipeline the node comes from: 0 this file, k its k-th include (not hashed).
    pub source: usize,
    /// A packing compaction's name without its final strain: runs that differ only in how
    /// far they compact share it, so a longer one can continue where a shorter one ended.
    pub continuation: Option<blake3::Hash>,
}

impl Node {
    /// 16 hex digits of the hash, for file names and messages.
    pub fn short(&self) -> String {
        self.hash.to_hex()[..16].to_string()
    }

    /// The node's output folder under the pipeline's: `<stage>/<case>/`, except the one
    /// analyse node of a pipeline, whose files are the contract's `analyse/summary.json` etc.
    pub fn dir(&self, root: &std::path::Path) -> std::path::PathBuf {
        match self.stage {
            Stage::Analyse => root.join(self.stage.name()),
            _ => root.join(self.stage.name()).join(&self.case),
        }
    }

    /// The case's inter-grain friction: `Some` on compact nodes only.
    pub fn friction(&self) -> Option<f64> {
        self.params["compact"]["friction"].as_f64()
    }

    /// File name of the node's checkpoint.
    pub fn checkpoint_name(&self) -> String {
        format!("{}.{}.{}.ckpt", self.stage.name(), self.case, self.short())
    }
}

/// The version of a stage's computation, hashed into its nodes' names (when not 0) so that a
/// change of results renames them and earlier checkpoints are not reused. 0 for stages that
/// have never changed their results at a given format version, so their names stay as they
/// were before versions existed. `layout` is the scene's (None for the analysis).
fn version(stage: Stage, method: Option<Method>, layout: Option<Layout>) -> u32 {
    match (stage, method, layout) {
        (Stage::Analyse, _, _) => ANALYSIS_VERSION,
        (Stage::Discretise, Some(Method::Bpm), _) => crate::stages::discretise::BPM_VERSION,
        (Stage::Compact, _, Some(Layout::Packing)) => crate::compaction::PACKING_VERSION,
        _ => 0,
    }
}

fn node<P: Serialize>(
    stage: Stage,
    method: Option<Method>,
    layout: Option<Layout>,
    case: String,
    params: &P,
    upstream: Vec<usize>,
    nodes: &[Node],
) -> Node {
    let params = serde_json::to_value(params).expect("parameters serialise");
    let hash = |params: &serde_json::Value| {
        let mut h = blake3::Hasher::new();
        h.update(stage.name().as_bytes());
        h.update(&FORMAT_VERSION.to_le_bytes());
        let version = version(stage, method, layout);
        if version != 0 {
            h.update(&version.to_le_bytes());
        }
        h.update(&serde_json::to_vec(params).expect("json"));
        for &u in &upstream {
            h.update(nodes[u].hash.as_bytes());
        }
        h.finalize()
    };
    let continuation = (stage == Stage::Compact && layout == Some(Layout::Packing)).then(|| {
        let mut open_ended = params.clone();
        open_ended["compact"]["final_strain"] = serde_json::Value::Null;
        hash(&open_ended)
    });
    Node {
        stage,
        case,
        hash: hash(&params),
        params,
        upstream,
        method,
        source: 0,
        continuation,
    }
}

/// A section's canonical parameters with one fanned-out list key (`friction`,
/// `particle_diameter`) set to the case's own value, so that adding a value to the list
/// names a new case and leaves the finished ones cached.
fn one_of<S: Serialize, V: Serialize>(section: &S, key: &str, value: V) -> serde_json::Value {
    let mut v = serde_json::to_value(section).expect("parameters serialise");
    v[key] = serde_json::to_value(value).expect("parameters serialise");
    v
}

/// The solver section as hashed: `relaxation`, `anderson` and `islands` (added later) are
/// left out at their plain-NLGS values 1, 0 and false, so that the nodes of pipelines that
/// do not set them keep their names.
fn canonical_solver(s: &Solver) -> serde_json::Value {
    let mut v = serde_json::to_value(s).expect("parameters serialise");
    let section = v.as_object_mut().expect("a section");
    if s.relaxation == 1.0 {
        section.remove("relaxation");
    }
    if s.anderson == 0 {
        section.remove("anderson");
    }
    if !s.islands {
        section.remove("islands");
    }
    v
}

/// The output section as hashed: without `snapshot_every`, which changes no result (a run
/// resumed from a snapshot ends with the same bits), so that saving snapshots more or less
/// often does not redo finished stages. `every` and `vtk` stay: they decide the frames and
/// the rows a node records.
fn canonical_output(o: &Output) -> serde_json::Value {
    let mut v = serde_json::to_value(o).expect("parameters serialise");
    v.as_object_mut()
        .expect("a section")
        .remove("snapshot_every");
    v.as_object_mut().expect("a section").remove("mpm_every");
    v
}

/// The output settings an MPM compaction node is named by: `every` is the MPM pace
/// (`mpm_every` hashed under its own name would rename every other node of a pipeline
/// that sets it; under `every` the nodes of a pipeline without it keep their names).
fn canonical_mpm_output(o: &Output) -> serde_json::Value {
    let mut v = canonical_output(o);
    v["every"] = json!(o.every_for(Method::Mpm));
    v
}

/// Readable, stable number formatting for case names: 0.5 -> "0.5", 1.6e-4 -> "0.16" (mm).
fn mm(x: f64) -> String {
    format!("{}", (x * 1e3 * 1e6).round() / 1e6)
}

/// Plans every node of the pipeline and its includes in dependency order: the included
/// pipelines' stages first (cases prefixed `<name>.`), then this file's, then one analyse
/// node over every compact node (or discretise node, where nothing is compacted).
pub fn plan(loaded: &Loaded) -> Vec<Node> {
    let mut nodes = Vec::new();
    let mut ends = Vec::new();
    for (k, inc) in loaded.included.iter().enumerate() {
        let prefix = format!("{}.", inc.pipeline.name);
        ends.extend(plan_scene(&inc.pipeline, k + 1, &prefix, &mut nodes));
    }
    ends.extend(plan_scene(&loaded.pipeline, 0, "", &mut nodes));
    if let Some(a) = &loaded.pipeline.analyse {
        nodes.push(node(
            Stage::Analyse,
            None,
            None,
            "all".into(),
            a,
            ends,
            &nodes,
        ));
    }
    nodes
}

/// Appends the prepare, discretise and compact nodes of one pipeline; returns the nodes an
/// analysis reads (its compact nodes, or its discretise nodes if it compacts nothing).
fn plan_scene(p: &Pipeline, source: usize, prefix: &str, nodes: &mut Vec<Node>) -> Vec<usize> {
    let first = nodes.len();
    let case = match p.prepare.layout {
        Layout::Packing => "deposit",
        Layout::Single => "single",
        Layout::Explicit => "explicit",
    };
    let solver = canonical_solver(&p.solver);
    let output = canonical_output(&p.output);
    let mpm_output = canonical_mpm_output(&p.output);
    let mut prepare = serde_json::to_value(&p.prepare).expect("parameters serialise");
    if p.prepare.sleep.is_none() {
        // (added later: absent, it keeps the names of pipelines that do not set it)
        prepare.as_object_mut().expect("a section").remove("sleep");
    }
    let prep = json!({"seed": p.seed, "prepare": prepare, "solver": solver, "output": output});
    nodes.push(node(
        Stage::Prepare,
        None,
        Some(p.prepare.layout),
        case.into(),
        &prep,
        vec![],
        nodes,
    ));
    let prepared = nodes.len() - 1;
    let mut discretised = Vec::new();
    if let Some(d) = &p.discretise {
        for method in d.method.to_vec() {
            let planned: Vec<(String, serde_json::Value)> = match method {
                Method::Bpm => {
                    let bpm = d.bpm.clone().expect("validated");
                    let ranges = bpm.particle_diameter.to_vec();
                    ranges
                        .iter()
                        .map(|r| {
                            let case = if ranges.len() > 1 {
                                format!("bpm-d{}-{}", mm(r[0]), mm(r[1]))
                            } else {
                                "bpm".into()
                            };
                            let bpm = one_of(&bpm, "particle_diameter", r);
                            let params = json!({"seed": p.seed, "bpm": bpm});
                            (case, params)
                        })
                        .collect()
                }
                Method::Mpm => vec![("mpm".into(), json!({"seed": p.seed, "mpm": d.mpm}))],
            };
            for (case, params) in planned {
                nodes.push(node(
                    Stage::Discretise,
                    Some(method),
                    Some(p.prepare.layout),
                    case.clone(),
                    &params,
                    vec![prepared],
                    nodes,
                ));
                discretised.push((nodes.len() - 1, case));
            }
        }
    }
    let mut compacted = Vec::new();
    if let Some(c) = &p.compact {
        // The settings a BPM compaction solves with, `compact.solver` merged in (a key set
        // there to the pipeline's own value names the same node). The MPM grain contact does
        // not read them, but its nodes hash `solver` as they always have.
        let bpm_solver = canonical_solver(&p.compact_solver());
        for (up, dcase) in &discretised {
            for mu in c.friction.to_vec() {
                let case = format!("{dcase}-mu{mu}");
                let mut compact = one_of(c, "friction", mu);
                // the override is hashed merged into `solver` below, not here as well (a
                // null key here would rename every existing compact node)
                let section = compact.as_object_mut().expect("a section");
                section.remove("solver");
                // added later: hashed only when set, so that the nodes of pipelines without
                // it keep their names
                if c.newton_tolerance.is_none() {
                    section.remove("newton_tolerance");
                }
                let solver = match nodes[*up].method {
                    Some(Method::Bpm) => &bpm_solver,
                    _ => &solver,
                };
                let output = match nodes[*up].method {
                    Some(Method::Mpm) => &mpm_output,
                    _ => &output,
                };
                let params = json!({"compact": compact, "solver": solver, "output": output});
                let method = nodes[*up].method;
                nodes.push(node(
                    Stage::Compact,
                    method,
                    Some(p.prepare.layout),
                    case,
                    &params,
                    vec![*up],
                    nodes,
                ));
                compacted.push(nodes.len() - 1);
            }
        }
    }
    for n in &mut nodes[first..] {
        n.source = source;
        n.case = format!("{prefix}{}", n.case);
    }
    if compacted.is_empty() {
        discretised.into_iter().map(|(u, _)| u).collect()
    } else {
        compacted
    }
}
