//! The packing laws of the paper fitted to (x = σ/σ0 − 1, Φ) points: Eq. 14 (BPM,
//! exponential) and Eq. 16 (MPM, linear). Pure functions on slices.

use serde::Serialize;

/// A one-parameter fit with its goodness and the data it used.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Fit {
    /// α of Eq. 14 or the slope β/K_g of Eq. 16.
    pub value: f64,
    /// R² of the fitted Φ(x) against the measured Φ: 1 − SS_res/SS_tot.
    pub r2: f64,
    pub points: usize,
}

/// Eq. 14: Φ = 1 − (1 − Φ0) exp(−α x).
pub fn eq14_phi(alpha: f64, phi0: f64, x: f64) -> f64 {
    1.0 - (1.0 - phi0) * (-alpha * x).exp()
}

/// Eq. 16: Φ = s x + Φ0.
pub fn eq16_phi(slope: f64, phi0: f64, x: f64) -> f64 {
    slope * x + phi0
}

fn r2(phi: &[f64], model: impl Fn(f64) -> f64, x: &[f64]) -> f64 {
    let mean = phi.iter().sum::<f64>() / phi.len() as f64;
    let ss_tot: f64 = phi.iter().map(|p| (p - mean).powi(2)).sum();
    let ss_res: f64 = x
        .iter()
        .zip(phi)
        .map(|(&x, p)| (p - model(x)).powi(2))
        .sum();
    1.0 - ss_res / ss_tot
}

/// Least squares through the origin, b = Σ x y / Σ x²; None without a nonzero x.
fn through_origin(x: &[f64], y: &[f64]) -> Option<f64> {
    let sxx: f64 = x.iter().map(|x| x * x).sum();
    (sxx > 0.0).then(|| x.iter().zip(y).map(|(x, y)| x * y).sum::<f64>() / sxx)
}

/// Eq. 14 linearised: y = ln((1 − Φ)/(1 − Φ0)) = −α x, α by least squares through the
/// origin (METHODS.md §5). Needs Φ < 1 everywhere.
pub fn eq14(x: &[f64], phi: &[f64], phi0: f64) -> Option<Fit> {
    if x.len() < 2 || phi.iter().any(|&p| p >= 1.0) {
        return None;
    }
    let y: Vec<f64> = phi
        .iter()
        .map(|p| ((1.0 - p) / (1.0 - phi0)).ln())
        .collect();
    let alpha = -through_origin(x, &y)?;
    Some(Fit {
        value: alpha,
        r2: r2(phi, |x| eq14_phi(alpha, phi0, x), x),
        points: x.len(),
    })
}

/// Eq. 14 by nonlinear least squares on Φ itself (Gauss-Newton on the one parameter α,
/// started from the linearised fit): weighs the points as the figure shows them.
pub fn eq14_nls(x: &[f64], phi: &[f64], phi0: f64) -> Option<Fit> {
    let mut alpha = eq14(x, phi, phi0)?.value;
    for _ in 0..100 {
        // residual r = Φ − Φ̂, dΦ̂/dα = (1 − Φ0) x exp(−α x)
        let (mut jr, mut jj) = (0.0, 0.0);
        for (&x, &p) in x.iter().zip(phi) {
            let j = (1.0 - phi0) * x * (-alpha * x).exp();
            jr += j * (p - eq14_phi(alpha, phi0, x));
            jj += j * j;
        }
        if jj <= 0.0 {
            return None;
        }
        let step = jr / jj;
        alpha += step;
        if step.abs() <= 1e-12 * alpha.abs().max(1e-12) {
            break;
        }
    }
    alpha.is_finite().then(|| Fit {
        value: alpha,
        r2: r2(phi, |x| eq14_phi(alpha, phi0, x), x),
        points: x.len(),
    })
}

/// Eq. 16: Φ − Φ0 = s x, s by least squares through the origin (the line passes through
/// (0, Φ0) by definition of σ0).
pub fn eq16(x: &[f64], phi: &[f64], phi0: f64) -> Option<Fit> {
    if x.len() < 2 {
        return None;
    }
    let y: Vec<f64> = phi.iter().map(|p| p - phi0).collect();
    let slope = through_origin(x, &y)?;
    Some(Fit {
        value: slope,
        r2: r2(phi, |x| eq16_phi(slope, phi0, x), x),
        points: x.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xs() -> Vec<f64> {
        (0..40).map(|k| 0.25 * k as f64).collect()
    }

    #[test]
    fn eq14_recovers_alpha_from_exact_and_noisy_data() {
        let x = xs();
        let phi: Vec<f64> = x.iter().map(|&x| eq14_phi(0.27, 0.8, x)).collect();
        let f = eq14(&x, &phi, 0.8).unwrap();
        assert!((f.value - 0.27).abs() < 1e-12 && (f.r2 - 1.0).abs() < 1e-12);
        assert_eq!(f.points, 40);
        // a deterministic ±0.002 wiggle in Φ: α within 1%
        let noisy: Vec<f64> = phi
            .iter()
            .enumerate()
            .map(|(k, p)| p + 0.002 * (k as f64 * 1.7).sin())
            .collect();
        for f in [eq14(&x, &noisy, 0.8), eq14_nls(&x, &noisy, 0.8)] {
            let f = f.unwrap();
            assert!((f.value / 0.27 - 1.0).abs() < 0.01, "{f:?}");
            assert!(f.r2 > 0.99);
        }
        assert!(eq14(&[1.0, 2.0], &[0.9, 1.0], 0.8).is_none());
    }

    #[test]
    fn eq14_nls_is_exact_on_exact_data_and_beats_the_linearised_fit_in_phi() {
        let x = xs();
        let phi: Vec<f64> = x.iter().map(|&x| eq14_phi(0.4, 0.8, x)).collect();
        assert!((eq14_nls(&x, &phi, 0.8).unwrap().value - 0.4).abs() < 1e-9);
        // curve bent off the model: the NLS R² (in Φ) is at least the linearised one's
        let bent: Vec<f64> = x
            .iter()
            .map(|&x| eq14_phi(0.4, 0.8, x) - 0.01 * x / 10.0)
            .collect();
        let (lin, nls) = (
            eq14(&x, &bent, 0.8).unwrap(),
            eq14_nls(&x, &bent, 0.8).unwrap(),
        );
        assert!(nls.r2 >= lin.r2 - 1e-12, "{lin:?} {nls:?}");
    }

    #[test]
    fn eq16_recovers_its_slope() {
        let x = xs();
        let phi: Vec<f64> = x.iter().map(|&x| eq16_phi(0.08, 0.8, x)).collect();
        let f = eq16(&x, &phi, 0.8).unwrap();
        assert!((f.value - 0.08).abs() < 1e-12 && (f.r2 - 1.0).abs() < 1e-12);
        let noisy: Vec<f64> = phi
            .iter()
            .enumerate()
            .map(|(k, p)| p + 0.002 * (k as f64 * 2.3).cos())
            .collect();
        let f = eq16(&x, &noisy, 0.8).unwrap();
        assert!((f.value / 0.08 - 1.0).abs() < 0.01, "{f:?}");
        assert!(eq16(&[0.0, 0.0], &[0.8, 0.8], 0.8).is_none());
    }
}
