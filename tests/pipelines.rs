//! Every shipped packing pipeline gets through prepare and discretise and starts its
//! compaction. `compact.initial_phi` must lie below the deposit's packing fraction, and that
//! moves with round-off between builds: `paper-coarse.yaml`'s deposit went from Φ = 0.644 to
//! 0.631 (closed-area convention) from session 17's build to session 25's, and its Φ0 = 0.64
//! stopped the compaction at step 0 until session 25. (`quick.yaml` runs whole in `.ci/run`.)

mod common;

use common::{softgrain, stderr, temp_dir};

/// Runs `file` to a strain of 1e-5 with `sets` in its own folder `tag` and asserts that
/// every compaction case ran.
fn starts(tag: &str, file: &str, sets: &[&str], cases: usize) {
    let dir = temp_dir(&format!("start-{tag}"));
    let path = format!("{}/pipelines/{file}", env!("CARGO_MANIFEST_DIR"));
    let mut args = vec![
        "pipeline",
        "run",
        &path,
        "--out",
        dir.to_str().unwrap(),
        "--until",
        "compact",
        "-q",
        "--set",
        "compact.final_strain=1e-5",
        "--set",
        "output.vtk=false",
    ];
    for s in sets {
        args.extend(["--set", s]);
    }
    let o = softgrain(&args);
    assert!(o.status.success(), "{file}: {}", stderr(&o));
    // the cases' folders: OUT/<name>/compact/<case>/ (each pipeline is named as its file)
    let name = file.trim_end_matches(".yaml");
    let stages = common::compact_stage_jsons(&dir, name);
    assert_eq!(stages.len(), cases, "{file}: {stages:?}");
    for (s, j) in stages {
        assert!(
            j["figures"]["steps"].as_u64().unwrap() > 0,
            "{}: {j}",
            s.display()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn paper_coarse_starts_its_compaction() {
    starts("coarse", "paper-coarse.yaml", &[], 2);
}

#[test]
fn the_mpm_packing_pipelines_start_their_compaction() {
    starts("paper-mpm", "paper-mpm.yaml", &[], 2);
    starts("mpm-small", "mpm-packing-small.yaml", &[], 2);
    // (the BPM solver settings are refused without a BPM case; they name no MPM node)
    starts(
        "paper-mpm-half",
        "paper.yaml",
        &["include=[]", "discretise.method=mpm", "compact.solver=null"],
        2,
    );
}

/// The paper's BPM scene: 75,000 particles to discretise (about two CPU-minutes).
#[test]
fn paper_bpm_starts_its_compaction() {
    starts(
        "paper-bpm-half",
        "paper.yaml",
        &["include=[]", "discretise.method=bpm"],
        2,
    );
}
