//! The analyse stage through the command line on a small single MPM grain: its files, its
//! numbers against the compact checkpoint's, and a fit-range change that recomputes only it.

mod common;

use softgrain::pipeline::store;
use softgrain::stages::StageState;
use std::path::Path;

const SMALL: [&str; 6] = [
    "--set",
    "discretise.mpm.resolution=0.06",
    "--set",
    "compact.final_strain=0.06",
    "--set",
    "output.vtk=false",
];

fn run(out: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "pipeline",
        "run",
        "pipelines/single-grain-mpm.yaml",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(SMALL);
    args.extend(extra);
    let o = common::softgrain(&args);
    assert!(o.status.success(), "{}", common::stderr(&o));
    common::stdout(&o)
}

fn line<'a>(stdout: &'a str, stage: &str) -> &'a str {
    stdout
        .lines()
        .find(|l| l.starts_with(stage))
        .unwrap_or_else(|| panic!("no {stage} line in\n{stdout}"))
}

#[test]
fn analyse_writes_its_files_from_the_checkpoint_and_reruns_alone() {
    let dir = common::temp_dir("analyse-pipe");
    let first = run(&dir, &[]);
    assert!(line(&first, "analyse").contains("done"), "{first}");
    let out = dir.join("single-grain-mpm");
    let an = out.join("analyse");
    for f in [
        "summary.json",
        "summary.parquet",
        "single_grains.parquet",
        "report.md",
        "fig6_single_grain.png",
        "fig6_single_grain.svg",
    ] {
        assert!(an.join(f).exists(), "analyse/{f} missing");
    }
    // no packing and no BPM grain here: no Figs. 7 and 9-11
    assert!(!an.join("fig7_bpm_particle_sizes.png").exists());
    assert!(!an.join("packings.parquet").exists());

    // the numbers against the compact checkpoint's
    let ckpt = common::checkpoint_of(&out, "compact");
    let Some(Ok(StageState::MpmCompacted(c))) = store::load::<StageState>(&ckpt).unwrap() else {
        panic!("no MPM compact checkpoint")
    };
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(an.join("summary.json")).unwrap()).unwrap();
    let s = &summary["mpm-mu0"];
    assert_eq!(s["method"], "mpm");
    assert_eq!(s["friction"], 0.0);
    for (key, k) in [
        ("force_over_eq13_at_0.02", 0),
        ("force_over_eq13_at_0.05", 1),
    ] {
        let v = s[key].as_f64().unwrap();
        assert!(
            (v - c.small_strain[k].over_eq13).abs() < 1e-12,
            "{key}: {v} vs {:?}",
            c.small_strain[k]
        );
    }
    // the fitted slope from the rows by hand: Σ ε F / Σ ε² on 0 < ε <= 0.02, over Eq. 13
    let k13 = std::f64::consts::FRAC_PI_4 * 1e7 / (1.0 - 0.45f64.powi(2)) * 5e-3;
    let small: Vec<_> = c
        .rows
        .iter()
        .filter(|r| r.strain > 0.0 && r.strain <= 0.02)
        .collect();
    let f = |r: &&softgrain::mpm::driver::Row| 0.5 * (r.force_top + r.force_bottom);
    let slope = small.iter().map(|r| r.strain * f(r)).sum::<f64>()
        / small.iter().map(|r| r.strain * r.strain).sum::<f64>();
    let ratio = s["eq13_ratio"].as_f64().unwrap();
    assert!(
        (ratio - slope / k13).abs() < 1e-9 * ratio,
        "{ratio} vs {}",
        slope / k13
    );
    // Eq. 13 over-predicts the elastic disk (METHODS.md §5)
    assert!(ratio > 0.5 && ratio < 0.9, "{ratio}");

    // the parquet table holds every recorded row
    let rows = {
        use polars::prelude::*;
        let file = std::fs::File::open(an.join("single_grains.parquet")).unwrap();
        ParquetReader::new(file).finish().unwrap()
    };
    assert_eq!(rows.height(), c.rows.len());
    let report = std::fs::read_to_string(an.join("report.md")).unwrap();
    assert!(report.contains("| mpm-mu0 | 1 | 0."), "{report}");
    assert!(report.contains("![Fig. 6"));

    // a new fit range: only analyse runs again, and its numbers change
    let again = run(&dir, &["--set", "analyse.small_strain=0.04"]);
    assert!(line(&again, "compact").contains("cached"), "{again}");
    assert!(line(&again, "discretise").contains("cached"), "{again}");
    assert!(line(&again, "analyse").contains("done"), "{again}");
    let changed: serde_json::Value =
        serde_json::from_slice(&std::fs::read(an.join("summary.json")).unwrap()).unwrap();
    assert_ne!(changed["mpm-mu0"]["eq13_ratio"], s["eq13_ratio"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_fit_range_is_refused_with_its_key() {
    let o = common::softgrain(&[
        "validate",
        "pipelines/single-grain-mpm.yaml",
        "--set",
        "analyse.eq14_phi=[0.9,0.8]",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = common::stderr(&o);
    assert!(
        err.contains("analyse.eq14_phi") && err.contains("0.9"),
        "{err}"
    );
}

/// The analyse stage on BPM single grains of two particle-size ranges (Figs. 6 and 7): the
/// small-strain slope and the plateau σ<a0>/F0 of each case recomputed by hand from its
/// compact checkpoint, and Fig. 7 written.
#[test]
fn analyse_of_bpm_grains_gives_the_plateau_and_slope_of_their_checkpoints() {
    let dir = common::temp_dir("analyse-bpm");
    let o = common::softgrain(&[
        "pipeline",
        "run",
        "pipelines/single-grain-bpm.yaml",
        "--out",
        dir.to_str().unwrap(),
        "-q",
        "--set",
        "prepare.radius=1.5e-3",
        "--set",
        "discretise.bpm.particle_diameter=[[1.6e-4,2.6e-4],[2.2e-4,2.8e-4]]",
        "--set",
        "compact.final_strain=0.15",
        "--set",
        "output.vtk=false",
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let out = dir.join("single-grain-bpm");
    let an = out.join("analyse");
    for f in [
        "fig6_single_grain.png",
        "fig7_bpm_particle_sizes.png",
        "report.md",
    ] {
        assert!(an.join(f).exists(), "analyse/{f} missing");
    }
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(an.join("summary.json")).unwrap()).unwrap();
    let mut checked = 0;
    for ckpt in common::checkpoints(&out) {
        let Ok(Some(Ok(StageState::Compacted(c)))) = store::load::<StageState>(&ckpt) else {
            continue;
        };
        let case = summary
            .as_object()
            .unwrap()
            .values()
            .find(|s| s["particles"].as_u64() == Some(c.final_particles.len() as u64))
            .expect("a summary for the checkpoint's grain");
        assert_eq!(case["method"], "bpm");
        // the single-grain pipeline's analyse ranges: slope on ε <= 0.02, plateau on ε >= 0.1
        let small: Vec<_> = c
            .rows
            .iter()
            .filter(|r| r.strain > 0.0 && r.strain <= 0.02)
            .collect();
        let slope = small.iter().map(|r| r.strain * r.sigma).sum::<f64>()
            / small.iter().map(|r| r.strain * r.strain).sum::<f64>();
        let late = |f: fn(&softgrain::stages::compact::Row) -> f64| {
            let v: Vec<f64> = c.rows.iter().filter(|r| r.strain >= 0.1).map(f).collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        let plateau_stress = late(|r| r.sigma);
        let fig = &c.figures;
        let plateau = plateau_stress * fig.mean_a0 / fig.f0;
        for (key, expected) in [
            ("small_strain_slope", slope),
            ("plateau_stress", plateau_stress),
            ("plateau", plateau),
            (
                "plateau_prestress",
                late(|r| r.sigma_c) * fig.mean_a0 / fig.f0,
            ),
            ("plateau_sin_phi", late(|r| r.sin_phi)),
        ] {
            let got = case[key].as_f64().unwrap();
            assert!(
                (got - expected).abs() <= 1e-9 * expected.abs(),
                "{key}: {got} vs {expected}"
            );
        }
        // the compact stage's own plateau figure is the same mean
        assert!((fig.plateau - plateau).abs() <= 1e-9 * plateau, "{fig:?}");
        // a plastic plateau of order F0/<a0> (the README's 0.1-0.2 for grains this small)
        assert!(plateau > 0.05 && plateau < 0.5, "{plateau}");
        checked += 1;
    }
    assert_eq!(checked, 2, "two particle-size cases");
    let report = std::fs::read_to_string(an.join("report.md")).unwrap();
    assert!(
        report.contains("## BPM plateaus and what sets them"),
        "{report}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
