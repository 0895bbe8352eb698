//! Running a pipeline: plan the stage graph, skip nodes whose checkpoint exists, run the
//! others, save their checkpoints. Only this module reads or writes checkpoints.
//!
//! The graph is run in waves: each wave is the nodes whose upstream nodes are done, which
//! depend on nothing else of the wave (a deposit's discretisations, a discretisation's
//! compaction cases). A wave's nodes run side by side on the run's thread pool, as many at
//! once as it has threads, so their parallel loops share its threads: on two threads, two
//! MPM compaction cases, whose steps gain far less than twice from a second thread, finish
//! sooner side by side than one after the other (100 grains, both frictions: 394 s against
//! 534 s; 300 grains: 81 min against 37 + 69 min alone, 76 min with a later build; README
//! "MPM packings"). A stage's results do not depend on the threads it gets (the same bits,
//! `tests/pipeline.rs`).

pub mod codec;
mod lock;
mod plan;
mod progress;
pub mod store;

pub use plan::{Node, Stage, plan};
pub use progress::Progress;

use crate::config::{InputError, Loaded};
use crate::stages::{self, StageState};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

/// How a run failed; the CLI maps `Input` to exit status 2 and the rest to 1.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    Input(#[from] Box<InputError>),
    #[error("{stage} [{case}]: {cause}")]
    Stage {
        stage: &'static str,
        case: String,
        cause: String,
    },
    #[error("{path}: {cause}")]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("{0}")]
    Locked(String),
    #[error("{stage} [{case}]: interrupted; a snapshot was saved, run again to resume")]
    Interrupted { stage: &'static str, case: String },
}

/// Set by the command line's Ctrl-C handler; long stages poll it, save a snapshot and stop.
pub static INTERRUPT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// What a stage returns when it stopped on `INTERRUPT` after saving its snapshot.
pub const INTERRUPTED: &str = "interrupted";

#[derive(Clone, Debug)]
pub struct RunOptions {
    pub out: PathBuf,
    /// Recompute this stage and everything after it.
    pub from: Option<Stage>,
    /// Stop after this stage.
    pub until: Option<Stage>,
    pub quiet: bool,
}

/// What happened to one node.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    Cached,
    Computed { seconds: f64, summary: String },
}

/// Where a pipeline's files go: DIR/<name>/.
pub fn run_dir(out: &Path, loaded: &Loaded) -> PathBuf {
    out.join(&loaded.pipeline.name)
}

/// What a snapshot's note (`<node>.snap.json`, beside `<node>.snap`) holds: where the
/// stage's progress bar stood and the wall seconds all runs of the stage had spent when it
/// was saved.
#[derive(Serialize, serde::Deserialize)]
struct SnapshotNote {
    progress: String,
    wall_s: f64,
}

impl SnapshotNote {
    fn path(snapshot: &Path) -> PathBuf {
        snapshot.with_extension("snap.json")
    }

    fn read(snapshot: &Path) -> Option<SnapshotNote> {
        let bytes = std::fs::read(Self::path(snapshot)).ok()?;
        serde_json::from_slice(&bytes).ok()
    }
}

/// The per-node context a stage runs in: its output folder, snapshots, progress.
pub struct StageCtx {
    pub dir: PathBuf,
    /// The nodes this one reads, in the order of its upstream states (their cases and
    /// parameters).
    pub upstream: Vec<Node>,
    snapshot: PathBuf,
    /// When this run of the stage started, and the wall seconds of the earlier runs that
    /// made the snapshot it resumed from (f64 bits; 0 for a fresh start).
    started: Instant,
    earlier_s: AtomicU64,
    /// Where a packing compaction keeps its state at the end (`Node::continuation`), for a
    /// longer run of the same settings to continue from.
    continuation: Option<PathBuf>,
    pub quiet: bool,
    /// Lets a BPM grain run above the compact stage's 0.5 t0 step limit: only the bench's
    /// stability map sets it, to find where the scheme really fails.
    pub beyond_step_limit: bool,
    /// Wall seconds of this run by part of the stage's work (`note_times`), for `stage.json`.
    timings: Mutex<Vec<(String, f64)>>,
}

impl StageCtx {
    /// A context for stage functions called outside a pipeline (the bench): outputs in
    /// `dir`, no snapshot unless the pipeline asks for them, no progress bars.
    pub fn scratch(dir: PathBuf) -> Self {
        StageCtx {
            snapshot: dir.join("scratch.snap"),
            dir,
            upstream: Vec::new(),
            started: Instant::now(),
            earlier_s: AtomicU64::new(0),
            continuation: None,
            quiet: true,
            beyond_step_limit: false,
            timings: Mutex::default(),
        }
    }

    /// The last snapshot of this node, if one exists and verifies. A bad one is reported and
    /// set aside (`set_aside`), and the stage starts from zero: a snapshot another build wrote
    /// may hold hours of work that build can still resume, so it is never overwritten.
    pub fn load_snapshot<T: DeserializeOwned>(&self) -> Option<T> {
        match store::load(&self.snapshot) {
            Ok(Some(Ok(s))) => {
                let earlier = SnapshotNote::read(&self.snapshot).map_or(0.0, |n| n.wall_s);
                self.earlier_s.store(earlier.to_bits(), Ordering::Relaxed);
                Some(s)
            }
            Ok(Some(Err(e))) => {
                let kept = match set_aside(&self.snapshot) {
                    Ok(to) => format!("kept as {}", to.display()),
                    Err(why) => format!("could not be set aside ({why}) and will be replaced"),
                };
                eprintln!(
                    "  snapshot {} not used ({e}); {kept}; starting from zero",
                    self.snapshot.display()
                );
                None
            }
            _ => None,
        }
    }

    /// Saves the node's snapshot, and beside it a note of where `bar` stands and of the wall
    /// time spent so far in all runs of the stage (`pipeline status` shows both).
    pub fn save_snapshot<T: Serialize>(&self, state: &T, bar: &Progress) -> std::io::Result<()> {
        store::save(&self.snapshot, state)?;
        let note = SnapshotNote {
            progress: bar.describe(),
            wall_s: self.wall_s(),
        };
        let json = serde_json::to_vec(&note).expect("json");
        store::write_atomic(&SnapshotNote::path(&self.snapshot), &json)
    }

    /// The end state of a finished run that differs from this node only in its final strain,
    /// if one was kept and verifies (the stage checks that it ended short of its own).
    pub fn load_continuation<T: DeserializeOwned>(&self) -> Option<T> {
        match store::load(self.continuation.as_ref()?) {
            Ok(Some(Ok(s))) => Some(s),
            _ => None,
        }
    }

    /// Keeps the state at the end of the compaction loop (before the last partial recording)
    /// for a longer run to continue from: it then passes through exactly this state. A kept
    /// state that `reach`es as far or further (the strain it ended at) stays: a shorter run
    /// that finishes after a longer one must not replace the longer one's end.
    pub fn save_continuation<T: Serialize + DeserializeOwned>(
        &self,
        state: &T,
        reach: impl Fn(&T) -> f64,
    ) -> std::io::Result<()> {
        let Some(path) = &self.continuation else {
            return Ok(());
        };
        if let Ok(Some(Ok(kept))) = store::load::<T>(path)
            && reach(&kept) >= reach(state)
        {
            return Ok(());
        }
        store::save(path, state)
    }

    /// Notes the wall seconds this run of the stage spent on each part of its steps (as
    /// `step_<part>`) and on the rest of its work; `stage.json` lists them by name as
    /// `timings_s` (a run resumed from a snapshot counts its own work only).
    pub fn note_times(&self, step: &[(&str, f64)], rest: &[(&str, f64)]) {
        let mut t = self.timings.lock().expect("no panic while held");
        t.extend(step.iter().map(|(k, s)| (format!("step_{k}"), *s)));
        t.extend(rest.iter().map(|(k, s)| (k.to_string(), *s)));
    }

    /// Wall seconds spent on this stage: this run's and those of the runs it resumed.
    fn wall_s(&self) -> f64 {
        self.earlier_s() + self.started.elapsed().as_secs_f64()
    }

    /// Wall seconds of the earlier runs whose snapshot this run resumed (0 for a fresh start).
    fn earlier_s(&self) -> f64 {
        f64::from_bits(self.earlier_s.load(Ordering::Relaxed))
    }

    /// True once Ctrl-C was pressed: save a snapshot and return `Err(INTERRUPTED.into())`.
    pub fn interrupted(&self) -> bool {
        INTERRUPT.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// A progress bar labelled `label` and the node's case (its folder), e.g.
    /// "compact bpm-mu0".
    pub fn progress(&self, label: &str, total: u64) -> Progress {
        let case = self.dir.file_name().and_then(|c| c.to_str()).unwrap_or("");
        Progress::new(&format!("{label} {case}"), total, self.quiet)
    }

    /// Writes a whole output file atomically.
    pub fn write(&self, name: &str, bytes: &[u8]) -> std::io::Result<()> {
        store::write_atomic(&self.dir.join(name), bytes)
    }
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RunError + '_ {
    move |cause| RunError::Io {
        path: path.to_path_buf(),
        cause,
    }
}

/// Runs the pipeline; returns each node with its outcome.
pub fn run(loaded: &Loaded, opts: &RunOptions) -> Result<Vec<(Node, Outcome)>, RunError> {
    let nodes = plan(loaded);
    let wanted: Vec<usize> = (0..nodes.len())
        .filter(|&k| opts.until.is_none_or(|u| nodes[k].stage <= u))
        .collect();
    // Refuse what this build cannot do before any work starts.
    for &k in &wanted {
        if let Err(why) = stages::supported(loaded.pipeline(nodes[k].source), &nodes[k]) {
            return Err(Box::new(InputError {
                file: loaded.file(nodes[k].source).to_path_buf(),
                key: nodes[k].stage.name().into(),
                value: nodes[k].case.clone(),
                message: format!("{why}; remove it from the pipeline or stop earlier with --until"),
                at: None,
                from_set: false,
            })
            .into());
        }
    }
    let root = run_dir(&opts.out, loaded);
    let _lock = lock::Lock::take(&root.join(".lock")).map_err(RunError::Locked)?;
    // Holding the lock, any temporary file here is a killed run's half-written file.
    store::remove_temp_files(&root);
    let ckpt_dir = root.join("checkpoints");
    let mut states: Vec<Option<StageState>> = vec![None; nodes.len()];
    let mut outcomes = Vec::new();
    let mut remaining = wanted;
    while !remaining.is_empty() {
        // a wave: the nodes whose upstream is done, independent of each other
        let (wave, rest): (Vec<usize>, Vec<usize>) = remaining
            .iter()
            .partition(|&&k| nodes[k].upstream.iter().all(|&u| states[u].is_some()));
        assert!(!wave.is_empty(), "the plan is ordered upstream first");
        remaining = rest;
        let mut todo = Vec::new();
        for &k in &wave {
            let node = &nodes[k];
            let path = ckpt_dir.join(node.checkpoint_name());
            let forced = opts.from.is_some_and(|f| node.stage >= f);
            match (!forced).then(|| cached(opts, &root, node, &path)) {
                Some(Ok(Some(state))) => {
                    states[k] = Some(state);
                    outcomes.push((k, node.clone(), Outcome::Cached));
                }
                Some(Err(e)) => return Err(e),
                _ => todo.push(k),
            }
        }
        // Independent nodes run side by side (`run_side_by_side`); none is started after
        // one has failed.
        let results = run_side_by_side(loaded, opts, &nodes, &root, &ckpt_dir, &states, &todo);
        let mut failed = None;
        for (&k, result) in todo.iter().zip(results) {
            match result {
                Some(Ok((state, outcome))) => {
                    states[k] = Some(state);
                    outcomes.push((k, nodes[k].clone(), outcome));
                }
                Some(Err(e)) => {
                    failed.get_or_insert(e);
                }
                None => {}
            }
        }
        if let Some(e) = failed {
            return Err(e);
        }
    }
    outcomes.sort_by_key(|o| o.0);
    Ok(outcomes.into_iter().map(|(_, n, o)| (n, o)).collect())
}

/// The node's state if its checkpoint (or an equal node's in a sibling pipeline under the
/// same `--out`) holds it, reported as cached; `None` if it must run.
fn cached(
    opts: &RunOptions,
    root: &Path,
    node: &Node,
    path: &Path,
) -> Result<Option<StageState>, RunError> {
    match store::load::<StageState>(path).map_err(io_err(path))? {
        Some(Ok(state)) => {
            if outputs_are_own(node, root) {
                report(opts, node, "cached");
            } else {
                let what = format!(
                    "cached, but the files in {} are from other parameters (--from {} rewrites them)",
                    node.dir(root).display(),
                    node.stage.name()
                );
                report(opts, node, &what);
                if opts.quiet {
                    eprintln!("{} {}: {what}", node.stage.name(), node.case);
                }
            }
            Ok(Some(state))
        }
        Some(Err(e)) => {
            eprintln!(
                "{}: checkpoint {} is not valid ({e}); recomputing",
                node.stage.name(),
                path.display()
            );
            Ok(None)
        }
        None => {
            // Equal names are equal work: another pipeline under the same --out may have
            // computed this node already.
            if let Some((state, from)) = shared_checkpoint(&opts.out, root, node) {
                store::save(path, &state).map_err(io_err(path))?;
                report(opts, node, &format!("cached (from {from})"));
                return Ok(Some(state));
            }
            Ok(None)
        }
    }
}

/// A computed node's state and outcome, or why it failed.
type Computed = Result<(StageState, Outcome), RunError>;

/// Runs the nodes `todo` (independent, their upstream states in `states`) side by side on
/// the run's thread pool, each one's parallel loops on whichever threads are free: two
/// compaction cases on two threads finish sooner than one after the other, each on both
/// (module doc). As many runners as threads take the nodes in order, each the next as it
/// ends one (a node spawned on the pool for itself could be taken up by a thread waiting
/// inside another node's parallel loop, which would then wait for it). After a failure no
/// runner starts another node, and the running ones finish and save. Each node's result
/// in order, `None` for those not started.
fn run_side_by_side(
    loaded: &Loaded,
    opts: &RunOptions,
    nodes: &[Node],
    root: &Path,
    ckpt_dir: &Path,
    states: &[Option<StageState>],
    todo: &[usize],
) -> Vec<Option<Computed>> {
    let slots: Vec<Mutex<Option<Computed>>> = todo.iter().map(|_| Mutex::new(None)).collect();
    let (next, stop) = (AtomicUsize::new(0), AtomicBool::new(false));
    let runners = rayon::current_num_threads().clamp(1, todo.len().max(1));
    rayon::scope(|scope| {
        for _ in 0..runners {
            scope.spawn(|_| {
                while !stop.load(Ordering::Relaxed) {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&k) = todo.get(i) else { break };
                    let upstream: Vec<&StageState> = nodes[k]
                        .upstream
                        .iter()
                        .map(|&u| states[u].as_ref().expect("upstream runs first"))
                        .collect();
                    let r = compute(loaded, opts, nodes, root, ckpt_dir, k, &upstream);
                    if let Err(e) = &r {
                        stop.store(true, Ordering::Relaxed);
                        // (on Ctrl-C every case stops and says so at the end)
                        if todo.len() > 1 && !matches!(e, RunError::Interrupted { .. }) {
                            eprintln!("{e}; the cases running beside it go on");
                        }
                    }
                    *slots[i].lock().expect("no panic while held") = Some(r);
                }
            });
        }
    });
    slots
        .into_iter()
        .map(|s| s.into_inner().expect("no panic while held"))
        .collect()
}

/// Runs node `k` of `nodes` on its upstream states and saves its files and checkpoint.
fn compute(
    loaded: &Loaded,
    opts: &RunOptions,
    nodes: &[Node],
    root: &Path,
    ckpt_dir: &Path,
    k: usize,
    upstream: &[&StageState],
) -> Computed {
    let node = &nodes[k];
    let path = ckpt_dir.join(node.checkpoint_name());
    let ctx = StageCtx {
        dir: node.dir(root),
        upstream: node.upstream.iter().map(|&u| nodes[u].clone()).collect(),
        snapshot: snapshot_path(root, node),
        started: Instant::now(),
        earlier_s: AtomicU64::new(0),
        continuation: continuation_path(root, node),
        quiet: opts.quiet,
        beyond_step_limit: false,
        timings: Mutex::default(),
    };
    std::fs::create_dir_all(&ctx.dir).map_err(io_err(&ctx.dir))?;
    let (state, summary) = stages::run(loaded.pipeline(node.source), node, upstream, &ctx)
        .map_err(|cause| {
            let (stage, case) = (node.stage.name(), node.case.clone());
            if cause == INTERRUPTED {
                RunError::Interrupted { stage, case }
            } else {
                RunError::Stage { stage, case, cause }
            }
        })?;
    let seconds = ctx.started.elapsed().as_secs_f64();
    // a stage resumed from a snapshot also counts the runs that made it
    let total = seconds + ctx.earlier_s();
    let mut figures = serde_json::json!({
        "stage": node.stage.name(),
        "case": node.case,
        "hash": node.hash.to_hex().as_str(),
        "wall_s": total,
        "summary": summary,
        "figures": state.figures(),
    });
    if total > seconds {
        figures["wall_s_last_run"] = seconds.into();
    }
    {
        let timings = ctx.timings.lock().expect("no panic while held");
        if !timings.is_empty() {
            let parts: serde_json::Map<String, serde_json::Value> = timings
                .iter()
                .map(|(k, v)| (k.clone(), (*v).into()))
                .collect();
            figures["timings_s"] = parts.into();
        }
    }
    let json = serde_json::to_vec_pretty(&figures).expect("json");
    ctx.write("stage.json", &json).map_err(io_err(&ctx.dir))?;
    // The checkpoint last: it is the commit point of the node.
    store::save(&path, &state).map_err(io_err(&path))?;
    let _ = std::fs::remove_file(&ctx.snapshot);
    let _ = std::fs::remove_file(SnapshotNote::path(&ctx.snapshot));
    let took = if total > seconds {
        format!("done in {seconds:.1} s ({total:.1} s with the runs it resumed)")
    } else {
        format!("done in {seconds:.1} s")
    };
    report(opts, node, &format!("{took}: {summary}"));
    Ok((state, Outcome::Computed { seconds, summary }))
}

/// Whether the files in a cached node's folder are its checkpoint's: the folder's
/// `stage.json` names the node's hash. A run with other parameters into the same `--out`
/// rewrites the folders of the cases it shares by name, while this checkpoint stays valid.
fn outputs_are_own(node: &Node, root: &Path) -> bool {
    std::fs::read(node.dir(root).join("stage.json"))
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .is_some_and(|v| v["hash"] == node.hash.to_hex().as_str())
}

/// A valid checkpoint of this node's stage and hash (under any case name: an included
/// pipeline's cases carry a prefix) in a sibling pipeline's folder under `out`, with that
/// pipeline's name.
fn shared_checkpoint(out: &Path, own: &Path, node: &Node) -> Option<(StageState, String)> {
    let (head, tail) = (
        format!("{}.", node.stage.name()),
        format!(".{}.ckpt", node.short()),
    );
    let mut files: Vec<PathBuf> = std::fs::read_dir(out)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .filter(|d| d != own)
        .filter_map(|d| std::fs::read_dir(d.join("checkpoints")).ok())
        .flat_map(|entries| entries.flatten().map(|e| e.path()))
        .filter(|f| {
            f.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(&head) && n.ends_with(&tail))
        })
        .collect();
    files.sort();
    files.into_iter().find_map(|f| {
        let state = store::load::<StageState>(&f).ok()??.ok()?;
        let pipeline = f.parent()?.parent()?.file_name()?;
        Some((state, pipeline.to_string_lossy().into_owned()))
    })
}

fn report(opts: &RunOptions, node: &Node, what: &str) {
    if !opts.quiet {
        println!(
            "{:<10} {:<36} {}  {what}",
            node.stage.name(),
            node.case,
            node.short()
        );
    }
}

/// One line per node: `cached` (`cached, files from other parameters` when another run
/// rewrote its folder), `stale` (a checkpoint for other parameters exists) or `missing`;
/// a node that is not cached and has a snapshot adds where it stood and when it was saved
/// ("missing, snapshot at 40% (ε = 0.180) saved 12 min ago"), and any snapshots set aside
/// as unreadable (`set_aside`). Reads file names, headers, `stage.json` and snapshot notes
/// only; computes nothing.
pub fn status(loaded: &Loaded, out: &Path) -> Vec<(Node, String)> {
    let root = run_dir(out, loaded);
    let ckpt_dir = root.join("checkpoints");
    let names: Vec<String> = std::fs::read_dir(&ckpt_dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    plan(loaded)
        .into_iter()
        .map(|node| {
            let own = node.checkpoint_name();
            let prefix = format!("{}.{}.", node.stage.name(), node.case);
            let valid = std::fs::read(ckpt_dir.join(&own))
                .map(|b| store::verify(&b).is_ok())
                .unwrap_or(false);
            let word = if valid && outputs_are_own(&node, &root) {
                "cached"
            } else if valid {
                "cached, files from other parameters"
            } else if names
                .iter()
                .any(|n| n.starts_with(&prefix) && n.ends_with(".ckpt") && *n != own)
            {
                "stale"
            } else {
                "missing"
            };
            let snapshot = snapshot_path(&root, &node);
            let line = match std::fs::metadata(&snapshot) {
                Ok(m) if !valid => {
                    let at = SnapshotNote::read(&snapshot)
                        .map_or_else(|| "an unknown point".into(), |n| n.progress);
                    let age = m.modified().ok().and_then(|t| t.elapsed().ok());
                    let age = age.map_or_else(String::new, |a| format!(" saved {} ago", ago(a)));
                    format!("{word}, snapshot at {at}{age}")
                }
                _ => word.to_string(),
            };
            let aside = set_aside_of(&snapshot);
            let line = match aside.as_slice() {
                [] => line,
                names => format!(
                    "{line}; set aside, unreadable by the build that found them: {}",
                    names.join(", ")
                ),
            };
            (node, line)
        })
        .collect()
}

/// "45 s", "12 min", "3.5 h".
fn ago(d: std::time::Duration) -> String {
    match d.as_secs() {
        s if s < 120 => format!("{s} s"),
        s if s < 7200 => format!("{} min", s / 60),
        s => format!("{:.1} h", s as f64 / 3600.0),
    }
}

/// The process id of the run writing to the pipeline's output folder now, if any.
pub fn running(loaded: &Loaded, out: &Path) -> Option<String> {
    lock::holder(&run_dir(out, loaded).join(".lock"))
}

/// Renames an unusable snapshot and its note to the first free `<name>.unused[.N]`, so that
/// the run starting afresh does not write over it; returns the new snapshot name.
fn set_aside(snapshot: &Path) -> std::io::Result<PathBuf> {
    let to = (1..)
        .map(|n| match n {
            1 => snapshot.with_extension("snap.unused"),
            n => snapshot.with_extension(format!("snap.unused.{n}")),
        })
        .find(|p| !p.exists())
        .expect("a free name");
    std::fs::rename(snapshot, &to)?;
    let note = SnapshotNote::path(snapshot);
    if note.exists() {
        let mut note_to = to.clone().into_os_string();
        note_to.push(".json");
        std::fs::rename(&note, note_to)?;
    }
    Ok(to)
}

/// The file names of the snapshots `set_aside` moved from `snapshot`, in order.
fn set_aside_of(snapshot: &Path) -> Vec<String> {
    let (Some(dir), Some(name)) = (snapshot.parent(), snapshot.file_name()) else {
        return Vec::new();
    };
    let prefix = format!("{}.unused", name.to_string_lossy());
    let mut found: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with(&prefix) && !n.ends_with(".json"))
                .collect()
        })
        .unwrap_or_default();
    // `.unused` first, then `.unused.2`, `.unused.3`, ... by number
    found.sort_by_key(|n| {
        n[prefix.len()..]
            .trim_start_matches('.')
            .parse::<u32>()
            .unwrap_or(1)
    });
    found
}

/// Where a node's snapshot is kept while its stage runs.
fn snapshot_path(root: &Path, node: &Node) -> PathBuf {
    root.join("snapshots")
        .join(node.checkpoint_name().replace(".ckpt", ".snap"))
}

/// Where a packing compaction keeps its end state for longer runs (`Node::continuation`).
fn continuation_path(root: &Path, node: &Node) -> Option<PathBuf> {
    let key = node.continuation?.to_hex();
    let name = format!("{}.{}.{}.end", node.stage.name(), node.case, &key[..16]);
    Some(root.join("snapshots").join(name))
}
