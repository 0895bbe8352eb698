//! The shortcuts of `src/shortcuts.rs` (issue #7, "skip what a scene does not need") give
//! the full computation's result: bit for bit where the skipped work cannot change a number
//! (the tangential solve of frictionless contacts, the Verlet list, the thread count), and
//! where the shortcut changes the solver's path (the warm start, the MPM system's size)
//! within the Newton tolerance (MPM) or the run's own fluctuations (BPM). Their speed-ups are measured by
//! `softgrain bench pipelines/bench.yaml` (section `skips`), not here.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn pipeline(name: &str) -> String {
    format!("{}/pipelines/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// Runs `file` with `sets` into a fresh folder, with the shortcuts `without` turned off and
/// `jobs` threads; returns that folder.
fn run(tag: &str, file: &str, sets: &[&str], without: &str, jobs: usize) -> PathBuf {
    let out = common::temp_dir(tag);
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_softgrain"));
    cmd.args([
        "pipeline",
        "run",
        file,
        "-q",
        "--jobs",
        &jobs.to_string(),
        "--out",
    ])
    .arg(&out)
    .env("SOFTGRAIN_WITHOUT", without);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let o = cmd.output().expect("run softgrain");
    assert!(o.status.success(), "{tag}: {}", common::stderr(&o));
    out
}

/// Every `timeseries.csv` under `dir`, by path, with its text.
fn series(dir: &Path) -> Vec<(PathBuf, String)> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.ends_with("timeseries.csv") {
                let text = std::fs::read_to_string(&p).unwrap();
                found.push((p.strip_prefix(dir).unwrap().to_path_buf(), text));
            }
        }
    }
    found.sort();
    assert!(
        !found.is_empty(),
        "no timeseries.csv under {}",
        dir.display()
    );
    found
}

/// (strain, column) rows of a timeseries.
fn column(text: &str, name: &str) -> Vec<[f64; 2]> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let (e, c) = (
        header.iter().position(|h| *h == "strain").unwrap(),
        header.iter().position(|h| *h == name).unwrap(),
    );
    lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .map(|f| [f[e].parse().unwrap(), f[c].parse().unwrap()])
        .collect()
}

/// Runs the scene with every shortcut, then without each of `exact` and on one thread, and
/// asserts every timeseries is byte-identical to the reference's.
fn assert_bit_identical(tag: &str, file: &str, sets: &[&str], exact: &[&str]) {
    let reference = run(&format!("{tag}-ref"), file, sets, "", 2);
    let expected = series(&reference);
    let mut variants: Vec<(String, PathBuf)> = exact
        .iter()
        .map(|w| {
            (
                format!("without {w}"),
                run(&format!("{tag}-{w}"), file, sets, w, 2),
            )
        })
        .collect();
    variants.push((
        "one thread".into(),
        run(&format!("{tag}-jobs1"), file, sets, "", 1),
    ));
    for (what, dir) in &variants {
        let got = series(dir);
        assert_eq!(got.len(), expected.len(), "{tag}, {what}");
        for ((p, a), (q, b)) in expected.iter().zip(&got) {
            assert_eq!(p, q);
            assert!(a == b, "{tag}, {what}: {} differs", p.display());
        }
        let _ = std::fs::remove_dir_all(dir);
    }
    let _ = std::fs::remove_dir_all(&reference);
}

const BPM_GRAIN: [&str; 5] = [
    "prepare.radius=1.5e-3",
    "discretise.bpm.particle_diameter=[1.6e-4,2.6e-4]",
    "output.vtk=false",
    "output.every=20",
    "analyse=null",
];

#[test]
fn a_bpm_grain_is_bit_identical_without_the_frictionless_and_verlet_shortcuts() {
    // every bond inside a grain is frictionless: the shortcut skips their tangential solve
    let mut sets = BPM_GRAIN.to_vec();
    sets.push("compact.final_strain=0.1");
    assert_bit_identical(
        "skip-grain",
        &pipeline("single-grain-bpm.yaml"),
        &sets,
        &["frictionless", "verlet"],
    );
}

#[test]
fn a_frictional_bpm_packing_is_bit_identical_without_the_exact_shortcuts() {
    // frictional contacts between grains (μ = 0.5) beside frictionless bonds inside them
    assert_bit_identical(
        "skip-pack",
        &pipeline("quick.yaml"),
        &[
            "prepare.grains=16",
            // (these 16 grains' deposit is at Φ = 0.616, below quick.yaml's Φ0)
            "compact.initial_phi=0.55",
            "compact.friction=0.5",
            "compact.final_strain=0.1",
            "output.vtk=false",
            "output.every=50",
            "analyse=null",
        ],
        &["frictionless", "verlet"],
    );
}

#[test]
fn the_mpm_warm_start_changes_the_force_by_less_than_the_newton_tolerance() {
    assert_mpm_force_within_newton_tolerance("warm_start");
}

#[test]
fn solving_every_grid_node_changes_the_mpm_force_by_less_than_the_newton_tolerance() {
    assert_mpm_force_within_newton_tolerance("active_nodes");
}

/// A small MPM grain with every shortcut and without `without`: the same steps, and
/// forces equal to the Newton tolerance.
fn assert_mpm_force_within_newton_tolerance(without: &str) {
    let file = pipeline("single-grain-mpm.yaml");
    let sets = [
        "discretise.mpm.resolution=0.1",
        "compact.final_strain=0.06",
        "output.vtk=false",
        "analyse=null",
    ];
    let (a, b) = (
        run(&format!("skip-mpm-ref-{without}"), &file, &sets, "", 2),
        run(&format!("skip-mpm-{without}"), &file, &sets, without, 2),
    );
    let (fa, fb) = (series(&a), series(&b));
    let (ra, rb) = (column(&fa[0].1, "force"), column(&fb[0].1, "force"));
    assert_eq!(ra.len(), rb.len());
    let scale = ra.iter().map(|r| r[1].abs()).fold(0.0, f64::max);
    for (x, y) in ra.iter().zip(&rb) {
        assert_eq!(x[0], y[0], "same strains");
        // Newton stops at a residual of 1e-6 of the force scale (the default tolerance)
        assert!(
            (x[1] - y[1]).abs() <= 1e-6 * scale,
            "ε = {}: {} vs {}",
            x[0],
            x[1],
            y[1]
        );
    }
    for d in [a, b] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// Means of the column over `n` equal windows of ε in [lo, hi] (the recorded forces are
/// single steps' and jump from step to step; window means of ε-width 0.02 are nearly
/// independent).
fn window_means(rows: &[[f64; 2]], lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let w = (hi - lo) / n as f64;
    (0..n)
        .map(|k| {
            let (a, b) = (lo + k as f64 * w, lo + (k + 1) as f64 * w);
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| r[0] >= a && r[0] < b)
                .map(|r| r[1])
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        })
        .collect()
}

/// Mean of `x` and its standard error.
fn mean_and_error(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn the_bpm_warm_start_saves_sweeps_and_keeps_the_plateau_within_its_scatter() {
    // a 2.5 mm grain (about 420 particles): the 1.5 mm one's plateau scatters by 20%
    let file = pipeline("single-grain-bpm.yaml");
    let mut sets = BPM_GRAIN.to_vec();
    sets[0] = "prepare.radius=2.5e-3";
    sets.push("compact.final_strain=0.4");
    let (a, b) = (
        run("skip-bpm-ref", &file, &sets, "", 2),
        run("skip-bpm-cold", &file, &sets, "warm_start", 2),
    );
    let (ta, tb) = (&series(&a)[0].1, &series(&b)[0].1);
    // the saving, counted in NLGS sweeps (machine-independent)
    let sweeps = |t: &str| {
        column(t, "nlgs_iterations")
            .iter()
            .map(|r| r[1])
            .sum::<f64>()
    };
    let (warm, cold) = (sweeps(ta), sweeps(tb));
    assert!(
        warm < 0.7 * cold,
        "sweeps with the warm start {warm}, without {cold}"
    );
    // the plastic plateau (ε in [0.1, 0.4]) agrees within three standard errors. The force
    // still rises through that range (the grain hardens as it flattens), in
    // both runs alike, so the two are compared window by window: the standard error of the
    // paired differences counts the runs' fluctuations, not the trend they share. Up to
    // ε = 0.3 only, 3σ was 29-36% of the plateau depending on the build's rounding, too
    // close to the sensitivity asked below; to 0.4 it is 24% (FORMAT_VERSION 11).
    let (wa, wb) = (
        window_means(&column(ta, "force"), 0.1, 0.4, 15),
        window_means(&column(tb, "force"), 0.1, 0.4, 15),
    );
    let diff: Vec<f64> = wa.iter().zip(&wb).map(|(x, y)| x - y).collect();
    let (d, sd) = mean_and_error(&diff);
    let (pa, pb) = (mean_and_error(&wa).0, mean_and_error(&wb).0);
    let bound = 3.0 * sd;
    eprintln!(
        "plateau {pa:.1} and {pb:.1} N/m, paired difference {d:.1} ± {sd:.1} (3σ = {:.1}% of it)",
        100.0 * bound / pa
    );
    assert!(
        d.abs() <= bound,
        "plateau {pa:.1} N/m with, {pb:.1} N/m without the warm start: {d:.1} ± {sd:.1} apart"
    );
    // and the bound is tight enough to matter: a plateau 35% off would fail
    assert!(bound < 0.35 * pa, "scatter {bound:.1} against {pa:.1}");
    for d in [a, b] {
        let _ = std::fs::remove_dir_all(d);
    }
}
