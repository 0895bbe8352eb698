//! `softgrain bench` on a tiny sweep (two values per knob, one repeat, all families): the CSV
//! has the contract's columns and one row per setting, every family has its plot, the
//! stability maps and the skips table are written; a wrong bench file exits 2 naming the file, the key and the value.

mod common;

const TINY: &str = "name: tiny
repeats: 1
mpm:
  final_strain: 0.06
  base: {resolution: 0.125, travel_per_step: 0.1, newton_tolerance: 1.0e-6, shape: bspline}
  resolution: [0.125, 0.1]
  travel_per_step: [0.2, 0.1]
  newton_tolerance: [1.0e-3, 1.0e-6]
  shape: [bilinear, bspline]
cd:
  grains: 12
  base: {tolerance: 1.0e-3, time_step: 0.04, alert: 0.05}
  tolerance: [1.0e-2, 1.0e-3]
  time_step: [0.08, 0.04]
  alert: [0.05, 0.2]
bpm:
  final_strain: 0.12
  base: {tolerance: 1.0e-3, time_step: 0.2}
  tolerance: [1.0e-2, 1.0e-3]
  time_step: [0.4, 0.2]
compaction:
  grains: 6
  initial_phi: 0.5
  final_strain: 0.55
  base: {tolerance: 1.0e-3, time_step: 0.2, wall_velocity: 1.0}
  tolerance: [1.0e-2, 1.0e-3]
bpm_stability:
  accuracy: 0.5
  final_strain: 0.05
  particle_diameter: [[2.4e-4, 3.9e-4]]
  f0: [100.0]
  wall_velocity: [2.0]
  time_step: [0.25, 8.0]
mpm_stability:
  final_strain: 0.025
  accuracy: 0.02
  resolution: [0.125]
  young: [1.0e7]
  poisson: [0.45]
  travel_per_step: [0.1, 0.2]
";

fn is_png(path: &std::path::Path) -> bool {
    std::fs::read(path).is_ok_and(|b| b.len() > 1000 && b.starts_with(b"\x89PNG"))
}

#[test]
fn a_tiny_sweep_writes_the_csv_and_one_plot_per_family() {
    let dir = common::temp_dir("bench");
    // a skips section: one MPM grain, with and without the warm start of its contacts
    let skips = format!(
        "skips:\n  - name: grain\n    pipeline: {}/pipelines/single-grain-mpm.yaml\n    set: [discretise.mpm.resolution=0.125, compact.final_strain=0.03, output.vtk=false, analyse=null]\n    compare: force\n    variants:\n      - {{name: cold, without: [warm_start]}}\n",
        env!("CARGO_MANIFEST_DIR")
    );
    let file = common::write(&dir, "tiny.yaml", &format!("{TINY}{skips}"));
    let out = dir.join("runs");
    let o = common::softgrain(&[
        "bench",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(common::stdout(&o).contains("Pareto-best settings:"));
    let bench = out.join("tiny/bench");
    let csv = std::fs::read_to_string(bench.join("work_precision.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for col in [
        "family",
        "knob",
        "value",
        "wall_s",
        "error",
        "peak_rss_mb",
        "pareto",
    ] {
        assert!(header.contains(&col), "no column {col} in {header:?}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 20, "{csv}");
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for r in &rows {
        assert_eq!(r.len(), header.len(), "{r:?}");
        assert!(r[col("failure")].is_empty(), "a setting failed: {r:?}");
        let wall: f64 = r[col("wall_s")].parse().unwrap();
        let rss: f64 = r[col("peak_rss_mb")].parse().unwrap();
        assert!(wall > 0.0 && rss > 1.0, "{r:?}");
    }
    // every knob names at least one Pareto-best value
    for knob in [
        "resolution",
        "travel_per_step",
        "shape",
        "tolerance",
        "time_step",
        "alert",
    ] {
        assert!(
            rows.iter()
                .any(|r| r[col("knob")] == knob && r[col("pareto")] == "true"),
            "{knob}: no Pareto-best value"
        );
    }
    for png in [
        "work_precision_mpm.png",
        "work_precision_cd.png",
        "work_precision_compaction.png",
        "mpm_stability.png",
        "bpm_stability.png",
    ] {
        assert!(is_png(&bench.join(png)), "{png}");
    }
    let map = std::fs::read_to_string(bench.join("mpm_stability.csv")).unwrap();
    assert_eq!(map.lines().count(), 3, "{map}");
    // the BPM map: both steps run; 0.25 t0 is its own reference and stable
    let map = std::fs::read_to_string(bench.join("bpm_stability.csv")).unwrap();
    let lines: Vec<Vec<&str>> = map.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(lines.len(), 3, "{map}");
    let at = |name: &str| lines[0].iter().position(|h| *h == name).unwrap();
    assert_eq!(lines[1][at("time_step_t0")], "0.25");
    assert_eq!(lines[1][at("stable")], "true", "{map}");
    // skips.csv: the reference and the variant, the variant's force within Newton's tolerance
    let skips = std::fs::read_to_string(bench.join("skips.csv")).unwrap();
    let lines: Vec<Vec<&str>> = skips.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(lines.len(), 3, "{skips}");
    let at = |name: &str| lines[0].iter().position(|h| *h == name).unwrap();
    assert_eq!(lines[1][at("variant")], "reference");
    assert_eq!(lines[1][at("identical")], "true");
    assert_eq!(lines[2][at("without")], "warm_start");
    let diff: f64 = lines[2][at("rms_difference")].parse().unwrap();
    assert!(diff < 1e-6, "{skips}");
    assert!(lines[2][at("ratio_to_reference")].parse::<f64>().unwrap() > 0.0);
    assert!(
        !dir.join("runs/tiny/bench/skips-runs").exists(),
        "scratch runs left"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_wrong_bench_file_exits_2_naming_file_key_and_value() {
    let dir = common::temp_dir("bench-bad");
    let unknown = common::write(&dir, "u.yaml", &TINY.replace("repeats: 1", "repeat: 1"));
    let o = common::softgrain(&["bench", unknown.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let msg = common::stderr(&o);
    assert!(msg.contains("u.yaml") && msg.contains("repeat"), "{msg}");

    let range = common::write(
        &dir,
        "r.yaml",
        &TINY.replace("[0.125, 0.1]", "[0.125, 0.9]"),
    );
    let o = common::softgrain(&["bench", range.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let msg = common::stderr(&o);
    assert!(
        msg.contains("r.yaml:6:") && msg.contains("mpm.resolution = 0.9"),
        "{msg}"
    );

    let o = common::softgrain(&[
        "bench",
        unknown
            .to_str()
            .unwrap()
            .replace("u.yaml", "r.yaml")
            .as_str(),
        "--set",
        "mpm.resolution=[0.1]",
        "--set",
        "cd.grains=1",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let msg = common::stderr(&o);
    assert!(msg.contains("--set cd.grains = 1"), "{msg}");
    let _ = std::fs::remove_dir_all(&dir);
}
