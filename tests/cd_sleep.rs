//! Sleeping (`cd/sleep.rs`): a resting pile that sleeps still carries its weight, costs no
//! solve, and wakes when a falling disk lands on it.

mod common;

use softgrain::cd::{Coulomb, LawTable, Scene, SleepParams};
use softgrain::geom::{V2, Wall};

const G: f64 = 9.81;

#[test]
fn a_sleeping_pile_carries_its_weight_and_wakes_when_a_disk_lands_on_it() {
    // 6 × 3 touching disks on a floor between two walls, and one disk 12 mm above them that
    // lands after about 50 ms, once the pile has fallen asleep.
    let (r, nx, ny) = (1e-3, 6, 3);
    let mut bodies = common::lattice(r, nx, ny);
    let pile = bodies.len();
    let top = (2 * ny - 1) as f64 * r;
    bodies.push(
        V2::new(5.0 * r, top + 2.0 * r + 12e-3),
        r,
        1000.0,
        pile as u32,
    );
    let width = 2.0 * nx as f64 * r;
    let walls = vec![
        Wall::new(V2::new(0.0, 0.0), V2::new(width, 0.0)),
        Wall::new(V2::new(0.0, 0.1), V2::new(0.0, 0.0)),
        Wall::new(V2::new(width, 0.0), V2::new(width, 0.1)),
    ];
    let pile_weight = (0..pile).map(|i| bodies.mass(i)).sum::<f64>() * G;
    let weight = bodies.total_mass() * G;
    let mu = Coulomb { mu: 0.3 };
    let laws = LawTable::new(mu, mu, vec![mu; 3]);
    let mut params = common::cd_params(1e-4);
    params.sleep = Some(SleepParams {
        speed: 1e-4,
        time: 0.01,
    });
    let mut scene = Scene::new(bodies, walls, laws, params, 7);

    // the pile sleeps while the disk falls, and costs no solve
    let mut asleep_at = None;
    while scene.bodies.pos[pile].y > top + 2.0 * r + 1e-3 {
        let report = scene.step().unwrap();
        if asleep_at.is_some() {
            assert_eq!(scene.sleeping(), pile, "the pile woke before the impact");
            assert_eq!(report.contacts, 0, "a sleeping pile's contacts were solved");
        } else if scene.sleeping() == pile {
            asleep_at = Some(scene.time);
        }
    }
    let asleep_at = asleep_at.expect("the pile never slept");
    assert!(asleep_at < 0.03, "the pile slept only at t = {asleep_at} s");
    // asleep, it still puts its weight on the floor (the disk above is in free fall)
    let floor = scene.wall_force[0].y;
    assert!(
        (floor / pile_weight - 1.0).abs() < 1e-4,
        "floor {floor} N/m against the pile's weight {pile_weight} N/m"
    );

    // the impact wakes the pile, which then carries the disk
    let mut woke = false;
    for _ in 0..200 {
        scene.step().unwrap();
        woke |= scene.sleeping() == 0;
    }
    assert!(woke, "the landing disk did not wake the pile");
    // everything comes to rest and sleeps again, the floor carrying the whole weight
    for _ in 0..2000 {
        if scene.sleeping() == pile + 1 {
            break;
        }
        scene.step().unwrap();
    }
    assert_eq!(
        scene.sleeping(),
        pile + 1,
        "not asleep again after the impact"
    );
    let floor = scene.wall_force[0].y;
    assert!(
        (floor / weight - 1.0).abs() < 1e-4,
        "floor {floor} N/m against the weight {weight} N/m"
    );
    // the disk rests on the pile: no overlap beyond the solver's tolerance
    let b = &scene.bodies;
    let worst = (0..pile)
        .map(|i| 2.0 * r - (b.pos[i] - b.pos[pile]).norm())
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(
        worst.abs() < 1e-6 * r,
        "disk on the pile at overlap {worst}"
    );
}
