//! Energy-growth guard: stops a contact-dynamics run whose kinetic energy grows beyond
//! anything the loads could have supplied (an unstable explicit force, a corrupted state).
//!
//! Energy balance of a correct run, from the step the guard started at (t_s) to t:
//!
//!   K(t) + D = K(t_s) + W_g + W_ext + W_walls + U(t_s) - U(t),   D ≥ 0 (dissipation)
//!
//! where the W are the work of gravity, of the constant external forces and of the driven
//! walls, and U ≤ 0 the potential of the smooth (cohesive) laws (`InteractionLaw::potential`).
//! Contacts with zero restitution and friction only dissipate. As U(t_s) ≤ 0, every correct
//! run satisfies
//!
//!   K(t) ≤ B(t) = K(t_s) + Σ_steps h (Σ_i |(m_i g + F_i)·v_i| + Σ_w |F_w·V_w|) - U(t).
//!
//! The guard fires when K > `FACTOR` B: the explicit force evaluation can miss the balance
//! by a fraction of B, never by a factor of 1000, while an unstable mode grows geometrically
//! and passes it within a few steps. A kinetic energy below `½ M (1e-6 r_max/h)²` (every
//! disk moving a millionth of a radius per step) never fires it: a scene at rest with no
//! loads has B = 0 and round-off velocities.
//!
//! The state is not checkpointed: after a resume the guard restarts from the loaded state,
//! for which the bound holds as well.

use super::{Bodies, CdError, Contact, InteractionLaw, LawTable, Partner, Scene};

/// How far the kinetic energy may exceed the energy budget before the run is stopped.
pub const FACTOR: f64 = 1e3;

/// The budget B of the module documentation, accumulated step by step.
#[derive(Clone, Debug, Default)]
pub struct EnergyGuard {
    /// K(t_s) + the work supplied since (J/m); `None` until the first step.
    supplied: Option<f64>,
}

impl EnergyGuard {
    /// Called at the start of a step: the first call records K(t_s).
    pub fn start(&mut self, b: &Bodies) {
        if self.supplied.is_none() {
            self.supplied = Some(b.kinetic_energy());
        }
    }
}

impl<L: InteractionLaw> Scene<L> {
    /// Called after the positions, wall forces and contacts of the step are updated.
    pub(super) fn check_energy(&mut self) -> Result<(), CdError> {
        let b = &self.bodies;
        let g = self.params.gravity;
        let h = self.params.dt;
        let body_power: f64 = b
            .movable()
            .map(|i| (b.mass(i) * g + b.force[i]).dot(&b.vel[i]).abs())
            .sum();
        let wall_power: f64 = (self.walls.iter().zip(&self.wall_force))
            .map(|(w, f)| f.dot(&w.velocity).abs())
            .sum();
        let supplied = self.energy.supplied.unwrap_or(0.0) + h * (body_power + wall_power);
        self.energy.supplied = Some(supplied);
        let kinetic = b.kinetic_energy();
        let still = 0.5 * b.total_mass() * (1e-6 * b.max_radius() / h).powi(2);
        // B ≥ supplied (U ≤ 0): the potential is only summed when that does not settle it.
        if kinetic <= still || kinetic <= FACTOR * supplied {
            return Ok(());
        }
        let budget = supplied - potential(b, &self.contacts, &self.laws);
        if kinetic > FACTOR * budget {
            return Err(CdError::EnergyGrowth {
                step: self.steps,
                kinetic,
                budget,
            });
        }
        Ok(())
    }
}

/// U(t): the smooth laws' potential over the disk pairs of the step, at the current gaps.
fn potential<L: InteractionLaw>(b: &Bodies, contacts: &[Contact], laws: &LawTable<L>) -> f64 {
    contacts
        .iter()
        .filter_map(|c| match c.j {
            Partner::Body(j) => {
                let (i, j) = (c.i as usize, j as usize);
                let a0 = b.radius[i] + b.radius[j];
                let law = laws.get(c.law);
                (law.range(a0) > 0.0).then(|| law.potential((b.pos[i] - b.pos[j]).norm() - a0, a0))
            }
            Partner::Wall(_) => None,
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bpm::BpmLaw;

    #[test]
    fn the_bpm_potential_is_the_integral_of_its_force() {
        let law = BpmLaw::Cohesive {
            f0: 2.0,
            gamma: 7.0,
            cutoff: 1.0,
            rolling: 0.0,
        };
        let a0 = 0.3;
        assert_eq!(law.potential(1.01 * a0, a0), 0.0);
        assert!(law.potential(0.0, a0) < 0.0);
        assert_eq!(law.potential(-0.1, a0), law.potential(0.0, a0));
        for g in [0.01, 0.1, 0.2, 0.29] {
            let d = 1e-6;
            let dudg = (law.potential(g + d, a0) - law.potential(g - d, a0)) / (2.0 * d);
            let f = law.smooth_force(g, a0);
            assert!(
                (dudg + f).abs() < 1e-6 * f.abs(),
                "g {g}: U' = {dudg}, f = {f}"
            );
        }
    }
}
