//! Which figures of the paper this run can draw, built from the cases' frames: Figs. 6, 7
//! for single grains; Figs. 9a, 9b, 10, 11 for packings. The paper's stated values are
//! marked where it gives them (`reference.rs`).

use super::fits;
use super::plots::{Chart, Curve, Line, Mark};
use super::reference::{Stated, lookup};
use super::series::values;
use super::summary::CaseSummary;
use polars::prelude::*;

/// A case's summary and its time series.
pub type Case = (CaseSummary, DataFrame);

fn xy(df: &DataFrame, x: &str, y: &str, scale: f64) -> PolarsResult<Vec<(f64, f64)>> {
    Ok(values(df, x)?
        .into_iter()
        .zip(values(df, y)?)
        .map(|(x, y)| (x, y * scale))
        .collect())
}

fn solid(k: usize, label: &str, points: Vec<(f64, f64)>) -> Curve {
    Curve {
        label: label.into(),
        points,
        line: Line::Solid,
        color: Some(k),
    }
}

/// A horizontal dashed line at a stated value over [x0, x1].
fn stated_level(s: &Stated, label: String, y: f64, x: (f64, f64)) -> Curve {
    Curve {
        label: format!("{label} ({})", s.source),
        points: vec![(x.0, y), (x.1, y)],
        line: Line::Dashed,
        color: None,
    }
}

fn strain_span(cases: &[&Case]) -> PolarsResult<(f64, f64)> {
    let mut hi: f64 = 0.0;
    for (_, df) in cases {
        hi = values(df, "strain")?.into_iter().fold(hi, f64::max);
    }
    Ok((0.0, hi))
}

/// Fig. 6: σ against ε for every single grain; MPM with Eq. 13 as σ = k ε / L, BPM with
/// the paper's 0.5 MPa plateau.
pub fn fig6(singles: &[Case], refs: &[Stated]) -> PolarsResult<Option<Chart>> {
    if singles.is_empty() {
        return Ok(None);
    }
    let mut curves = Vec::new();
    for (k, (s, df)) in singles.iter().enumerate() {
        curves.push(solid(k, &s.case, xy(df, "strain", "sigma", 1e-6)?));
        if let Some(k13) = s.eq13_slope {
            let eq13 = values(df, "strain")?
                .into_iter()
                .zip(values(df, "width")?)
                .filter(|(e, _)| *e <= 0.1)
                .map(|(e, w)| (e, k13 * e / w * 1e-6))
                .collect();
            curves.push(Curve {
                label: format!("Eq. 13, σ = (π/4) E/(1−ν²) R ε / L ({})", s.case),
                points: eq13,
                line: Line::Dashed,
                color: Some(k),
            });
        }
    }
    let all: Vec<&Case> = singles.iter().collect();
    let span = strain_span(&all)?;
    if let Some(st) = singles
        .iter()
        .find_map(|(s, _)| lookup(refs, "plateau_stress", s))
    {
        curves.push(stated_level(
            st,
            "paper: BPM plateau 0.5 MPa".into(),
            st.value * 1e-6,
            span,
        ));
    }
    Ok(Some(Chart {
        stem: "fig6_single_grain".into(),
        title: "Fig. 6: single grain between two plates".into(),
        x_label: "cumulative strain ε = ln(h0/h)".into(),
        y_label: "vertical stress σ = F/L (MPa)".into(),
        curves,
        marks: vec![],
    }))
}

/// Fig. 7: σ<a0>/F0 against ε for the BPM grains (one per particle-size range).
pub fn fig7(singles: &[Case], refs: &[Stated]) -> PolarsResult<Option<Chart>> {
    let bpm: Vec<&Case> = singles.iter().filter(|(s, _)| s.method == "bpm").collect();
    if bpm.is_empty() {
        return Ok(None);
    }
    let mut curves = Vec::new();
    for (k, (s, df)) in bpm.iter().enumerate() {
        let scale = s.mean_a0.unwrap_or(f64::NAN) / s.f0.unwrap_or(f64::NAN);
        let label = match s.particles {
            Some(n) => format!("{} ({n} particles)", s.case),
            None => s.case.clone(),
        };
        curves.push(solid(k, &label, xy(df, "strain", "sigma", scale)?));
    }
    if let Some(st) = lookup(refs, "plateau", &bpm[0].0) {
        curves.push(stated_level(
            st,
            "paper: σ_Y = F0/⟨a0⟩".into(),
            st.value,
            strain_span(&bpm)?,
        ));
    }
    Ok(Some(Chart {
        stem: "fig7_bpm_particle_sizes".into(),
        title: "Fig. 7: BPM grain, primary-particle size ranges".into(),
        x_label: "cumulative strain ε = ln(h0/h)".into(),
        y_label: "σ ⟨a0⟩ / F0".into(),
        curves,
        marks: vec![],
    }))
}

/// The paper's stated (x_key → x, y_key → y) points that apply to any of the cases.
fn marks(refs: &[Stated], cases: &[Case], points: &[(&str, f64, &str, f64, &str)]) -> Vec<Mark> {
    let applies = |key: &str| cases.iter().any(|(s, _)| lookup(refs, key, s).is_some());
    points
        .iter()
        .filter(|(kx, _, ky, _, _)| applies(kx) && applies(ky))
        .map(|(_, x, _, y, label)| Mark {
            label: label.to_string(),
            x: *x,
            y: *y,
        })
        .collect()
}

/// Figs. 9a (Z) and 9b (Φ) against ε for every packing.
pub fn fig9(packings: &[Case], refs: &[Stated]) -> PolarsResult<Vec<Chart>> {
    if packings.is_empty() {
        return Ok(vec![]);
    }
    let curves = |y: &str| -> PolarsResult<Vec<Curve>> {
        packings
            .iter()
            .enumerate()
            .map(|(k, (s, df))| Ok(solid(k, &s.case, xy(df, "strain", y, 1.0)?)))
            .collect()
    };
    let v = |key: &str| {
        refs.iter()
            .find(|s| s.key == key)
            .map_or(f64::NAN, |s| s.value)
    };
    let jam = (v("jamming_strain"), v("jamming_z"), v("jamming_phi"));
    Ok(vec![
        Chart {
            stem: "fig9a_coordination".into(),
            title: "Fig. 9a: coordination number".into(),
            x_label: "cumulative strain ε = ln(h0/h)".into(),
            y_label: "Z (grain contacts per grain)".into(),
            curves: curves("z")?,
            marks: marks(
                refs,
                packings,
                &[("jamming_strain", jam.0, "jamming_z", jam.1, "MPM jamming")],
            ),
        },
        Chart {
            stem: "fig9b_packing_fraction".into(),
            title: "Fig. 9b: packing fraction".into(),
            x_label: "cumulative strain ε = ln(h0/h)".into(),
            y_label: "packing fraction Φ".into(),
            curves: curves("phi")?,
            marks: marks(
                refs,
                packings,
                &[
                    (
                        "phi_initial",
                        0.0,
                        "phi_initial",
                        v("phi_initial"),
                        "Fig. 8a",
                    ),
                    ("jamming_strain", jam.0, "jamming_phi", jam.2, "MPM jamming"),
                    (
                        "strain_at_phi0",
                        v("strain_at_phi0"),
                        "strain_at_phi0",
                        0.8,
                        "Fig. 8b",
                    ),
                    (
                        "phi_at_strain_0.45",
                        0.45,
                        "phi_at_strain_0.45",
                        v("phi_at_strain_0.45"),
                        "Fig. 8c",
                    ),
                ],
            ),
        },
    ])
}

/// The rows from the consolidation point on (σ0 known, ε' >= 0).
fn consolidated(df: &DataFrame) -> PolarsResult<DataFrame> {
    df.clone()
        .lazy()
        .filter(col("strain_prime").gt_eq(lit(0.0)))
        .collect()
}

/// Fig. 10: σ/σ0 against ε'.
pub fn fig10(packings: &[Case]) -> PolarsResult<Option<Chart>> {
    let mut curves = Vec::new();
    for (k, (s, df)) in packings.iter().enumerate() {
        let rows = consolidated(df)?;
        if rows.height() > 0 {
            curves.push(solid(
                k,
                &s.case,
                xy(&rows, "strain_prime", "sigma_over_sigma0", 1.0)?,
            ));
        }
    }
    Ok((!curves.is_empty()).then(|| Chart {
        stem: "fig10_stress".into(),
        title: "Fig. 10: stress from the consolidation point".into(),
        x_label: "ε' = ε − ε(σ0)".into(),
        y_label: "σ / σ0".into(),
        curves,
        marks: vec![],
    }))
}

/// Fig. 11: Φ against σ/σ0 with each case's Eq. 14 or 16 fit (dotted) and the paper's
/// (dashed).
pub fn fig11(packings: &[Case], refs: &[Stated], phi0: f64) -> PolarsResult<Option<Chart>> {
    let mut curves = Vec::new();
    let mut x_max: f64 = 0.0;
    for (k, (s, df)) in packings.iter().enumerate() {
        let rows = consolidated(df)?;
        if rows.height() == 0 {
            continue;
        }
        let pts = xy(&rows, "sigma_over_sigma0", "phi", 1.0)?;
        let top = pts
            .iter()
            .map(|p| p.0)
            .filter(|x| x.is_finite())
            .fold(1.0, f64::max);
        x_max = x_max.max(top);
        curves.push(solid(k, &s.case, pts));
        let line = |label: String, f: &dyn Fn(f64) -> f64| Curve {
            label,
            points: (0..=60)
                .map(|i| 1.0 + (top - 1.0) * i as f64 / 60.0)
                .map(|x| (x, f(x - 1.0)))
                .collect(),
            line: Line::Dotted,
            color: Some(k),
        };
        if let (Some(a), Some(r2)) = (s.alpha, s.r2) {
            curves.push(line(
                format!("Eq. 14 fit α = {a:.3}, R² = {r2:.3}"),
                &|x| fits::eq14_phi(a, phi0, x),
            ));
        }
        if let (Some(b), Some(r2)) = (s.slope, s.r2) {
            curves.push(line(
                format!("Eq. 16 fit slope = {b:.3}, R² = {r2:.3}"),
                &|x| fits::eq16_phi(b, phi0, x),
            ));
        }
    }
    if curves.is_empty() {
        return Ok(None);
    }
    let paper = |key: &str| packings.iter().find_map(|(s, _)| lookup(refs, key, s));
    let grid = |f: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
        (0..=60)
            .map(|i| 1.0 + (x_max - 1.0) * i as f64 / 60.0)
            .map(|x| (x, f(x - 1.0)))
            .collect()
    };
    if let Some(st) = paper("alpha") {
        let a = st.value;
        curves.push(Curve {
            label: format!("paper Eq. 14, α = {a} ({})", st.source),
            points: grid(&|x| fits::eq14_phi(a, phi0, x)),
            line: Line::Dashed,
            color: None,
        });
    }
    if let Some(st) = paper("slope") {
        let b = st.value;
        curves.push(Curve {
            label: format!("paper Eq. 16, slope = {b} ({})", st.source),
            points: grid(&|x| fits::eq16_phi(b, phi0, x))
                .into_iter()
                .filter(|p| p.1 <= 1.0)
                .collect(),
            line: Line::Dashed,
            color: None,
        });
    }
    Ok(Some(Chart {
        stem: "fig11_phi_vs_stress".into(),
        title: "Fig. 11: packing fraction against normalised stress".into(),
        x_label: "σ / σ0".into(),
        y_label: "packing fraction Φ".into(),
        curves,
        marks: vec![],
    }))
}
