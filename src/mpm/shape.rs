//! Tensor-product grid shape functions `S_ip = S(x_p - x_i) S(y_p - y_i)` (METHODS §3.1).

use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

/// Most nodes a point can reach along one axis (3 for uGIMP and the quadratic B-spline).
pub const MAX_PER_AXIS: usize = 3;
/// Most nodes a point can reach in 2D.
pub const MAX_NODES: usize = MAX_PER_AXIS * MAX_PER_AXIS;

/// Which basis maps points to nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ShapeKind {
    /// Linear hat `1 - |ξ|/h` (the paper's four-node quadrilaterals); gradient jumps at nodes.
    Bilinear,
    /// uGIMP with a fixed particle half-width `l_p` (Bardenhagen & Kober 2004); `C¹` weights.
    Gimp,
    /// Quadratic B-spline (3 nodes per axis, `C¹`).
    BSpline2,
}

impl ShapeKind {
    /// Support radius along one axis, in cells, for half-width ratio `lp_h = l_p/h`.
    fn support_cells(self, lp_h: f64) -> f64 {
        match self {
            ShapeKind::Bilinear => 1.0,
            ShapeKind::Gimp => 1.0 + lp_h,
            ShapeKind::BSpline2 => 1.5,
        }
    }

    /// 1-D weight and its derivative for the signed distance `xi = x_p - x_i`.
    pub fn eval_1d(self, xi: f64, h: f64, lp: f64) -> (f64, f64) {
        let a = xi.abs();
        let s = xi.signum();
        match self {
            ShapeKind::Bilinear => {
                if a < h {
                    (1.0 - a / h, -s / h)
                } else {
                    (0.0, 0.0)
                }
            }
            ShapeKind::Gimp => {
                if a < lp {
                    (1.0 - (xi * xi + lp * lp) / (2.0 * h * lp), -xi / (h * lp))
                } else if a <= h - lp {
                    (1.0 - a / h, -s / h)
                } else if a < h + lp {
                    let d = h + lp - a;
                    (d * d / (4.0 * h * lp), -s * d / (2.0 * h * lp))
                } else {
                    (0.0, 0.0)
                }
            }
            ShapeKind::BSpline2 => {
                let r = a / h;
                if r < 0.5 {
                    (0.75 - r * r, -2.0 * xi / (h * h))
                } else if r < 1.5 {
                    let d = 1.5 - r;
                    (0.5 * d * d, -s * d / h)
                } else {
                    (0.0, 0.0)
                }
            }
        }
    }

    /// Nodes reached along one axis from grid coordinate `xg = (x - origin)/h`:
    /// fills `(node index, weight, derivative)` and returns how many (weights > 0 only).
    pub fn axis(
        self,
        xg: f64,
        h: f64,
        lp: f64,
        out: &mut [(i64, f64, f64); MAX_PER_AXIS],
    ) -> usize {
        let r = self.support_cells(lp / h);
        let first = (xg - r).floor() as i64;
        let last = (xg + r).ceil() as i64;
        let mut n = 0;
        for i in first..=last {
            let (w, dw) = self.eval_1d((xg - i as f64) * h, h, lp);
            if w > 0.0 && n < MAX_PER_AXIS {
                out[n] = (i, w, dw);
                n += 1;
            }
        }
        n
    }
}

/// Weights and gradients of one point: `(grid node id, S_ip, ∇S_ip)`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stencil {
    pub len: usize,
    pub node: [usize; MAX_NODES],
    pub w: [f64; MAX_NODES],
    pub grad: [Vector2<f64>; MAX_NODES],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partition_of_unity_and_consistent_derivatives() {
        let (h, lp) = (1.0, 0.25);
        for kind in [ShapeKind::Bilinear, ShapeKind::Gimp, ShapeKind::BSpline2] {
            for k in 0..97 {
                let xg = 3.0 + k as f64 / 97.0 + 1e-3;
                let mut out = [(0, 0.0, 0.0); MAX_PER_AXIS];
                let n = kind.axis(xg, h, lp, &mut out);
                let sw: f64 = out[..n].iter().map(|t| t.1).sum();
                let sd: f64 = out[..n].iter().map(|t| t.2).sum();
                let first_moment: f64 = out[..n].iter().map(|t| t.1 * t.0 as f64).sum();
                assert!((sw - 1.0).abs() < 1e-12, "{kind:?} {xg} {sw}");
                assert!(sd.abs() < 1e-12, "{kind:?} {sd}");
                assert!(
                    (first_moment - xg).abs() < 1e-12,
                    "{kind:?} linear reproduction"
                );
                for t in &out[..n] {
                    let e = 1e-6;
                    let (wp, _) = kind.eval_1d((xg - t.0 as f64) * h + e, h, lp);
                    let (wm, _) = kind.eval_1d((xg - t.0 as f64) * h - e, h, lp);
                    assert!(
                        ((wp - wm) / (2.0 * e) - t.2).abs() < 1e-5,
                        "{kind:?} derivative"
                    );
                }
            }
        }
    }
}
