//! A single MPM grain through its own driver against the same scene in the packing engine
//! (issue #7: "a single grain uses no packing machinery"): wall time, median of `--runs`
//! (default 5), and the largest top-plate force difference.
//!
//!     cargo bench --bench single_grain -- [--runs N] [--resolution R] [--strain E]

use softgrain::mpm::Control;
use softgrain::mpm::driver::{SingleGrainParams, run_single_grain};
use softgrain::mpm::packing::{Packing, TOP};
use std::time::Instant;

fn arg(name: &str, default: f64) -> f64 {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|k| args.get(k + 1))
        .map_or(default, |v| v.parse().expect("a number"))
}

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn main() {
    let runs = arg("--runs", 5.0) as usize;
    let mut p = SingleGrainParams::paper();
    p.resolution = arg("--resolution", 0.057);
    p.final_strain = arg("--strain", 0.1);
    let (mut driver, mut packing) = (Vec::new(), Vec::new());
    let (mut forces_driver, mut forces_packing) = (Vec::new(), Vec::new());
    for _ in 0..runs {
        let t = Instant::now();
        let single = run_single_grain(p.clone(), |_| Control::Continue).expect("driver run");
        driver.push(t.elapsed().as_secs_f64());
        forces_driver = single.rows.iter().map(|r| r.force_top).collect();

        let t = Instant::now();
        let mut pk = Packing::single_grain(&p).expect("packing scene");
        let mut f = Vec::new();
        while pk.strain() < p.final_strain - 1e-12 {
            pk.step().expect("packing step");
            f.push(pk.walls[TOP].normal_force());
        }
        packing.push(t.elapsed().as_secs_f64());
        forces_packing = f;
    }
    let scale = forces_driver.iter().cloned().fold(0.0, f64::max);
    let diff = forces_driver
        .iter()
        .zip(&forces_packing)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let (d, k) = (median(driver), median(packing));
    println!(
        "single grain, Δr/R = {}, to ε = {}, {} steps, median of {runs}:",
        p.resolution,
        p.final_strain,
        forces_driver.len()
    );
    println!("  driver         {d:.3} s");
    println!("  packing engine {k:.3} s  ({:.2} × the driver)", k / d);
    println!(
        "  largest force difference {:.2e} of the peak force ({} vs {} steps)",
        diff / scale,
        forces_driver.len(),
        forces_packing.len()
    );
}
