//! A small MPM packing through the pipeline (deposit, discretise, compact): the paper's
//! trends that hold at small scale.

mod common;

use softgrain::compaction::PackingCompacted;
use softgrain::config::Method;
use softgrain::stages::StageState;

/// 12 grains, inter-grain friction `mu`, to ε = 0.3, a row every 10 steps (the MPM pace
/// `output.mpm_every`, with `output.every` far beyond the run); also returns the run folder.
fn small_packing(tag: &str, mu: f64) -> (PackingCompacted, std::path::PathBuf) {
    small_packing_with(tag, mu, &["discretise.mpm.contact=node"])
}

/// The same with more `--set`s.
fn small_packing_with(tag: &str, mu: f64, sets: &[&str]) -> (PackingCompacted, std::path::PathBuf) {
    let dir = common::temp_dir(tag);
    let file = std::path::Path::new("pipelines/mpm-packing-small.yaml");
    let friction = format!("compact.friction={mu}");
    let mut all = vec![
        "prepare.grains=12",
        &friction,
        "compact.final_strain=0.3",
        "output.every=100000",
        "output.mpm_every=10",
    ];
    all.extend_from_slice(sets);
    let state = common::run_to_state(&dir, file, &all);
    let StageState::Packing(c) = state else {
        panic!("compact produced another state")
    };
    (c, dir)
}

#[test]
fn a_small_mpm_packing_jams_with_phi_following_the_box_and_the_grain_area() {
    let (c, dir) = small_packing("mpm-packing-pipe", 0.5);
    assert_eq!(c.method, Method::Mpm);
    // recorded at the MPM pace: a row every 10 steps
    assert!(
        c.rows.len() as u64 >= c.figures.steps / 10,
        "{} rows for {} steps",
        c.rows.len(),
        c.figures.steps
    );
    assert_eq!(c.grains, 12);
    let rows = &c.rows;
    let phi0 = 0.65;
    // the first row is the start: the box holds the grains' seeded area at Φ0
    assert_eq!(rows[0].strain, 0.0);
    assert!(
        (rows[0].phi / phi0 - 1.0).abs() < 1e-12,
        "Φ(0) = {}",
        rows[0].phi
    );
    assert!(rows[1].strain > 0.0);
    // mass is carried by the points: exact
    assert_eq!(c.figures.mass_change, Some(0.0));
    // the recorded area change is the rows' Σ v_p = Φ × box area against the start's
    let area_change = rows
        .iter()
        .map(|r| (r.phi * (-r.strain).exp() / phi0 - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(
        (c.figures.area_change - area_change).abs() < 1e-9 && c.figures.area_change > 0.0,
        "area change {} against the rows' {area_change}",
        c.figures.area_change
    );
    // before any contact the grains keep their area: Φ = Φ0 e^ε (rigid side walls)
    let free: Vec<_> = rows
        .iter()
        .filter(|r| r.z == 0.0 && r.sigma == 0.0 && r.sigma_top == 0.0)
        .collect();
    assert!(!free.is_empty());
    for r in &free {
        let expect = phi0 * r.strain.exp();
        assert!(
            (r.phi - expect).abs() < 1e-6,
            "ε = {}: Φ = {} vs Φ0 e^ε = {expect}",
            r.strain,
            r.phi
        );
    }
    // afterwards Σ v_p stays within the elastic volume change: σ stays below 0.4 MPa and
    // the plane-strain bulk modulus λ + μ is 34.5 MPa, so about 1 %
    let sigma_max = rows
        .iter()
        .map(|r| r.sigma.max(r.sigma_top))
        .fold(0.0, f64::max);
    assert!(sigma_max < 4e5, "σ reached {sigma_max}");
    for r in rows {
        let area_ratio = r.phi * (-r.strain).exp() / phi0;
        assert!(
            (area_ratio - 1.0).abs() < 0.012,
            "ε = {}: Σ v_p / Σ V_p0 = {area_ratio}",
            r.strain
        );
    }
    let last = rows.last().unwrap();
    assert!(
        (last.strain - 0.3).abs() < 0.01,
        "ended at ε = {}",
        last.strain
    );
    // jammed: the grains touch each other and the stress rises with strain
    assert!(last.z > 0.0, "Z = {}", last.z);
    assert!(last.phi > phi0 * 1.25, "Φ = {}", last.phi);
    let n = rows.len();
    let mean = |rs: &[softgrain::compaction::Row]| {
        rs.iter().map(|r| r.sigma).sum::<f64>() / rs.len() as f64
    };
    let (mid, end) = (mean(&rows[n / 3..2 * n / 3]), mean(&rows[2 * n / 3..]));
    assert!(end > 2.0 * mid && end > 0.0, "σ: {mid} then {end}");
    // the worst overlap is located: two grains, a node inside the box, a recorded strain
    let site = c.figures.overlap_site;
    assert!(
        site.overlap == c.figures.overlap_max && site.overlap > 0.0,
        "{site:?}"
    );
    assert!(site.grains[0] != site.grains[1] && site.grains.iter().all(|&g| g < 12));
    assert!(
        rows.iter()
            .any(|r| r.strain == site.strain && r.overlap == site.overlap)
    );
    let loaded = c.figures.overlap_max_loaded;
    assert!(
        loaded > 0.0 && loaded <= site.overlap,
        "{loaded} once loaded, {site:?}"
    );
    let (w, h) = (c.geometry.width, c.geometry.height(site.strain));
    assert!(
        (0.0..=w).contains(&site.at[0]) && (0.0..=h).contains(&site.at[1]),
        "{site:?}"
    );
    // every step kept converged contact forces, and the rows say how close they came
    assert_eq!(c.figures.unconverged_steps, 0);
    assert!(rows.iter().all(|r| r.unconverged == 0 && r.residual <= 1.0));
    let closest = rows.iter().map(|r| r.residual).fold(0.0, f64::max);
    assert!(closest > 0.0 && closest == c.figures.residual_max);
    let run = dir.join("mpm-packing-small/compact/mpm-mu0.5");
    let csv = std::fs::read_to_string(run.join("timeseries.csv")).unwrap();
    assert!(csv.starts_with("time,strain,phi,z,sigma"));
    assert!(
        csv.lines()
            .next()
            .unwrap()
            .ends_with(",residual,unconverged,sigma_box,sigma_lever,points_inside,point_overlap")
    );
    assert!(run.join("series.pvd").exists());
    // stage.json says where the run's time went: every part of the step and of the
    // recording, none negative, the contact solve and the factorisations not empty, and
    // together no more than the stage's wall time
    let stage: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("stage.json")).unwrap()).unwrap();
    let parts = [
        "step_begin",
        "step_detect",
        "step_residual",
        "step_factorise",
        "step_contact",
        "step_update",
        "step_finish",
        "measures",
        "rows",
        "snapshots",
    ];
    common::check_timings(&stage, &parts, &["step_contact", "step_factorise"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Without friction the grains rock and spin in the packing. The linear-elastic law once
/// took its strain increment in the start-of-step configuration, so the O(θ²) outward
/// motion of a linearised rotation increment strained nothing and a rocking grain swelled
/// unresisted: Σ v_p grew by 15 % by ε = 0.3 on 16 grains. With the Hughes–Winget
/// midpoint gradient the area stays within the elastic volume change, as with friction.
#[test]
fn a_frictionless_mpm_packing_keeps_its_grain_area() {
    let (c, dir) = small_packing("mpm-packing-mu0", 0.0);
    let phi0 = 0.65;
    for r in &c.rows {
        let area_ratio = r.phi * (-r.strain).exp() / phi0;
        assert!(
            (area_ratio - 1.0).abs() < 0.012,
            "ε = {}: Σ v_p / Σ V_p0 = {area_ratio}",
            r.strain
        );
    }
    assert_eq!(c.figures.unconverged_steps, 0);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The default surface contact keeps the grains apart: no point has a face a half-size or
/// more inside another grain (`mpm::overlap::points_inside`), while the node contact lets
/// 2-7% of the points through. Swept over seeds 7, 1, 2, 3 with μ = 0 and 0.5 (session
/// 34's build): none in 6 of the 8 runs; in two frictionless ones 1 and 2 points at one
/// record, ε ≈ 0.13, where grains driven by the wall collide before the packing carries
/// load (σ ≈ 12-15 kPa); none once loaded in any. Here no two points of different grains
/// overlap by a half-size (h_g/4) either: 0.17 h_g at worst (session 34), where the node
/// gap reads 0.52 h_g. Over the eight runs the deepest pair once loaded is 0.12-0.27 h_g
/// (the 0.27 at seed 1, μ = 0.5), and 0.34 in a collision before loading.
#[test]
fn a_small_mpm_packing_keeps_its_grains_apart() {
    let (c, dir) = small_packing_with(
        "mpm-packing-overlap",
        0.5,
        &["discretise.mpm.contact=surface"],
    );
    let loaded = softgrain::compaction::max_after_jamming(&c.rows, |r| r.points_inside);
    assert!(
        c.figures.points_inside_max == 0.0,
        "{}% of the points inside another grain ({}% once loaded), worst node gap {} cells",
        100.0 * c.figures.points_inside_max,
        100.0 * loaded,
        c.figures.overlap_max
    );
    let deepest = c.rows.iter().map(|r| r.point_overlap).fold(0.0, f64::max);
    assert!(
        c.figures.point_overlap_max == Some(deepest) && deepest > 0.0 && deepest < 0.25,
        "two points overlap by {deepest} h_g"
    );
    // once loaded (the floor at a tenth of its largest stress or more): no deeper
    let pair_loaded = c.figures.point_overlap_max_loaded.unwrap();
    assert!(pair_loaded > 0.0 && pair_loaded <= deepest, "{pair_loaded}");
    // and located: two grains, inside the box, at a recorded strain
    let site = c
        .figures
        .point_overlap_site
        .expect("MPM locates its deepest pair");
    assert!(site.overlap == deepest, "{site:?}");
    assert!(
        site.grains[0] < site.grains[1] && site.grains[1] < 12,
        "{site:?}"
    );
    assert!(
        c.rows
            .iter()
            .any(|r| r.strain == site.strain && r.point_overlap == deepest)
    );
    let (w, h) = (c.geometry.width, c.geometry.height(site.strain));
    assert!(
        (0.0..=w).contains(&site.at[0]) && (0.0..=h).contains(&site.at[1]),
        "{site:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `discretise.mpm.contact: surface` puts each grain contact on the two grains' surface
/// layers at its node, so that its force moves the points that set the gap. Without
/// friction the node contact lets these 12 grains overlap by 1.2-2.4 h_g (a fixed length:
/// more cells on a finer grid, README); the surface contact by 0.42-0.58 h_g. The runs are
/// chaotic, so the comparisons below are of means over three seeds (7, 1, 2). Measured in
/// session 37 over the seeds where the default box fits (9 with the surface contact, 4
/// with the node contact): worst node gap 0.49 ± 0.06 h_g against 1.6; area under two
/// grains at the end 0.62% against 3.6%; points inside another grain (a face a half-size
/// or more inside, `mpm::overlap::points_inside`) at most 0.04% (one run of nine) against
/// 4.8%; deepest point pair 0.26 ± 0.10 h_g against 0.49, the measure's ceiling (two whole
/// points with one centre: l_p + l_q = h_g/2, times their stretch). Until session 37 this
/// test compared one seed (7), where that pair read 0.15 h_g, and asserted it below half
/// the node contact's, which the seeds do not support (0.54 of it on the means). The
/// grains carry more stress with the surface contact, so their area may shrink more, but
/// only elastically: the grains' mean pressure is at most σ/Φ, so
/// |ΔΣv_p/Σv_p| <= σ/(Φ (λ + μ)).
#[test]
fn surface_contact_at_least_halves_the_overlap_of_a_small_mpm_packing() {
    let seeded = |seed: u64, contact: &str| {
        let (c, dir) = small_packing_with(
            &format!("mpm-packing-{contact}-{seed}"),
            0.0,
            &[
                &format!("discretise.mpm.contact={contact}"),
                &format!("seed={seed}"),
            ],
        );
        let _ = std::fs::remove_dir_all(&dir);
        c
    };
    let seeds = [7, 1, 2];
    let nodes: Vec<PackingCompacted> = seeds.iter().map(|&s| seeded(s, "node")).collect();
    let surfaces: Vec<PackingCompacted> = seeds.iter().map(|&s| seeded(s, "surface")).collect();
    let over_seeds = |runs: &[PackingCompacted], f: fn(&PackingCompacted) -> f64| {
        runs.iter().map(f).sum::<f64>() / runs.len() as f64
    };
    let compare = |what: &str, f: fn(&PackingCompacted) -> f64, ratio: f64| {
        let (s, n) = (over_seeds(&surfaces, f), over_seeds(&nodes, f));
        assert!(
            s < ratio * n,
            "{what}: {s} with the surface contact, {n} with the node contact"
        );
    };
    compare("worst node gap (h_g)", |c| c.figures.overlap_max, 0.5);
    compare(
        "area under two grains at the end",
        |c| c.rows.last().unwrap().overlap_area,
        0.5,
    );
    compare(
        "points inside another grain",
        |c| c.figures.points_inside_max,
        0.1,
    );
    // below the ceiling the node contact sits at
    compare(
        "deepest point pair (h_g)",
        |c| c.figures.point_overlap_max.unwrap(),
        0.75,
    );
    let (node, c) = (&nodes[0], &surfaces[0]);
    assert_eq!(c.figures.mass_change, Some(0.0));
    assert_eq!(c.figures.unconverged_steps, 0);
    let (e, nu) = (1e7, 0.45);
    let bulk = e / (2.0 * (1.0 + nu) * (1.0 - 2.0 * nu));
    let phi0 = 0.65;
    for r in &c.rows {
        let area_ratio = r.phi * (-r.strain).exp() / phi0;
        let sigma = r
            .sigma
            .max(r.sigma_top)
            .max(r.sigma_left)
            .max(r.sigma_right);
        assert!(
            (area_ratio - 1.0).abs() <= 1e-3 + sigma / (r.phi * bulk),
            "ε = {}: Σ v_p / Σ V_p0 = {area_ratio} at σ = {sigma}",
            r.strain
        );
    }
    let last = c.rows.last().unwrap();
    assert!(last.z > 0.0 && last.sigma > 0.0);
    // The grains' stress over the box is what the walls put in less the surface contact's
    // pair moment (`Packing::contact_moments`), within the wall contact nodes' offset from
    // the walls (up to a cell, 3% of this box's height) and the grains' ringing: measured
    // 2.1% here and 1.0% for the node contact, whose pairs add nothing. The pairs' term is
    // not small: 9.8% of the walls' stress.
    let late = &c.rows[2 * c.rows.len() / 3..];
    let mean = |rows: &[softgrain::compaction::Row], f: fn(&softgrain::compaction::Row) -> f64| {
        rows.iter().map(f).sum::<f64>() / rows.len() as f64
    };
    for (rows, surface) in [(late, true), (&node.rows[2 * node.rows.len() / 3..], false)] {
        let (walls, lever) = (mean(rows, |r| r.sigma_top), mean(rows, |r| r.sigma_lever));
        let stress = mean(rows, |r| r.sigma_box);
        assert!(
            ((walls - lever) / stress - 1.0).abs() < 0.05,
            "surface {surface}: walls {walls}, lever {lever}, grains {stress}"
        );
        if surface {
            assert!(lever > 0.05 * walls, "lever {lever}, walls {walls}");
        } else {
            assert!(lever.abs() < 1e-9 * walls);
        }
    }
}

/// `compact.newton_tolerance` sets the coupling's residual tolerance (default 1e-5,
/// `mpm::packing::COUPLING_TOLERANCE`): at 1e-6 the same packing takes more coupling
/// iterations per step and, the box setting Φ, ends at the same packing fraction.
#[test]
fn the_newton_tolerance_key_sets_the_coupling_tolerance() {
    let (loose, dir) = small_packing_with("mpm-packing-tol", 0.5, &[]);
    let _ = std::fs::remove_dir_all(&dir);
    let (tight, dir) = small_packing_with(
        "mpm-packing-tol-tight",
        0.5,
        &["compact.newton_tolerance=1e-6"],
    );
    let _ = std::fs::remove_dir_all(&dir);
    let per_step = |c: &PackingCompacted| c.figures.iterations_mean;
    assert!(
        per_step(&tight) > per_step(&loose),
        "coupling iterations per step: {} at 1e-6, {} at the default",
        per_step(&tight),
        per_step(&loose)
    );
    let end = |c: &PackingCompacted| c.rows.last().map(|r| (r.strain, r.phi)).unwrap();
    let ((e1, phi1), (e2, phi2)) = (end(&loose), end(&tight));
    assert!(
        (e1 - e2).abs() < 1e-9 && (phi1 - phi2).abs() < 2e-3,
        "{e1} {phi1} / {e2} {phi2}"
    );
}
