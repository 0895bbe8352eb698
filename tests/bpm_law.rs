//! The BPM interaction laws inside the contact-dynamics engine (paper Eq. 1, Fig. 1):
//! at contact the force between two particles of one grain takes any value in [-F0, ∞);
//! beyond the cut-off they feel nothing; particles of different grains never attract.

use softgrain::bpm::BpmLaw;
use softgrain::cd::{Bodies, CdParams, LawTable, NlgsParams, Partner, Scene};
use softgrain::geom::{V2, Wall};

const F0: f64 = 1.0;
const R: f64 = 0.5;

/// Two unit-diameter particles (scale-free: F0 = 1, d = 1, ρ = 1) at gap `gap`, in grains
/// `g1`, `g2`, pulled apart by ±`pull` along x.
fn pair(gap: f64, g1: u32, g2: u32, pull: f64) -> Scene<BpmLaw> {
    let mut b = Bodies::default();
    b.push(V2::new(0.0, 0.0), R, 1.0, g1);
    b.push(V2::new(2.0 * R + gap, 0.0), R, 1.0, g2);
    b.force[0] = V2::new(-pull, 0.0);
    b.force[1] = V2::new(pull, 0.0);
    let t0 = (b.mass(0) * 2.0 * R / F0).sqrt();
    let cohesive = BpmLaw::Cohesive {
        f0: F0,
        gamma: 7.0,
        cutoff: 1.0,
        rolling: 0.0,
    };
    let laws = LawTable::new(cohesive, BpmLaw::Coulomb { mu: 0.5 }, vec![]);
    let params = CdParams {
        dt: 0.1 * t0,
        theta: 1.0,
        gravity: V2::zeros(),
        alert: 0.05,
        skin: 0.1,
        nlgs: NlgsParams {
            tol: 1e-8,
            check_every: 1,
            max_iter: 100,
            relax: 1.0,
            anderson: 0,
            islands: false,
        },
        sleep: None,
    };
    Scene::new(b, vec![], laws, params, 1)
}

fn gap(s: &Scene<BpmLaw>) -> f64 {
    (s.bodies.pos[1] - s.bodies.pos[0]).norm() - 2.0 * R
}

/// Total interaction force on particle 0 along the normal: repulsion p_n/h plus attraction.
fn interaction(s: &Scene<BpmLaw>) -> f64 {
    let c = s
        .contacts
        .iter()
        .find(|c| c.j == Partner::Body(1))
        .expect("the pair is listed");
    let law = s.laws.get(c.law);
    use softgrain::cd::InteractionLaw;
    c.p_n / s.params.dt + law.smooth_force(c.gap, 2.0 * R)
}

#[test]
fn touching_particles_of_one_grain_hold_any_pull_up_to_f0() {
    for pull in [0.0, 0.3, 0.9] {
        let mut s = pair(0.0, 0, 0, pull);
        for _ in 0..200 {
            s.step().unwrap();
        }
        assert!(gap(&s).abs() < 1e-12, "pull {pull}: gap {}", gap(&s));
        assert!(s.bodies.vel.iter().all(|v| v.norm() < 1e-12));
        // the interaction balances the pull: force on 0 along n (from 1 into 0) = -pull
        let f = interaction(&s);
        assert!((f + pull).abs() < 1e-9, "pull {pull}: interaction {f}");
        assert!(f >= -F0 - 1e-12);
    }
}

#[test]
fn a_pull_beyond_f0_separates_them() {
    let mut s = pair(0.0, 0, 0, 1.2);
    for _ in 0..200 {
        s.step().unwrap();
    }
    assert!(gap(&s) > 0.01, "gap {}", gap(&s));
}

#[test]
fn past_the_cutoff_particles_of_one_grain_feel_nothing() {
    let mut s = pair(1.01 * 2.0 * R, 0, 0, 0.0);
    let start = s.bodies.pos.clone();
    for _ in 0..100 {
        s.step().unwrap();
    }
    assert_eq!(s.bodies.pos, start);
    // inside the cut-off they are drawn together with F0 (1 + δ/a0)^-7
    let mut s = pair(0.5 * 2.0 * R, 0, 0, 0.0);
    s.step().unwrap();
    let a = s.bodies.vel[0].x / s.params.dt * s.bodies.mass(0);
    assert!((a - F0 * 1.5f64.powi(-7)).abs() < 1e-12, "{a}");
}

#[test]
fn particles_of_different_grains_never_attract() {
    for gap0 in [0.0, 0.1, 0.5] {
        let mut s = pair(gap0, 0, 1, 0.0);
        let start = s.bodies.pos.clone();
        for _ in 0..100 {
            s.step().unwrap();
        }
        assert_eq!(s.bodies.pos, start, "gap {gap0}");
    }
}

#[test]
fn at_the_default_step_the_same_pair_comes_together_without_alarm() {
    let mut s = pair(0.3 * 2.0 * R, 0, 0, 0.0);
    for _ in 0..2000 {
        s.step().unwrap();
    }
    assert!(gap(&s).abs() < 1e-9, "gap {}", gap(&s));
}

/// Rolling resistance (METHODS.md §1.10): two touching particles of one grain, held at
/// contact by the attraction (reaction F0), spun in opposite senses. The rolling moment is
/// at most μ_r ℓ F0, ℓ = r r/(r + r) = R/2, so their relative spin Ω = ω0 − ω1 falls at
/// the constant rate 2 μ_r ℓ F0 / I and stops at t* = Ω0 I / (2 μ_r ℓ F0), and their total
/// spin, I (ω0 + ω1) = 0, is kept. Without it (the paper) the spins never change.
#[test]
fn rolling_resistance_stops_a_relative_spin_at_the_moment_limit() {
    let spun = |mu_r: f64| {
        let mut s = pair(0.0, 0, 0, 0.0);
        s.laws.laws[0] = BpmLaw::Cohesive {
            f0: F0,
            gamma: 7.0,
            cutoff: 1.0,
            rolling: mu_r,
        };
        s.bodies.omega = vec![0.3, -0.3];
        s
    };
    let mut free = spun(0.0);
    for _ in 0..100 {
        free.step().unwrap();
    }
    assert_eq!(free.bodies.omega, vec![0.3, -0.3]);

    let mu_r = 0.2;
    let mut s = spun(mu_r);
    let inertia = 1.0 / s.bodies.inv_inertia[0];
    let rate = 2.0 * mu_r * (R / 2.0) * F0 / inertia;
    let t_stop = 0.6 / rate;
    let h = s.params.dt;
    let half = (0.5 * t_stop / h).round() as usize;
    for _ in 0..half {
        s.step().unwrap();
    }
    let relative = s.bodies.omega[0] - s.bodies.omega[1];
    let expected = 0.6 - rate * half as f64 * h;
    assert!(
        (relative - expected).abs() < 1e-6 * 0.6,
        "relative spin {relative} after {half} steps, expected {expected}"
    );
    for _ in 0..2 * half {
        s.step().unwrap();
        assert!((s.bodies.omega[0] + s.bodies.omega[1]).abs() < 1e-12);
    }
    assert!(
        (s.bodies.omega[0] - s.bodies.omega[1]).abs() < 1e-9,
        "{:?}",
        s.bodies.omega
    );
    // the pair stayed in contact and at rest: the moment did not disturb the normal solve
    assert!(gap(&s).abs() < 1e-12 && s.bodies.vel.iter().all(|v| v.norm() < 1e-12));
}

/// Why rolling resistance makes friction matter (the paper's conclusion): a triangle of
/// three grain-mates on a frictional slope (μ = 0.5 ≥ tan θ / 3, θ = 20°, gravity tilted).
/// Without it the top disk feels no torque and slides on its frictionless bonds while the
/// two bottom disks roll: 3m a = 3m g sin θ − 2 (m a / 2), a = (3/4) g sin θ. With it the
/// three disks must turn together, and the floor's friction spins all of them:
/// 3m a = 3m g sin θ − 3 (m a / 2), a = (2/3) g sin θ, a single rolling disk's.
#[test]
fn rolling_resistance_lets_floor_friction_turn_the_whole_grain() {
    let theta = 20f64.to_radians();
    let slide = |mu_r: f64| {
        let mut b = Bodies::default();
        b.push(V2::new(0.0, R), R, 1.0, 0);
        b.push(V2::new(2.0 * R, R), R, 1.0, 0);
        b.push(V2::new(R, R + 3f64.sqrt() * R), R, 1.0, 0);
        let f0 = 100.0;
        let t0 = (b.mass(0) * 2.0 * R / f0).sqrt();
        let cohesive = BpmLaw::Cohesive {
            f0,
            gamma: 7.0,
            cutoff: 1.0,
            rolling: mu_r,
        };
        let floor = BpmLaw::Coulomb { mu: 0.5 };
        let laws = LawTable::new(cohesive, floor, vec![floor]);
        let params = CdParams {
            dt: 0.1 * t0,
            theta: 1.0,
            gravity: V2::new(theta.sin(), -theta.cos()),
            alert: 0.05,
            skin: 0.1,
            nlgs: NlgsParams {
                tol: 1e-10,
                check_every: 1,
                max_iter: 1000,
                relax: 1.0,
                anderson: 0,
                islands: false,
            },
            sleep: None,
        };
        let floor_wall = Wall::new(V2::new(-100.0, 0.0), V2::new(100.0, 0.0));
        let mut s = Scene::new(b, vec![floor_wall], laws, params, 1);
        let steps = 300;
        for _ in 0..steps {
            s.step().unwrap();
        }
        let v = s.bodies.vel.iter().map(|v| v.x).sum::<f64>() / 3.0;
        (v / (steps as f64 * s.params.dt), s)
    };
    let (free, s) = slide(0.0);
    assert!(
        (free / (0.75 * theta.sin()) - 1.0).abs() < 0.01,
        "a = {free} g without rolling resistance"
    );
    assert_eq!(s.bodies.omega[2], 0.0, "the top disk turned");
    let (locked, s) = slide(0.1);
    assert!(
        (locked / (2.0 / 3.0 * theta.sin()) - 1.0).abs() < 0.01,
        "a = {locked} g with rolling resistance"
    );
    let w = &s.bodies.omega;
    assert!((w[2] / w[0] - 1.0).abs() < 1e-6, "spins {w:?}");
}
