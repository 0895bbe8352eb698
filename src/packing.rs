//! Rigid-disk packings: size distributions, a loose initial layout, the box walls.

use crate::geom::{V2, Wall};
use crate::rng::Rng;
use serde::{Deserialize, Serialize};

/// Size distribution of disks with diameters in [d_min, d_max] (METHODS.md §2.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Distribution {
    /// Equal total area per diameter bin, n(D) ∝ D⁻², sampled as
    /// D = 1/(1/D_min - U (1/D_min - 1/D_max)): the paper's grains, "uniform by volume
    /// fractions" in Radjai-group usage.
    EqualAreaPerSize,
    /// Each disk's area uniform in [A_min, A_max], D = sqrt(D_min² + U (D_max² - D_min²)):
    /// the paper's primary particles, "uniform by particle volumes" (reproduces its 1750).
    UniformArea,
    /// Diameter uniform in [D_min, D_max].
    UniformDiameter,
}

impl Distribution {
    pub fn sample(self, [lo, hi]: [f64; 2], rng: &mut Rng) -> f64 {
        let u = rng.uniform();
        match self {
            Distribution::EqualAreaPerSize => 1.0 / (1.0 / lo - u * (1.0 / lo - 1.0 / hi)),
            Distribution::UniformArea => (lo * lo + u * (hi * hi - lo * lo)).sqrt(),
            Distribution::UniformDiameter => lo + u * (hi - lo),
        }
    }

    /// Mean disk area of the distribution (exact).
    pub fn mean_area(self, [lo, hi]: [f64; 2]) -> f64 {
        let q = std::f64::consts::FRAC_PI_4;
        if hi == lo {
            return q * lo * lo;
        }
        match self {
            // n(D) ∝ D⁻² on [lo, hi]: <D²> = (hi - lo) / (1/lo - 1/hi) = lo hi
            Distribution::EqualAreaPerSize => q * lo * hi,
            Distribution::UniformArea => q * 0.5 * (lo * lo + hi * hi),
            Distribution::UniformDiameter => q * (lo * lo + lo * hi + hi * hi) / 3.0,
        }
    }
}

/// Diameters of `n` disks.
pub fn diameters(dist: Distribution, range: [f64; 2], n: usize, rng: &mut Rng) -> Vec<f64> {
    (0..n).map(|_| dist.sample(range, rng)).collect()
}

/// Centres of a loose layout in a box of `width` above the floor y = 0: rows on a lattice
/// of pitch 1.1 d_max with a small random shift, so no two disks touch. Returns the centres
/// and the height of the top of the layout.
pub fn loose_layout(diameters: &[f64], width: f64, rng: &mut Rng) -> (Vec<V2>, f64) {
    let d_max = diameters.iter().cloned().fold(0.0, f64::max);
    let pitch = 1.1 * d_max;
    let per_row = ((width / pitch).floor() as usize).max(1);
    let slack = pitch - d_max;
    let pos: Vec<V2> = (0..diameters.len())
        .map(|k| {
            let (row, col) = (k / per_row, k % per_row);
            let jitter = V2::new(rng.uniform() - 0.5, rng.uniform() - 0.5) * slack * 0.9;
            V2::new((col as f64 + 0.5) * pitch, (row as f64 + 0.5) * pitch) + jitter
        })
        .collect();
    let rows = diameters.len().div_ceil(per_row);
    (pos, rows as f64 * pitch)
}

/// Floor (index 0), left (1) and right (2) walls of an open box of `width` and `height`,
/// each extended by `overhang` past the corners so corner disks see their interiors.
pub fn box_walls(width: f64, height: f64, overhang: f64) -> Vec<Wall> {
    let o = overhang;
    vec![
        Wall::new(V2::new(-o, 0.0), V2::new(width + o, 0.0)),
        Wall::new(V2::new(0.0, height + o), V2::new(0.0, -o)),
        Wall::new(V2::new(width, -o), V2::new(width, height + o)),
    ]
}

/// Box width that makes a deposit of `n` disks about as high as wide at packing
/// fraction `phi`.
pub fn square_box_width(dist: Distribution, range: [f64; 2], n: usize, phi: f64) -> f64 {
    (n as f64 * dist.mean_area(range) / phi).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampled_mean_areas_match_the_closed_forms() {
        let range = [1.4e-3, 2.4e-3];
        for dist in [
            Distribution::EqualAreaPerSize,
            Distribution::UniformArea,
            Distribution::UniformDiameter,
        ] {
            let mut rng = Rng::new(3);
            let n = 200_000;
            let d = diameters(dist, range, n, &mut rng);
            assert!(d.iter().all(|&x| (range[0]..=range[1]).contains(&x)));
            let mean = d
                .iter()
                .map(|x| std::f64::consts::FRAC_PI_4 * x * x)
                .sum::<f64>()
                / n as f64;
            assert!(
                (mean / dist.mean_area(range) - 1.0).abs() < 3e-3,
                "{dist:?}"
            );
        }
    }

    #[test]
    fn equal_area_per_size_puts_equal_area_in_each_bin() {
        let range = [1.0, 2.0];
        let mut rng = Rng::new(5);
        let d = diameters(Distribution::EqualAreaPerSize, range, 400_000, &mut rng);
        let mut bins = [0.0; 4];
        for x in d {
            bins[(((x - 1.0) * 4.0) as usize).min(3)] += x * x;
        }
        let total: f64 = bins.iter().sum();
        for b in bins {
            assert!((b / total - 0.25).abs() < 0.005, "{bins:?}");
        }
    }
}
