//! `report.md`: every figure the paper states beside what this run measured, the fits, and
//! the figures themselves.

use super::reference::Stated;
use super::summary::CaseSummary;
use std::fmt::Write as _;

fn num(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e4 {
        format!("{v:.0}")
    } else if v != 0.0 && (v.abs() >= 1e4 || v.abs() < 1e-3) {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

/// A summary field by its JSON name (the reference table's key).
fn measured(s: &CaseSummary, key: &str) -> Option<f64> {
    serde_json::to_value(s).ok()?.get(key)?.as_f64()
}

/// The comparison table: one row per stated figure and case it applies to; a stated figure
/// that no case of this run applies to, or that this run does not measure, says so.
pub fn comparison(refs: &[Stated], cases: &[CaseSummary]) -> String {
    let mut t = String::from(
        "| quantity | case | paper | this run | run / paper | where the paper states it |\n| --- | --- | --- | --- | --- | --- |\n",
    );
    for st in refs {
        let applies: Vec<&CaseSummary> = cases.iter().filter(|c| st.applies_to(c)).collect();
        let what = if st.unit.is_empty() {
            st.statement.clone()
        } else {
            format!("{} ({})", st.statement, st.unit)
        };
        if applies.is_empty() {
            let _ = writeln!(
                t,
                "| {what} | {} | {} | no such case in this pipeline | | {} |",
                st.case,
                num(st.value),
                st.source
            );
        }
        for c in applies {
            let (run, ratio) = match measured(c, &st.key) {
                Some(m) => (num(m), num(m / st.value)),
                None => ("not measured".into(), String::new()),
            };
            let _ = writeln!(
                t,
                "| {what} | {} | {} | {run} | {ratio} | {} |",
                c.case,
                num(st.value),
                st.source
            );
        }
    }
    t
}

/// The fits of the packing cases.
fn fits(cases: &[CaseSummary]) -> String {
    let mut t = String::from(
        "| case | law | value | R² | Φ range | points | α by nonlinear least squares (R²) | stress scale σ0/value (Pa) |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    let opt = |v: Option<f64>| v.map_or("—".to_string(), num);
    for c in cases.iter().filter(|c| c.fit.is_some()) {
        let (law, value) = match (c.alpha, c.slope) {
            (Some(a), _) => ("Eq. 14, α", a),
            (_, Some(b)) => ("Eq. 16, slope", b),
            _ => ("none (too few points)", f64::NAN),
        };
        let nls = match (c.alpha_nls, c.r2_nls) {
            (Some(a), Some(r)) => format!("{} ({})", num(a), num(r)),
            _ => "—".into(),
        };
        let _ = writeln!(
            t,
            "| {} | {law} | {} | {} | [{}, {}] | {} | {nls} | {} |",
            c.case,
            num(value),
            opt(c.r2),
            opt(c.fit_phi_min),
            opt(c.fit_phi_max),
            c.fit_points.unwrap_or(0),
            opt(c.stress_scale)
        );
    }
    t
}

/// How far the packings' grains passed into each other, and how well each step was solved.
fn soundness(cases: &[CaseSummary]) -> String {
    let mut t = String::from(
        "| case | worst overlap | deepest point pair (MPM) | points inside another grain, at most | steps whose contact forces stopped short of the tolerance |\n| --- | --- | --- | --- | --- |\n",
    );
    for c in cases.iter().filter(|c| c.kind == "packing") {
        let unit = if c.method == "bpm" { "d_min" } else { "h_g" };
        let _ = writeln!(
            t,
            "| {} | {} {unit} | {} | {}% | {} |",
            c.case,
            c.overlap_max.map_or("—".into(), num),
            c.point_overlap_max
                .map_or("—".into(), |v| format!("{} h_g", num(v))),
            c.points_inside_max.map_or("—".into(), |v| num(100.0 * v)),
            c.unconverged_steps.map_or("—".into(), |v| v.to_string())
        );
    }
    t
}

/// The BPM grains' plateau beside what sets it (README, "the plateau level"): the
/// attraction's prestress σ_c and the contact network's mobilised friction s give a
/// grain-mean vertical stress 2 σ_c s/(1 − s), all in units of F0/<a0>.
fn plateaus(cases: &[CaseSummary]) -> String {
    let mut t = String::from(
        "| case | plateau σ<a0>/F0 | prestress σ_c<a0>/F0 | mobilised friction s | 2 σ_c s/(1 − s) |\n| --- | --- | --- | --- | --- |\n",
    );
    for c in cases {
        if let (Some(p), Some(sc), Some(s)) = (c.plateau, c.plateau_prestress, c.plateau_sin_phi) {
            let _ = writeln!(
                t,
                "| {} | {} | {} | {} | {} |",
                c.case,
                num(p),
                num(sc),
                num(s),
                num(2.0 * sc * s / (1.0 - s))
            );
        }
    }
    t
}

/// The whole report. `figures` are (title, PNG file name) in drawing order.
pub fn markdown(
    pipeline: &str,
    refs: &[Stated],
    cases: &[CaseSummary],
    figures: &[(String, String)],
    notes: &[String],
) -> String {
    let mut r = format!(
        "# Analysis of `{pipeline}`\n\nCases: {}. Measures and fits as in METHODS.md §5; every number here is also in `summary.json` and `summary.parquet`, the time series in `*.parquet`.\n\n",
        cases
            .iter()
            .map(|c| format!("`{}` ({}, μ = {})", c.case, c.method, c.friction))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for n in notes {
        let _ = writeln!(r, "- {n}");
    }
    if !notes.is_empty() {
        r.push('\n');
    }
    r.push_str("## The paper's figures beside this run\n\n");
    r.push_str(&comparison(refs, cases));
    if cases.iter().any(|c| c.plateau_prestress.is_some()) {
        r.push_str("\n## BPM plateaus and what sets them\n\nThe attraction holds a grain under the prestress σ_c; its frictionless contact network yields at the mobilised friction s, so with free sides the grain-mean vertical stress is 2 σ_c s/(1 − s) (README, \"the plateau level\"; σ = F/L, over the widest section, lies below it). The paper's σ_Y = F0/<a0> is the scale, not the level.\n\n");
        r.push_str(&plateaus(cases));
    }
    if cases.iter().any(|c| c.kind == "packing") {
        r.push_str("\n## How far grains passed into each other, and the contact solver\n\nThe worst overlap is a particle pair's over the smallest particle diameter (BPM) or a contact node's point-cloud gap over the cell size (MPM). A particle or point whose centre lies inside another grain marks an overlap deeper than its radius or half-size (README, \"Measures\").\n\n");
        r.push_str(&soundness(cases));
    }
    if cases.iter().any(|c| c.fit.is_some()) {
        r.push_str("\n## Fits of Eqs. 14 and 16 (Φ against x = σ/σ0 − 1, R² of Φ)\n\n");
        r.push_str(&fits(cases));
    }
    if !figures.is_empty() {
        r.push_str("\n## Figures\n\n");
        for (title, png) in figures {
            let _ = writeln!(r, "### {title}\n\n![{title}]({png})\n");
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::reference::paper;

    #[test]
    fn the_table_sets_each_stated_figure_beside_the_measure() {
        let c = CaseSummary {
            case: "mpm-mu0".into(),
            method: "mpm".into(),
            kind: "packing".into(),
            slope: Some(0.04),
            jamming_strain: Some(0.1),
            fit: Some("eq16".into()),
            r2: Some(0.99),
            ..Default::default()
        };
        let t = comparison(&paper(), std::slice::from_ref(&c));
        // the slope is half the paper's, its row says so
        assert!(
            t.lines()
                .any(|l| l.contains("beta/K_g") && l.contains("| 0.0400 | 0.5000 |")),
            "{t}"
        );
        assert!(
            t.lines()
                .any(|l| l.contains("jamming at eps") && l.contains("| 1.2500 |"))
        );
        assert!(t.contains("no such case in this pipeline"));
        assert!(
            t.lines()
                .any(|l| l.contains("Z about 3") && l.contains("not measured"))
        );
        let md = markdown(
            "x",
            &paper(),
            &[c],
            &[("Fig. 11".into(), "fig11.png".into())],
            &[],
        );
        assert!(md.contains("![Fig. 11](fig11.png)") && md.contains("Eq. 16, slope"));
        assert!(!md.contains("BPM plateaus"));
    }

    #[test]
    fn each_packing_says_how_far_its_grains_passed_into_each_other() {
        let packing = |case: &str, method: &str, overlap, inside, short| CaseSummary {
            case: case.into(),
            method: method.into(),
            kind: "packing".into(),
            overlap_max: Some(overlap),
            points_inside_max: Some(inside),
            unconverged_steps: Some(short),
            ..Default::default()
        };
        let grain = CaseSummary {
            case: "mpm".into(),
            kind: "single_grain".into(),
            ..Default::default()
        };
        let cases = [
            packing("bpm-mu0", "bpm", 2e-4, 0.0, 0),
            CaseSummary {
                point_overlap_max: Some(0.125),
                ..packing("mpm-mu0.5", "mpm", 1.25, 0.028, 3)
            },
            grain,
        ];
        let md = markdown("x", &paper(), &cases, &[], &[]);
        assert!(
            md.contains("| bpm-mu0 | 2.000e-4 d_min | — | 0% | 0 |"),
            "{md}"
        );
        assert!(
            md.contains("| mpm-mu0.5 | 1.2500 h_g | 0.1250 h_g | 2.8000% | 3 |"),
            "{md}"
        );
        // single grains have no grain pairs: no row
        assert_eq!(soundness(&cases).lines().count(), 4);
        assert!(!markdown("x", &paper(), &cases[2..], &[], &[]).contains("passed into each other"));
    }

    #[test]
    fn a_bpm_grain_gets_its_plateau_beside_the_prestress_prediction() {
        let c = CaseSummary {
            case: "bpm-mu0".into(),
            method: "bpm".into(),
            kind: "single_grain".into(),
            plateau: Some(0.2),
            plateau_prestress: Some(1.3),
            plateau_sin_phi: Some(0.08),
            ..Default::default()
        };
        let md = markdown("x", &paper(), &[c], &[], &[]);
        // 2 · 1.3 · 0.08 / 0.92 = 0.2261
        assert!(
            md.lines()
                .any(|l| l == "| bpm-mu0 | 0.2000 | 1.3000 | 0.0800 | 0.2261 |"),
            "{md}"
        );
    }
}
