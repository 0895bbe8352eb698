//! Uniform background grid of square cells; node `(i, j)` sits at `origin + h (i, j)`.

use super::shape::{MAX_PER_AXIS, ShapeKind, Stencil};
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Grid {
    /// Position of node (0, 0) (m).
    pub origin: Vector2<f64>,
    /// Cell size `h_g` (m).
    pub h: f64,
    /// Number of nodes along x and y.
    pub nx: usize,
    pub ny: usize,
}

impl Grid {
    pub fn node_count(&self) -> usize {
        self.nx * self.ny
    }

    /// Position of node `id = j nx + i`.
    pub fn node_position(&self, id: usize) -> Vector2<f64> {
        let (i, j) = (id % self.nx, id / self.nx);
        self.origin + Vector2::new(i as f64, j as f64) * self.h
    }

    /// B-bar group of a point at `x`: the cell containing it for the bilinear and uGIMP
    /// bases, the cell centred on its nearest node for the quadratic B-spline (so that all
    /// points of a group share one 3×3 stencil). `None` outside the grid.
    pub fn bbar_group(&self, kind: ShapeKind, x: &Vector2<f64>) -> Option<usize> {
        let shift = if kind == ShapeKind::BSpline2 {
            0.5
        } else {
            0.0
        };
        let g = (x - self.origin) / self.h;
        let (i, j) = ((g.x - shift).floor(), (g.y - shift).floor());
        if i < 0.0 || j < 0.0 || i >= self.nx as f64 || j >= self.ny as f64 {
            return None;
        }
        Some(j as usize * self.nx + i as usize)
    }

    /// Weights and gradients of a point at `x` with half-width `lp`; `None` if its
    /// support leaves the grid.
    pub fn stencil(&self, kind: ShapeKind, x: &Vector2<f64>, lp: f64) -> Option<Stencil> {
        let g = (x - self.origin) / self.h;
        let mut ax = [(0, 0.0, 0.0); MAX_PER_AXIS];
        let mut ay = [(0, 0.0, 0.0); MAX_PER_AXIS];
        let nx = kind.axis(g.x, self.h, lp, &mut ax);
        let ny = kind.axis(g.y, self.h, lp, &mut ay);
        let mut s = Stencil::default();
        for &(j, wy, dy) in &ay[..ny] {
            for &(i, wx, dx) in &ax[..nx] {
                if i < 0 || j < 0 || i >= self.nx as i64 || j >= self.ny as i64 {
                    return None;
                }
                let k = s.len;
                s.node[k] = j as usize * self.nx + i as usize;
                s.w[k] = wx * wy;
                s.grad[k] = Vector2::new(dx * wy, wx * dy);
                s.len += 1;
            }
        }
        Some(s)
    }
}
