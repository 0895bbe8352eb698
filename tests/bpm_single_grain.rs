//! One BPM grain between two plates (paper section 3, Fig. 6), on a grain small enough for
//! CI: R = 1.5 mm, particles 0.16-0.26 mm (about 150). The paper-size grain (1750
//! particles) is the pipeline `pipelines/single-grain-bpm.yaml`, recorded in the README.

mod common;

use softgrain::stages::StageState;
use softgrain::stages::compact::Compacted;

const GRAIN: &str = "name: g\nseed: 1\nprepare:\n  layout: single\n  radius: 1.5e-3\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [1.6e-4, 2.6e-4]\n    f0: 100.0\ncompact:\n  wall_velocity: 0.2\n  final_strain: 0.3\nsolver:\n  tolerance: 1.0e-3\noutput:\n  every: 100\n  vtk: false\n";

fn compress(tag: &str, sets: &[&str]) -> Compacted {
    let dir = common::temp_dir(tag);
    let file = common::write(&dir, "g.yaml", GRAIN);
    let state = common::run_to_state(&dir, &file, sets);
    let _ = std::fs::remove_dir_all(&dir);
    match state {
        StageState::Compacted(c) => c,
        other => panic!("compact produced {other:?}"),
    }
}

fn mean_over(
    c: &Compacted,
    lo: f64,
    hi: f64,
    f: impl Fn(&softgrain::stages::compact::Row) -> f64,
) -> f64 {
    let rows: Vec<f64> = c
        .rows
        .iter()
        .filter(|r| r.strain > lo && r.strain <= hi)
        .map(f)
        .collect();
    rows.iter().sum::<f64>() / rows.len() as f64
}

#[test]
fn a_bpm_grain_yields_plastically_keeps_its_area_and_its_particles() {
    let c = compress("bpm1", &[]);
    let f = &c.figures;
    let scale = f.f0 / f.mean_a0;
    // a plastic plateau of order F0/<a0> (about 0.2, as for the paper's 1750-particle grain)
    assert!(
        f.plateau > 0.1 && f.plateau < 2.0,
        "plateau σ<a0>/F0 = {}",
        f.plateau
    );
    // a plateau, not elastic growth: the mean stress hardly changes from [0.1, 0.2] to [0.2, 0.3]
    let (s1, s2) = (
        mean_over(&c, 0.1, 0.2, |r| r.sigma),
        mean_over(&c, 0.2, 0.3, |r| r.sigma),
    );
    assert!(
        s2 / s1 < 2.0 && s2 / s1 > 0.5,
        "σ over [0.1,0.2] = {:.3}, [0.2,0.3] = {:.3} F0/<a0>",
        s1 / scale,
        s2 / scale
    );
    // stiff start: by 3% strain the stress has reached a good part of the plateau
    let early = mean_over(&c, 0.02, 0.04, |r| r.sigma);
    assert!(
        early > 0.3 * s1,
        "σ(2-4%) = {:.3} vs plateau {:.3} F0/<a0>",
        early / scale,
        s1 / scale
    );
    // quasi-static: the two plates carry the same mean force
    let (bottom, top) = (
        mean_over(&c, 0.05, 0.3, |r| r.force),
        mean_over(&c, 0.05, 0.3, |r| r.force_top),
    );
    assert!(
        (top / bottom - 1.0).abs() < 0.05,
        "top {top} vs bottom {bottom}"
    );
    // nearly constant area (frictionless rearrangements do not dilate) and no escape
    assert!(f.area_change < 0.05, "area changed by {}", f.area_change);
    assert_eq!(f.escaped_max, 0);

    // The plateau level (README, "the plateau level"): the attraction holds the grain under
    // an isotropic tension σ_c ≈ Z_a φ/π F0/<a0> ≈ 1.2-1.3 (Z_a ≈ 4.7 attracting pairs per
    // particle weighted by F_a/F0, φ ≈ 0.77), and the contact network, loaded by that plus
    // the plate, yields at the internal friction of frictionless disks, s ≈ 0.1. With
    // σ_xx = 0 on the free sides the grain-mean vertical stress is then 2 σ_c s/(1 - s).
    assert!(
        f.plateau_prestress > 1.0 && f.plateau_prestress < 1.6,
        "σ_c <a0>/F0 = {}",
        f.plateau_prestress
    );
    assert!(
        f.plateau_sin_phi > 0.03 && f.plateau_sin_phi < 0.15,
        "mobilised friction {}",
        f.plateau_sin_phi
    );
    // grain-mean vertical stress from the plates, F h/A (h the plate gap, A the grain area)
    let h0 = c.rows[0].area.sqrt() * 2.0 / std::f64::consts::PI.sqrt();
    let plate = mean_over(&c, 0.1, 0.3, |r| r.force * h0 * (-r.strain).exp() / r.area);
    let s = f.plateau_sin_phi;
    let internal = 2.0 * f.plateau_prestress * scale * s / (1.0 - s);
    assert!(
        (internal / plate - 1.0).abs() < 0.2,
        "2 σ_c s/(1 - s) = {internal:.4e} Pa against F h/A = {plate:.4e} Pa"
    );
}

/// `stage.json` says where the compaction's time went, by part of the contact-dynamics
/// step and of the recording (as for packings, `tests/bpm_packing.rs`).
#[test]
fn the_compact_stage_reports_its_time_by_part_of_the_step() {
    common::check_cd_timings("bpm-grain-timings", "g", GRAIN);
}
