//! Nothing lost: killed runs resume to the same bits, Ctrl-C saves a snapshot, one run at a
//! time per folder.

mod common;

use common::{checkpoint_of, checkpoints, softgrain, stderr, stdout, temp_dir, write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const GRAIN: &str = "name: g\nseed: 5\nprepare:\n  layout: single\n  radius: 1.5e-3\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [1.6e-4, 2.6e-4]\n    f0: 100.0\ncompact:\n  wall_velocity: 0.2\n  final_strain: 0.12\nsolver:\n  tolerance: 1.0e-3\noutput:\n  every: 100\n  snapshot_every: 150\n";

const DEPOSIT: &str = "name: g\nseed: 5\nprepare:\n  grains: 120\n  diameter: [1.4e-3, 2.4e-3]\noutput:\n  every: 100\n  snapshot_every: 100\n";

const PACKING: &str = "name: g\nseed: 7\nprepare:\n  grains: 12\n  diameter: [1.4e-3, 2.4e-3]\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [2.0e-4, 3.4e-4]\n    f0: 100.0\ncompact:\n  wall_velocity: 1.0\n  final_strain: 0.3\n  initial_phi: 0.55\noutput:\n  every: 100\n  snapshot_every: 150\n";

/// `n` kill times in [lo, hi) ms, increasing, drawn from the clock (printed, so a failure
/// can be replayed by pasting them into the test).
fn random_kills(n: usize, lo: u64, hi: u64) -> Vec<u64> {
    let mut x = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64
        | 1;
    let mut v: Vec<u64> = (0..n)
        .map(|_| {
            // xorshift64
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            lo + x % (hi - lo)
        })
        .collect();
    v.sort_unstable();
    eprintln!("kill times (ms): {v:?}");
    v
}

const MPM_PACKING: &str = "name: g\nseed: 5\nprepare:\n  grains: 8\n  diameter: [1.4e-3, 2.4e-3]\ndiscretise:\n  method: mpm\n  mpm:\n    young: 1.0e7\n    poisson: 0.45\n    density: 990.0\n    resolution: 0.12\ncompact:\n  wall_velocity: 0.2\n  final_strain: 0.15\n  friction: 0.5\noutput:\n  every: 10\n  snapshot_every: 15\n";

fn spawn(file: &Path, out: &Path) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_softgrain"))
        .args([
            "pipeline",
            "run",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// `softgrain pipeline run FILE --out OUT -q`, waited for.
fn run_quietly(file: &Path, out: &Path) -> std::process::Output {
    let (file, out) = (file.to_str().unwrap(), out.to_str().unwrap());
    softgrain(&["pipeline", "run", file, "--out", out, "-q"])
}

/// The same with the stage lines on stdout.
fn run_loudly(file: &Path, out: &Path) -> std::process::Output {
    let (file, out) = (file.to_str().unwrap(), out.to_str().unwrap());
    softgrain(&["pipeline", "run", file, "--out", out])
}

/// `softgrain pipeline status FILE --out OUT`'s stdout.
fn status(file: &Path, out: &Path) -> String {
    let (file, out) = (file.to_str().unwrap(), out.to_str().unwrap());
    stdout(&softgrain(&["pipeline", "status", file, "--out", out]))
}

fn files(run: &Path, rel: &str) -> Vec<u8> {
    std::fs::read(run.join(rel)).unwrap()
}

/// Every file under `dir` whose name marks it as temporary.
fn temp_files(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().unwrap().to_string_lossy().contains(".tmp-") {
                found.push(p.display().to_string());
            }
        }
    }
    found
}

fn killed_runs_end_as_uninterrupted(yaml: &str, tag: &str, kills_ms: &[u64], compare: &[&str]) {
    let dir = temp_dir(tag);
    let file = write(&dir, "g.yaml", yaml);
    let clean = dir.join("clean");
    let o = run_quietly(&file, &clean);
    assert!(o.status.success(), "{}", stderr(&o));
    let killed = dir.join("killed");
    for &ms in kills_ms {
        let mut child = spawn(&file, &killed);
        std::thread::sleep(Duration::from_millis(ms));
        let _ = Command::new("kill")
            .args(["-9", &child.id().to_string()])
            .status();
        let _ = child.wait();
    }
    // a killed run's lock went with its process: the next run takes it and finishes
    let o = run_quietly(&file, &killed);
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, b) = (
        checkpoints(&clean.join("g")),
        checkpoints(&killed.join("g")),
    );
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.file_name(), y.file_name());
        assert!(
            std::fs::read(x).unwrap() == std::fs::read(y).unwrap(),
            "{} differs after resuming",
            x.display()
        );
    }
    for rel in compare {
        assert!(
            files(&clean.join("g"), rel) == files(&killed.join("g"), rel),
            "{rel} differs"
        );
    }
    assert!(
        temp_files(&killed).is_empty(),
        "left behind: {:?}",
        temp_files(&killed)
    );
    assert!(!killed.join("g/.lock").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_deposit_killed_several_times_ends_as_an_uninterrupted_one() {
    killed_runs_end_as_uninterrupted(DEPOSIT, "kill-dep", &random_kills(4, 100, 800), &[]);
}

#[test]
fn a_deposit_with_its_separation_killed_several_times_ends_as_an_uninterrupted_one() {
    // the separation's state (done or not, and its figures) lives in the snapshot
    let yaml = DEPOSIT.replace(
        "  diameter: [1.4e-3, 2.4e-3]\n",
        "  diameter: [1.4e-3, 2.4e-3]\n  separation: {at: 1.0e-6, tolerance: 7.0e-4}\nsolver:\n  tolerance: 4.0e-3\n",
    );
    killed_runs_end_as_uninterrupted(&yaml, "kill-dep-sep", &random_kills(4, 100, 800), &[]);
}

#[test]
fn a_packing_compaction_killed_at_random_points_ends_as_an_uninterrupted_one() {
    killed_runs_end_as_uninterrupted(
        PACKING,
        "kill-pack",
        &random_kills(4, 200, 2500),
        &["compact/bpm-mu0/timeseries.csv"],
    );
}

#[test]
fn a_compaction_killed_several_times_ends_as_an_uninterrupted_one() {
    killed_runs_end_as_uninterrupted(
        GRAIN,
        "kill-bpm",
        &random_kills(4, 300, 2000),
        &["compact/bpm-mu0/timeseries.csv"],
    );
}

#[test]
fn an_mpm_packing_killed_several_times_ends_as_an_uninterrupted_one() {
    killed_runs_end_as_uninterrupted(
        MPM_PACKING,
        "kill-mpm-packing",
        &random_kills(3, 1000, 5000),
        &["compact/mpm-mu0.5/timeseries.csv"],
    );
}

#[test]
fn ctrl_c_saves_a_snapshot_and_stops_within_a_second() {
    signal_saves_a_snapshot_and_stops_within_a_second("INT");
}

/// SIGTERM is what `kill` and batch schedulers (at a job's time limit) send.
#[test]
fn sigterm_saves_a_snapshot_and_stops_within_a_second() {
    signal_saves_a_snapshot_and_stops_within_a_second("TERM");
}

fn signal_saves_a_snapshot_and_stops_within_a_second(signal: &str) {
    let dir = temp_dir(&format!("sig{}", signal.to_lowercase()));
    let file = write(
        &dir,
        "g.yaml",
        &GRAIN
            .replace("final_strain: 0.12", "final_strain: 0.3")
            .replace("snapshot_every: 150", "snapshot_every: 100000"),
    );
    let mut child = spawn(&file, &dir);
    // wait until the compaction is under way
    let start = Instant::now();
    while !dir.join("g/compact/bpm-mu0/frame_000002.vtu").exists() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "compaction never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // `status` names the run that holds the folder
    let now = status(&file, &dir);
    assert!(
        now.contains(&format!("a run (pid {}) is writing", child.id())),
        "{now}"
    );
    let _ = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status();
    let sent = Instant::now();
    let exit = child.wait().unwrap();
    assert!(
        sent.elapsed() < Duration::from_secs(1),
        "took {:?}",
        sent.elapsed()
    );
    assert_eq!(exit.code(), Some(1));
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert!(err.contains("interrupted; a snapshot was saved"), "{err}");
    let snaps: Vec<_> = std::fs::read_dir(dir.join("g/snapshots"))
        .unwrap()
        .flatten()
        .collect();
    // the snapshot and its note (where it stood, the wall time so far)
    assert_eq!(snaps.len(), 2);
    let after = status(&file, &dir);
    let line = after.lines().find(|l| l.starts_with("compact")).unwrap();
    assert!(
        line.contains("missing, snapshot at ") && line.contains("(ε = "),
        "{after}"
    );
    assert!(!after.contains("is writing"), "{after}");
    // resumed to the end, the stage counts the interrupted run's time too
    let done = run_quietly(&file, &dir);
    assert!(done.status.success(), "{}", stderr(&done));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("g/compact/bpm-mu0/stage.json")).unwrap())
            .unwrap();
    let (total, last) = (
        json["wall_s"].as_f64().unwrap(),
        json["wall_s_last_run"].as_f64().unwrap(),
    );
    assert!(total > last && last > 0.0, "{json}");
    assert_eq!(
        std::fs::read_dir(dir.join("g/snapshots")).unwrap().count(),
        0
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A snapshot this build cannot read (another build's format, or damaged) may still be hours
/// of work for the build that wrote it: the run starts afresh and keeps it under another name.
#[test]
fn a_snapshot_this_build_cannot_read_is_kept_aside_not_overwritten() {
    let dir = temp_dir("foreignsnap");
    let file = write(&dir, "g.yaml", GRAIN);
    let o = run_quietly(&file, &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let compact = checkpoint_of(&dir.join("g"), "compact");
    let expected = std::fs::read(&compact).unwrap();
    std::fs::remove_file(&compact).unwrap();
    let name = compact
        .file_name()
        .unwrap()
        .to_string_lossy()
        .replace(".ckpt", ".snap");
    let snapshots = dir.join("g/snapshots");
    std::fs::create_dir_all(&snapshots).unwrap();
    let foreign = b"a snapshot written by some other build".to_vec();
    std::fs::write(snapshots.join(&name), &foreign).unwrap();
    std::fs::write(snapshots.join(format!("{name}.json")), b"{}").unwrap();
    let o = run_quietly(&file, &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let kept = snapshots.join(format!("{name}.unused"));
    assert!(
        stderr(&o).contains("not used") && stderr(&o).contains(&kept.display().to_string()),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&kept).unwrap(), foreign);
    assert_eq!(
        std::fs::read(snapshots.join(format!("{name}.unused.json"))).unwrap(),
        b"{}"
    );
    // the fresh start ends as the first run did, and its own snapshot is gone
    assert!(std::fs::read(&compact).unwrap() == expected);
    assert!(!snapshots.join(&name).exists());
    // a second foreign snapshot takes the next free name; `status` lists both
    std::fs::remove_file(&compact).unwrap();
    std::fs::write(snapshots.join(&name), b"another").unwrap();
    let o = run_quietly(&file, &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(snapshots.join(format!("{name}.unused.2"))).unwrap(),
        b"another"
    );
    assert_eq!(std::fs::read(&kept).unwrap(), foreign);
    let text = status(&file, &dir);
    let line = text.lines().find(|l| l.contains("compact")).unwrap();
    assert!(
        line.contains(&format!(
            "set aside, unreadable by the build that found them: {name}.unused, {name}.unused.2"
        )),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_second_run_on_the_same_folder_is_refused_while_the_first_holds_the_lock() {
    let dir = temp_dir("lock");
    let file = write(&dir, "g.yaml", DEPOSIT);
    std::fs::create_dir_all(dir.join("g")).unwrap();
    // a live holder: this test process, holding the lock as a run does
    let held = std::fs::File::create(dir.join("g/.lock")).unwrap();
    held.try_lock().unwrap();
    std::fs::write(dir.join("g/.lock"), format!("{}\n", std::process::id())).unwrap();
    let o = run_quietly(&file, &dir);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("another softgrain run"),
        "{}",
        stderr(&o)
    );
    // the file a dead holder leaves (its lock went with its process) does not block
    drop(held);
    std::fs::write(dir.join("g/.lock"), "4000000000\n").unwrap();
    let o = run_quietly(&file, &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_that_fills_its_disk_fails_clearly_keeps_its_checkpoints_and_resumes() {
    let dir = temp_dir("fsize");
    let file = write(&dir, "g.yaml", GRAIN);
    let cmd = format!(
        "ulimit -f 64; exec {} pipeline run {} --out {} -q",
        env!("CARGO_BIN_EXE_softgrain"),
        file.display(),
        dir.display()
    );
    // a 64 KiB file-size limit: the first stages fit, the compaction's frames do not
    let o = Command::new("sh").args(["-c", &cmd]).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("compact [bpm-mu0]: writing output")
            && stderr(&o).contains("File too large"),
        "{}",
        stderr(&o)
    );
    let kept = checkpoints(&dir.join("g"));
    assert_eq!(kept.len(), 2, "prepare and discretise stay");
    // space is back: the run resumes and finishes; the earlier stages are not redone
    let o = run_loudly(&file, &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(common::stdout(&o).matches("cached").count(), 2);
    assert_eq!(checkpoints(&dir.join("g")).len(), 3);
    assert!(temp_files(&dir).is_empty(), "{:?}", temp_files(&dir));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_failed_contact_solution_stops_the_run_early_and_saves_nothing() {
    let dir = temp_dir("fault");
    // two disks placed one inside the other: contacts never push overlaps apart, so this
    // can only be a bad packing; the run must say so at once, not run on with it
    let yaml = "name: f\nprepare:\n  layout: explicit\n  duration: 0.1\n  time_step: 1.0e-4\n  bodies:\n    - position: [0.0, 0.01]\n      radius: 0.005\n    - position: [0.003, 0.01]\n      radius: 0.005\n  walls:\n    - from: [-1.0, 0.0]\n      to: [1.0, 0.0]\n";
    let file = write(&dir, "f.yaml", yaml);
    let o = run_quietly(&file, &dir);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("prepare [explicit]: step 0: disks 0 and 1 overlap by 7.000e-3 m"),
        "{err}"
    );
    assert!(
        checkpoints(&dir.join("f")).is_empty(),
        "no checkpoint of a bad state"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn two_runs_started_together_on_one_folder_leave_one_valid_result() {
    let dir = temp_dir("race");
    let file = write(&dir, "g.yaml", DEPOSIT);
    let (mut a, mut b) = (spawn(&file, &dir), spawn(&file, &dir));
    let (sa, sb) = (a.wait().unwrap(), b.wait().unwrap());
    let mut errs = String::new();
    for c in [&mut a, &mut b] {
        std::io::Read::read_to_string(c.stderr.as_mut().unwrap(), &mut errs).unwrap();
    }
    assert!(sa.success() || sb.success(), "{errs}");
    if !(sa.success() && sb.success()) {
        assert!(errs.contains("another softgrain run"), "{errs}");
    }
    // whatever the interleaving: one valid checkpoint, no temporary file, and it is reused
    assert_eq!(checkpoints(&dir.join("g")).len(), 1);
    assert!(temp_files(&dir).is_empty());
    let o = run_loudly(&file, &dir);
    assert!(
        common::stdout(&o).contains("cached"),
        "{}",
        common::stdout(&o)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Compacts `yaml` (case `case`) to `short` and then to its own final strain in one folder, and straight to
/// its final strain in another: the second run continues the first's end state, and its
/// checkpoint and time series are byte-identical to the straight run's.
fn a_longer_compaction_continues_a_shorter_one(yaml: &str, long: &str, short: &str, case: &str) {
    let dir = temp_dir(&format!("cont-{case}"));
    let (straight, stepwise) = (dir.join("straight"), dir.join("stepwise"));
    let file = write(&dir, "g.yaml", yaml);
    let o = run_quietly(&file, &straight);
    assert!(o.status.success(), "{}", stderr(&o));
    let first = write(&dir, "short.yaml", &yaml.replace(long, short));
    let o = run_quietly(&first, &stepwise);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run_loudly(&file, &stepwise);
    assert!(o.status.success(), "{}", stderr(&o));
    let said = format!("{}{}", stdout(&o), stderr(&o));
    assert!(
        said.contains("continued from a finished run at ε = "),
        "{said}"
    );
    for ckpt in checkpoints(&straight.join("g")) {
        let name = ckpt.file_name().unwrap();
        let other = stepwise.join("g/checkpoints").join(name);
        assert!(
            std::fs::read(&ckpt).unwrap() == std::fs::read(&other).unwrap(),
            "{name:?} differs"
        );
    }
    let series = format!("g/compact/{case}/timeseries.csv");
    assert!(files(&straight, &series) == files(&stepwise, &series));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_longer_bpm_compaction_continues_a_finished_shorter_one_to_the_same_bits() {
    a_longer_compaction_continues_a_shorter_one(
        PACKING,
        "final_strain: 0.3",
        "final_strain: 0.12",
        "bpm-mu0",
    );
}

/// The kept end state is the furthest one: a shorter run finishing after a longer one in the
/// same folder (it starts from zero, as the kept state is past its own end) leaves the longer
/// one's end for the next, longer run to continue from.
#[test]
fn a_shorter_compaction_finishing_last_keeps_the_longer_ones_end_state() {
    let dir = temp_dir("cont-keep");
    let out = dir.join("out");
    let run = |strain: &str| {
        let file = write(
            &dir,
            &format!("g{strain}.yaml"),
            &PACKING.replace("final_strain: 0.3", &format!("final_strain: {strain}")),
        );
        let o = run_loudly(&file, &out);
        assert!(o.status.success(), "{}", stderr(&o));
        format!("{}{}", stdout(&o), stderr(&o))
    };
    assert!(!run("0.3").contains("continued from"));
    assert!(!run("0.12").contains("continued from"));
    let said = run("0.32");
    assert!(
        said.contains("continued from a finished run at ε = 0.30"),
        "{said}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_longer_mpm_compaction_continues_a_finished_shorter_one_to_the_same_bits() {
    a_longer_compaction_continues_a_shorter_one(
        MPM_PACKING,
        "final_strain: 0.15",
        "final_strain: 0.07",
        "mpm-mu0.5",
    );
}
