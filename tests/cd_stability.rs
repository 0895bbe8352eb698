//! The energy-growth guard of the contact-dynamics engine (`src/cd/guard.rs`): an explicit
//! force integrated with a step above its stability limit stops the run within a few steps
//! with an error naming the kinetic energy and the step; the same scene at a stable step
//! runs on. The deposit, incline and BPM tests exercise the guard on correct runs.

use softgrain::cd::{
    Bodies, CdError, CdParams, Coulomb, InteractionLaw, LawTable, NlgsParams, Scene,
};
use softgrain::geom::V2;

/// A two-sided linear bond: f = -k (gap - g_eq) for gaps up to 2 g_eq, explicit like the
/// BPM attraction; its potential ½ k (g - g_eq)² - ½ k g_eq² is ≤ 0 over the range.
#[derive(Clone, Copy, Debug)]
struct Bond {
    k: f64,
    g_eq: f64,
}

impl InteractionLaw for Bond {
    fn friction(&self) -> f64 {
        0.0
    }
    fn range(&self, _a0: f64) -> f64 {
        2.0 * self.g_eq
    }
    fn smooth_force(&self, gap: f64, _a0: f64) -> f64 {
        if gap <= 2.0 * self.g_eq {
            -self.k * (gap - self.g_eq)
        } else {
            0.0
        }
    }
    fn potential(&self, gap: f64, _a0: f64) -> f64 {
        if gap <= 2.0 * self.g_eq {
            0.5 * self.k * ((gap - self.g_eq).powi(2) - self.g_eq.powi(2))
        } else {
            0.0
        }
    }
}

/// Two unit disks (density 1/π, mass 1) bonded at gap 1.3 g_eq; the pair's frequency is
/// ω = sqrt(k/m*) = 1 (m* = 1/2), so the explicit step is stable for h < 2.
fn pair(dt: f64) -> Scene<Bond> {
    let g_eq = 0.5;
    let mut b = Bodies::default();
    b.push(V2::new(0.0, 0.0), 1.0, 1.0 / std::f64::consts::PI, 0);
    b.push(
        V2::new(2.0 + 1.3 * g_eq, 0.0),
        1.0,
        1.0 / std::f64::consts::PI,
        0,
    );
    let bond = Bond { k: 0.5, g_eq };
    let params = CdParams {
        dt,
        theta: 1.0,
        gravity: V2::zeros(),
        // the pair stays in the contact solve whatever the step (no pass-through)
        alert: 10.0,
        skin: 0.1,
        nlgs: NlgsParams {
            tol: 1e-6,
            check_every: 5,
            max_iter: 1000,
            relax: 1.0,
            anderson: 0,
            islands: false,
        },
        sleep: None,
    };
    Scene::new(b, vec![], LawTable::new(bond, bond, vec![]), params, 1)
}

#[test]
fn an_explicit_force_above_its_stable_step_trips_the_energy_guard() {
    let mut s = pair(3.0);
    let mut tripped = None;
    for _ in 0..20 {
        match s.step() {
            Ok(_) => {}
            Err(e) => {
                tripped = Some(e);
                break;
            }
        }
    }
    let e = tripped.expect("an unstable run went on");
    match &e {
        CdError::EnergyGrowth {
            step,
            kinetic,
            budget,
        } => {
            assert!(*step < 5, "tripped only at step {step}");
            assert!(kinetic > &(1e3 * budget));
        }
        other => panic!("expected EnergyGrowth, got {other}"),
    }
    let msg = e.to_string();
    assert!(
        msg.contains("kinetic energy") && msg.contains("step"),
        "{msg}"
    );
}

#[test]
fn the_same_bond_at_a_stable_step_runs_without_alarm() {
    let mut s = pair(0.1);
    for _ in 0..2000 {
        s.step().unwrap();
    }
    // it oscillates in its well: the energy stays near the initial potential drop
    assert!(s.bodies.kinetic_energy() < 0.5 * 0.5 * (0.3f64 * 0.5).powi(2) * 1.1);
}

#[test]
fn rigid_disks_at_rest_with_round_off_velocities_never_trip_it() {
    let mut b = Bodies::default();
    b.push(V2::new(0.0, 0.0), 1.0, 1.0, 0);
    b.vel[0] = V2::new(1e-18, 0.0);
    let laws = LawTable::new(Coulomb { mu: 0.0 }, Coulomb { mu: 0.0 }, vec![]);
    let mut s = Scene::new(b, vec![], laws, pair(0.1).params, 1);
    for _ in 0..10 {
        s.step().unwrap();
    }
}

/// The BPM attraction is explicit too, but its rigid, zero-restitution contacts keep it from
/// pumping energy: at 2 t0 (four times the step the compact stage allows) a grain still
/// loses kinetic energy, and at 5 t0 the contacts fail first, so the run stops at step 0
/// on the penetration guard instead of going on with a bad state.
#[test]
fn a_bpm_grain_far_above_its_step_limit_stops_at_once() {
    use softgrain::bpm::{BpmLaw, build_grain};
    let mut rng = softgrain::rng::Rng::new(3);
    let (pos, rad) = build_grain(1.5e-3, [1.6e-4, 2.6e-4], &mut rng);
    let mut b = Bodies::default();
    for (x, r) in pos.iter().zip(&rad) {
        b.push(*x, *r, 990.0, 0);
    }
    let t0 = softgrain::stages::discretise::t0(&b, 100.0);
    let scene = |k: f64| {
        let law = BpmLaw::Cohesive {
            f0: 100.0,
            gamma: 7.0,
            cutoff: 1.0,
            rolling: 0.0,
        };
        let params = CdParams {
            dt: k * t0,
            theta: 1.0,
            gravity: V2::zeros(),
            alert: 0.05 * 1.6e-4,
            skin: 0.2 * 1.6e-4,
            nlgs: NlgsParams {
                tol: 1.666e-4,
                check_every: 10,
                max_iter: 5000,
                relax: 1.0,
                anderson: 0,
                islands: false,
            },
            sleep: None,
        };
        let laws = LawTable::new(law, BpmLaw::Coulomb { mu: 0.0 }, vec![]);
        Scene::new(b.clone(), vec![], laws, params, 1)
    };
    let mut s = scene(2.0);
    s.step().unwrap();
    let first = s.bodies.kinetic_energy();
    for _ in 0..300 {
        s.step().unwrap();
    }
    assert!(s.bodies.kinetic_energy() < first);
    match scene(5.0).step() {
        Err(CdError::Penetration { step: 0, .. }) => {}
        other => panic!("expected a penetration at step 0, got {other:?}"),
    }
}

/// The penetration guard covers walls too: a disk that starts more than half its radius
/// into a wall (a failed wall contact, or a bad layout) stops the run at step 0 naming the
/// disk and the wall; at a third of its radius the contact only stops it from going deeper.
#[test]
fn a_disk_deep_in_a_wall_stops_at_step_zero_naming_the_wall() {
    use softgrain::geom::Wall;
    let scene = |depth: f64| {
        let mut b = Bodies::default();
        b.push(V2::new(0.0, 1.0 - depth), 1.0, 1.0, 0);
        let floor = Wall::new(V2::new(-5.0, 0.0), V2::new(5.0, 0.0));
        let mut params = pair(0.01).params;
        params.gravity = V2::new(0.0, -9.81);
        let law = Coulomb { mu: 0.0 };
        Scene::new(
            b,
            vec![floor],
            LawTable::new(law, law, vec![law]),
            params,
            1,
        )
    };
    let mut shallow = scene(0.3);
    for _ in 0..20 {
        shallow.step().unwrap();
    }
    let y = shallow.bodies.pos[0].y;
    assert!((y - 0.7).abs() < 1e-9, "the disk moved to y = {y}");
    match scene(0.7).step() {
        Err(CdError::WallPenetration {
            step: 0,
            body: 0,
            wall: 0,
            depth,
        }) => assert!((depth - 0.7).abs() < 1e-3, "depth {depth}"),
        other => panic!("expected a wall penetration at step 0, got {other:?}"),
    }
}
