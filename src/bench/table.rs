//! The work-precision table: one row per setting, the error each knob is judged by, the
//! Pareto-best settings of each family, and the CSV.

use super::{Outcome, Setting, mpm, skips};

/// One row of `work_precision.csv`.
pub struct Row {
    pub family: &'static str,
    pub knob: &'static str,
    pub value: String,
    pub wall_s: f64,
    /// The knob's error (dimensionless); `None` for the reference run or a failed one.
    pub error: Option<f64>,
    pub error_kind: &'static str,
    /// No other setting of the family is both faster and more accurate.
    pub pareto: bool,
    pub outcome: Outcome,
    /// MPM: RMS force-curve difference to the finest run of the knob, over its RMS;
    /// compaction: the same for σ(ε).
    pub rms_vs_finest: Option<f64>,
    /// Compaction: the same for Φ(ε).
    pub phi_rms_vs_finest: Option<f64>,
}

/// Builds the rows. MPM resolution and shape are judged against Johnson's solution (the
/// larger of |F/F_J - 1| at ε = 0.02 and 0.05); MPM time step and Newton tolerance against
/// the finest value of the knob (force-curve RMS); CD settings by the worst of the floor
/// balance, the max overlap over <r> and the incline acceleration error; BPM settings by
/// the plateau against the knob's finest value; compaction settings by the larger of the
/// σ(ε) (means over ten strain windows) and Φ(ε) RMS differences to the knob's finest value.
pub fn rows(settings: &[Setting], outcomes: Vec<Outcome>) -> Vec<Row> {
    let finest = |family: &str, knob: &str| {
        (settings.iter().zip(&outcomes))
            .filter(|(s, o)| s.knob == knob && s.family == family && o.failure.is_none())
            .filter_map(|(s, o)| Some((s.number?, o)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(x, o)| (x, o.curve.clone(), o.phi_curve.clone()))
    };
    // BPM: the plateau of the knob's finest (smallest) value
    let plateau_ref = |knob: &str| {
        (settings.iter().zip(&outcomes))
            .filter(|(s, _)| s.knob == knob && s.family == "bpm")
            .filter_map(|(s, o)| Some((s.number?, o.plateau?)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    let mut rows: Vec<Row> = (settings.iter().zip(outcomes.iter()))
        .map(|(s, o)| {
            let reference = finest(s.family, s.knob);
            let compared = o.failure.is_none() && matches!(s.family, "mpm" | "compaction");
            let (rms, phi_rms) = match (&reference, compared) {
                (Some((x, curve, phi)), true) if s.number != Some(*x) => {
                    if s.family == "compaction" {
                        // σ of single steps jumps by tens of percent: compared on the
                        // means of ten strain windows; Φ is smooth
                        (
                            Some(skips::windowed_difference(&o.curve, curve, 10)),
                            Some(mpm::rms_difference(&o.phi_curve, phi)),
                        )
                    } else {
                        (Some(mpm::rms_difference(&o.curve, curve)), None)
                    }
                }
                _ => (None, None),
            };
            let (error, kind) = match (s.family, s.knob) {
                ("mpm", "resolution" | "shape") => {
                    (o.johnson.map(|[a, b]| a.abs().max(b.abs())), "johnson")
                }
                ("mpm", _) if rms.is_none() && o.failure.is_none() => (None, "reference"),
                ("mpm", _) => (rms, "rms_vs_finest"),
                ("compaction", _) if rms.is_none() && o.failure.is_none() => (None, "reference"),
                ("compaction", _) => (
                    rms.zip(phi_rms).map(|(a, b)| a.max(b)),
                    "sigma_or_phi_rms_vs_finest",
                ),
                ("bpm", knob) => match (plateau_ref(knob), o.plateau) {
                    (Some((x, _)), Some(_)) if s.number == Some(x) => (None, "reference"),
                    (Some((_, r)), Some(p)) => (Some((p / r - 1.0).abs()), "plateau_vs_finest"),
                    _ => (None, "plateau_vs_finest"),
                },
                _ => (
                    match (o.floor_balance, o.max_overlap, o.incline) {
                        (Some(a), Some(b), Some(c)) => Some(a.max(b).max(c)),
                        _ => None,
                    },
                    "worst_of_floor_overlap_incline",
                ),
            };
            Row {
                family: s.family,
                knob: s.knob,
                value: s.value.clone(),
                wall_s: o.wall_s,
                error: error.filter(|e| e.is_finite()),
                error_kind: kind,
                pareto: false,
                outcome: o.clone(),
                rms_vs_finest: rms,
                phi_rms_vs_finest: phi_rms,
            }
        })
        .collect();
    mark_pareto(&mut rows);
    rows
}

/// A row is Pareto-best when no other value of its knob (same family, same error measure)
/// is at least as fast and as accurate and strictly better in one of the two.
fn mark_pareto(rows: &mut [Row]) {
    let flags: Vec<bool> = rows
        .iter()
        .map(|r| {
            let Some(e) = r.error else { return false };
            !rows.iter().any(|o| {
                o.family == r.family
                    && o.knob == r.knob
                    && o.error.is_some_and(|oe| {
                        oe <= e && o.wall_s <= r.wall_s && (oe < e || o.wall_s < r.wall_s)
                    })
            })
        })
        .collect();
    for (r, f) in rows.iter_mut().zip(flags) {
        r.pareto = f;
    }
}

pub const HEADER: &str = "family,knob,value,wall_s,error,error_kind,peak_rss_mb,pareto,johnson_0.02,johnson_0.05,rms_vs_finest,phi_rms_vs_finest,floor_balance,max_overlap,incline,plateau,failure";

pub fn csv(rows: &[Row]) -> String {
    let opt = |x: Option<f64>| x.map(|v| format!("{v:.6e}")).unwrap_or_default();
    let mut out = format!("{HEADER}\n");
    for r in rows {
        let o = &r.outcome;
        let failure = o
            .failure
            .as_deref()
            .unwrap_or("")
            .replace([',', '\n', '"'], " ");
        out += &format!(
            "{},{},{},{:.6},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.family,
            r.knob,
            r.value,
            r.wall_s,
            opt(r.error),
            r.error_kind,
            o.peak_rss_mb.map(|m| format!("{m:.1}")).unwrap_or_default(),
            r.pareto,
            opt(o.johnson.map(|j| j[0])),
            opt(o.johnson.map(|j| j[1])),
            opt(r.rms_vs_finest),
            opt(r.phi_rms_vs_finest),
            opt(o.floor_balance),
            opt(o.max_overlap),
            opt(o.incline),
            opt(o.plateau),
            failure
        );
    }
    out
}

/// `mpm_stability.csv`.
pub fn stability_csv(runs: &[mpm::StabilityRun]) -> String {
    let mut out = String::from(
        "resolution,young,poisson,travel_per_step,dt_s,dt_over_cfl,completed,halvings,newton_per_step,rms_vs_smallest_step,wall_s,largest_accurate,failure\n",
    );
    for r in runs {
        out += &format!(
            "{},{:e},{},{},{:.6e},{:.4},{},{},{:.2},{:.6e},{:.4},{},{}\n",
            r.resolution,
            r.young,
            r.poisson,
            r.travel_per_step,
            r.dt,
            r.dt_over_cfl,
            r.failure.is_none(),
            r.halvings,
            r.newton_per_step,
            r.error,
            r.wall_s,
            r.largest_accurate,
            r.failure
                .as_deref()
                .unwrap_or("")
                .replace([',', '\n', '"'], " ")
        );
    }
    out
}

/// `bpm_stability.csv`.
pub fn bpm_stability_csv(runs: &[super::bpm::StabilityRun]) -> String {
    let mut out = String::from(
        "d_min,d_max,f0,wall_velocity,time_step_t0,dt_s,completed,escaped,area_change,stable,largest_stable,force_vs_smallest_step,wall_s,failure\n",
    );
    for r in runs {
        out += &format!(
            "{:e},{:e},{},{},{},{:.6e},{},{},{:.4e},{},{},{:.4e},{:.4},{}\n",
            r.particle_diameter[0],
            r.particle_diameter[1],
            r.f0,
            r.wall_velocity,
            r.time_step,
            r.dt,
            r.failure.is_none(),
            r.escaped,
            r.area_change,
            r.stable,
            r.largest_stable,
            r.error,
            r.wall_s,
            r.failure
                .as_deref()
                .unwrap_or("")
                .replace([',', '\n', '"'], " ")
        );
    }
    out
}
