//! Newmark relations on the nodal displacement increment `u` (METHODS §3.3 step 2).

use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

/// Newmark parameters; `β = 1/4, γ = 1/2` is the trapezoidal rule of Guilkey & Weiss (2003),
/// unconditionally stable and without numerical damping. `γ > 1/2` with
/// `β = (γ + 1/2)²/4` damps the high frequencies (METHODS §6).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Newmark {
    pub beta: f64,
    pub gamma: f64,
}

impl Default for Newmark {
    fn default() -> Self {
        Newmark {
            beta: 0.25,
            gamma: 0.5,
        }
    }
}

impl Newmark {
    /// Damped variant for a given `γ`, with `β = (γ + 1/2)²/4`.
    pub fn damped(gamma: f64) -> Self {
        Newmark {
            beta: (gamma + 0.5).powi(2) / 4.0,
            gamma,
        }
    }

    /// Coefficient of the mass matrix in the effective stiffness, `1/(β Δt²)`.
    pub fn mass_factor(&self, dt: f64) -> f64 {
        1.0 / (self.beta * dt * dt)
    }

    /// `a^{n+1} = (u - Δt v^n)/(β Δt²) - (1 - 2β)/(2β) a^n`.
    pub fn accel(
        &self,
        u: Vector2<f64>,
        v: Vector2<f64>,
        a: Vector2<f64>,
        dt: f64,
    ) -> Vector2<f64> {
        (u - v * dt) * self.mass_factor(dt) - a * ((1.0 - 2.0 * self.beta) / (2.0 * self.beta))
    }

    /// `v^{n+1} = v^n + Δt [(1 - γ) a^n + γ a^{n+1}]`.
    pub fn velocity(
        &self,
        v: Vector2<f64>,
        a: Vector2<f64>,
        a_new: Vector2<f64>,
        dt: f64,
    ) -> Vector2<f64> {
        v + (a * (1.0 - self.gamma) + a_new * self.gamma) * dt
    }

    /// `v^{n+1}` is linear in the increment: `v^{n+1} = rate · u + offset`, with
    /// `rate = γ/(β Δt)` (`2/Δt` for the trapezoidal rule).
    pub fn velocity_rate(&self, dt: f64) -> f64 {
        self.gamma / (self.beta * dt)
    }

    /// The `offset` of `velocity_rate`: `v^n (1 - γ/β) + Δt a^n (1 - γ - γ(1 - 2β)/(2β))`
    /// (`-v^n` for the trapezoidal rule).
    pub fn velocity_offset(&self, v: Vector2<f64>, a: Vector2<f64>, dt: f64) -> Vector2<f64> {
        let (b, g) = (self.beta, self.gamma);
        v * (1.0 - g / b) + a * (dt * (1.0 - g - g * (1.0 - 2.0 * b) / (2.0 * b)))
    }

    /// Predictor with unchanged acceleration: `u = Δt v + Δt²/2 a`.
    pub fn predictor(&self, v: Vector2<f64>, a: Vector2<f64>, dt: f64) -> Vector2<f64> {
        v * dt + a * (0.5 * dt * dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_end_of_step_velocity_is_rate_times_increment_plus_offset() {
        let (v, a, u, dt) = (
            Vector2::new(0.3, -1.2),
            Vector2::new(40.0, 7.0),
            Vector2::new(2e-5, 1e-5),
            1e-4,
        );
        for nm in [Newmark::default(), Newmark::damped(0.6)] {
            let direct = nm.velocity(v, a, nm.accel(u, v, a, dt), dt);
            let linear = u * nm.velocity_rate(dt) + nm.velocity_offset(v, a, dt);
            assert!((direct - linear).norm() < 1e-12 * direct.norm(), "{nm:?}");
        }
        // the trapezoidal rule: v^{n+1} = 2u/Δt - v^n
        let nm = Newmark::default();
        assert_eq!(nm.velocity_offset(v, a, dt), -v);
    }
}
