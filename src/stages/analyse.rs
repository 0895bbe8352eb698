//! The analyse stage: reads every upstream case's state (never re-simulates), measures and
//! fits them (`crate::analysis`) and writes under `DIR/<name>/analyse/`: `summary.json`,
//! `summary.parquet`, `packings.parquet` and `single_grains.parquet` (time series),
//! `report.md`, the paper's figures as PNG and SVG, and `network_<case>` pictures.

use super::StageState;
use crate::analysis::figures::{self, Case};
use crate::analysis::plots::{self, Chart, Network};
use crate::analysis::{reference, report, series, summary};
use crate::config::{Analyse, Pipeline};
use crate::mpm::analytic::plane_strain_modulus;
use crate::pipeline::{StageCtx, store};
use polars::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Version of what this stage computes from unchanged upstream states, in its node's hash:
/// bumping it redoes cached analyses (cheap) without recomputing what they read, as bumping
/// `FORMAT_VERSION` would. Version 2 adds the fits' stress scale; 3 the final σ over a
/// window (`analyse.final_window`); 4 the packings' worst overlap, points inside another
/// grain and unconverged steps (`summary::CaseSummary::overlap_max` and the report's table);
/// 5 writes the unconverged steps as a count (an integer) in `summary.json`.
pub const ANALYSIS_VERSION: u32 = 5;

/// The checkpoint payload: the summary (as `summary.json` holds it) and the files written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Analysed {
    pub summary_json: String,
    pub files: Vec<String>,
}

fn pe(e: PolarsError) -> String {
    format!("polars: {e}")
}

fn parquet(df: &mut DataFrame) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    ParquetWriter::new(&mut bytes).finish(df).map_err(pe)?;
    Ok(bytes)
}

/// The upstream cases of the stage: (case name, friction, state).
pub fn inputs<'a>(
    ctx: &StageCtx,
    upstream: &[&'a StageState],
) -> Vec<(String, f64, &'a StageState)> {
    ctx.upstream
        .iter()
        .zip(upstream)
        .map(|(n, &s)| {
            // (an upstream discretise node, a single grain not compacted, has none)
            let mu = n.friction().unwrap_or(0.0);
            (n.case.clone(), mu, s)
        })
        .collect()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), String> {
    let path = dir.join(name);
    store::write_atomic(&path, bytes).map_err(|e| format!("writing {}: {e}", path.display()))
}

/// Analyses the cases and writes every file into `dir`.
pub fn run(
    p: &Pipeline,
    a: &Analyse,
    cases: &[(String, f64, &StageState)],
    dir: &Path,
) -> Result<(Analysed, String), String> {
    let refs = reference::paper();
    let mut singles: Vec<Case> = Vec::new();
    let mut packings: Vec<Case> = Vec::new();
    let mut networks = Vec::new();
    let mut notes = Vec::new();
    for (case, mu, state) in cases {
        let (case, mu) = (case.as_str(), *mu);
        match state {
            StageState::Packing(c) => {
                let df = series::packing(case, c).map_err(pe)?;
                packings.push(summary::packing(&df, a).map_err(pe)?);
                networks.push((case.to_string(), c));
            }
            StageState::Compacted(c) => {
                let df = series::single_bpm(case, mu, c).map_err(pe)?;
                let f = &c.figures;
                let n = c.final_particles.len();
                let s = summary::single_bpm(&df, a, f.mean_a0, f.f0, n).map_err(pe)?;
                singles.push((s, df));
            }
            StageState::MpmCompacted(c) => {
                let df = series::single_mpm(case, mu, c).map_err(pe)?;
                let m = p.discretise.as_ref().and_then(|d| d.mpm.as_ref());
                let (m, r) = m
                    .zip(p.prepare.radius)
                    .ok_or("an MPM grain needs discretise.mpm and prepare.radius")?;
                // Eq. 13: F = (π/4) E/(1−ν²) R ε
                let k13 =
                    std::f64::consts::FRAC_PI_4 * plane_strain_modulus(m.young, m.poisson) * r;
                singles.push((summary::single_mpm(&df, a, k13).map_err(pe)?, df));
            }
            _ => notes.push(format!(
                "`{case}` has no compaction to analyse (run the compact stage)"
            )),
        }
    }
    let mut files = Vec::new();
    // time series
    for (name, cases) in [
        ("single_grains.parquet", &singles),
        ("packings.parquet", &packings),
    ] {
        if cases.is_empty() {
            continue;
        }
        let frames: Vec<DataFrame> = cases.iter().map(|c| c.1.clone()).collect();
        let mut all = series::stack(&frames).map_err(pe)?;
        write(dir, name, &parquet(&mut all)?)?;
        files.push(name.to_string());
    }
    // summary
    let all: Vec<summary::CaseSummary> = singles
        .iter()
        .chain(&packings)
        .map(|c| c.0.clone())
        .collect();
    let by_case: serde_json::Map<String, serde_json::Value> = all
        .iter()
        .map(|s| (s.case.clone(), serde_json::to_value(s).unwrap_or_default()))
        .collect();
    let json = serde_json::to_string_pretty(&by_case).expect("json");
    write(dir, "summary.json", json.as_bytes())?;
    files.push("summary.json".into());
    if !all.is_empty() {
        let mut t = summary::table(&all).map_err(pe)?;
        write(dir, "summary.parquet", &parquet(&mut t)?)?;
        files.push("summary.parquet".into());
    }
    // figures
    let mut charts: Vec<Chart> = Vec::new();
    charts.extend(figures::fig6(&singles, &refs).map_err(pe)?);
    charts.extend(figures::fig7(&singles, &refs).map_err(pe)?);
    charts.extend(figures::fig9(&packings, &refs).map_err(pe)?);
    charts.extend(figures::fig10(&packings).map_err(pe)?);
    charts.extend(figures::fig11(&packings, &refs, a.phi0).map_err(pe)?);
    let mut shown = Vec::new();
    for c in &charts {
        let [png, svg] = plots::chart(dir, c)?;
        shown.push((c.title.clone(), png.clone()));
        files.extend([png, svg]);
    }
    for (case, c) in networks {
        let n = Network {
            stem: format!("network_{case}"),
            title: format!(
                "Final contact forces, {case} (line width ∝ force; red: between grains)"
            ),
            width: c.geometry.width,
            height: c.geometry.height(c.rows.last().map_or(0.0, |r| r.strain)),
            particles: &c.particles,
            lines: &c.network,
        };
        let [png, svg] = plots::network(dir, &n)?;
        shown.push((n.title.clone(), png.clone()));
        files.extend([png, svg]);
    }
    let md = report::markdown(&p.name, &refs, &all, &shown, &notes);
    write(dir, "report.md", md.as_bytes())?;
    files.push("report.md".into());
    let line = format!(
        "{} single grains, {} packings, {} figures; {}",
        singles.len(),
        packings.len(),
        shown.len(),
        headline(&all)
    );
    Ok((
        Analysed {
            summary_json: json,
            files,
        },
        line,
    ))
}

/// The key figure of each case, for the run's one-line summary.
fn headline(all: &[summary::CaseSummary]) -> String {
    all.iter()
        .map(|s| {
            let v = s
                .alpha
                .map(|x| format!("α = {x:.3}"))
                .or_else(|| s.slope.map(|x| format!("slope = {x:.3}")))
                .or_else(|| s.eq13_ratio.map(|x| format!("slope/Eq. 13 = {x:.3}")))
                .or_else(|| s.plateau.map(|x| format!("plateau σ<a0>/F0 = {x:.3}")))
                .unwrap_or_else(|| "no fit".into());
            format!("{}: {v}", s.case)
        })
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compaction::{BoxGeometry, ForceLine, PackingCompacted, Particle, Row};
    use crate::config::Method;

    /// A packing whose Φ(ε) is the kinematic Φ0 e^ε (capped at 0.995) and whose σ follows
    /// Eq. 14 (BPM, α = `law`) or Eq. 16 (MPM, slope = `law`) from Φ = 0.8 on with
    /// σ0 = 1e4 Pa; before that σ rises linearly from 0 at ε = 0.1 to σ0.
    fn packing(method: Method, law: f64) -> PackingCompacted {
        let rows = (0..=100)
            .map(|k| {
                let strain = 0.005 * k as f64;
                let phi = (0.65 * f64::exp(strain)).min(0.995);
                let x = match method {
                    Method::Bpm => -((1.0 - phi) / 0.2).ln() / law,
                    Method::Mpm => (phi - 0.8) / law,
                };
                let sigma = if phi >= 0.8 {
                    1e4 * (1.0 + x)
                } else {
                    (1e4 * (strain - 0.1) / ((0.8f64 / 0.65).ln() - 0.1)).max(0.0)
                };
                Row {
                    time: strain,
                    strain,
                    phi,
                    z: 2.0 + 8.0 * strain,
                    z_star: 3.0 + 6.0 * strain,
                    sigma,
                    ..Default::default()
                }
            })
            .collect();
        let particles = (0..4)
            .map(|g| Particle {
                pos: [0.25 + 0.5 * (g % 2) as f64, 0.25 + 0.5 * (g / 2) as f64],
                size: 0.25,
                grain: g,
            })
            .collect();
        let line = |b: [f64; 2], force: f64, between_grains: bool| ForceLine {
            a: [0.25, 0.25],
            b,
            force,
            between_grains,
        };
        PackingCompacted {
            method,
            friction: 0.5,
            geometry: BoxGeometry {
                width: 1.0,
                h0: 0.5f64.exp(),
            },
            grains: 4,
            rows,
            particles,
            network: vec![
                line([0.75, 0.25], 2.0, true),
                line([0.25, 0.75], 1.0, false),
            ],
            figures: Default::default(),
        }
    }

    #[test]
    fn two_packings_give_their_fits_figures_and_report() {
        let p: Pipeline = serde_saphyr::from_str(
            "name: t\nprepare:\n  layout: packing\n  grains: 4\n  diameter: [1.0e-3, 2.0e-3]\nanalyse: {}\n",
        )
        .unwrap();
        let a = Analyse::default();
        let sb = StageState::Packing(packing(Method::Bpm, 0.27));
        let sm = StageState::Packing(packing(Method::Mpm, 0.08));
        let cases = [
            ("bpm-mu0.5".to_string(), 0.5, &sb),
            ("mpm-mu0.5".to_string(), 0.5, &sm),
        ];
        let dir = std::env::temp_dir().join(format!("softgrain-analyse-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (out, line) = run(&p, &a, &cases, &dir).unwrap();
        assert!(line.contains("2 packings"), "{line}");
        let j: serde_json::Value = serde_json::from_str(&out.summary_json).unwrap();
        let (b, m) = (&j["bpm-mu0.5"], &j["mpm-mu0.5"]);
        // Φ = 0.8 at ε = ln(0.8/0.65), interpolated between rows; σ0 = 1e4
        let e0 = (0.8f64 / 0.65).ln();
        assert!(
            (b["strain_at_phi0"].as_f64().unwrap() - e0).abs() < 1e-4,
            "{b}"
        );
        assert!(
            (b["sigma0"].as_f64().unwrap() / 1e4 - 1.0).abs() < 1e-2,
            "{b}"
        );
        // the fits within 1% (σ0 carries the interpolation error)
        for (v, want) in [
            (&b["alpha"], 0.27),
            (&b["alpha_nls"], 0.27),
            (&m["slope"], 0.08),
        ] {
            assert!((v.as_f64().unwrap() / want - 1.0).abs() < 0.01, "{b} {m}");
        }
        assert!(m["r2"].as_f64().unwrap() > 0.999 && m.get("alpha").is_none());
        // jamming: σ above 1% of its final value (BPM: 1.47e3 Pa, reached at ε = 0.116)
        let jam = b["jamming_strain"].as_f64().unwrap();
        assert!((jam - 0.12).abs() < 1e-9, "{jam}");
        assert_eq!(b["friction"], 0.5);
        assert!((b["phi_initial"].as_f64().unwrap() - 0.65).abs() < 1e-12);
        for f in [
            "summary.json",
            "summary.parquet",
            "packings.parquet",
            "report.md",
            "fig9a_coordination.png",
            "fig9b_packing_fraction.svg",
            "fig10_stress.png",
            "fig11_phi_vs_stress.png",
            "fig11_phi_vs_stress.svg",
            "network_bpm-mu0.5.png",
            "network_mpm-mu0.5.svg",
        ] {
            assert!(
                dir.join(f).exists() && out.files.iter().any(|x| x == f),
                "{f}"
            );
        }
        assert!(!dir.join("fig6_single_grain.png").exists());
        let svg = std::fs::read_to_string(dir.join("fig11_phi_vs_stress.svg")).unwrap();
        assert!(svg.contains("Eq. 14 fit") && svg.contains("paper Eq. 16"));
        let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
        assert!(
            report.contains("up to Phi about 0.98 | bpm-mu0.5 | 0.2700 |"),
            "{report}"
        );
        assert!(report.contains("![Fig. 11"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
