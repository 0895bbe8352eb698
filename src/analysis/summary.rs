//! The measured figures of one case (a row of `summary.json` and `summary.parquet`), each
//! from that case's Polars frame.

use super::{fits, measures};
use crate::config::Analyse;
use polars::prelude::*;
use serde::Serialize;

/// One case's figures; a field a case does not have is left out of the JSON (null in the
/// parquet table). Stresses in Pa (N/m per unit thickness), forces in N/m.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct CaseSummary {
    pub case: String,
    pub method: String,
    pub friction: f64,
    /// `packing` or `single_grain`.
    pub kind: String,
    // ---- packings ----
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phi_initial: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phi_final: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z_final: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z_star_final: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strain_final: Option<f64>,
    /// The floor's σ over the last `analyse.final_window` of strain (`measures::end_mean`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_final: Option<f64>,
    /// Φ at ε = 0.45 (Fig. 8c), interpolated.
    #[serde(rename = "phi_at_strain_0.45", skip_serializing_if = "Option::is_none")]
    pub phi_at_strain_045: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jamming_strain: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jamming_phi: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jamming_z: Option<f64>,
    /// σ0 = σ(Φ = Φ0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma0: Option<f64>,
    /// ε where Φ = Φ0 (Fig. 8b), the origin of ε'.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strain_at_phi0: Option<f64>,
    /// `eq14` (BPM) or `eq16` (MPM), with its Φ range and point count.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fit: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fit_phi_min: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fit_phi_max: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fit_points: Option<usize>,
    /// Eq. 14's α, linearised least squares, and its R² in Φ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
    /// Eq. 16's slope β/K_g.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slope: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub r2: Option<f64>,
    /// Eq. 14's α by nonlinear least squares on Φ, and its R².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha_nls: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub r2_nls: Option<f64>,
    /// The fit's stress scale (Pa): σ0/α for Eq. 14, where dΦ/dσ = (1 − Φ)/(σ0/α), and
    /// σ0/slope for Eq. 16, where dΦ/dσ = slope/σ0. α and the slope are proportional to σ0,
    /// which the packing reaches on the steep rise at jamming when Φ = Φ0 comes early; the
    /// ratio is set by the data above Φ0 and barely moves with σ0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stress_scale: Option<f64>,
    /// The worst interpenetration of the run (BPM: particle overlap over d_min; MPM: node
    /// gap over h_g), the largest share of particles or points whose centre lay inside
    /// another grain, and the steps whose contact forces stopped short of the tolerance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overlap_max: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points_inside_max: Option<f64>,
    /// MPM: the deepest overlap of two points of different grains over h_g.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point_overlap_max: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unconverged_steps: Option<u64>,
    // ---- single grains ----
    /// dσ/dε through the origin on 0 < ε <= `analyse.small_strain` (Pa).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub small_strain_slope: Option<f64>,
    /// MPM: dF/dε on the same range over Eq. 13's (π/4) E/(1−ν²) R.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eq13_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eq13_slope: Option<f64>,
    /// MPM: F/F_Eq.13 at ε = 0.02 and 0.05 (interpolated).
    #[serde(
        rename = "force_over_eq13_at_0.02",
        skip_serializing_if = "Option::is_none"
    )]
    pub force_over_eq13_002: Option<f64>,
    #[serde(
        rename = "force_over_eq13_at_0.05",
        skip_serializing_if = "Option::is_none"
    )]
    pub force_over_eq13_005: Option<f64>,
    /// BPM: mean σ<a0>/F0 over `analyse.plateau_strain`, and the mean σ itself (Pa).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plateau: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plateau_stress: Option<f64>,
    /// BPM, over the same strains: the cohesive prestress σ_c <a0>/F0 and the contact
    /// network's mobilised friction s; the plateau is close to 2 σ_c s/(1 − s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plateau_prestress: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plateau_sin_phi: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub particles: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_a0: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub f0: Option<f64>,
}

fn base(df: &DataFrame, kind: &str) -> PolarsResult<CaseSummary> {
    let text = |name: &str| -> PolarsResult<String> {
        Ok(df
            .column(name)?
            .str()?
            .get(0)
            .unwrap_or_default()
            .to_string())
    };
    Ok(CaseSummary {
        case: text("case")?,
        method: text("method")?,
        friction: df.column("friction")?.f64()?.get(0).unwrap_or(0.0),
        kind: kind.into(),
        ..Default::default()
    })
}

/// A packing: final state, jamming, σ0 and the Eq. 14 (BPM) or Eq. 16 (MPM) fit. Returns
/// the frame with `sigma_over_sigma0` and `strain_prime` added.
pub fn packing(df: &DataFrame, a: &Analyse) -> PolarsResult<(CaseSummary, DataFrame)> {
    let mut s = base(df, "packing")?;
    let first = df.clone().lazy().select([col("phi").first()]).collect()?;
    s.phi_initial = first.column("phi")?.f64()?.get(0);
    s.phi_final = measures::last(df, "phi")?;
    s.z_final = measures::last(df, "z")?;
    s.z_star_final = measures::last(df, "z_star")?;
    s.strain_final = measures::last(df, "strain")?;
    s.sigma_final = measures::end_mean(df, "strain", "sigma", a.final_window)?;
    s.phi_at_strain_045 = measures::crossing(df, "strain", "phi", 0.45)?;
    s.overlap_max = measures::max(df, "overlap")?;
    s.points_inside_max = measures::max(df, "points_inside")?;
    if s.method == "mpm" {
        s.point_overlap_max = measures::max(df, "point_overlap")?;
    }
    // a count: the rows' counts summed (the frame holds them as f64, `series::packing`)
    s.unconverged_steps = measures::sum(df, "unconverged")?.map(|n| n.round() as u64);
    if let Some(j) = measures::jamming(df, a.jamming_fraction)? {
        s.jamming_strain = Some(j.strain);
        s.jamming_phi = Some(j.phi);
        s.jamming_z = Some(j.z);
    }
    let at = measures::consolidation(df, a.phi0)?;
    let out = measures::with_consolidation(df, at)?;
    if let Some((sigma0, strain0)) = at {
        s.sigma0 = Some(sigma0);
        s.strain_at_phi0 = Some(strain0);
        let bpm = s.method == "bpm";
        let range = if bpm { a.eq14_phi } else { a.eq16_phi };
        let [x, phi] = measures::fit_points(df, sigma0, range)?;
        s.fit = Some(if bpm { "eq14" } else { "eq16" }.into());
        s.fit_phi_min = Some(range[0]);
        s.fit_phi_max = Some(range[1]);
        s.fit_points = Some(x.len());
        if bpm {
            let f = fits::eq14(&x, &phi, a.phi0);
            s.alpha = f.map(|f| f.value);
            s.r2 = f.map(|f| f.r2);
            let n = fits::eq14_nls(&x, &phi, a.phi0);
            s.alpha_nls = n.map(|f| f.value);
            s.r2_nls = n.map(|f| f.r2);
        } else {
            let f = fits::eq16(&x, &phi, a.phi0);
            s.slope = f.map(|f| f.value);
            s.r2 = f.map(|f| f.r2);
        }
        // a fit that makes Φ fall as σ rises has no stress scale
        s.stress_scale = s.alpha.or(s.slope).filter(|k| *k > 0.0).map(|k| sigma0 / k);
    }
    Ok((s, out))
}

/// A single BPM grain: the small-strain slope and the plateau σ<a0>/F0.
pub fn single_bpm(
    df: &DataFrame,
    a: &Analyse,
    mean_a0: f64,
    f0: f64,
    particles: usize,
) -> PolarsResult<CaseSummary> {
    let mut s = base(df, "single_grain")?;
    s.small_strain_slope = measures::slope_through_origin(df, "strain", "sigma", a.small_strain)?;
    s.plateau_stress = measures::mean_within(df, "strain", "sigma", a.plateau_strain)?;
    s.plateau = s.plateau_stress.map(|p| p * mean_a0 / f0);
    s.plateau_prestress =
        measures::mean_within(df, "strain", "sigma_c", a.plateau_strain)?.map(|p| p * mean_a0 / f0);
    s.plateau_sin_phi = measures::mean_within(df, "strain", "sin_phi", a.plateau_strain)?;
    s.particles = Some(particles);
    s.mean_a0 = Some(mean_a0);
    s.f0 = Some(f0);
    Ok(s)
}

/// A single MPM grain against Eq. 13, F = k ε with k = (π/4) E/(1−ν²) R.
pub fn single_mpm(df: &DataFrame, a: &Analyse, eq13_slope: f64) -> PolarsResult<CaseSummary> {
    let mut s = base(df, "single_grain")?;
    s.small_strain_slope = measures::slope_through_origin(df, "strain", "sigma", a.small_strain)?;
    let force_slope = measures::slope_through_origin(df, "strain", "force", a.small_strain)?;
    s.eq13_slope = Some(eq13_slope);
    s.eq13_ratio = force_slope.map(|k| k / eq13_slope);
    let at = |e: f64| -> PolarsResult<Option<f64>> {
        Ok(measures::crossing(df, "strain", "force", e)?.map(|f| f / (eq13_slope * e)))
    };
    s.force_over_eq13_002 = at(0.02)?;
    s.force_over_eq13_005 = at(0.05)?;
    Ok(s)
}

/// The summaries as one table, a column per field (null where a case has none).
pub fn table(all: &[CaseSummary]) -> PolarsResult<DataFrame> {
    let rows: Vec<serde_json::Map<String, serde_json::Value>> = all
        .iter()
        .map(|s| match serde_json::to_value(s) {
            Ok(serde_json::Value::Object(m)) => m,
            _ => Default::default(),
        })
        .collect();
    // every key in first-seen order
    let mut keys: Vec<String> = Vec::new();
    for r in &rows {
        for k in r.keys() {
            if !keys.contains(k) {
                keys.push(k.clone());
            }
        }
    }
    let columns = keys
        .iter()
        .map(|k| {
            let vals: Vec<Option<&serde_json::Value>> = rows.iter().map(|r| r.get(k)).collect();
            if vals.iter().flatten().all(|v| v.is_string()) {
                let v: Vec<Option<&str>> =
                    vals.iter().map(|v| v.and_then(|v| v.as_str())).collect();
                Column::new(k.as_str().into(), v)
            } else {
                let v: Vec<Option<f64>> = vals.iter().map(|v| v.and_then(|v| v.as_f64())).collect();
                Column::new(k.as_str().into(), v)
            }
        })
        .collect();
    DataFrame::new_infer_height(columns)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_synthetic_bpm_packing_gives_back_its_alpha() {
        // Φ(ε) rising linearly, σ built so that Eq. 14 holds exactly above Φ0 = 0.8 with
        // α = 0.27 and σ0 = 1000 Pa; below Φ0, σ small and rising from jamming at ε = 0.1
        let strain: Vec<f64> = (0..=90).map(|k| 0.005 * k as f64).collect();
        let phi: Vec<f64> = strain.iter().map(|e| 0.65 + 0.75 * e).collect();
        let sigma: Vec<f64> = phi
            .iter()
            .zip(&strain)
            .map(|(&p, &e)| {
                if p >= 0.8 {
                    1000.0 * (1.0 - ((1.0 - p) / 0.2).ln() / 0.27)
                } else {
                    (1000.0 * (e - 0.1) / 0.1).max(0.0)
                }
            })
            .collect();
        let n = strain.len();
        let df = df!(
            "case" => vec!["bpm-mu0"; n], "method" => vec!["bpm"; n], "friction" => vec![0.0; n],
            "strain" => strain, "phi" => phi, "z" => vec![4.0; n], "z_star" => vec![4.0; n],
            "sigma" => sigma,
            "overlap" => (0..n).map(|k| k as f64 / 1e5).collect::<Vec<f64>>(),
            "points_inside" => vec![0.0; n],
            "unconverged" => (0..n).map(|k| f64::from(k % 30 == 0)).collect::<Vec<f64>>(),
        )
        .unwrap();
        let (s, out) = packing(&df, &Analyse::default()).unwrap();
        // the worst overlap is the last row's, and rows 0, 30, 60 and 90 stopped short
        assert_eq!(s.overlap_max, Some(9e-4));
        assert_eq!(s.points_inside_max, Some(0.0));
        assert_eq!(s.unconverged_steps, Some(4));
        assert!((s.sigma0.unwrap() - 1000.0).abs() < 1e-6, "{s:?}");
        assert!((s.strain_at_phi0.unwrap() - 0.2).abs() < 1e-9);
        assert!((s.alpha.unwrap() / 0.27 - 1.0).abs() < 1e-9);
        assert!((s.alpha_nls.unwrap() / 0.27 - 1.0).abs() < 1e-9);
        assert!((s.stress_scale.unwrap() / (1000.0 / 0.27) - 1.0).abs() < 1e-9);
        assert!(s.slope.is_none() && s.r2.unwrap() > 0.999_999);
        assert!((s.phi_initial.unwrap() - 0.65).abs() < 1e-12);
        // σ over the last 0.01 of strain: the two rows from ε = 0.44, taken over their spans
        let sig = |e: f64| 1000.0 * (1.0 - ((0.35 - 0.75 * e) / 0.2).ln() / 0.27);
        let final_mean = (sig(0.445) + sig(0.45)) / 2.0;
        assert!((s.sigma_final.unwrap() / final_mean - 1.0).abs() < 1e-12);
        // Φ up to 0.98 only: 0.8 + 0.75 k 0.005 <= 0.98 -> 49 points
        assert_eq!(s.fit_points, Some(49));
        assert!(out.column("strain_prime").is_ok());
        let t = table(&[
            s.clone(),
            CaseSummary {
                case: "x".into(),
                ..Default::default()
            },
        ])
        .unwrap();
        assert_eq!(t.height(), 2);
        assert_eq!(t.column("alpha").unwrap().null_count(), 1);
        let j = serde_json::to_value(&s).unwrap();
        assert!(j.get("slope").is_none() && j["alpha"].as_f64().is_some());
    }
}
