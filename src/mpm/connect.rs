//! Which nodes each material point reaches this step: stencils at `x^n` (light nodes
//! dropped), B-bar groups with the union of their points' nodes, and the numbering of the
//! active nodes. One `Connectivity` per grain; a multi-grain solver keeps one each.

use super::error::MpmError;
use super::grid::Grid;
use super::points::Points;
use super::shape::{ShapeKind, Stencil};
use nalgebra::Vector2;

/// Nodes lighter than this fraction of the mean nodal mass are dropped (METHODS §6
/// suggests about 1e-8; uGIMP and B-splines needed a larger cut for Newton's increments
/// to converge, see `Connectivity::drop_light_nodes`).
pub const LIGHT_NODE: f64 = 1e-4;

/// Point-to-node maps of one grain for one step. Per point `p` in group `g`, the entries
/// `pt_off[p]..pt_off[p] + len(g)` of `pt_w`/`pt_g0` line up with the group's nodes
/// `grp_nodes[grp_off[g]..grp_off[g + 1]]` (active indices; weight 0 where `p` does not
/// reach a node of its group).
#[derive(Default)]
pub struct Connectivity {
    /// Each point's own stencil (grid node ids).
    pub own: Vec<Stencil>,
    node_mass: Vec<f64>,
    key: Vec<usize>,
    /// Points sorted by group.
    pub order: Vec<usize>,
    union: Vec<usize>,
    pub grp_off: Vec<usize>,
    pub grp_nodes: Vec<usize>,
    /// Group `g` holds `order[grp_pts_off[g]..grp_pts_off[g + 1]]`.
    pub grp_pts_off: Vec<usize>,
    pub pt_grp: Vec<usize>,
    pub pt_off: Vec<usize>,
    /// Weights `S_ip` and start-of-step gradients `∇S_ip`.
    pub pt_w: Vec<f64>,
    pub pt_g0: Vec<Vector2<f64>>,
    /// Each point's own nodes as active indices: `own_act[own_off[p]..own_off[p + 1]]`.
    pub own_act: Vec<usize>,
    pub own_off: Vec<usize>,
    /// Grid node id to active index (`usize::MAX` if inactive), and back.
    pub node_map: Vec<usize>,
    pub act_grid: Vec<usize>,
    pub node_pos: Vec<Vector2<f64>>,
}

impl Connectivity {
    /// Stencils at `x^n`, B-bar groups, active nodes and their numbering for `points`.
    pub fn build(
        &mut self,
        shape: ShapeKind,
        bbar: bool,
        grid: &Grid,
        points: &Points,
        step: u64,
    ) -> Result<(), MpmError> {
        let np = points.len();
        self.own.clear();
        self.key.clear();
        for p in 0..np {
            let s = grid
                .stencil(shape, &points.x[p], points.half_size)
                .ok_or(MpmError::OutOfGrid { step, point: p })?;
            self.own.push(s);
            let key = if bbar {
                grid.bbar_group(shape, &points.x[p])
                    .ok_or(MpmError::OutOfGrid { step, point: p })?
            } else {
                p
            };
            self.key.push(key);
        }
        self.drop_light_nodes(grid, points);
        self.order.clear();
        self.order.extend(0..np);
        let key = &self.key;
        self.order.sort_by_key(|&p| key[p]);

        // Groups of points sharing a key, each with the union of its points' nodes.
        self.grp_off.clear();
        self.grp_nodes.clear();
        self.grp_pts_off.clear();
        self.pt_grp.resize(np, 0);
        self.pt_off.resize(np, 0);
        self.pt_w.clear();
        self.pt_g0.clear();
        self.grp_off.push(0);
        let mut start = 0;
        while start < np {
            let k = self.key[self.order[start]];
            let mut end = start;
            while end < np && self.key[self.order[end]] == k {
                end += 1;
            }
            self.union.clear();
            for &p in &self.order[start..end] {
                let s = &self.own[p];
                self.union.extend_from_slice(&s.node[..s.len]);
            }
            self.union.sort_unstable();
            self.union.dedup();
            let g = self.grp_off.len() - 1;
            self.grp_pts_off.push(start);
            for &p in &self.order[start..end] {
                self.pt_grp[p] = g;
                self.pt_off[p] = self.pt_w.len();
                let s = &self.own[p];
                for &node in &self.union {
                    match s.node[..s.len].iter().position(|&x| x == node) {
                        Some(q) => {
                            self.pt_w.push(s.w[q]);
                            self.pt_g0.push(s.grad[q]);
                        }
                        None => {
                            self.pt_w.push(0.0);
                            self.pt_g0.push(Vector2::zeros());
                        }
                    }
                }
            }
            self.grp_nodes.extend_from_slice(&self.union);
            self.grp_off.push(self.grp_nodes.len());
            start = end;
        }
        self.grp_pts_off.push(np);

        // Active nodes: every node left in a stencil (light ones were dropped above),
        // numbered in grid order (`shortcuts::Shortcuts::active_nodes`).
        if self.node_map.len() != grid.node_count() {
            self.node_map = vec![usize::MAX; grid.node_count()];
        } else {
            for &g in &self.act_grid {
                self.node_map[g] = usize::MAX;
            }
        }
        self.act_grid.clear();
        if crate::shortcuts::get().active_nodes {
            self.act_grid.extend_from_slice(&self.grp_nodes);
            self.act_grid.sort_unstable();
            self.act_grid.dedup();
        } else {
            // every node of the grid: the empty ones carry no mass or stiffness, only
            // the solver's diagonal shift, and get a zero increment
            self.act_grid.extend(0..grid.node_count());
        }
        for (i, &g) in self.act_grid.iter().enumerate() {
            self.node_map[g] = i;
        }
        for g in self.grp_nodes.iter_mut() {
            *g = self.node_map[*g];
        }
        self.node_pos.clear();
        self.node_pos
            .extend(self.act_grid.iter().map(|&g| grid.node_position(g)));
        self.own_act.clear();
        self.own_off.clear();
        self.own_off.push(0);
        for s in &self.own {
            self.own_act
                .extend(s.node[..s.len].iter().map(|&g| self.node_map[g]));
            self.own_off.push(self.own_act.len());
        }

        Ok(())
    }

    /// Removes nodes whose lumped mass is below `LIGHT_NODE` of the mean nodal mass from
    /// the stencils, renormalising the weights and shifting the gradients so that
    /// `Σ S = 1` and `Σ ∇S = 0` still hold (momentum stays exact). Such nodes have mass
    /// and stiffness ~S² and make Newton's increments stall without moving any point.
    fn drop_light_nodes(&mut self, grid: &Grid, points: &Points) {
        self.node_mass.clear();
        self.node_mass.resize(grid.node_count(), 0.0);
        let (mut total, mut count) = (0.0, 0usize);
        for (p, s) in self.own.iter().enumerate() {
            for k in 0..s.len {
                if self.node_mass[s.node[k]] == 0.0 {
                    count += 1;
                }
                self.node_mass[s.node[k]] += s.w[k] * points.mass[p];
                total += s.w[k] * points.mass[p];
            }
        }
        let cut = LIGHT_NODE * total / count.max(1) as f64;
        for s in self.own.iter_mut() {
            let mut k = 0;
            let mut dropped = false;
            while k < s.len {
                if self.node_mass[s.node[k]] < cut {
                    s.len -= 1;
                    s.node[k] = s.node[s.len];
                    s.w[k] = s.w[s.len];
                    s.grad[k] = s.grad[s.len];
                    dropped = true;
                } else {
                    k += 1;
                }
            }
            if dropped {
                let wsum: f64 = s.w[..s.len].iter().sum();
                let gsum: Vector2<f64> = s.grad[..s.len].iter().sum();
                for k in 0..s.len {
                    s.w[k] /= wsum;
                    s.grad[k] -= gsum * s.w[k];
                }
            }
        }
    }

    /// Volume-weighted average of the points' gradients over each group.
    pub fn average(&self, grads: &[Vector2<f64>], vol: &[f64], out: &mut [Vector2<f64>]) {
        for g in 0..self.grp_off.len() - 1 {
            let (a, b) = (self.grp_off[g], self.grp_off[g + 1]);
            out[a..b].iter_mut().for_each(|d| *d = Vector2::zeros());
            let mut vsum = 0.0;
            for &p in &self.order[self.grp_pts_off[g]..self.grp_pts_off[g + 1]] {
                vsum += vol[p];
                for k in 0..b - a {
                    out[a + k] += grads[self.pt_off[p] + k] * vol[p];
                }
            }
            out[a..b].iter_mut().for_each(|d| *d /= vsum);
        }
    }
}
