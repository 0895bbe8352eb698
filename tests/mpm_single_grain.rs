//! Single MPM grain between two plates: small-strain force against Johnson's 2D solution,
//! scaling, time-step stability, locking, mass, checkpoint/resume and typed errors.
//! Coarse grids and small strains keep each test to about a second in release; the
//! refinement study is `examples/mpm_convergence.rs` and the ignored test at the end.

use softgrain::mpm::analytic::{eq13_force, johnson_force};
use softgrain::mpm::{
    Control, MaterialKind, MpmError, Row, ShapeKind, SingleGrain, SingleGrainParams, force_at,
    run_single_grain, window_mean_over_johnson,
};

fn params(resolution: f64, final_strain: f64) -> SingleGrainParams {
    let mut p = SingleGrainParams::paper();
    p.resolution = resolution;
    p.final_strain = final_strain;
    p
}

fn run(p: SingleGrainParams) -> Vec<Row> {
    run_single_grain(p, |_| Control::Continue).unwrap().rows
}

#[test]
fn small_strain_force_is_near_johnson_and_below_eq13() {
    let p = params(0.04, 0.021);
    let (e, nu, r) = (p.material.young, p.material.poisson, p.radius);
    let rows = run(p);
    let f = force_at(&rows, 0.02);
    let johnson = johnson_force(e, nu, r, 0.02).unwrap();
    // Measured 1.009 at Δr/R = 0.04 (Eq. 13 ratio 0.653).
    assert!(
        (f / johnson - 1.0).abs() < 0.05,
        "F/Johnson = {}",
        f / johnson
    );
    assert!(f / eq13_force(e, nu, r, 0.02) < 0.75);
    for row in &rows {
        let mean = 0.5 * (row.force_top + row.force_bottom);
        assert!(
            (row.force_top - row.force_bottom).abs() < 0.05 * mean + 1.0,
            "{row:?}"
        );
        assert!(row.width > 2.0 * r && row.sigma > 0.0);
    }
}

#[test]
fn force_scales_with_plane_strain_modulus_and_radius() {
    let base = params(0.04, 0.021);
    let f0 = force_at(&run(base.clone()), 0.02);
    let mut stiff = base.clone();
    stiff.material.young *= 2.0;
    let f_e = force_at(&run(stiff), 0.02);
    assert!((f_e / f0 / 2.0 - 1.0).abs() < 0.02, "E: {}", f_e / f0);
    let mut big = base.clone();
    big.radius *= 2.0;
    let f_r = force_at(&run(big), 0.02);
    assert!((f_r / f0 / 2.0 - 1.0).abs() < 0.02, "R: {}", f_r / f0);
}

/// ν at fixed E* = E/(1-ν²) against the plane-strain finite-element reference
/// (`bench/disk-fe-reference.md`, Q9 and Q2P1 to 660k DOFs, exact frictionless contact):
/// in linear elasticity F(δ) depends on ν only through E*, exactly; with the MPM's
/// neo-Hookean law, averaged over ε in [0.01, 0.05] (`disk_fe_reference.py --window`),
/// F(0.3)/F(0.45) = 0.9928 and F(0.49)/F(0.45) = 1.0042. The MPM's error in these ratios
/// is a discretisation error that falls under refinement (README): measured 0.9806 and
/// 1.0110 at Δr/R = 0.04, 0.9850 and 1.0067 at 0.0156, 0.9901 and 1.0054 at 0.01.
#[test]
fn force_at_fixed_plane_strain_modulus_converges_to_the_fe_reference_in_nu() {
    let ratios = |resolution: f64| {
        let mean = |nu: f64| {
            let mut p = params(resolution, 0.051);
            p.material.kind = MaterialKind::NeoHookean;
            p.material = p.material.with_poisson_at_fixed_plane_strain_modulus(nu);
            let (material, radius) = (p.material, p.radius);
            window_mean_over_johnson(&run(p), &material, radius)
        };
        let f45 = mean(0.45);
        [mean(0.3) / f45, mean(0.49) / f45]
    };
    let fe = [0.9928, 1.0042];
    let coarse = ratios(0.04);
    let fine = ratios(0.0156);
    for k in 0..2 {
        let (ec, ef) = (coarse[k] / fe[k] - 1.0, fine[k] / fe[k] - 1.0);
        assert!(
            ef.abs() < 0.01 && ef.abs() < ec.abs(),
            "ratio {k}: {} at Δr/R = 0.04, {} at 0.0156, FE {}",
            coarse[k],
            fine[k],
            fe[k]
        );
    }
    // The scaling statement: F(0.3) and F(0.45) at equal E* within 2%.
    assert!((fine[0] - 1.0).abs() < 0.02, "F(0.3)/F(0.45) = {}", fine[0]);
}

#[test]
fn implicit_steps_far_beyond_the_explicit_limit_are_stable() {
    // Plate travel 0.1 h_g per step: about 98 times h_g / c_p for the paper's grain.
    let mut p = params(0.08, 0.1);
    p.travel_per_step = 0.1;
    let out = run_single_grain(p, |_| Control::Continue).unwrap();
    let s = &out.stats;
    assert!(s.dt >= 10.0 * s.dt_cfl, "dt {} cfl {}", s.dt, s.dt_cfl);
    let mut last = 0.0;
    for row in &out.rows {
        let mean = 0.5 * (row.force_top + row.force_bottom);
        assert!(mean.is_finite() && mean > last, "force must grow: {row:?}");
        assert!(
            (row.force_top - row.force_bottom).abs() < 0.1 * mean,
            "{row:?}"
        );
        last = mean;
    }
}

#[test]
fn bbar_removes_volumetric_locking() {
    // On the paper's bilinear cells, where locking is the known issue.
    let slope = |bbar: bool| {
        let mut p = params(0.08, 0.021);
        p.solver.shape = ShapeKind::Bilinear;
        p.solver.bbar = bbar;
        force_at(&run(p), 0.02) / 0.02
    };
    let (with, without) = (slope(true), slope(false));
    // Secant slope to ε = 0.02, without/with B-bar: 1.087 at Δr/R = 0.08, 1.053 at 0.04,
    // 1.018 at 0.029 (ν = 0.45, 2×2 points per cell: mild locking).
    assert!(without > 1.05 * with, "with {with:.0} without {without:.0}");
}

#[test]
fn neo_hookean_agrees_with_linear_elasticity_at_small_strain() {
    let le = force_at(&run(params(0.08, 0.021)), 0.02);
    let mut p = params(0.08, 0.021);
    p.material.kind = MaterialKind::NeoHookean;
    let nh = force_at(&run(p), 0.02);
    assert!((nh / le - 1.0).abs() < 0.03, "NH/LE = {}", nh / le);
}

#[test]
fn mass_and_seeded_area_are_exact() {
    let p = params(0.029, 0.01);
    let r = p.radius;
    let mut g = SingleGrain::new(p).unwrap();
    let area: f64 = g.points.vol0.iter().sum();
    assert!((area / (std::f64::consts::PI * r * r) - 1.0).abs() < 1e-13);
    assert!((3500..3900).contains(&g.points.len()), "{}", g.points.len());
    let m0 = g.points.total_mass();
    while !g.is_done() {
        g.step().unwrap();
    }
    assert_eq!(g.points.total_mass(), m0);
}

#[test]
fn a_checkpointed_run_resumes_to_the_same_state() {
    let p = params(0.08, 0.02);
    let mut whole = SingleGrain::new(p.clone()).unwrap();
    let mut first = SingleGrain::new(p).unwrap();
    for _ in 0..4 {
        whole.step().unwrap();
        first.step().unwrap();
    }
    // The checkpoint store's format (bincode 2 over serde), and JSON.
    let cfg = bincode::config::standard();
    let bytes = bincode::serde::encode_to_vec(&first, cfg).unwrap();
    let (from_bincode, _): (SingleGrain, usize) =
        bincode::serde::decode_from_slice(&bytes, cfg).unwrap();
    assert_eq!(from_bincode.points.x, first.points.x);
    let saved = serde_json::to_string(&first).unwrap();
    let mut resumed: SingleGrain = serde_json::from_str(&saved).unwrap();
    while !whole.is_done() {
        whole.step().unwrap();
        resumed.step().unwrap();
    }
    assert!(resumed.is_done());
    for (a, b) in whole.rows.iter().zip(&resumed.rows) {
        assert!(
            (a.force_top - b.force_top).abs() <= 1e-6 * a.force_top.abs(),
            "{a:?} {b:?}"
        );
    }
}

#[test]
fn the_callback_can_stop_a_run() {
    let mut calls = 0;
    let out = run_single_grain(params(0.08, 0.05), |p| {
        calls += 1;
        assert!(p.fraction > 0.0 && p.fraction <= 1.0);
        if calls == 3 {
            Control::Stop
        } else {
            Control::Continue
        }
    })
    .unwrap();
    assert!(out.stopped_early);
    assert_eq!(out.rows.len(), 3);
    assert_eq!(out.points.position.len(), out.points.von_mises.len());
}

#[test]
fn failures_are_typed_errors() {
    let mut p = params(0.08, 0.02);
    p.material.poisson = 0.5;
    assert!(matches!(
        SingleGrain::new(p),
        Err(MpmError::InvalidParameter {
            name: "poisson",
            ..
        })
    ));
    // No Newton iteration allowed: even the halved steps cannot converge.
    let mut p = params(0.08, 0.02);
    p.solver.newton.max_iterations = 0;
    match run_single_grain(p, |_| Control::Continue) {
        Err(MpmError::NotConverged { step: 0, .. }) => {}
        other => panic!("expected NotConverged at step 0, got {other:?}"),
    }
}

/// The paper's grain (Δr/R = 0.029, B-spline) to 30 % strain: within 5 % of Johnson at
/// ε = 0.02 and 0.05. About 10 s in release; `cargo test --release -- --ignored`.
#[test]
#[ignore]
fn paper_grain_to_thirty_percent() {
    let p = SingleGrainParams::paper();
    let (e, nu, r) = (p.material.young, p.material.poisson, p.radius);
    let out = run_single_grain(p, |_| Control::Continue).unwrap();
    let f2 = force_at(&out.rows, 0.02);
    assert!((f2 / johnson_force(e, nu, r, 0.02).unwrap() - 1.0).abs() < 0.05);
    let f5 = force_at(&out.rows, 0.05);
    assert!((f5 / johnson_force(e, nu, r, 0.05).unwrap() - 1.0).abs() < 0.05);
    assert!(out.rows.last().unwrap().strain >= 0.3 - 1e-12);
}

#[test]
fn a_failed_step_is_redone_in_halves() {
    let base = run_single_grain(params(0.08, 0.021), |_| Control::Continue).unwrap();
    assert_eq!(base.stats.halvings, 0);
    // Too few Newton iterations for a full step, enough for half steps.
    let mut p = params(0.08, 0.021);
    p.solver.newton.max_iterations = 4;
    let out = run_single_grain(p, |_| Control::Continue).unwrap();
    assert!(out.stats.halvings > 0);
    assert_eq!(out.rows.len(), base.rows.len());
    let (a, b) = (force_at(&base.rows, 0.02), force_at(&out.rows, 0.02));
    // The halved steps are solved with Δt/2: 1.3 % apart on this coarse grid.
    assert!((a / b - 1.0).abs() < 0.03, "{a} vs {b}");
}

#[test]
fn the_guard_reports_energy_growth_and_non_finite_state() {
    // Kinetic energy that the plates never supplied.
    let mut g = SingleGrain::new(params(0.08, 0.02)).unwrap();
    for v in g.points.v.iter_mut() {
        v.x += 10.0;
    }
    assert!(matches!(
        g.step(),
        Err(MpmError::EnergyGrowth { step: 0, .. })
    ));
    // A NaN in the state is caught before it spreads.
    let mut g = SingleGrain::new(params(0.08, 0.02)).unwrap();
    g.points.stress[7].xx = f64::NAN;
    assert!(matches!(g.step(), Err(MpmError::NonFinite { step: 0, .. })));
}

#[test]
fn wall_friction_obeys_coulomb_and_barely_stiffens_compression() {
    let f_smooth = force_at(&run(params(0.08, 0.051)), 0.05);
    let mut p = params(0.08, 0.051);
    p.wall_friction = 0.3;
    let f_rough = force_at(&run(p), 0.05);
    // Friction only resists the spreading of the contact: measured +0.4 %.
    assert!(
        f_rough >= 0.999 * f_smooth && f_rough < 1.05 * f_smooth,
        "{f_rough} vs {f_smooth}"
    );

    // A top plate sliding sideways drags the grain through friction, never beyond μ f_n.
    for mu in [0.0, 0.1] {
        let mut p = params(0.08, 0.03);
        p.wall_friction = mu;
        let mut g = SingleGrain::new(p).unwrap();
        g.walls[1].velocity.x = 0.2;
        let mut dragged = false;
        while !g.is_done() {
            g.step().unwrap();
            for w in &g.walls {
                let (ft, fn_) = (w.force.x.abs(), w.normal_force());
                assert!(
                    ft <= mu * fn_ * (1.0 + 1e-9) + 1e-9,
                    "μ {mu}: |F_t| {ft} > μ F_n {fn_}"
                );
                dragged |= ft > 1e-3 * fn_;
            }
        }
        assert_eq!(dragged, mu > 0.0);
    }
}
