//! Constitutive laws in plane strain (METHODS §3.3 step 4).

use super::points::Stress;
use nalgebra::{Matrix2, Matrix3};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum MaterialKind {
    /// The paper's Eq. 4, integrated incrementally with the Hughes–Winget rotation
    /// (objective); tangent `D = C`.
    LinearElastic,
    /// Compressible neo-Hookean, `σ = μ/J (b - I) + λ ln J / J I` with `F33 = 1`.
    NeoHookean,
}

/// Grain material: law, Young's modulus `E` (Pa), Poisson's ratio `ν`, density `ρ` (kg/m³).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub kind: MaterialKind,
    pub young: f64,
    pub poisson: f64,
    pub density: f64,
}

/// Result of a constitutive update at one point.
pub struct Update {
    pub stress: Stress,
    pub def_grad: Matrix2<f64>,
    /// Spatial tangent in Voigt form `(xx, yy, xy)` with engineering shear.
    pub tangent: Matrix3<f64>,
}

impl Material {
    /// The same material at Poisson ratio `nu` with the plane-strain modulus
    /// `E* = E/(1-ν²)` kept (E rescaled): the comparison of `bench/disk-fe-reference.md`.
    pub fn with_poisson_at_fixed_plane_strain_modulus(&self, nu: f64) -> Material {
        Material {
            young: self.young * (1.0 - nu * nu) / (1.0 - self.poisson * self.poisson),
            poisson: nu,
            ..*self
        }
    }

    /// Lamé constants `(λ, μ)` (Pa).
    pub fn lame(&self) -> (f64, f64) {
        let (e, nu) = (self.young, self.poisson);
        (
            e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            e / (2.0 * (1.0 + nu)),
        )
    }

    /// Plane-strain P-wave speed `c_p = sqrt((λ + 2μ)/ρ)` (m/s).
    pub fn p_wave_speed(&self) -> f64 {
        let (l, m) = self.lame();
        ((l + 2.0 * m) / self.density).sqrt()
    }

    /// Plane-strain elasticity in Voigt form (engineering shear).
    pub fn elastic_matrix(&self) -> Matrix3<f64> {
        let (l, m) = self.lame();
        Matrix3::new(l + 2.0 * m, l, 0.0, l, l + 2.0 * m, 0.0, 0.0, 0.0, m)
    }

    /// Stress after the increment with displacement gradient `l = ∂Δu/∂x^n` from the
    /// start-of-step state `(σ^n, F^n)`.
    pub fn update(&self, stress_n: &Stress, def_grad_n: &Matrix2<f64>, l: &Matrix2<f64>) -> Update {
        let def_grad = (Matrix2::identity() + l) * def_grad_n;
        match self.kind {
            MaterialKind::LinearElastic => {
                let (lam, mu) = self.lame();
                // Hughes–Winget take the increment's gradient in the midpoint
                // configuration, `G = L (I + L/2)^{-1}`: a rigid rotation `L = R - I` then
                // gives a skew `G` (no strain, `Q = R` exactly), and a linearised rotation
                // `L = θJ`, whose points move out by `det(I + L) = 1 + θ²`, gives the
                // matching dilatation `tr sym G = θ² + O(θ⁴)`. With the start-of-step
                // gradient it gave none, and a grain rocking at 0.1 rad per step in a
                // packing swelled by 1.6 % per step with no stress to stop it.
                let g = l
                    * (Matrix2::identity() + 0.5 * l)
                        .try_inverse()
                        .unwrap_or_else(Matrix2::identity);
                let de = 0.5 * (g + g.transpose());
                let w = 0.5 * (g - g.transpose());
                // Hughes–Winget: Q = (I - W/2)^{-1} (I + W/2), orthogonal for skew W.
                let a = Matrix2::identity() - 0.5 * w;
                let q = a.try_inverse().unwrap_or_else(Matrix2::identity)
                    * (Matrix2::identity() + 0.5 * w);
                let s = q * stress_n.matrix() * q.transpose();
                let tr = de[(0, 0)] + de[(1, 1)];
                let stress = Stress {
                    xx: s[(0, 0)] + lam * tr + 2.0 * mu * de[(0, 0)],
                    yy: s[(1, 1)] + lam * tr + 2.0 * mu * de[(1, 1)],
                    xy: 0.5 * (s[(0, 1)] + s[(1, 0)]) + 2.0 * mu * de[(0, 1)],
                    zz: stress_n.zz + lam * tr,
                };
                // Spatial tangent of the Jaumann rate, written for the Truesdell rate of
                // Kirchhoff stress that the updated-Lagrangian assembly expects:
                // c = C + σ ⊗ 1 - (δσ + σδ) terms; the σ ⊗ 1 part is symmetrised so the
                // tangent stays symmetric (Cholesky) at the cost of O(σ/E) inconsistency.
                let (sx, sy, sxy) = (stress.xx, stress.yy, stress.xy);
                let d1 = Matrix3::new(
                    sx,
                    0.5 * (sx + sy),
                    0.5 * sxy,
                    0.5 * (sx + sy),
                    sy,
                    0.5 * sxy,
                    0.5 * sxy,
                    0.5 * sxy,
                    0.0,
                );
                let d2 = Matrix3::new(
                    2.0 * sx,
                    0.0,
                    sxy,
                    0.0,
                    2.0 * sy,
                    sxy,
                    sxy,
                    sxy,
                    0.5 * (sx + sy),
                );
                Update {
                    stress,
                    def_grad,
                    tangent: self.elastic_matrix() + d1 - d2,
                }
            }
            MaterialKind::NeoHookean => {
                let (lam, mu) = self.lame();
                let j = def_grad.determinant();
                let b = def_grad * def_grad.transpose();
                let p = lam * j.ln() / j;
                let stress = Stress {
                    xx: mu / j * (b[(0, 0)] - 1.0) + p,
                    yy: mu / j * (b[(1, 1)] - 1.0) + p,
                    xy: mu / j * b[(0, 1)],
                    zz: p,
                };
                let (lp, mp) = (lam / j, (mu - lam * j.ln()) / j);
                let tangent =
                    Matrix3::new(lp + 2.0 * mp, lp, 0.0, lp, lp + 2.0 * mp, 0.0, 0.0, 0.0, mp);
                Update {
                    stress,
                    def_grad,
                    tangent,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_strain_agrees_and_rotation_is_objective() {
        let base = Material {
            kind: MaterialKind::LinearElastic,
            young: 10e6,
            poisson: 0.45,
            density: 990.0,
        };
        let nh = Material {
            kind: MaterialKind::NeoHookean,
            ..base
        };
        let l = Matrix2::new(-1e-6, 2e-7, 3e-7, 5e-7);
        let a = base
            .update(&Stress::default(), &Matrix2::identity(), &l)
            .stress;
        let b = nh
            .update(&Stress::default(), &Matrix2::identity(), &l)
            .stress;
        assert!((a.xx - b.xx).abs() < 1e-3 * a.xx.abs().max(1.0));
        assert!((a.zz - b.zz).abs() < 1e-3 * a.zz.abs().max(1.0));
        // A pure rotation increment leaves the invariants of σ unchanged.
        let s0 = Stress {
            xx: 1e5,
            yy: -2e5,
            xy: 3e4,
            zz: 0.0,
        };
        // A rigid rotation increment rotates σ exactly and strains nothing.
        let (c, sn) = (0.3f64.cos(), 0.3f64.sin());
        let r = Matrix2::new(c, -sn, sn, c);
        let s1 = base
            .update(&s0, &Matrix2::identity(), &(r - Matrix2::identity()))
            .stress;
        let expect = r * s0.matrix() * r.transpose();
        assert!((s1.matrix() - expect).norm() < 1e-9 * s0.von_mises());
        assert!((s1.zz - s0.zz).abs() < 1e-9 * s0.von_mises());
        // A linearised rotation `θJ` moves the points out by det(I + θJ) = 1 + θ²: the
        // law sees that dilatation (to O(θ⁴)), so the pressure resists it.
        let theta = 0.1;
        let lin_rot = Matrix2::new(0.0, -theta, theta, 0.0);
        let u = base.update(&Stress::default(), &Matrix2::identity(), &lin_rot);
        let (lam, mu) = base.lame();
        let dilatation = (u.stress.xx + u.stress.yy) / (2.0 * (lam + mu));
        let kinematic = u.def_grad.determinant().ln();
        assert!(
            (dilatation - kinematic).abs() < theta.powi(4),
            "{dilatation} vs ln det {kinematic}"
        );
    }

    /// The linear-elastic law integrates the Jaumann rate, whose simple-shear response is
    /// not monotone (Dienes 1979): σ_xy = μ sin γ, σ_xx = -σ_yy = μ (1 - cos γ). Past
    /// γ = π/2 the shear stress falls as the shear grows; the neo-Hookean law stays
    /// monotone (σ_xy = μ γ). This is why the linear-elastic grain's force drops at large
    /// strain (`tests/stress.rs`) while the neo-Hookean one does not.
    #[test]
    fn the_linear_law_follows_the_jaumann_rate_in_simple_shear() {
        let lin = Material {
            kind: MaterialKind::LinearElastic,
            young: 10e6,
            poisson: 0.45,
            density: 990.0,
        };
        let nh = Material {
            kind: MaterialKind::NeoHookean,
            ..lin
        };
        let (_, mu) = lin.lame();
        let n = 4000;
        let dg = 3.0 / n as f64;
        let (mut s, mut f) = (Stress::default(), Matrix2::identity());
        let mut nh_state = (Stress::default(), Matrix2::identity());
        for k in 1..=n {
            // the increment's gradient with respect to the current configuration
            let l = Matrix2::new(0.0, dg, 0.0, 0.0);
            let u = lin.update(&s, &f, &l);
            (s, f) = (u.stress, u.def_grad);
            let v = nh.update(&nh_state.0, &nh_state.1, &l);
            nh_state = (v.stress, v.def_grad);
            let g = k as f64 * dg;
            if k % 500 == 0 {
                // first order in the step (the elastic increment is added after the
                // rotation): the error is below dγ μ to γ = 3 and halves with the step
                let tol = 2.0 * dg * mu;
                assert!((s.xy - mu * g.sin()).abs() < tol, "γ = {g}: σ_xy {}", s.xy);
                assert!(
                    (s.xx - mu * (1.0 - g.cos())).abs() < tol,
                    "γ = {g}: σ_xx {}",
                    s.xx
                );
                assert!(
                    (s.yy + mu * (1.0 - g.cos())).abs() < tol,
                    "γ = {g}: σ_yy {}",
                    s.yy
                );
                assert!((nh_state.0.xy - mu * g).abs() < 1e-9 * mu, "γ = {g}");
            }
        }
    }
}
