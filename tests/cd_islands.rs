//! Islands of the contact graph solved apart (`solver.islands`): the same solution, each
//! island converged on its own, less work, and no dependence on the thread count.

mod common;

use softgrain::cd::{Bodies, CdParams, Coulomb, LawTable, Scene};
use softgrain::geom::{V2, Wall};

const G: f64 = 9.81;
const DT: f64 = 1e-4;

/// The CD tests' settings with the islands switch, and room for the 30-disk column's sweeps.
fn params(islands: bool) -> CdParams {
    let mut p = common::cd_params(DT);
    p.nlgs.max_iter = 20_000;
    p.nlgs.islands = islands;
    p
}

/// Columns of touching frictional disks of radius `r` standing on the floor, 4r apart, of the
/// given heights, each lifted by `lift` (0: resting). Returns the scene and each disk's column.
fn columns(heights: &[usize], r: f64, lift: f64, islands: bool) -> (Scene<Coulomb>, Vec<usize>) {
    let mut bodies = Bodies::default();
    let mut column = Vec::new();
    for (c, &n) in heights.iter().enumerate() {
        for k in 0..n {
            let y = (2 * k + 1) as f64 * r + lift;
            bodies.push(
                V2::new(4.0 * r * c as f64, y),
                r,
                1000.0,
                column.len() as u32,
            );
            column.push(c);
        }
    }
    let floor = Wall::new(V2::new(-1.0, 0.0), V2::new(1.0, 0.0));
    let mu = Coulomb { mu: 0.3 };
    let laws = LawTable::new(mu, mu, vec![mu]);
    (
        Scene::new(bodies, vec![floor], laws, params(islands), 7),
        column,
    )
}

/// Fraction of each column's weight the floor does not carry after the step.
fn missing_per_column(scene: &Scene<Coulomb>, column: &[usize], n_columns: usize) -> Vec<f64> {
    let mut weight = vec![0.0; n_columns];
    let mut floor = vec![0.0; n_columns];
    for (i, &c) in column.iter().enumerate() {
        weight[c] += G / scene.bodies.inv_mass[i];
    }
    for c in &scene.contacts {
        if matches!(c.j, softgrain::cd::Partner::Wall(_)) {
            floor[column[c.i as usize]] += c.p_n * c.n.y / DT;
        }
    }
    (floor.iter().zip(&weight))
        .map(|(f, w)| 1.0 - f / w)
        .collect()
}

#[test]
fn each_island_is_converged_and_the_work_drops() {
    // One tall column, whose load Gauss-Seidel passes down about one contact per sweep, beside
    // a hundred single disks on the floor, which one block solves. Solved as one problem every
    // contact is swept as long as the column needs; solved apart the disks stop after their
    // first block.
    let heights: Vec<usize> = std::iter::once(30).chain([1; 100]).collect();
    let mut work = Vec::new();
    for islands in [false, true] {
        let (mut scene, column) = columns(&heights, 1e-3, 0.0, islands);
        let report = scene.step().unwrap();
        assert!(report.nlgs.converged, "islands {islands}");
        let missing = missing_per_column(&scene, &column, heights.len());
        for (c, m) in missing.iter().enumerate() {
            // the column's missing fraction is the solver's creep at tolerance 1e-6 (2.4e-4
            // in `tests/cd_physics.rs`); a lone disk on the floor is solved exactly
            let bound = if heights[c] > 1 { 5e-4 } else { 1e-9 };
            assert!(
                m.abs() < bound,
                "islands {islands}, column {c}: {m} of its weight missing"
            );
        }
        work.push(report.updates);
    }
    // 130 contacts, 30 of them in the column: with islands the disks' 100 cost one block each
    assert!(
        work[1] * 3 < work[0],
        "contact updates with islands {} against {} without",
        work[1],
        work[0]
    );
}

#[test]
fn islands_give_the_same_bits_on_one_and_two_threads() {
    // 2000 columns of two to five disks, shaken sideways: over 4096 contacts in the solve,
    // enough for the islands to be solved in parallel
    let heights: Vec<usize> = (0..2000).map(|c| 2 + c % 4).collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| {
            let (mut scene, _) = columns(&heights, 1e-3, 0.0, true);
            for (i, v) in scene.bodies.vel.iter_mut().enumerate() {
                v.x = 0.01 * (i % 7) as f64 - 0.03;
            }
            let mut contacts = 0;
            for _ in 0..40 {
                contacts = contacts.max(scene.step().unwrap().contacts);
            }
            (scene.bodies.pos, scene.bodies.vel, contacts)
        })
    };
    let (one, two) = (run(1), run(2));
    assert!(one.2 >= 4096, "{} contacts: the serial path only", one.2);
    assert!(
        one.0 == two.0 && one.1 == two.1,
        "positions or velocities differ"
    );
}
