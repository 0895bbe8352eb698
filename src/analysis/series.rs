//! The recorded time series of every case as Polars frames, read from the compact stages'
//! checkpoints (never re-simulated). One schema per kind, so cases stack into one table.

use crate::compaction::PackingCompacted;
use crate::config::Method;
use crate::stages::compact::Compacted;
use crate::stages::mpm_single::MpmCompacted;
use polars::prelude::*;

pub fn method_name(m: Method) -> &'static str {
    match m {
        Method::Bpm => "bpm",
        Method::Mpm => "mpm",
    }
}

/// A packing's rows: `case, method, friction, time, strain, phi, z, z_star, sigma`.
pub fn packing(case: &str, c: &PackingCompacted) -> PolarsResult<DataFrame> {
    let n = c.rows.len();
    let get = |f: fn(&crate::compaction::Row) -> f64| c.rows.iter().map(f).collect::<Vec<f64>>();
    df!(
        "case" => vec![case; n],
        "method" => vec![method_name(c.method); n],
        "friction" => vec![c.friction; n],
        "time" => get(|r| r.time),
        "strain" => get(|r| r.strain),
        "phi" => get(|r| r.phi),
        "z" => get(|r| r.z),
        "z_star" => get(|r| r.z_star),
        "sigma" => get(|r| r.sigma),
    )
}

/// A single grain's rows: `case, method, friction, time, strain, force, width, sigma`, with
/// `force` the force behind σ = force/width (BPM: the bottom plate; MPM: the mean of the
/// two plates).
fn single(
    case: &str,
    method: Method,
    friction: f64,
    rows: [Vec<f64>; 5],
) -> PolarsResult<DataFrame> {
    let n = rows[0].len();
    let [time, strain, force, width, sigma] = rows;
    df!(
        "case" => vec![case; n],
        "method" => vec![method_name(method); n],
        "friction" => vec![friction; n],
        "time" => time,
        "strain" => strain,
        "force" => force,
        "width" => width,
        "sigma" => sigma,
    )
}

pub fn single_bpm(case: &str, friction: f64, c: &Compacted) -> PolarsResult<DataFrame> {
    let get = |f: fn(&crate::stages::compact::Row) -> f64| c.rows.iter().map(f).collect();
    single(
        case,
        Method::Bpm,
        friction,
        [
            get(|r| r.time),
            get(|r| r.strain),
            get(|r| r.force),
            get(|r| r.width),
            get(|r| r.sigma),
        ],
    )
}

pub fn single_mpm(case: &str, friction: f64, c: &MpmCompacted) -> PolarsResult<DataFrame> {
    let get = |f: fn(&crate::mpm::driver::Row) -> f64| c.rows.iter().map(f).collect();
    single(
        case,
        Method::Mpm,
        friction,
        [
            get(|r| r.time),
            get(|r| r.strain),
            get(|r| 0.5 * (r.force_top + r.force_bottom)),
            get(|r| r.width),
            get(|r| r.sigma),
        ],
    )
}

/// The cases' frames stacked into one (an empty frame for none).
pub fn stack(frames: &[DataFrame]) -> PolarsResult<DataFrame> {
    let mut it = frames.iter();
    let Some(first) = it.next() else {
        return Ok(DataFrame::empty());
    };
    let mut all = first.clone();
    for f in it {
        all.vstack_mut(f)?;
    }
    Ok(all)
}

/// A column as plain numbers (nulls as NaN), for fits and figures.
pub fn values(df: &DataFrame, name: &str) -> PolarsResult<Vec<f64>> {
    Ok(df
        .column(name)?
        .f64()?
        .iter()
        .map(|v| v.unwrap_or(f64::NAN))
        .collect())
}
