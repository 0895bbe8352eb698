//! The BPM interaction laws inside the contact-dynamics engine (paper Eq. 1, Fig. 1):
//! at contact the force between two particles of one grain takes any value in [-F0, ∞);
//! beyond the cut-off they feel nothing; particles of different grains never attract.

use softgrain::bpm::BpmLaw;
use softgrain::cd::{Bodies, CdParams, LawTable, NlgsParams, Partner, Scene};
use softgrain::geom::V2;

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
        },
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
