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

    /// Predictor with unchanged acceleration: `u = Δt v + Δt²/2 a`.
    pub fn predictor(&self, v: Vector2<f64>, a: Vector2<f64>, dt: f64) -> Vector2<f64> {
        v * dt + a * (0.5 * dt * dt)
    }
}
