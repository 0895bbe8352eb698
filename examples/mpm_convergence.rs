//! Refinement study of the single MPM grain against Johnson's 2D solution and Eq. 13.
//!
//! `cargo run --release --example mpm_convergence -- [resolutions] [shape] [bbar] [final_strain]
//! [travel_per_step] [material] [poisson] [wall_velocity] [wall_friction]`, e.g.
//! `-- 0.08,0.04,0.029 bilinear on 0.05 0.05 neohookean 0.3`. A Poisson ratio other than the
//! paper's 0.45 keeps E* = E/(1-ν²) at the paper's value (the FE reference's comparison,
//! `bench/disk-fe-reference.md`).
//! Prints a table; nothing is written.

use softgrain::mpm::analytic::{eq13_force, johnson_force};
use softgrain::mpm::{
    Control, MaterialKind, ShapeKind, SingleGrainParams, force_at, run_single_grain,
    window_mean_over_johnson,
};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let res: Vec<f64> = args
        .get(1)
        .map(|s| {
            s.split(',')
                .map(|x| x.parse().expect("resolution"))
                .collect()
        })
        .unwrap_or(vec![0.08, 0.04, 0.029]);
    let shape = match args.get(2).map(String::as_str) {
        Some("gimp") => ShapeKind::Gimp,
        Some("bspline") => ShapeKind::BSpline2,
        _ => ShapeKind::Bilinear,
    };
    let bbar = args.get(3).map(|s| s != "off").unwrap_or(true);
    let final_strain: f64 = args
        .get(4)
        .map(|s| s.parse().expect("strain"))
        .unwrap_or(0.05);
    let travel: f64 = args
        .get(5)
        .map(|s| s.parse().expect("travel"))
        .unwrap_or(0.05);
    let kind = match args.get(6).map(String::as_str) {
        Some("neohookean") => MaterialKind::NeoHookean,
        _ => MaterialKind::LinearElastic,
    };
    let poisson: Option<f64> = args.get(7).map(|s| s.parse().expect("poisson"));
    let wall_velocity: Option<f64> = args.get(8).map(|s| s.parse().expect("wall velocity"));
    let wall_friction: Option<f64> = args.get(9).map(|s| s.parse().expect("wall friction"));
    println!(
        "shape {shape:?}, B-bar {bbar}, final strain {final_strain}, travel/step {travel} h_g, {kind:?}, ν {poisson:?}"
    );
    println!(
        "{:>6} {:>6} {:>5} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6} {:>6} {:>5} {:>8} {:>8}",
        "dr/R",
        "points",
        "cells",
        "F(.02)",
        "F(.05)",
        "J(.02)",
        "E13(.02)",
        "J(.05)",
        "E13(.05)",
        "J(mean)",
        "steps",
        "iters",
        "max",
        "dt/cfl",
        "wall_s"
    );
    for r in res {
        let mut p = SingleGrainParams::paper();
        p.resolution = r;
        p.solver.shape = shape;
        p.solver.bbar = bbar;
        p.final_strain = final_strain;
        p.travel_per_step = travel;
        p.material.kind = kind;
        if let Some(mu) = wall_friction {
            p.wall_friction = mu;
        }
        if let Some(v) = wall_velocity {
            p.wall_velocity = v;
        }
        if let Some(nu) = poisson {
            p.material = p.material.with_poisson_at_fixed_plane_strain_modulus(nu);
        }
        let (e, nu, rad, material) = (p.material.young, p.material.poisson, p.radius, p.material);
        match run_single_grain(p, |_| Control::Continue) {
            Ok(out) => {
                let f2 = force_at(&out.rows, 0.02);
                let f5 = force_at(&out.rows, 0.05);
                let s = &out.stats;
                println!(
                    "{:>6.4} {:>6} {:>5.0} {:>9.1} {:>9.1} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.4} {:>6} {:>6} {:>5} {:>8.1} {:>8.3}",
                    r,
                    s.points,
                    2.0 * rad / s.cell_size,
                    f2,
                    f5,
                    f2 / johnson_force(e, nu, rad, 0.02).unwrap(),
                    f2 / eq13_force(e, nu, rad, 0.02),
                    f5 / johnson_force(e, nu, rad, 0.05).unwrap(),
                    f5 / eq13_force(e, nu, rad, 0.05),
                    window_mean_over_johnson(&out.rows, &material, rad),
                    s.steps,
                    s.newton_iterations,
                    s.max_newton_iterations,
                    s.dt / s.dt_cfl,
                    s.wall_seconds
                );
                let last = out.rows.last().expect("rows");
                println!(
                    "       final: ε = {:.3}, F = {:.0} N/m (top {:.0}, bottom {:.0}), L/2R = {:.3}, σ = {:.3} MPa, max von Mises {:.2} MPa, area/πR² = {:.4}, {:.1} Newton iterations/step, {} symbolic factorisations, {} halved steps",
                    last.strain,
                    0.5 * (last.force_top + last.force_bottom),
                    last.force_top,
                    last.force_bottom,
                    last.width / (2.0 * rad),
                    last.sigma * 1e-6,
                    out.points.von_mises.iter().cloned().fold(0.0, f64::max) * 1e-6,
                    out.points.volume.iter().sum::<f64>() / (std::f64::consts::PI * rad * rad),
                    s.newton_iterations as f64 / s.steps as f64,
                    s.symbolic_factorisations,
                    s.halvings
                );
            }
            Err(err) => println!("{r}: {err}"),
        }
    }
}
