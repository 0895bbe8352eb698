//! Measures on one case's time series, as Polars expressions (METHODS.md §5): crossings
//! by linear interpolation, the jamming point, σ0 and ε', small-strain slopes, plateaus.

use polars::prelude::*;

/// The single value of a one-row result, None when null, NaN or absent.
fn scalar(df: &DataFrame, name: &str) -> PolarsResult<Option<f64>> {
    if df.height() == 0 {
        return Ok(None);
    }
    Ok(df.column(name)?.f64()?.get(0).filter(|v| v.is_finite()))
}

/// The last value of a column.
pub fn last(df: &DataFrame, name: &str) -> PolarsResult<Option<f64>> {
    let out = df.clone().lazy().select([col(name).last()]).collect()?;
    scalar(&out, name)
}

/// The largest value of a column (None for an empty frame).
pub fn max(df: &DataFrame, name: &str) -> PolarsResult<Option<f64>> {
    let out = df.clone().lazy().select([col(name).max()]).collect()?;
    scalar(&out, name)
}

/// The sum of a column.
pub fn sum(df: &DataFrame, name: &str) -> PolarsResult<Option<f64>> {
    let out = df.clone().lazy().select([col(name).sum()]).collect()?;
    scalar(&out, name)
}

/// y where x first reaches x0, linear between that row and the one before (the first row
/// itself if it is already there); None if x never reaches x0.
pub fn crossing(df: &DataFrame, x: &str, y: &str, x0: f64) -> PolarsResult<Option<f64>> {
    let (xp, yp) = (col("_x_prev"), col("_y_prev"));
    let w = when(col(x).eq(xp.clone()))
        .then(lit(1.0))
        .otherwise((lit(x0) - xp.clone()) / (col(x) - xp));
    let out = df
        .clone()
        .lazy()
        .with_columns([
            col(x).shift(lit(1)).fill_null(col(x)).alias("_x_prev"),
            col(y).shift(lit(1)).fill_null(col(y)).alias("_y_prev"),
        ])
        .filter(col(x).gt_eq(lit(x0)))
        .select([(yp.clone() + w * (col(y) - yp)).first().alias("v")])
        .collect()?;
    scalar(&out, "v")
}

/// The jamming point of a packing: the first row from which σ stays above `fraction` of its
/// final value (σ's minimum over the rows ahead, a reverse cumulative minimum, exceeds it).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Jamming {
    pub strain: f64,
    pub phi: f64,
    pub z: f64,
    pub sigma: f64,
}

pub fn jamming(df: &DataFrame, fraction: f64) -> PolarsResult<Option<Jamming>> {
    if last(df, "sigma")?.is_none_or(|s| s <= 0.0) {
        return Ok(None);
    }
    let threshold = col("sigma").last() * lit(fraction);
    let out = df
        .clone()
        .lazy()
        .filter(col("sigma").cum_min(true).gt(threshold))
        .select([
            col("strain").first(),
            col("phi").first(),
            col("z").first(),
            col("sigma").first(),
        ])
        .collect()?;
    let get = |n| scalar(&out, n);
    Ok(
        match (get("strain")?, get("phi")?, get("z")?, get("sigma")?) {
            (Some(strain), Some(phi), Some(z), Some(sigma)) => Some(Jamming {
                strain,
                phi,
                z,
                sigma,
            }),
            _ => None,
        },
    )
}

/// The consolidation point: σ0 = σ(Φ = Φ0) and the strain there.
pub fn consolidation(df: &DataFrame, phi0: f64) -> PolarsResult<Option<(f64, f64)>> {
    Ok(
        match (
            crossing(df, "phi", "sigma", phi0)?,
            crossing(df, "phi", "strain", phi0)?,
        ) {
            (Some(s), Some(e)) if s > 0.0 => Some((s, e)),
            _ => None,
        },
    )
}

/// Adds `sigma_over_sigma0` = σ/σ0 and `strain_prime` = ε' = ε − ε(σ0) (Fig. 10, 11); nulls
/// when the packing never reached Φ0.
pub fn with_consolidation(df: &DataFrame, at: Option<(f64, f64)>) -> PolarsResult<DataFrame> {
    let (s, e) = match at {
        Some((s, e)) => (lit(s), lit(e)),
        None => (
            lit(NULL).cast(DataType::Float64),
            lit(NULL).cast(DataType::Float64),
        ),
    };
    df.clone()
        .lazy()
        .with_columns([
            (col("sigma") / s).alias("sigma_over_sigma0"),
            (col("strain") - e).alias("strain_prime"),
        ])
        .collect()
}

/// The (x = σ/σ0 − 1, Φ) points with Φ in `range`, for Eqs. 14 and 16.
pub fn fit_points(df: &DataFrame, sigma0: f64, range: [f64; 2]) -> PolarsResult<[Vec<f64>; 2]> {
    let out = df
        .clone()
        .lazy()
        .filter(
            col("phi")
                .gt_eq(lit(range[0]))
                .and(col("phi").lt_eq(lit(range[1]))),
        )
        .select([
            (col("sigma") / lit(sigma0) - lit(1.0)).alias("x"),
            col("phi"),
        ])
        .collect()?;
    Ok([
        super::series::values(&out, "x")?,
        super::series::values(&out, "phi")?,
    ])
}

/// Least-squares slope through the origin of y against x on 0 < x <= x_max.
pub fn slope_through_origin(
    df: &DataFrame,
    x: &str,
    y: &str,
    x_max: f64,
) -> PolarsResult<Option<f64>> {
    let out = df
        .clone()
        .lazy()
        .filter(col(x).gt(lit(0.0)).and(col(x).lt_eq(lit(x_max))))
        .select([
            (col(x) * col(y)).sum().alias("sxy"),
            (col(x) * col(x)).sum().alias("sxx"),
        ])
        .collect()?;
    Ok(match (scalar(&out, "sxy")?, scalar(&out, "sxx")?) {
        (Some(sxy), Some(sxx)) if sxx > 0.0 => Some(sxy / sxx),
        _ => None,
    })
}

/// Mean of `y` over the rows with `x` in [lo, hi].
pub fn mean_within(df: &DataFrame, x: &str, y: &str, range: [f64; 2]) -> PolarsResult<Option<f64>> {
    let out = df
        .clone()
        .lazy()
        .filter(col(x).gt_eq(lit(range[0])).and(col(x).lt_eq(lit(range[1]))))
        .select([col(y).mean()])
        .collect()?;
    scalar(&out, y)
}

/// The mean of `y` over the last `window` of `x` (x rising). Each row's `y` is taken as the
/// mean over its span from the row before (as a compaction row's stresses are over its
/// recording interval), weighted by the part of that span inside the window. None without
/// rows.
pub fn end_mean(df: &DataFrame, x: &str, y: &str, window: f64) -> PolarsResult<Option<f64>> {
    let Some(end) = last(df, x)? else {
        return Ok(None);
    };
    let start = lit(end - window);
    let prev = col(x).shift(lit(1)).fill_null(col(x));
    // the overlap of (prev, x] with (end - window, end], never negative
    let inside = col(x)
        - when(prev.clone().gt(start.clone()))
            .then(prev)
            .otherwise(start);
    let weight = when(inside.clone().gt(lit(0.0)))
        .then(inside)
        .otherwise(lit(0.0));
    let out = df
        .clone()
        .lazy()
        .select([
            (weight.clone() * col(y)).sum().alias("wy"),
            weight.sum().alias("w"),
        ])
        .collect()?;
    Ok(match (scalar(&out, "wy")?, scalar(&out, "w")?) {
        (Some(wy), Some(w)) if w > 0.0 => Some(wy / w),
        _ => last(df, y)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic compaction: Φ = 0.65 e^ε (constant grain area), σ = 0 before ε = 0.1 apart
    /// from a spike at ε = 0.05, then σ = 1e5 (ε − 0.1)^2 ... rising.
    fn synthetic() -> DataFrame {
        let strain: Vec<f64> = (0..=100).map(|k| 0.005 * k as f64).collect();
        let phi: Vec<f64> = strain.iter().map(|e| 0.65 * e.exp()).collect();
        let z: Vec<f64> = strain.iter().map(|e| 2.0 + 10.0 * e).collect();
        let sigma: Vec<f64> = strain
            .iter()
            .map(|&e| {
                if (e - 0.05).abs() < 1e-9 {
                    500.0 // a transient spike before jamming: not "staying above"
                } else if e > 0.1 {
                    1e5 * (e - 0.1)
                } else {
                    0.0
                }
            })
            .collect();
        df!("strain" => strain, "phi" => phi, "z" => z, "sigma" => sigma).unwrap()
    }

    #[test]
    fn crossing_interpolates_linearly() {
        let df = df!("x" => [0.0, 1.0, 2.0, 3.0], "y" => [0.0, 10.0, 30.0, 0.0]).unwrap();
        assert_eq!(crossing(&df, "x", "y", 1.5).unwrap(), Some(20.0));
        assert_eq!(crossing(&df, "x", "y", 0.0).unwrap(), Some(0.0));
        assert_eq!(crossing(&df, "x", "y", 3.5).unwrap(), None);
        assert_eq!(last(&df, "y").unwrap(), Some(0.0));
    }

    #[test]
    fn the_final_mean_weights_each_row_by_the_strain_it_spans_in_the_window() {
        // rows every 0.015 of strain, then a last short one (0.002) carrying a jump
        let df = df!(
            "strain" => [0.40, 0.415, 0.430, 0.445, 0.447],
            "sigma" => [800.0, 850.0, 900.0, 960.0, 1030.0]
        )
        .unwrap();
        // window 0.01: (0.437, 0.445] of the 960 row and (0.445, 0.447] of the last
        let m = end_mean(&df, "strain", "sigma", 0.01).unwrap().unwrap();
        let exact = (0.008 * 960.0 + 0.002 * 1030.0) / 0.01;
        assert!((m - exact).abs() < 1e-9, "{m} vs {exact}");
        // a window reaching past the first row: every row's full span, the first has none
        let all = end_mean(&df, "strain", "sigma", 1.0).unwrap().unwrap();
        let exact = (0.015 * (850.0 + 900.0 + 960.0) + 0.002 * 1030.0) / 0.047;
        assert!((all - exact).abs() < 1e-9, "{all} vs {exact}");
        // one row: its own value
        let one = df!("strain" => [0.1], "sigma" => [5.0]).unwrap();
        assert_eq!(end_mean(&one, "strain", "sigma", 0.01).unwrap(), Some(5.0));
    }

    #[test]
    fn jamming_is_the_first_sustained_rise() {
        let df = synthetic();
        // final σ = 1e5 * 0.4 = 4e4; 1% = 400: the spike (500) is not sustained; σ > 400
        // from ε > 0.104, i.e. the first row ε = 0.105
        let j = jamming(&df, 0.01).unwrap().unwrap();
        assert!((j.strain - 0.105).abs() < 1e-12, "{j:?}");
        assert!((j.phi - 0.65 * 0.105f64.exp()).abs() < 1e-12);
        assert!((j.z - 3.05).abs() < 1e-12);
        let flat = df!("strain" => [0.0, 0.1], "phi" => [0.6, 0.7], "z" => [0.0, 0.0], "sigma" => [0.0, 0.0]).unwrap();
        assert_eq!(jamming(&flat, 0.01).unwrap(), None);
    }

    #[test]
    fn sigma0_and_strain_prime_at_phi_0_8() {
        let df = synthetic();
        let (s0, e0) = consolidation(&df, 0.8).unwrap().unwrap();
        // Φ = 0.8 at ε = ln(0.8/0.65) = 0.2076; σ linear there: σ0 = 1e5 (ε0 − 0.1), within
        // the interpolation error of Φ's curvature over one 0.005 step
        let exact = (0.8f64 / 0.65).ln();
        assert!((e0 - exact).abs() < 1e-5, "{e0} vs {exact}");
        assert!((s0 - 1e5 * (exact - 0.1)).abs() < 1.0, "{s0}");
        let out = with_consolidation(&df, Some((s0, e0))).unwrap();
        let x = crate::analysis::series::values(&out, "strain_prime").unwrap();
        assert!((x[0] + e0).abs() < 1e-12);
        assert!(consolidation(&df, 1.5).unwrap().is_none());
        let none = with_consolidation(&df, None).unwrap();
        assert_eq!(
            none.column("sigma_over_sigma0").unwrap().null_count(),
            df.height()
        );
    }

    #[test]
    fn slope_and_mean_over_a_range() {
        let df =
            df!("e" => [0.0, 0.01, 0.02, 0.03, 0.2], "s" => [0.0, 2.0, 4.0, 9.0, 7.0]).unwrap();
        assert_eq!(
            slope_through_origin(&df, "e", "s", 0.02).unwrap(),
            Some(200.0)
        );
        assert_eq!(mean_within(&df, "e", "s", [0.025, 1.0]).unwrap(), Some(8.0));
        assert_eq!(mean_within(&df, "e", "s", [2.0, 3.0]).unwrap(), None);
        let pts = fit_points(
            &df!("phi" => [0.7, 0.8, 0.9, 0.99], "sigma" => [1.0, 2.0, 4.0, 8.0]).unwrap(),
            2.0,
            [0.8, 0.98],
        )
        .unwrap();
        assert_eq!(pts, [vec![0.0, 1.0], vec![0.8, 0.9]]);
    }
}
