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

/// A packing's rows: `case, method, friction, time, strain, phi, z, z_star, sigma, inertial`,
/// and how far grains passed into each other and how well each interval was solved:
/// `overlap` (BPM: over d_min; MPM: over h_g), `points_inside`, `point_overlap` (MPM, over
/// h_g; BPM NaN), `unconverged`.
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
        "inertial" => get(|r| r.inertial),
        "overlap" => get(|r| r.overlap),
        "points_inside" => get(|r| r.points_inside),
        "point_overlap" => get(|r| r.point_overlap),
        "unconverged" => get(|r| r.unconverged as f64),
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

/// A BPM grain's rows also carry its cohesive prestress `sigma_c` (Pa) and the mobilised
/// friction `sin_phi` of its contact network (`bpm::measure::GrainStress`).
pub fn single_bpm(case: &str, friction: f64, c: &Compacted) -> PolarsResult<DataFrame> {
    let get = |f: fn(&crate::stages::compact::Row) -> f64| c.rows.iter().map(f).collect();
    let mut df = single(
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
    )?;
    df.with_column(Column::new("sigma_c".into(), get(|r| r.sigma_c)))?;
    df.with_column(Column::new("sin_phi".into(), get(|r| r.sin_phi)))?;
    Ok(df)
}

/// An MPM grain has no cohesive prestress: its `sigma_c` and `sin_phi` are null, so that
/// both methods' rows stack into one table.
fn without_cohesion(mut df: DataFrame) -> PolarsResult<DataFrame> {
    let n = df.height();
    for name in ["sigma_c", "sin_phi"] {
        df.with_column(Column::full_null(name.into(), n, &DataType::Float64))?;
    }
    Ok(df)
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
    .and_then(without_cohesion)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::compact::Row;

    #[test]
    fn bpm_and_mpm_grains_stack_into_one_table() {
        let rows = vec![
            Row {
                strain: 0.1,
                sigma_c: 2.0,
                sin_phi: 0.1,
                ..Default::default()
            };
            3
        ];
        let bpm = Compacted {
            rows,
            final_particles: Default::default(),
            figures: Default::default(),
        };
        let bpm = single_bpm("bpm-mu0", 0.0, &bpm).unwrap();
        let mpm = single(
            "mpm-mu0",
            Method::Mpm,
            0.0,
            std::array::from_fn(|_| vec![1.0; 2]),
        )
        .and_then(without_cohesion)
        .unwrap();
        let all = stack(&[bpm, mpm]).unwrap();
        assert_eq!(all.height(), 5);
        let sigma_c = values(&all, "sigma_c").unwrap();
        assert_eq!(&sigma_c[..3], &[2.0; 3]);
        assert!(sigma_c[3..].iter().all(|v| v.is_nan()));
    }
}
