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
    let ckpt = common::checkpoints(&out)
        .into_iter()
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("compact.")
        })
        .unwrap();
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
