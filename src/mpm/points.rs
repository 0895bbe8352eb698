//! Material points as structure-of-arrays, and the seeding of a circular grain.

use super::grid::Grid;
use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};

/// Cauchy stress in plane strain: in-plane components and the out-of-plane `σzz` (Pa).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stress {
    pub xx: f64,
    pub yy: f64,
    pub xy: f64,
    pub zz: f64,
}

impl Stress {
    pub fn matrix(&self) -> Matrix2<f64> {
        Matrix2::new(self.xx, self.xy, self.xy, self.yy)
    }

    /// Von Mises stress including `σzz` (plane strain).
    pub fn von_mises(&self) -> f64 {
        let (a, b, c) = (self.xx - self.yy, self.yy - self.zz, self.zz - self.xx);
        (0.5 * (a * a + b * b + c * c) + 3.0 * self.xy * self.xy).sqrt()
    }

    pub fn is_finite(&self) -> bool {
        self.xx.is_finite() && self.yy.is_finite() && self.xy.is_finite() && self.zz.is_finite()
    }
}

/// All material points of one grain (SoA). Units: m, m/s, m/s², kg/m, m²/m (area).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Points {
    pub x: Vec<Vector2<f64>>,
    pub v: Vec<Vector2<f64>>,
    pub a: Vec<Vector2<f64>>,
    pub mass: Vec<f64>,
    /// Initial area `V_p0`.
    pub vol0: Vec<f64>,
    /// Current area `v_p = det F V_p0`.
    pub vol: Vec<f64>,
    pub def_grad: Vec<Matrix2<f64>>,
    pub stress: Vec<Stress>,
    /// Half-width `l_p` of every point's domain (uGIMP width).
    pub half_size: f64,
    /// Initial distance from the point to its domain's edge toward `-x, +x, -y, +y`:
    /// `l_p`, clipped by the seeded circle, so that gaps and widths see the circle rather
    /// than the staircase of cells. Stretched with `F` (see [`Points::reach`]).
    pub extent: Vec<[f64; 4]>,
}

impl Points {
    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    pub fn momentum(&self) -> Vector2<f64> {
        self.v
            .iter()
            .zip(&self.mass)
            .fold(Vector2::zeros(), |acc, (v, m)| acc + v * *m)
    }

    /// Σ m_p x_p / Σ m_p.
    pub fn centre_of_mass(&self) -> Vector2<f64> {
        self.x
            .iter()
            .zip(&self.mass)
            .fold(Vector2::zeros(), |acc, (x, m)| acc + x * *m)
            / self.total_mass()
    }

    pub fn kinetic_energy(&self) -> f64 {
        self.v
            .iter()
            .zip(&self.mass)
            .map(|(v, m)| 0.5 * m * v.norm_squared())
            .sum()
    }

    /// Current reach of point `p` from its centre toward the axis direction `dir`
    /// (0: -x, 1: +x, 2: -y, 3: +y): the initial extent times the stretch `|F e_axis|`.
    pub fn reach(&self, p: usize, dir: usize) -> f64 {
        self.extent[p][dir] * self.def_grad[p].column(dir / 2).norm()
    }

    /// Largest horizontal extent `max(x_p + l_p) - min(x_p - l_p)` (m), with the
    /// directional reach in place of `l_p`.
    pub fn width(&self) -> f64 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in 0..self.len() {
            lo = lo.min(self.x[p].x - self.reach(p, 0));
            hi = hi.max(self.x[p].x + self.reach(p, 1));
        }
        hi - lo
    }

    /// Seeds a disk of `radius` centred at `centre`: 2×2 points per cell of `grid` at the
    /// quarter-cell centres, keeping those inside the circle. Each point gets the same
    /// area `π R² / N`, so `Σ V_p = π R²` exactly (the paper's "fit best to the circle"
    /// is not defined; this rescale is our choice).
    pub fn seed_disk(grid: &Grid, centre: Vector2<f64>, radius: f64, density: f64) -> Points {
        let dr = 0.5 * grid.h;
        let mut x = Vec::new();
        for j in 0..2 * (grid.ny - 1) {
            for i in 0..2 * (grid.nx - 1) {
                let p = grid.origin + Vector2::new(i as f64 + 0.5, j as f64 + 0.5) * dr;
                if (p - centre).norm() < radius {
                    x.push(p);
                }
            }
        }
        let n = x.len();
        let area = std::f64::consts::PI * radius * radius / n as f64;
        let lp = 0.5 * dr;
        // Distance from a point inside the circle to the circle along ±x and ±y.
        let chord = |a: f64| (radius * radius - a * a).max(0.0).sqrt();
        let extent = x
            .iter()
            .map(|p| {
                let d = p - centre;
                let (cx, cy) = (chord(d.y), chord(d.x));
                [
                    lp.min(d.x + cx),
                    lp.min(cx - d.x),
                    lp.min(d.y + cy),
                    lp.min(cy - d.y),
                ]
            })
            .collect();
        Points {
            v: vec![Vector2::zeros(); n],
            a: vec![Vector2::zeros(); n],
            mass: vec![density * area; n],
            vol0: vec![area; n],
            vol: vec![area; n],
            def_grad: vec![Matrix2::identity(); n],
            stress: vec![Stress::default(); n],
            half_size: lp,
            extent,
            x,
        }
    }
}
