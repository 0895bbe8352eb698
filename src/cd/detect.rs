//! Broad phase: a Verlet list of disk pairs built from a cell list (METHODS.md §1.7).
//! Pairs closer than `range + skin` are listed; the list stays valid until some disk has
//! moved more than skin/2 since the build, so most steps skip the cell list entirely.

use super::PAR_MIN;
use crate::geom::{CellList, V2};
use rayon::prelude::*;

#[derive(Clone, Debug, Default)]
pub struct Neighbours {
    /// (i, j) with i < j, sorted: contacts built from it come out in a fixed order.
    pub pairs: Vec<(u32, u32)>,
    ref_pos: Vec<V2>,
    half_skin: f64,
    range: f64,
}

impl Neighbours {
    /// Makes sure every pair with gap ≤ `range` is listed; rebuilds when needed.
    pub fn update(&mut self, pos: &[V2], radius: &[f64], range: f64, skin: f64) {
        let moved = |(p, q): (&V2, &V2)| (p - q).norm_squared() > self.half_skin * self.half_skin;
        let stale = self.ref_pos.len() != pos.len()
            || range > self.range
            || if pos.len() < PAR_MIN {
                pos.iter().zip(&self.ref_pos).any(moved)
            } else {
                pos.par_iter().zip(&self.ref_pos).any(moved)
            };
        if stale {
            self.build(pos, radius, range, skin);
        }
    }

    fn build(&mut self, pos: &[V2], radius: &[f64], range: f64, skin: f64) {
        let r_max = radius.iter().cloned().fold(0.0, f64::max);
        let reach = range + skin;
        let cells = CellList::build(pos, 2.0 * r_max + reach);
        let near = |i: usize| {
            let mut near = Vec::new();
            cells.for_each_near(pos[i], |k| {
                if k > i && (pos[k] - pos[i]).norm() - radius[i] - radius[k] <= reach {
                    near.push((i as u32, k as u32));
                }
            });
            near.sort_unstable();
            near
        };
        self.pairs = if pos.len() < PAR_MIN {
            (0..pos.len()).flat_map(near).collect()
        } else {
            let per_body: Vec<Vec<(u32, u32)>> = (0..pos.len()).into_par_iter().map(near).collect();
            per_body.concat()
        };
        self.ref_pos = pos.to_vec();
        self.half_skin = 0.5 * skin;
        self.range = range;
    }
}
