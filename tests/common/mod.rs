//! Helpers shared by the tests: temporary folders, running the binary, and the contact
//! solver settings of the CD physics tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh folder under the system temp dir, unique per test.
pub fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("softgrain-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `softgrain ARGS` and returns its output.
pub fn softgrain(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_softgrain"))
        .args(args)
        .output()
        .expect("run softgrain")
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Every checkpoint file of a run, sorted by name.
pub fn checkpoints(run: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(run.join("checkpoints"))
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    v.sort();
    v
}

/// The run's checkpoint of `stage` (the first, if the stage has several cases).
pub fn checkpoint_of(run: &Path, stage: &str) -> PathBuf {
    checkpoints(run)
        .into_iter()
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with(&format!("{stage}."))
        })
        .unwrap_or_else(|| panic!("no {stage} checkpoint in {}", run.display()))
}

/// Runs pipeline `file` quietly in the library into `dir`, up to the compact stage (analyse
/// has its own tests), and returns the state of its last node, read back from its checkpoint.
pub fn run_to_state(dir: &Path, file: &Path, sets: &[&str]) -> softgrain::stages::StageState {
    use softgrain::pipeline::{self, RunOptions, store};
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let loaded = softgrain::config::load(file, &sets).unwrap();
    let opts = RunOptions {
        out: dir.to_path_buf(),
        from: None,
        until: Some(pipeline::Stage::Compact),
        quiet: true,
    };
    let out = pipeline::run(&loaded, &opts).unwrap();
    let node = &out.last().unwrap().0;
    let path = pipeline::run_dir(dir, &loaded)
        .join("checkpoints")
        .join(node.checkpoint_name());
    store::load(&path).unwrap().unwrap().unwrap()
}

/// The CD tests' settings under gravity g = 9.81 m/s² at step `dt`: θ = 1, alert and skin
/// 0.1 mm, plain NLGS to a tight tolerance (1e-6, checked every 5 sweeps, at most 10,000).
pub fn cd_params(dt: f64) -> softgrain::cd::CdParams {
    softgrain::cd::CdParams {
        dt,
        theta: 1.0,
        gravity: softgrain::geom::V2::new(0.0, -9.81),
        alert: 1e-4,
        skin: 1e-4,
        nlgs: softgrain::cd::NlgsParams {
            tol: 1e-6,
            check_every: 5,
            max_iter: 10_000,
            relax: 1.0,
            anderson: 0,
            islands: false,
        },
        sleep: None,
    }
}

/// nx × ny touching disks of radius r and density 1000 kg/m³ in a square lattice on the
/// floor y = 0 from x = 0, each its own group.
pub fn lattice(r: f64, nx: usize, ny: usize) -> softgrain::cd::Bodies {
    let mut bodies = softgrain::cd::Bodies::default();
    for j in 0..ny {
        for i in 0..nx {
            let p = softgrain::geom::V2::new((2 * i + 1) as f64 * r, (2 * j + 1) as f64 * r);
            bodies.push(p, r, 1000.0, (j * nx + i) as u32);
        }
    }
    bodies
}

/// The `stage.json` of every compact case of pipeline `name` run into `dir`
/// (`DIR/<name>/compact/<case>/`), with its path.
pub fn compact_stage_jsons(dir: &Path, name: &str) -> Vec<(PathBuf, serde_json::Value)> {
    std::fs::read_dir(dir.join(name).join("compact"))
        .unwrap()
        .flatten()
        .map(|e| e.path().join("stage.json"))
        .filter(|p| p.exists())
        .map(|p| {
            let j = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
            (p, j)
        })
        .collect()
}

/// Runs the BPM pipeline `yaml` (named `name`) to ε = 0.05 in its own folder `tag` and
/// checks that its one compact case says where its time went, by part of the
/// contact-dynamics step and of the recording (`check_timings`).
pub fn check_cd_timings(tag: &str, name: &str, yaml: &str) {
    let dir = temp_dir(tag);
    let file = write(&dir, &format!("{name}.yaml"), yaml);
    run_to_state(&dir, &file, &["compact.final_strain=0.05"]);
    let stages = compact_stage_jsons(&dir, name);
    assert_eq!(stages.len(), 1, "{stages:?}");
    let parts = [
        "step_detect",
        "step_free",
        "step_solve",
        "step_finish",
        "rows",
        "snapshots",
    ];
    check_timings(&stages[0].1, &parts, &["step_solve", "step_detect"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Checks a compaction's `stage.json` (`stage`) says where its time went: `timings_s` has
/// exactly the keys `parts`, none negative, those of `busy` above zero, and together no
/// more than the stage's wall time nor less than half of it.
pub fn check_timings(stage: &serde_json::Value, parts: &[&str], busy: &[&str]) {
    let timings = stage["timings_s"].as_object().expect("timings_s");
    let mut keys: Vec<&str> = timings.keys().map(String::as_str).collect();
    keys.sort_unstable();
    let mut expected = parts.to_vec();
    expected.sort_unstable();
    assert_eq!(keys, expected);
    let seconds = |k: &str| timings[k].as_f64().unwrap();
    assert!(parts.iter().all(|k| seconds(k) >= 0.0), "{timings:?}");
    assert!(busy.iter().all(|k| seconds(k) > 0.0), "{timings:?}");
    let sum: f64 = parts.iter().map(|k| seconds(k)).sum();
    let wall = stage["wall_s"].as_f64().unwrap();
    assert!(
        sum <= wall && sum > 0.5 * wall,
        "parts {sum} s, stage {wall} s"
    );
}
