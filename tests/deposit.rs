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
