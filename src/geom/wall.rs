use super::{V2, perp};
use serde::{Deserialize, Serialize};

/// A straight rigid wall segment from `a` to `b`; grains live on its left side, so its
/// normal `perp(b - a)` points toward them. It translates at the imposed `velocity`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wall {
    pub a: V2,
    pub b: V2,
    pub velocity: V2,
}

impl Wall {
    pub fn new(a: V2, b: V2) -> Self {
        Wall {
            a,
            b,
            velocity: V2::zeros(),
        }
    }

    /// Unit normal pointing to the grains' side.
    pub fn normal(&self) -> V2 {
        perp(self.b - self.a).normalize()
    }

    /// Gap and unit normal (from the wall into the disk) between this segment, shifted by
    /// `shift`, and a disk. The closest point of the segment is used, so at an end point the
    /// normal is the direction from that point to the centre. `None` when the centre lies
    /// behind the wall line (a one-sided wall never pulls a disk through itself).
    pub fn gap(&self, shift: V2, centre: V2, radius: f64) -> Option<(f64, V2)> {
        let a = self.a + shift;
        let d = self.b - self.a;
        let len2 = d.norm_squared();
        let rel = centre - a;
        let n_wall = perp(d) / len2.sqrt();
        if rel.dot(&n_wall) <= 0.0 {
            return None;
        }
        let s = (rel.dot(&d) / len2).clamp(0.0, 1.0);
        if s > 0.0 && s < 1.0 {
            return Some((rel.dot(&n_wall) - radius, n_wall));
        }
        let to_centre = rel - s * d;
        let dist = to_centre.norm();
        Some((dist - radius, to_centre / dist))
    }

    pub fn translate(&mut self, by: V2) {
        self.a += by;
        self.b += by;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_gap_and_end_point_normal() {
        let w = Wall::new(V2::new(0.0, 0.0), V2::new(1.0, 0.0));
        let (g, n) = w.gap(V2::zeros(), V2::new(0.5, 0.3), 0.1).unwrap();
        assert!((g - 0.2).abs() < 1e-15 && (n - V2::new(0.0, 1.0)).norm() < 1e-15);
        let (g, n) = w.gap(V2::zeros(), V2::new(1.3, 0.4), 0.1).unwrap();
        assert!((g - 0.4).abs() < 1e-12 && (n - V2::new(0.6, 0.8)).norm() < 1e-12);
        assert!(w.gap(V2::zeros(), V2::new(0.5, -0.3), 0.1).is_none());
    }
}
