//! The BPM interaction laws (paper section 2.1, METHODS.md §1.9).

use crate::cd::InteractionLaw;
use serde::{Deserialize, Serialize};

/// Primary particles of one grain: frictionless unilateral contact plus the attraction of
/// Eq. (1), F_a = -F0 (1 + δ/a0)^(-γ) for gaps 0 ≤ δ ≤ cutoff·a0 (not shifted: the force
/// drops from F0 2^(-γ) to 0 at the cut-off, as the paper's law is written). At contact
/// the total normal force p_n/h - F0 takes any value in [-F0, ∞).
///
/// The attraction is explicit (option E): taken at the start of the step as a smooth
/// force. Its stiffness is at most k_a = γ F0/a0, so it is stable for h < 2 sqrt(m*/k_a)
/// ≈ 0.53 t0 with t0 = sqrt(m a0/F0); the compact stage uses h = 0.1 t0 (smallest particle)
/// by default, five times inside that limit and accurate (METHODS.md §1.9).
/// Option I (the attraction inside the local solve) is not used: its local problem has
/// three solutions for some approach velocities once h > t0/√(2θγ) ≈ 0.27 t0, so it would
/// not allow larger steps (README, "Methods and decisions").
///
/// `rolling` is the optional rolling resistance μ_r between particles of one grain (off, 0,
/// by default, as in the paper): without it boundary particles turn freely, so friction on
/// a grain's surface cannot be mobilised (the paper's conclusion).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum BpmLaw {
    Cohesive {
        f0: f64,
        gamma: f64,
        cutoff: f64,
        rolling: f64,
    },
    /// Inter-grain and wall contacts: Coulomb friction, no attraction.
    Coulomb { mu: f64 },
}

impl InteractionLaw for BpmLaw {
    fn friction(&self) -> f64 {
        match self {
            BpmLaw::Cohesive { .. } => 0.0,
            BpmLaw::Coulomb { mu } => *mu,
        }
    }

    fn rolling(&self) -> f64 {
        match self {
            BpmLaw::Cohesive { rolling, .. } => *rolling,
            BpmLaw::Coulomb { .. } => 0.0,
        }
    }

    fn range(&self, a0: f64) -> f64 {
        match self {
            BpmLaw::Cohesive { cutoff, .. } => cutoff * a0,
            BpmLaw::Coulomb { .. } => 0.0,
        }
    }

    fn smooth_force(&self, gap: f64, a0: f64) -> f64 {
        match *self {
            BpmLaw::Cohesive {
                f0, gamma, cutoff, ..
            } if gap <= cutoff * a0 => -f0 * pow(1.0 + gap.max(0.0) / a0, -gamma),
            _ => 0.0,
        }
    }

    /// `U(g) = -F0 a0/(γ-1) [(1 + g/a0)^(1-γ) - (1 + cutoff)^(1-γ)]`, constant below contact.
    fn potential(&self, gap: f64, a0: f64) -> f64 {
        match *self {
            BpmLaw::Cohesive {
                f0, gamma, cutoff, ..
            } if gap <= cutoff * a0 => {
                let x = |g: f64| pow(1.0 + g / a0, 1.0 - gamma);
                -f0 * a0 / (gamma - 1.0) * (x(gap.max(0.0)) - x(cutoff * a0))
            }
            _ => 0.0,
        }
    }
}

/// x^e, by repeated multiplication when e is a whole number (the paper's γ = 7): glibc's
/// `pow` was a tenth of a paper-size BPM compaction's time, evaluated for every cohesive
/// pair at every step; `powi` agrees with it to a few ulp.
fn pow(x: f64, e: f64) -> f64 {
    if e.fract() == 0.0 && e.abs() <= 64.0 {
        x.powi(e as i32)
    } else {
        x.powf(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_exponents_multiply_and_agree_with_powf() {
        for e in [-7.0, -6.0, 1.0 - 7.0, -1.0, 0.0, 3.0] {
            for k in 0..=100 {
                let x = 1.0 + k as f64 / 100.0;
                let (fast, slow) = (pow(x, e), x.powf(e));
                assert!(
                    (fast - slow).abs() <= 1e-14 * slow,
                    "{x}^{e}: {fast} vs {slow}"
                );
            }
        }
        // a fractional exponent keeps powf, bit for bit
        assert_eq!(pow(1.37, -6.5), 1.37f64.powf(-6.5));
        assert_eq!(pow(2.0, -7.0), 1.0 / 128.0);
    }

    #[test]
    fn the_attraction_is_eq_1_and_the_potential_its_integral() {
        let law = BpmLaw::Cohesive {
            f0: 100.0,
            gamma: 7.0,
            cutoff: 1.0,
            rolling: 0.0,
        };
        let a0 = 1e-4;
        // F0 at contact, F0 2^-γ at the cut-off, nothing beyond
        assert_eq!(law.smooth_force(0.0, a0), -100.0);
        assert!((law.smooth_force(a0, a0) + 100.0 / 128.0).abs() < 1e-12);
        assert_eq!(law.smooth_force(1.01 * a0, a0), 0.0);
        // -dU/dg = F (central difference)
        let g = 0.3 * a0;
        let dg = 1e-6 * a0;
        let du = (law.potential(g + dg, a0) - law.potential(g - dg, a0)) / (2.0 * dg);
        assert!((-du - law.smooth_force(g, a0)).abs() < 1e-6 * 100.0);
    }
}
