//! Closed-form references for a disk compressed between two rigid plates (plane strain).
//!
//! * Paper Eq. 13 (a linearisation): `F = (π/4) E/(1-ν²) R ε`.
//! * Johnson, *Contact Mechanics* (1985) §5.6, 2D disk between flat plates: total approach
//!   `δ = (4F/(π E*)) (ln(4R/b) - 1/2)`, contact half-width `b = sqrt(4FR/(π E*))`,
//!   `E* = E/(1-ν²)`; with the plate gap `h = 2R e^{-ε}`, `δ = 2R (1 - e^{-ε})`.
//!
//! Forces are per unit thickness (N/m).

/// Plane-strain modulus `E* = E/(1-ν²)` (Pa).
pub fn plane_strain_modulus(young: f64, poisson: f64) -> f64 {
    young / (1.0 - poisson * poisson)
}

/// Paper Eq. 13: `F = (π/4) E* R ε` (N/m).
pub fn eq13_force(young: f64, poisson: f64, radius: f64, strain: f64) -> f64 {
    std::f64::consts::FRAC_PI_4 * plane_strain_modulus(young, poisson) * radius * strain
}

/// Johnson's approach `δ(F)` for a disk between two plates (m).
pub fn johnson_approach(force: f64, young: f64, poisson: f64, radius: f64) -> f64 {
    let es = plane_strain_modulus(young, poisson);
    let b = (4.0 * force * radius / (std::f64::consts::PI * es)).sqrt();
    4.0 * force / (std::f64::consts::PI * es) * ((4.0 * radius / b).ln() - 0.5)
}

/// Johnson's force `F(ε)` (N/m), solving `δ(F) = 2R(1 - e^{-ε})` by bisection in `ln F`.
///
/// `δ(F)` is increasing while `b < 4R/e`, which covers every strain where the formula
/// is meaningful; returns `None` above that range or for `ε <= 0`.
pub fn johnson_force(young: f64, poisson: f64, radius: f64, strain: f64) -> Option<f64> {
    if strain <= 0.0 {
        return None;
    }
    let target = 2.0 * radius * (1.0 - (-strain).exp());
    let es = plane_strain_modulus(young, poisson);
    // Largest admissible force: b = 4R/e, i.e. F = π E* (4R/e)² / (4R).
    let f_max =
        std::f64::consts::PI * es * (4.0 * radius / std::f64::consts::E).powi(2) / (4.0 * radius);
    if johnson_approach(f_max, young, poisson, radius) < target {
        return None;
    }
    let (mut lo, mut hi) = ((f_max * 1e-16).ln(), f_max.ln());
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if johnson_approach(mid.exp(), young, poisson, radius) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some((0.5 * (lo + hi)).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn johnson_inverts_and_matches_the_quoted_ratios() {
        let (e, nu, r) = (10e6, 0.45, 5e-3);
        for eps in [0.005, 0.02, 0.05, 0.1] {
            let f = johnson_force(e, nu, r, eps).unwrap();
            let d = johnson_approach(f, e, nu, r);
            assert!((d / (2.0 * r * (1.0 - (-eps).exp())) - 1.0).abs() < 1e-12);
        }
        let ratio = |eps| johnson_force(e, nu, r, eps).unwrap() / eq13_force(e, nu, r, eps);
        // METHODS §5: about 0.65-0.66 at ε = 0.02 and 0.78-0.8 at ε = 0.05.
        assert!((ratio(0.02) - 0.655).abs() < 0.015, "{}", ratio(0.02));
        assert!((ratio(0.05) - 0.79).abs() < 0.015, "{}", ratio(0.05));
        // Linear in E*, and in R at fixed strain.
        let f1 = johnson_force(e, nu, r, 0.03).unwrap();
        assert!((johnson_force(2.0 * e, nu, r, 0.03).unwrap() / f1 - 2.0).abs() < 1e-9);
        assert!((johnson_force(e, nu, 2.0 * r, 0.03).unwrap() / f1 - 2.0).abs() < 1e-9);
        assert!(johnson_force(e, nu, r, 0.0).is_none());
    }
}
