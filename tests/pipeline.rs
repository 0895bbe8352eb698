//! The pipeline tool: caching, content hashes, --set, corruption, exit codes.

mod common;

use common::{checkpoints, softgrain, stderr, stdout, temp_dir, write};
use serde_json::json;
use softgrain::config;
use softgrain::pipeline::{Stage, plan};

const SMALL: &str = "name: small\nseed: 3\nprepare:\n  grains: 20\n  diameter: [1.4e-3, 2.4e-3]\noutput:\n  every: 100\n";

#[test]
fn second_run_recomputes_nothing_and_says_so() {
    let dir = temp_dir("cache");
    let f = write(&dir, "p.yaml", SMALL);
    let out = dir.to_str().unwrap();
    let first = softgrain(&["pipeline", "run", f.to_str().unwrap(), "--out", out]);
    assert!(first.status.success(), "{}", stderr(&first));
    assert!(stdout(&first).contains("done in"));
    let before = std::fs::read(&checkpoints(&dir.join("small"))[0]).unwrap();
    let second = softgrain(&["pipeline", "run", f.to_str().unwrap(), "--out", out]);
    assert!(second.status.success());
    let text = stdout(&second);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1);
    assert!(lines.iter().all(|l| l.ends_with("cached")), "{lines:?}");
    assert_eq!(
        before,
        std::fs::read(&checkpoints(&dir.join("small"))[0]).unwrap()
    );
    let status = softgrain(&["pipeline", "status", f.to_str().unwrap(), "--out", out]);
    assert!(stdout(&status).trim_end().ends_with("cached"));
    // --from prepare recomputes it
    let forced = softgrain(&[
        "pipeline",
        "run",
        f.to_str().unwrap(),
        "--out",
        out,
        "--from",
        "prepare",
        "-q",
    ]);
    assert!(forced.status.success());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_cached_node_whose_files_another_run_rewrote_says_so() {
    let dir = temp_dir("foreign");
    let f = write(&dir, "p.yaml", SMALL);
    let (f, out) = (f.to_str().unwrap(), dir.to_str().unwrap());
    let run = |extra: &[&str]| {
        let o = softgrain(&[&["pipeline", "run", f, "--out", out], extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        stdout(&o)
    };
    run(&[]);
    // other parameters, same case folder: its files are now the variant's
    run(&["--set", "prepare.friction=0.4"]);
    let text = run(&[]);
    assert!(
        text.contains("cached, but the files in") && text.contains("--from prepare"),
        "{text}"
    );
    let status = softgrain(&["pipeline", "status", f, "--out", out]);
    assert!(
        stdout(&status).contains("cached, files from other parameters"),
        "{}",
        stdout(&status)
    );
    // rewriting them makes the folder the checkpoint's again
    run(&["--from", "prepare"]);
    assert!(run(&[]).trim_end().ends_with("cached"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn same_seed_gives_byte_identical_checkpoints() {
    let dir = temp_dir("bits");
    let f = write(&dir, "p.yaml", SMALL);
    let run = |sub: &str| {
        let o = softgrain(&[
            "pipeline",
            "run",
            f.to_str().unwrap(),
            "--out",
            dir.join(sub).to_str().unwrap(),
            "-q",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(&checkpoints(&dir.join(sub).join("small"))[0]).unwrap()
    };
    assert_eq!(run("a"), run("b"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn truncated_or_flipped_checkpoint_is_detected_and_recomputed() {
    let dir = temp_dir("corrupt");
    let f = write(&dir, "p.yaml", SMALL);
    let args = [
        "pipeline",
        "run",
        f.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ];
    assert!(softgrain(&args).status.success());
    let ck = checkpoints(&dir.join("small"))[0].clone();
    let good = std::fs::read(&ck).unwrap();
    for bad in [good[..good.len() / 2].to_vec(), {
        let mut b = good.clone();
        let k = b.len() - 10;
        b[k] ^= 1;
        b
    }] {
        std::fs::write(&ck, &bad).unwrap();
        let o = softgrain(&args);
        assert!(o.status.success());
        assert!(stderr(&o).contains("is not valid"), "{}", stderr(&o));
        assert!(stdout(&o).contains("done in"), "recomputed");
        assert_eq!(std::fs::read(&ck).unwrap(), good);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

const GRAPH: &str = "name: g\nprepare:\n  grains: 20\n  diameter: [1.4e-3, 2.4e-3]\ndiscretise:\n  method: [bpm, mpm]\n  bpm:\n    particle_diameter: [[1.0e-4, 2.4e-4], [1.6e-4, 2.6e-4]]\n    f0: 1.0\n  mpm:\n    young: 1.0e7\n    poisson: 0.45\n    density: 990.0\n    resolution: 0.05\ncompact:\n  wall_velocity: 0.2\n  final_strain: 0.3\n  friction: [0.0, 0.5]\n";

fn hashes(dir: &std::path::Path, text: &str, sets: &[&str]) -> Vec<(Stage, String, String)> {
    let f = write(dir, "g.yaml", text);
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let l = config::load(&f, &sets).unwrap();
    plan(&l)
        .into_iter()
        .map(|n| (n.stage, n.case.clone(), n.short()))
        .collect()
}

#[test]
fn changing_a_key_renames_exactly_the_nodes_downstream_of_it() {
    let dir = temp_dir("graph");
    let base = hashes(&dir, GRAPH, &[]);
    let cases: Vec<&str> = base.iter().map(|(_, c, _)| c.as_str()).collect();
    assert_eq!(
        cases,
        [
            "deposit",
            "bpm-d0.1-0.24",
            "bpm-d0.16-0.26",
            "mpm",
            "bpm-d0.1-0.24-mu0",
            "bpm-d0.1-0.24-mu0.5",
            "bpm-d0.16-0.26-mu0",
            "bpm-d0.16-0.26-mu0.5",
            "mpm-mu0",
            "mpm-mu0.5"
        ]
    );
    let changed = |other: &[(Stage, String, String)]| -> Vec<String> {
        base.iter()
            .zip(other)
            .filter(|(a, b)| a.2 != b.2)
            .map(|(a, _)| a.1.clone())
            .collect()
    };
    // a compaction key: only the compact nodes
    let c = hashes(
        &dir,
        &GRAPH.replace("final_strain: 0.3", "final_strain: 0.4"),
        &[],
    );
    assert_eq!(changed(&c), cases[4..].to_vec());
    // an MPM material key: the MPM discretisation and its compactions
    let m = hashes(&dir, &GRAPH.replace("young: 1.0e7", "young: 2.0e7"), &[]);
    assert_eq!(changed(&m), ["mpm", "mpm-mu0", "mpm-mu0.5"]);
    // a deposit key: everything
    let p = hashes(&dir, &GRAPH.replace("grains: 20", "grains: 21"), &[]);
    assert_eq!(changed(&p).len(), base.len());
    // --set gives the hash of the edited file
    let s = hashes(&dir, GRAPH, &["discretise.mpm.young=2.0e7"]);
    assert_eq!(s, m);
    let s = hashes(&dir, GRAPH, &["compact.friction=[0.0,0.5]"]);
    assert_eq!(s, base);
    // a key added later keeps the old names at its default, and renames everything otherwise
    assert_eq!(hashes(&dir, GRAPH, &["solver.relaxation=1.0"]), base);
    let r = hashes(&dir, GRAPH, &["solver.relaxation=1.5"]);
    assert_eq!(changed(&r).len(), base.len());
    assert_eq!(hashes(&dir, GRAPH, &["solver.anderson=0"]), base);
    let r = hashes(&dir, GRAPH, &["solver.anderson=8"]);
    assert_eq!(changed(&r).len(), base.len());
    assert_eq!(hashes(&dir, GRAPH, &["solver.islands=false"]), base);
    let r = hashes(&dir, GRAPH, &["solver.islands=true"]);
    assert_eq!(changed(&r).len(), base.len());
    // the compact stage's own solver setting: the BPM compactions only (the MPM grain
    // contact does not read it), and nothing when it equals the pipeline's
    let r = hashes(&dir, GRAPH, &["compact.solver.anderson=8"]);
    assert_eq!(changed(&r), cases[4..8].to_vec());
    assert_eq!(hashes(&dir, GRAPH, &["compact.solver.anderson=0"]), base);
    let r = hashes(&dir, GRAPH, &["compact.solver.islands=true"]);
    assert_eq!(changed(&r), cases[4..8].to_vec());
    // sleeping in the deposit renames everything; how often snapshots are saved, nothing
    let r = hashes(&dir, GRAPH, &["prepare.sleep={speed: 1.0e-3, time: 0.02}"]);
    assert_eq!(changed(&r).len(), base.len());
    assert_eq!(hashes(&dir, GRAPH, &["output.snapshot_every=123"]), base);
    let r = hashes(&dir, GRAPH, &["output.every=123"]);
    assert_eq!(changed(&r).len(), base.len());
    // the MPM compactions' own pace renames them alone, and at `every` nothing
    let r = hashes(&dir, GRAPH, &["output.mpm_every=7"]);
    assert_eq!(changed(&r), ["mpm-mu0", "mpm-mu0.5"]);
    assert_eq!(hashes(&dir, GRAPH, &["output.mpm_every=100"]), base);
    // a case is named by its own friction and particle range, not by the lists: adding a
    // friction value or dropping one leaves the other cases' names (and work) alone
    let more = hashes(&dir, GRAPH, &["compact.friction=[0.0,0.25,0.5]"]);
    let fewer = hashes(&dir, GRAPH, &["compact.friction=0.5"]);
    assert_eq!((more.len(), fewer.len()), (base.len() + 3, base.len() - 3));
    for (_, case, hash) in &base {
        let same =
            |nodes: &[(Stage, String, String)]| nodes.iter().any(|n| &n.1 == case && &n.2 == hash);
        assert!(same(&more), "{case} renamed by adding a friction value");
        assert_eq!(same(&fewer), !case.ends_with("-mu0"), "{case}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn each_compact_case_gets_its_own_friction_and_particle_range() {
    // the stages read a case's friction and particle range from its node (what is hashed)
    let dir = temp_dir("case-values");
    let l = config::load(&write(&dir, "g.yaml", GRAPH), &[]).unwrap();
    for n in plan(&l) {
        let want = match n.stage {
            Stage::Compact if n.case.ends_with("-mu0.5") => Some(0.5),
            Stage::Compact => Some(0.0),
            _ => None,
        };
        assert_eq!(n.friction(), want, "{}", n.case);
        if n.stage == Stage::Discretise && n.case.starts_with("bpm-d0.16") {
            assert_eq!(
                n.params["bpm"]["particle_diameter"],
                json!([1.6e-4, 2.6e-4])
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_exits_2_naming_file_key_value_and_position() {
    let dir = temp_dir("bad");
    let cases = [
        (
            SMALL.replace("seed: 3", "seed: 3\nbogus: 1"),
            "p.yaml:3:1: bogus = 1: unknown field `bogus`",
        ),
        (SMALL.replace("grains: 20", "grains: [20"), "p.yaml:"),
        (
            SMALL.replace("diameter: [1.4e-3, 2.4e-3]", "diameter: [2.4e-3, 1.4e-3]"),
            "p.yaml:5:3: prepare.diameter = [0.0024, 0.0014]: must be [min, max]",
        ),
        (
            SMALL.replace("prepare:", "solver:\n  theta: 2.0\nprepare:"),
            "p.yaml:4:3: solver.theta = 2.0: must be in [0.5, 1]",
        ),
    ];
    for (text, expect) in cases {
        let f = write(&dir, "p.yaml", &text);
        for cmd in [
            &["validate"][..],
            &["pipeline", "run"],
            &["pipeline", "status"],
        ] {
            let mut args = cmd.to_vec();
            args.push(f.to_str().unwrap());
            let o = softgrain(&args);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
            assert!(
                stderr(&o).contains(expect),
                "expected `{expect}` in: {}",
                stderr(&o)
            );
        }
    }
    let f = write(&dir, "p.yaml", SMALL);
    let o = softgrain(&[
        "validate",
        f.to_str().unwrap(),
        "--set",
        "prepare.friction=-1",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--set prepare.friction = -1.0: must be a finite number >= 0"),
        "{}",
        stderr(&o)
    );
    let o = softgrain(&["validate", f.to_str().unwrap(), "--set", "prepare.nope=1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("unknown key `nope`"), "{}", stderr(&o));
    let o = softgrain(&["validate", dir.join("missing.yaml").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("missing.yaml: cannot read"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_stage_that_cannot_run_on_its_scene_is_refused_before_any_work() {
    let dir = temp_dir("unrunnable");
    // an explicit scene holds rigid disks only: nothing to discretise
    let yaml = "name: g\nprepare:\n  layout: explicit\n  duration: 0.01\n  time_step: 1.0e-4\n  bodies:\n    - position: [0.0, 0.01]\n      radius: 0.005\n  walls:\n    - from: [-1.0, 0.0]\n      to: [1.0, 0.0]\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [1.0e-4, 2.0e-4]\n    f0: 1.0\n";
    let f = write(&dir, "g.yaml", yaml);
    let o = softgrain(&[
        "pipeline",
        "run",
        f.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("discretise stage needs grains"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.join("g").exists(), "work started before the refusal");
    let o = softgrain(&[
        "pipeline",
        "run",
        f.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
        "--until",
        "prepare",
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn two_pipelines_share_their_common_upstream_work() {
    let dir = temp_dir("shared");
    let a = write(&dir, "a.yaml", SMALL);
    let b = write(&dir, "b.yaml", &SMALL.replace("name: small", "name: other"));
    let out = dir.to_str().unwrap();
    assert!(
        softgrain(&["pipeline", "run", a.to_str().unwrap(), "--out", out])
            .status
            .success()
    );
    let o = softgrain(&["pipeline", "run", b.to_str().unwrap(), "--out", out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("cached (from small)"), "{}", stdout(&o));
    let (x, y) = (
        checkpoints(&dir.join("small")),
        checkpoints(&dir.join("other")),
    );
    assert_eq!(std::fs::read(&x[0]).unwrap(), std::fs::read(&y[0]).unwrap());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_included_pipeline_joins_the_graph_with_its_own_hashes_and_checkpoints() {
    let dir = temp_dir("include");
    let inc = write(&dir, "small.yaml", SMALL);
    let main = write(
        &dir,
        "main.yaml",
        &format!(
            "{}include: [small.yaml]\n",
            SMALL
                .replace("name: small", "name: main")
                .replace("seed: 3", "seed: 4")
        ),
    );
    let standalone = config::load(&inc, &[]).unwrap();
    let both = config::load(&main, &[]).unwrap();
    let nodes = plan(&both);
    let names: Vec<String> = nodes.iter().map(|n| n.case.clone()).collect();
    assert_eq!(names, ["small.deposit", "deposit"]);
    // the included node hashes exactly as the file run alone, so their work is shared
    assert_eq!(nodes[0].hash, plan(&standalone)[0].hash);
    assert_ne!(nodes[0].hash, nodes[1].hash);
    let out = dir.to_str().unwrap();
    assert!(
        softgrain(&["pipeline", "run", inc.to_str().unwrap(), "--out", out])
            .status
            .success()
    );
    let o = softgrain(&["pipeline", "run", main.to_str().unwrap(), "--out", out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("small.deposit") && text.contains("cached (from small)"),
        "{text}"
    );
    assert!(dir.join("main/prepare/deposit/stage.json").exists());
    // an include that is not valid names the including file and key
    let bad = write(
        &dir,
        "bad.yaml",
        "name: bad\ninclude: [missing.yaml]\nprepare:\n  grains: 5\n  diameter: [1.0e-3, 2.0e-3]\n",
    );
    let o = softgrain(&["validate", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("bad.yaml") && e.contains("include[0]") && e.contains("missing.yaml"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Pipeline "g": one 1.5 mm BPM grain of about 150 particles pressed at 0.2 m/s to
/// `final_strain`, recorded every `every` steps, no VTK.
fn small_bpm_grain(final_strain: f64, every: u32) -> String {
    format!(
        "name: g\nseed: 1\nprepare:\n  layout: single\n  radius: 1.5e-3\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [1.6e-4, 2.6e-4]\n    f0: 100.0\ncompact:\n  wall_velocity: 0.2\n  final_strain: {final_strain}\noutput:\n  every: {every}\n  vtk: false\n"
    )
}

#[test]
fn a_compaction_only_solver_setting_recomputes_the_compaction_alone_and_reaches_its_solver() {
    let dir = temp_dir("compact-solver");
    let yaml = small_bpm_grain(0.05, 100);
    let f = write(&dir, "g.yaml", &yaml);
    let (f, out) = (f.to_str().unwrap(), dir.to_str().unwrap());
    let sweeps = || -> f64 {
        let text = std::fs::read_to_string(dir.join("g/compact/bpm-mu0/stage.json")).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let f = &v["figures"];
        f["nlgs_iterations"].as_f64().unwrap() / f["steps"].as_f64().unwrap()
    };
    let first = softgrain(&["pipeline", "run", f, "--out", out]);
    assert!(first.status.success(), "{}", stderr(&first));
    let plain = sweeps();
    let set = "compact.solver.tolerance=1.0e-2";
    let second = softgrain(&["pipeline", "run", f, "--out", out, "--set", set]);
    assert!(second.status.success(), "{}", stderr(&second));
    let text = stdout(&second);
    let line = |stage: &str| {
        text.lines()
            .find(|l| l.contains(stage))
            .unwrap()
            .to_string()
    };
    assert!(line("prepare").ends_with("cached"), "{text}");
    assert!(line("discretise").ends_with("cached"), "{text}");
    assert!(!line("compact").ends_with("cached"), "{text}");
    // a 60 times looser tolerance stops the sweeps sooner: the setting reached the solve
    let loose = sweeps();
    assert!(
        loose < 0.5 * plain,
        "{loose} against {plain} sweeps per step"
    );
    // a key over the pipeline's own value names the same node: the first run's is cached
    // (its files in the case folder being the second run's, which the line says)
    let same = softgrain(&[
        "pipeline",
        "run",
        f,
        "--out",
        out,
        "--set",
        "compact.solver.tolerance=1.666e-4",
    ]);
    assert!(
        stdout(&same).lines().all(|l| l.contains(" cached")),
        "{}",
        stdout(&same)
    );
    // checked like `solver`, and named so
    let bad = softgrain(&["validate", f, "--set", "compact.solver.anderson=20"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(
        stderr(&bad).contains("compact.solver.anderson = 20: must be in 0..=16"),
        "{}",
        stderr(&bad)
    );
    let bad = softgrain(&["validate", f, "--set", "compact.solver.nope=1"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("unknown"), "{}", stderr(&bad));
    let mpm = yaml.replace(
        "  method: bpm\n  bpm:\n    particle_diameter: [1.6e-4, 2.6e-4]\n    f0: 100.0\n",
        "  method: mpm\n  mpm:\n    young: 1.0e7\n    poisson: 0.45\n    density: 990.0\n    resolution: 0.1\n",
    );
    let m = write(&dir, "m.yaml", &mpm);
    let bad = softgrain(&["validate", m.to_str().unwrap(), "--set", set]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(
        stderr(&bad).contains("compact.solver") && stderr(&bad).contains("BPM compactions only"),
        "{}",
        stderr(&bad)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn progress_goes_to_the_log_as_lines_when_stderr_is_not_a_terminal() {
    let dir = temp_dir("progress-log");
    let f = write(&dir, "g.yaml", &small_bpm_grain(0.03, 20));
    let (f, out) = (f.to_str().unwrap(), dir.to_str().unwrap());
    // the test's stderr is a pipe, as under nohup or a batch scheduler
    let run = softgrain(&["pipeline", "run", f, "--out", out]);
    assert!(run.status.success(), "{}", stderr(&run));
    let log = stderr(&run);
    let percents: Vec<u64> = log
        .lines()
        .filter(|l| l.contains("compact bpm-mu0") && l.contains("% after") && l.contains("eta"))
        .map(|l| {
            let p = l
                .split('%')
                .next()
                .unwrap()
                .split_whitespace()
                .last()
                .unwrap();
            p.parse().unwrap()
        })
        .collect();
    // one line per 10% of the strain, in order (the last record may fall short of 100%)
    assert!(percents.len() >= 9, "{log}");
    assert!(percents.windows(2).all(|w| w[1] / 10 > w[0] / 10), "{log}");
    assert!(percents.last() >= Some(&90), "{log}");
    let quiet = softgrain(&[
        "pipeline", "run", f, "--out", out, "--from", "compact", "-q",
    ]);
    assert!(quiet.status.success(), "{}", stderr(&quiet));
    assert!(!stderr(&quiet).contains("% after"), "{}", stderr(&quiet));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Independent cases (a method's two frictions) run side by side on two threads
/// (`pipeline::run`'s waves) and give, byte for byte, the checkpoints that one thread gives
/// running them one after the other; every case is computed and reported.
#[test]
fn cases_run_side_by_side_give_the_bits_of_one_after_the_other() {
    let cases = [
        (
            "quick",
            vec![
                "prepare.grains=12",
                "compact.initial_phi=0.5",
                "compact.final_strain=0.05",
            ],
        ),
        (
            "mpm-packing-small",
            vec!["prepare.grains=8", "compact.final_strain=0.01"],
        ),
    ];
    for (name, sets) in cases {
        let dir = temp_dir(&format!("side-{name}"));
        let path = format!("{}/pipelines/{name}.yaml", env!("CARGO_MANIFEST_DIR"));
        let mut runs = Vec::new();
        for jobs in ["1", "2"] {
            let out = dir.join(format!("jobs{jobs}"));
            let mut args = vec!["pipeline", "run", &path, "--out", out.to_str().unwrap()];
            args.extend([
                "--jobs",
                jobs,
                "--until",
                "compact",
                "--set",
                "output.vtk=false",
            ]);
            for s in &sets {
                args.extend(["--set", s]);
            }
            let o = softgrain(&args);
            assert!(o.status.success(), "{name} --jobs {jobs}: {}", stderr(&o));
            let done = stdout(&o)
                .lines()
                .filter(|l| l.starts_with("compact") && l.contains("done in"))
                .count();
            assert_eq!(done, 2, "{name} --jobs {jobs}: {}", stdout(&o));
            runs.push(checkpoints(&out.join(name)));
        }
        assert_eq!(runs[0].len(), runs[1].len());
        assert_eq!(
            runs[0].len(),
            4,
            "{name}: prepare, discretise, two compactions"
        );
        for (a, b) in runs[0].iter().zip(&runs[1]) {
            assert_eq!(a.file_name(), b.file_name());
            assert!(
                std::fs::read(a).unwrap() == std::fs::read(b).unwrap(),
                "{name}: {} differs between one and two threads",
                a.display()
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
