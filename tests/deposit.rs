//! The contact-dynamics deposit (prepare stage) against statics: at rest, the floor carries
//! the whole weight (walls are frictionless), contacts barely overlap, no disk leaves the box.

mod common;

use softgrain::stages::StageState;

/// `extra`: further `prepare` keys, each line indented by two spaces.
fn deposit(
    grains: usize,
    friction: f64,
    extra: &str,
    tag: &str,
) -> softgrain::stages::prepare::Prepared {
    let dir = common::temp_dir(tag);
    let yaml = format!(
        "name: dep\nseed: 7\nprepare:\n  grains: {grains}\n  diameter: [1.4e-3, 2.4e-3]\n  friction: {friction}\n{extra}output:\n  every: 0\n  vtk: false\n"
    );
    let file = common::write(&dir, "dep.yaml", &yaml);
    let state = common::run_to_state(&dir, &file, &[]);
    let _ = std::fs::remove_dir_all(&dir);
    match state {
        StageState::Prepared(p) => p,
        other => panic!("prepare produced {other:?}"),
    }
}

fn check(p: &softgrain::stages::prepare::Prepared) {
    let f = &p.figures;
    assert!(
        (f.floor_force / f.weight - 1.0).abs() < 0.005,
        "floor carries {} of the weight",
        f.floor_force / f.weight
    );
    assert!(f.mean_overlap < 1e-3, "mean overlap {} <r>", f.mean_overlap);
    let b = &p.bodies;
    let tol = 1e-3 * b.mean_radius();
    for i in 0..b.len() {
        let (x, r) = (b.pos[i], b.radius[i]);
        assert!(
            x.y - r > -tol && x.x - r > -tol && x.x + r < p.box_width + tol,
            "disk {i} at {x:?} is outside the box"
        );
    }
}

#[test]
fn frictional_deposit_of_300_disks_rests_on_the_floor() {
    check(&deposit(300, 0.3, "", "dep300"));
}

#[test]
fn frictionless_deposit_rests_on_the_floor() {
    check(&deposit(100, 0.0, "", "dep100"));
}

#[test]
fn a_deposit_whose_resting_groups_sleep_rests_on_the_floor_as_well() {
    // Sleeping groups keep the impulses they rested on; the floor still carries the weight.
    let p = deposit(
        300,
        0.3,
        "  sleep: {speed: 1.0e-3, time: 0.02}\n",
        "dep300sleep",
    );
    check(&p);
    assert!(p.figures.sleeping > 0, "no disk fell asleep");
}

#[test]
fn one_separation_at_rest_removes_most_of_a_loose_solves_overlaps() {
    // A solve 24 times looser than the default keeps the overlaps its landing made (gap
    // anticipation never pushes one open). One separation as the pile comes to rest (README
    // "One separation at rest") removes them; the pile then settles to rest again, carrying
    // its weight, and a tighter tolerance for that last settling leaves fewer new ones.
    let loose = "solver:\n  tolerance: 4.0e-3\n  anderson: 8\n";
    let plain = deposit(300, 0.3, loose, "dep300loose");
    let once = deposit(
        300,
        0.3,
        &format!("  separation: {{at: 1.0e-6}}\n{loose}"),
        "dep300sep",
    );
    let tight = deposit(
        300,
        0.3,
        &format!("  separation: {{at: 1.0e-6, tolerance: 7.0e-4}}\n{loose}"),
        "dep300septight",
    );
    // (the loose solve alone leaves disks deeper than 1e-3 <r> in the walls, which `check`
    // refuses)
    check(&once);
    check(&tight);
    assert_eq!(plain.figures.separation, None);
    let mean = |p: &softgrain::stages::prepare::Prepared| p.figures.mean_overlap;
    eprintln!(
        "overlap at rest, mean and max (<r>): {:.2e} and {:.2e} without, {:.2e} and {:.2e} with \
         the separation, {:.2e} and {:.2e} with a tighter tolerance after it",
        mean(&plain),
        plain.figures.max_overlap,
        mean(&once),
        once.figures.max_overlap,
        mean(&tight),
        tight.figures.max_overlap
    );
    for p in [&once, &tight] {
        let (f, s) = (
            &p.figures,
            p.figures.separation.as_ref().expect("separated"),
        );
        assert!(s.deepest_after <= 1e-6, "{s:?}");
        assert!(s.deepest_before > 100.0 * s.deepest_after, "{s:?}");
        // rested again, for the rest test's full count of steps, after it
        assert!(
            f.steps >= s.step + 50,
            "{} steps, separated at {}",
            f.steps,
            s.step
        );
    }
    assert!(mean(&once) < 0.5 * mean(&plain));
    assert!(mean(&tight) < 0.5 * mean(&once));
}
