//! Log-log plots of the bench: time against error per family (one colour per knob, each
//! point labelled with its value, a line through the knob's Pareto-best values), and the MPM
//! stability map. Text is drawn with DejaVu Sans compiled into the binary (plotters'
//! `ab_glyph` backend), so no system font is needed.

use super::mpm::StabilityRun;
use super::table::Row;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;

type Fallible = Result<(), Box<dyn std::error::Error>>;

const FONT: &str = "sans-serif";

const PALETTE: [RGBColor; 9] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(23, 190, 207),
];

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // DejaVu Sans is a valid TrueType file: registration cannot fail
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

/// A log axis range around the positive values, padded by a factor 1.5 each side.
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        return 0.1..10.0;
    }
    lo / 1.5..hi * 1.5
}

/// A tick label with at most 3 significant digits (plotters prints log ticks in full, e.g.
/// 0.30000000000000004); powers of ten outside [1e-3, 1e4) as 1e-5.
fn tick(v: &f64) -> String {
    let v = *v;
    if v == 0.0 || !(1e-3..1e4).contains(&v.abs()) {
        return format!("{v:.0e}");
    }
    let decimals = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let t = format!("{v:.decimals$}");
    if t.contains('.') {
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        t
    }
}

/// `work_precision_<family>.png`: wall time per run against error.
pub fn work_precision(path: &Path, family: &str, rows: &[&Row]) -> Result<(), String> {
    draw_work_precision(path, family, rows).map_err(|e| format!("{}: {e}", path.display()))
}

fn draw_work_precision(path: &Path, family: &str, rows: &[&Row]) -> Fallible {
    register_font();
    let pts: Vec<(&Row, f64)> = rows
        .iter()
        .filter_map(|r| Some((*r, r.error.filter(|e| *e > 0.0)?)))
        .collect();
    let root = BitMapBackend::new(path, (960, 680)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut kinds: Vec<&str> = Vec::new();
    for (r, _) in &pts {
        if !kinds.contains(&r.error_kind) {
            kinds.push(r.error_kind);
        }
    }
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{family}: work against precision (median of repeats)"),
            (FONT, 22),
        )
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(
            log_range(pts.iter().map(|p| p.0.wall_s)).log_scale(),
            log_range(pts.iter().map(|p| p.1)).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("wall time per run (s)")
        .y_desc(format!("error ({})", kinds.join(", ")))
        .label_style((FONT, 14))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    let mut knobs: Vec<&str> = rows.iter().map(|r| r.knob).collect();
    knobs.dedup();
    for (k, knob) in knobs.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let mine: Vec<(f64, f64, String)> = pts
            .iter()
            .filter(|(r, _)| r.knob == *knob)
            .map(|(r, e)| (r.wall_s, *e, r.value.clone()))
            .collect();
        chart
            .draw_series(
                mine.iter()
                    .map(|(x, y, _)| Circle::new((*x, *y), 5, color.filled())),
            )?
            .label(*knob)
            .legend(move |(x, y)| Circle::new((x, y), 5, color.filled()));
        chart.draw_series(mine.iter().map(|(x, y, v)| {
            Text::new(
                format!(" {v}"),
                (*x, *y),
                (FONT, 13).into_font().color(&color),
            )
        }))?;
        // the knob's Pareto front
        let mut front: Vec<(f64, f64)> = pts
            .iter()
            .filter(|(r, _)| r.knob == *knob && r.pareto)
            .map(|(r, e)| (r.wall_s, *e))
            .collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart.draw_series(LineSeries::new(front, color.stroke_width(1)))?;
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}

/// `mpm_stability.png`: the largest accurate time step against resolution, one line per
/// material.
pub fn stability(path: &Path, runs: &[StabilityRun]) -> Result<(), String> {
    draw_stability(path, runs).map_err(|e| format!("{}: {e}", path.display()))
}

fn draw_stability(path: &Path, runs: &[StabilityRun]) -> Fallible {
    register_font();
    let best: Vec<&StabilityRun> = runs.iter().filter(|r| r.largest_accurate).collect();
    let root = BitMapBackend::new(path, (960, 680)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "MPM: largest step with a force curve within accuracy of the smallest step's",
            (FONT, 22),
        )
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(
            log_range(runs.iter().map(|r| r.resolution)).log_scale(),
            log_range(runs.iter().map(|r| r.dt)).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("resolution Δr/R")
        .y_desc("largest accurate Δt (s)")
        .label_style((FONT, 14))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    let mut materials: Vec<(f64, f64)> = runs.iter().map(|r| (r.young, r.poisson)).collect();
    materials.dedup();
    materials.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    materials.dedup();
    for (k, (e, nu)) in materials.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let mut line: Vec<(f64, f64)> = best
            .iter()
            .filter(|r| r.young == *e && r.poisson == *nu)
            .map(|r| (r.resolution, r.dt))
            .collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))?
            .label(format!("E = {e:.0e} Pa, ν = {nu}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        chart.draw_series(line.iter().map(|p| Circle::new(*p, 4, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()?;
    root.present()?;
    Ok(())
}

/// `bpm_stability.png`: each run as a point, time step (units of t0) against plate speed,
/// filled where stable, one colour per particle size and F0.
pub fn bpm_stability(path: &Path, runs: &[super::bpm::StabilityRun]) -> Result<(), String> {
    draw_bpm_stability(path, runs).map_err(|e| format!("{}: {e}", path.display()))
}

fn draw_bpm_stability(path: &Path, runs: &[super::bpm::StabilityRun]) -> Fallible {
    register_font();
    let root = BitMapBackend::new(path, (960, 680)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "BPM grain: stable (filled) and failed or lossy (open) runs",
            (FONT, 22),
        )
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(
            log_range(runs.iter().map(|r| r.wall_velocity)).log_scale(),
            log_range(runs.iter().map(|r| r.time_step)).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("plate speed (m/s)")
        .y_desc("time step / t0")
        .label_style((FONT, 14))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    let mut groups: Vec<([f64; 2], f64)> =
        runs.iter().map(|r| (r.particle_diameter, r.f0)).collect();
    groups.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    groups.dedup();
    let n = groups.len().max(1) as f64;
    for (k, (d, f0)) in groups.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        // side by side within a speed, so that the groups do not hide each other
        let shift = 1.0 + 0.25 * (k as f64 - 0.5 * (n - 1.0)) / n;
        let mine: Vec<&super::bpm::StabilityRun> = runs
            .iter()
            .filter(|r| r.particle_diameter == *d && r.f0 == *f0)
            .collect();
        chart
            .draw_series(mine.iter().map(|r| {
                let style = if r.stable {
                    color.filled()
                } else {
                    color.stroke_width(2)
                };
                Circle::new((r.wall_velocity * shift, r.time_step), 6, style)
            }))?
            .label(format!(
                "d = {:.2}-{:.2} mm, F0 = {f0} N/m",
                d[0] * 1e3,
                d[1] * 1e3
            ))
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}
