//! Contact dynamics against closed-form mechanics.

mod common;

use common::cd_params as params;
use softgrain::cd::{Bodies, Coulomb, LawTable, Scene};
use softgrain::geom::{V2, Wall};

const G: f64 = 9.81;

/// A disk of radius r resting on a wall inclined at `angle` (rad), released from rest.
/// Returns the measured acceleration along the slope (from the velocity at the end, since
/// the θ = 1 scheme integrates a constant acceleration exactly in velocity) and the
/// angular velocity times r.
fn incline(angle: f64, mu: f64) -> (f64, f64) {
    let r = 0.01;
    let dir = V2::new(angle.cos(), -angle.sin());
    let a = V2::new(0.0, 1.0);
    let wall = Wall::new(a, a + 2.0 * dir);
    let n = wall.normal();
    let mut bodies = Bodies::default();
    bodies.push(a + 0.1 * dir + r * n, r, 1000.0, 0);
    let laws = LawTable::new(Coulomb { mu }, Coulomb { mu }, vec![Coulomb { mu }]);
    let mut scene = Scene::new(bodies, vec![wall], laws, params(1e-4), 1);
    let steps = 2000;
    for _ in 0..steps {
        scene.step().unwrap();
    }
    let t = scene.time;
    let v = scene.bodies.vel[0];
    // it stays on the slope: no normal velocity, and its centre at distance r
    assert!(v.dot(&n).abs() < 1e-9, "normal velocity {}", v.dot(&n));
    let (gap, _) = scene.walls[0]
        .gap(V2::zeros(), scene.bodies.pos[0], r)
        .unwrap();
    assert!(gap.abs() < 1e-9 * r + 1e-12, "gap {gap}");
    (v.dot(&dir) / t, -scene.bodies.omega[0] * r / t)
}

#[test]
fn disk_rolls_without_slipping_when_friction_suffices() {
    for deg in [10.0f64, 25.0, 40.0] {
        let th = deg.to_radians();
        let mu = th.tan() / 3.0 * 1.2;
        let (a, spin) = incline(th, mu);
        let exact = 2.0 / 3.0 * G * th.sin();
        assert!(
            (a / exact - 1.0).abs() < 0.01,
            "{deg} deg: a = {a}, exact {exact}"
        );
        // rolling: the contact point does not slip, ω r = v
        assert!(
            (spin / a - 1.0).abs() < 0.01,
            "{deg} deg: ω r / v = {}",
            spin / a
        );
    }
}

#[test]
fn disk_slides_below_the_rolling_threshold() {
    for deg in [20.0f64, 35.0] {
        let th = deg.to_radians();
        for mu in [0.0, 0.5 * th.tan() / 3.0] {
            let (a, _) = incline(th, mu);
            let exact = G * (th.sin() - mu * th.cos());
            assert!(
                (a / exact - 1.0).abs() < 0.01,
                "{deg} deg mu {mu}: a = {a}, exact {exact}"
            );
        }
    }
}

#[test]
fn falling_disk_stops_dead_on_the_floor() {
    let r = 0.01;
    let floor = Wall::new(V2::new(-1.0, 0.0), V2::new(1.0, 0.0));
    let mut bodies = Bodies::default();
    bodies.push(V2::new(0.0, r + 0.05), r, 1000.0, 0);
    let laws = LawTable::new(
        Coulomb { mu: 0.5 },
        Coulomb { mu: 0.5 },
        vec![Coulomb { mu: 0.5 }],
    );
    let mut p = params(1e-3);
    p.alert = 0.02; // impact speed ~1 m/s covers 1 mm per step: the alert range sees it coming
    let mut scene = Scene::new(bodies, vec![floor], laws, p, 1);
    let mut touched = None;
    for k in 0..400 {
        scene.step().unwrap();
        let y = scene.bodies.pos[0].y;
        assert!(
            y >= r - 1e-12,
            "penetrated the floor at step {k}: y - r = {}",
            y - r
        );
        if let Some(k0) = touched
            && k > k0
        {
            // zero restitution: the step that closes the gap lands it exactly on the floor
            // (gap anticipation); from the next step on it neither bounces nor moves
            assert!(
                scene.bodies.vel[0].norm() < 1e-12,
                "step {k}: v = {}",
                scene.bodies.vel[0]
            );
            assert!((y - r).abs() < 1e-12);
        }
        if touched.is_none() && y - r < 1e-12 {
            touched = Some(k);
        }
    }
    assert!(touched.is_some(), "never reached the floor");
    // at rest it carries exactly its weight
    let weight = scene.bodies.mass(0) * G;
    assert!((scene.wall_force[0].y / weight - 1.0).abs() < 1e-9);
}

#[test]
fn a_scene_saved_and_loaded_mid_run_continues_bit_for_bit() {
    use softgrain::packing::{Distribution, box_walls, diameters, loose_layout};
    use softgrain::pipeline::codec;
    use softgrain::rng::Rng;
    let mut rng = Rng::new(9);
    let d = diameters(
        Distribution::EqualAreaPerSize,
        [1.0e-3, 2.0e-3],
        60,
        &mut rng,
    );
    let (pos, h) = loose_layout(&d, 12e-3, &mut rng);
    let mut bodies = Bodies::default();
    for (k, (x, dk)) in pos.iter().zip(&d).enumerate() {
        bodies.push(*x, 0.5 * dk, 990.0, k as u32);
    }
    let laws = LawTable::new(
        Coulomb { mu: 0.4 },
        Coulomb { mu: 0.4 },
        vec![Coulomb { mu: 0.0 }; 3],
    );
    let mut a = Scene::new(
        bodies,
        box_walls(12e-3, 2.0 * h, 2e-3),
        laws,
        params(2e-4),
        4,
    );
    for _ in 0..300 {
        a.step().unwrap();
    }
    let mut b: Scene<Coulomb> = codec::decode(&codec::encode(&a).unwrap()).unwrap();
    for _ in 0..300 {
        a.step().unwrap();
        b.step().unwrap();
    }
    assert!(
        a.contacts.len() > 50,
        "the run must have contacts to mean anything"
    );
    assert_eq!(codec::encode(&a).unwrap(), codec::encode(&b).unwrap());
}

#[test]
fn an_impact_through_a_spaced_column_gives_the_exact_step_solution() {
    // plain NLGS, over-relaxed and Anderson-accelerated: the same fixed point, so the same
    // exact solution
    for (relax, anderson) in [(1.0, 0), (1.5, 0), (1.0, 8)] {
        impact_through_a_spaced_column(relax, anderson);
    }
}

fn impact_through_a_spaced_column(relax: f64, anderson: u32) {
    // A striker at v hits the first of N resting disks spaced by δ along x, no gravity, no
    // friction. The resting pairs neither move nor lie within the alert distance, so the
    // local alert leaves them out of the solve at first; the impact closes them within the
    // step, and the solve must take them in. The step's exact solution (inelastic impacts,
    // gap anticipation u_n ≥ -δ/h): every contact active, v_0 = v_1 = a and
    // v_k = a - (k - 1) δ/h, with momentum kept: a = (v + (δ/h) N (N - 1)/2)/(N + 1).
    let (r, h, delta, v, n) = (1e-3, 1e-3, 1e-4, 2.0, 4usize);
    let mut bodies = Bodies::default();
    bodies.push(V2::zeros(), r, 1000.0, 0);
    for k in 1..=n {
        let x = 2.0 * r + (k - 1) as f64 * (2.0 * r + delta);
        bodies.push(V2::new(x, 0.0), r, 1000.0, k as u32);
    }
    bodies.vel[0] = V2::new(v, 0.0);
    let laws = LawTable::new(Coulomb { mu: 0.0 }, Coulomb { mu: 0.0 }, vec![]);
    let mut p = params(h);
    p.gravity = V2::zeros();
    p.alert = 0.1 * delta;
    p.nlgs.tol = 1e-9;
    p.nlgs.relax = relax;
    p.nlgs.anderson = anderson;
    let mut scene = Scene::new(bodies, vec![], laws, p, 1);
    let report = scene.step().unwrap();
    if softgrain::shortcuts::get().local_alert {
        assert!(report.resumed >= 1, "the column never entered the solve");
    }
    // striker-1 and the column pairs at least (the striker's reach also takes in disk 2)
    assert!(report.contacts >= n, "{} contacts solved", report.contacts);
    let s = delta / h;
    let a = (v + s * (n * (n - 1)) as f64 / 2.0) / (n + 1) as f64;
    for k in 0..=n {
        let want = a - (k.max(1) - 1) as f64 * s;
        let got = scene.bodies.vel[k];
        assert!(
            (got.x - want).abs() < 1e-6 * v && got.y.abs() < 1e-12,
            "ω = {relax}, Anderson {anderson}, disk {k}: v = {got}, exact {want}"
        );
    }
    // the N neighbour gaps closed exactly, none overlapping
    let gaps = scene.current_gaps();
    assert!(gaps.iter().all(|&g| g > -1e-6 * r), "gaps {gaps:?}");
    assert_eq!(gaps.iter().filter(|g| g.abs() < 1e-6 * r).count(), n);
}

#[test]
fn a_wide_stack_solved_by_the_coloured_sweep_carries_its_weight_with_any_thread_count() {
    // 1000 × 20 touching disks on a floor, released from rest: about 39,000 contacts, enough
    // for the coloured parallel sweep. The step's exact solution is rest with the whole weight
    // on the floor; one and two threads must give the same bits.
    use softgrain::cd::COLOURED_MIN;
    let (r, nx, ny) = (1e-3, 1000, 20);
    let bodies = common::lattice(r, nx, ny);
    let floor = Wall::new(V2::new(0.0, 0.0), V2::new(2.0 * nx as f64 * r, 0.0));
    let weight = bodies.total_mass() * G;
    let run = |threads: usize| {
        let laws = LawTable::new(
            Coulomb { mu: 0.3 },
            Coulomb { mu: 0.3 },
            vec![Coulomb { mu: 0.0 }],
        );
        let mut scene = Scene::new(bodies.clone(), vec![floor.clone()], laws, params(1e-4), 3);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let report = pool.install(|| scene.step().unwrap());
        (scene, report)
    };
    let (a, report) = run(2);
    assert!(
        report.contacts >= COLOURED_MIN,
        "{} contacts",
        report.contacts
    );
    assert!(report.nlgs.converged);
    // Momentum: the floor's impulse and what the disks keep add up to the weight's impulse
    // exactly (a race between the threads would break this bookkeeping) ...
    let floor_force = a.wall_force[0].y;
    let kept: f64 = (0..a.bodies.len())
        .map(|i| a.bodies.mass(i) * a.bodies.vel[i].y)
        .sum::<f64>()
        / 1e-4;
    assert!(
        ((floor_force - kept) / weight - 1.0).abs() < 1e-9,
        "floor {floor_force} N/m, kept {kept} N/m, weight {weight} N/m"
    );
    // ... and the disks keep little: the NLGS tolerance (1e-6 per check on the relative change
    // norms) leaves 1.0e-4 of the weight in the 20 layers
    assert!(
        (floor_force / weight - 1.0).abs() < 1e-3,
        "floor carries {floor_force} N/m of {weight}"
    );
    let (b, _) = run(1);
    assert!(a.bodies.vel == b.bodies.vel && a.bodies.omega == b.bodies.omega);
    assert!(a.contacts == b.contacts);
}

/// 30 touching frictional disks in a column on the floor, released from rest, solved for one
/// step with relaxation ω and Anderson depth m: (sweeps, fraction of the weight missing from
/// the floor). The exact step solution is rest with the whole weight on the floor.
fn column_at_rest(relax: f64, anderson: u32) -> (u32, f64) {
    let (r, n) = (1e-3, 30);
    let mut bodies = Bodies::default();
    for k in 0..n {
        bodies.push(V2::new(0.0, (2 * k + 1) as f64 * r), r, 1000.0, k as u32);
    }
    let floor = Wall::new(V2::new(-1.0, 0.0), V2::new(1.0, 0.0));
    let weight = bodies.total_mass() * G;
    let mu = Coulomb { mu: 0.3 };
    let mut p = params(1e-4);
    p.nlgs.relax = relax;
    p.nlgs.anderson = anderson;
    let laws = LawTable::new(mu, mu, vec![mu]);
    let mut scene = Scene::new(bodies, vec![floor], laws, p, 5);
    let report = scene.step().unwrap();
    let case = format!("ω = {relax}, Anderson {anderson}");
    assert!(report.nlgs.converged, "{case}");
    let missing = 1.0 - scene.wall_force[0].y / weight;
    assert!(
        (0.0..5e-4).contains(&missing),
        "{case}: {missing} of the weight missing"
    );
    let fastest = (scene.bodies.vel.iter())
        .map(|v| v.norm())
        .fold(0.0, f64::max);
    // what the missing floor impulse leaves in the column: at most g h times it
    assert!(
        fastest < 2.0 * missing * G * 1e-4,
        "{case}: a disk at {fastest} m/s"
    );
    (report.nlgs.iterations, missing)
}

#[test]
fn over_relaxation_finds_a_column_at_rest_in_fewer_sweeps() {
    // Gauss-Seidel passes the load down about one contact per sweep and creeps along the
    // chain, so its relative-change test stops it short (2.4e-4 of the weight missing from
    // the floor at tolerance 1e-6, after 3115 sweeps). Projected over-relaxation (ω = 1.5)
    // reaches the same solution closer (7.7e-5) in 1310 sweeps.
    let (plain, relaxed) = (column_at_rest(1.0, 0), column_at_rest(1.5, 0));
    assert!(
        2 * relaxed.0 <= plain.0 && relaxed.1 < plain.1,
        "over-relaxed {relaxed:?} against plain {plain:?} (sweeps, weight missing)"
    );
}

#[test]
fn anderson_acceleration_finds_a_column_at_rest_in_far_fewer_sweeps() {
    // The column's load path is a linear chain once every contact sticks: the slow error that
    // Gauss-Seidel creeps along is what Anderson's least-squares combination of past sweeps
    // removes (on a linear problem it is GMRES on the sweep): depth 8 stops after 190 sweeps
    // with 8.9e-5 of the weight missing, against plain NLGS's 3115 and 2.4e-4.
    let (plain, accelerated) = (column_at_rest(1.0, 0), column_at_rest(1.0, 8));
    assert!(
        5 * accelerated.0 <= plain.0 && accelerated.1 < plain.1,
        "Anderson {accelerated:?} against plain {plain:?} (sweeps, weight missing)"
    );
}
