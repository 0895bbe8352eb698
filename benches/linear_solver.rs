//! The implicit MPM's linear solve: faer's sparse Cholesky (the solver's choice) against
//! block-Jacobi conjugate gradients (issue #4: "choose by measurement"), on the effective
//! stiffness `K + 4M/Δt²` of the paper's grain after compression to `--strain` (default
//! 0.1), at the pipeline's time step, for each resolution. Prints the DOFs, the Cholesky
//! time (symbolic + numeric + solve, then numeric + solve as in a Newton iteration with an
//! unchanged pattern), the CG iterations and time to relative residuals 1e-8 and 1e-12,
//! and the CG solution's difference from the direct one. Medians of `--runs` (default 5).
//!
//!     cargo bench --bench linear_solver -- [--runs N] [--strain E] [--resolutions 0.057,0.029]

use softgrain::mpm::driver::{SingleGrain, SingleGrainParams};
use softgrain::mpm::solve::Solver;
use std::time::Instant;

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    let k = args.iter().position(|a| a == name)?;
    args.get(k + 1).cloned()
}

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// The paper's grain at `resolution`, compressed to `strain` through its own driver.
fn compressed_grain(resolution: f64, strain: f64) -> SingleGrain {
    let mut grain = SingleGrain::new(SingleGrainParams {
        resolution,
        final_strain: strain,
        ..SingleGrainParams::paper()
    })
    .expect("grain");
    while !grain.is_done() {
        grain.step().expect("step");
    }
    grain
}

fn main() {
    let runs: usize = arg("--runs").map_or(5, |v| v.parse().expect("--runs N"));
    let strain: f64 = arg("--strain").map_or(0.1, |v| v.parse().expect("--strain E"));
    let resolutions: Vec<f64> =
        arg("--resolutions").map_or(vec![0.057, 0.029, 0.02, 0.0156, 0.01], |v| {
            v.split(',')
                .map(|x| x.parse().expect("a resolution"))
                .collect()
        });
    println!(
        "{:>7} {:>7} {:>12} {:>12} {:>9} {:>10} {:>9} {:>10} {:>10}",
        "dr/R",
        "DOFs",
        "chol1st(ms)",
        "chol(ms)",
        "cg8 its",
        "cg8(ms)",
        "cg12 its",
        "cg12(ms)",
        "cg12 diff"
    );
    for res in resolutions {
        let grain = compressed_grain(res, strain);
        let (params, material) = (&grain.params.solver, &grain.params.material);
        // A workspace holding the effective stiffness and residual of the grain's state.
        let prepared = || {
            let mut s = Solver::default();
            s.begin(params, &grain.grid, &grain.points, grain.dt, 0)
                .expect("begin");
            s.evaluate_residual(params, material, &grain.points, grain.dt, 0)
                .expect("residual");
            s.assemble_stiffness(params, material, grain.dt);
            s
        };
        let solver = prepared();
        let rhs = solver.residual_vector().to_vec();
        // Factorise and solve; returns the seconds taken and the solution.
        let direct_solve = |s: &mut Solver| {
            let t = Instant::now();
            s.factorize(params, material, grain.dt, 0).expect("factor");
            let mut x = rhs.clone();
            s.solve(&mut x, 1, 0).expect("solve");
            (t.elapsed().as_secs_f64(), x)
        };
        let (mut first, mut again, mut direct) = (Vec::new(), Vec::new(), rhs.clone());
        for _ in 0..runs {
            let mut fresh = prepared();
            first.push(direct_solve(&mut fresh).0);
            let (t, x) = direct_solve(&mut fresh);
            again.push(t);
            direct = x;
        }
        let cg = |tol: f64| {
            let (mut times, mut its, mut x) = (Vec::new(), 0, rhs.clone());
            for _ in 0..runs {
                x = rhs.clone();
                let t = Instant::now();
                its = solver.solve_iterative(&mut x, tol, 0).expect("cg");
                times.push(t.elapsed().as_secs_f64());
            }
            (its, median(times), x)
        };
        let (its8, t8, _) = cg(1e-8);
        let (its12, t12, x12) = cg(1e-12);
        let scale = direct.iter().map(|v| v * v).sum::<f64>().sqrt();
        let diff = direct
            .iter()
            .zip(&x12)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt()
            / scale;
        println!(
            "{:>7} {:>7} {:>12.2} {:>12.2} {:>9} {:>10.2} {:>9} {:>10.2} {:>10.1e}",
            res,
            rhs.len(),
            1e3 * median(first),
            1e3 * median(again),
            its8,
            1e3 * t8,
            its12,
            1e3 * t12,
            diff
        );
    }
}
