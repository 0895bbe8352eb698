//! Interaction laws, called from the one generic NLGS loop (LMGC90-style): a law gives a
//! contact's friction, its rolling resistance and the projection onto its admissible set
//! (the loop's local solve projects the Gauss-Seidel trial impulse), and may add an explicit
//! smooth force (BPM cohesion).

use serde::{Deserialize, Serialize};

/// What the NLGS loop asks of a contact law.
pub trait InteractionLaw: Send + Sync {
    /// Coulomb friction coefficient (0 skips the tangential solve and the rotations it drives).
    fn friction(&self) -> f64;

    /// Rolling-resistance coefficient μ_r (METHODS.md §1.10): the relative rotation of the
    /// two disks is resisted by a moment up to μ_r ℓ p_n, ℓ = r_i r_j/(r_i + r_j). 0: none.
    fn rolling(&self) -> f64 {
        0.0
    }

    /// Range beyond contact (a gap, m) over which `smooth_force` acts; `a0` = r_i + r_j.
    fn range(&self, _a0: f64) -> f64 {
        0.0
    }

    /// Normal smooth force (N/m, positive repulsive) at gap `gap`, taken explicitly at the
    /// start of the step (METHODS.md §1.9 option E).
    fn smooth_force(&self, _gap: f64, _a0: f64) -> f64 {
        0.0
    }

    /// Potential of `smooth_force`, `U(gap) = ∫_gap^range f ds` (J/m), zero beyond the
    /// range (≤ 0 for an attraction). The energy guard (`guard.rs`) counts `-U` as energy
    /// the law may have released.
    fn potential(&self, _gap: f64, _a0: f64) -> f64 {
        0.0
    }

    /// The local solve of velocity-Signorini + Coulomb (restitution 0) on the admissible set
    /// `p_n ≥ 0`, `|p_t| ≤ μ p_n`: p_n clamped first, then p_t within ±μ p_n. Applied to
    /// the Gauss-Seidel trial impulse p − W⁻¹ u (u the contact's current, gap-augmented
    /// velocity) this is the exact local solution, because a disk contact's own Delassus
    /// block is diagonal (W_tn = 0); a relaxed impulse (`NlgsParams::relax`) is brought back
    /// the same way.
    fn project(&self, p_n: f64, p_t: f64) -> (f64, f64) {
        let p_n = p_n.max(0.0);
        let bound = self.friction() * p_n;
        // max/min rather than clamp, which panics on a NaN bound (a diverged run is reported
        // by the guard instead); + 0.0 turns -0.0 (bound 0, p_t < 0) into +0.0, so that a
        // frictionless or open contact keeps p_t = +0.0, bit for bit what skipping its
        // tangential solve keeps.
        (p_n, p_t.max(-bound).min(bound) + 0.0)
    }
}

/// Unilateral contact with Coulomb friction `mu` and no cohesion: rigid disks, inter-grain
/// contacts, walls.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Coulomb {
    pub mu: f64,
}

impl InteractionLaw for Coulomb {
    fn friction(&self) -> f64 {
        self.mu
    }
}

/// Which law acts on which pair: one law inside a group (grain), one between groups, and
/// one per wall.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LawTable<L> {
    pub laws: Vec<L>,
}

impl<L: InteractionLaw> LawTable<L> {
    pub const SAME_GROUP: u16 = 0;
    pub const OTHER_GROUP: u16 = 1;

    /// `walls[w]` acts between the disks and wall `w`.
    pub fn new(same_group: L, other_group: L, walls: Vec<L>) -> Self {
        let mut laws = vec![same_group, other_group];
        laws.extend(walls);
        LawTable { laws }
    }

    pub fn wall_law(w: usize) -> u16 {
        2 + w as u16
    }

    pub fn get(&self, id: u16) -> &L {
        &self.laws[id as usize]
    }

    /// Largest range of any disk-disk law for pairs with a0 ≤ `a0_max`.
    pub fn max_range(&self, a0_max: f64) -> f64 {
        self.laws[..2]
            .iter()
            .map(|l| l.range(a0_max))
            .fold(0.0, f64::max)
    }

    pub fn any_friction(&self) -> bool {
        self.laws.iter().any(|l| l.friction() > 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_projection_clamps_normal_then_tangential_and_keeps_zero_positive() {
        let (stick, free) = (Coulomb { mu: 0.5 }, Coulomb { mu: 0.0 });
        assert_eq!(stick.project(2.0, -3.0), (2.0, -1.0));
        assert_eq!(stick.project(2.0, 0.4), (2.0, 0.4));
        // an open contact, and a frictionless one: p_t is +0.0 bit for bit
        for (p_n, p_t) in [stick.project(-1.0, -1.0), free.project(1.0, -1.0)] {
            assert!(p_n >= 0.0);
            assert_eq!(p_t.to_bits(), 0.0f64.to_bits());
        }
        // a diverged impulse (0 × ∞ bound) gives a non-finite value for the guard, no panic
        assert!(free.project(f64::INFINITY, 1.0).0.is_infinite());
    }
}
