//! Node contact between grains, and between grains and walls, solved by contact dynamics on
//! the common grid (paper Eqs. 11–12, METHODS §4). Every node contact of a packing lives
//! here: detection, the local law and the nonlinear Gauss–Seidel (NLGS).
//!
//! * **Candidates.** A node of the common grid where two grains both have (non-light) mass
//!   gives one contact per pair of grains present (three grains: three contacts, §4.5),
//!   provided the two grains' mass gradients there are within 60° of opposite (`FACING`):
//!   beside a contact both point along the common tangent, and the pair's normal would lie
//!   in the surfaces (gaps of -4 h_g were measured there, and such a node locks sliding).
//!   Wall candidates are those of the single grain (`super::contact::detect`): nodes behind
//!   the wall or less than half a cell in front of it. Candidates whose gap exceeds the alert
//!   distance are dropped for this step.
//! * **Normal** from β into α, `n = (∇m^α - ∇m^β)/|∇m^α - ∇m^β|` with `∇m` the spatial
//!   gradient of the nodal mass at the start of the step, `-Σ_p m_p ∇S_ip` (∇S taken with
//!   respect to the point): one normal per pair, so
//!   `n^α = -n^β` (collinear). Walls use their own normal.
//! * **Gap** from the point clouds near the node (the points with `S_ip > 0`),
//!   `g = min_α (x_p·n - l_p(-n)) - max_β (x_q·n + l_q(n))`, with `l_p(n)` the support
//!   of the point's domain along `n` (`Points::support`: the ellipse on the extents, `Δr/2`
//!   clipped by the seeded circle, carried by `F` with its rotation). Until session 35 the
//!   extents were stretched along the spatial axes, ignoring rotation: a turned surface
//!   point presented its clipped face where its whole one should be (12 grains, 4 seeds ×
//!   2 frictions: a few points pressed into the other grain in 2 of 8 runs before, in none
//!   after; the deepest point pair the same within the runs' scatter).
//! * **Law** between grains, the paper's (Eqs. 11–12, METHODS §4.3): on the end-of-step
//!   relative velocity `v = v^α - v^β` with restitution 0, velocity Signorini with gap
//!   anticipation `v·n + max(g, 0)/Δt >= 0 ⊥ f_n >= 0` and Coulomb on `v·t`. Newmark
//!   makes `v` linear in the relative displacement increment `d = u^α - u^β`:
//!   `v = k (d + s)` with `k = γ/(βΔt)` and a per-contact shift `s` from the start-of-step
//!   nodal velocities and accelerations, so the NLGS works on `d + s`. With the
//!   lumped-mass compliance `W = β Δt² (1/m^α + 1/m^β)` this is the paper's
//!   `f = (2/Δt) m* (v - v_free)` times `Δt/2`; here `W` is the condensed compliance of
//!   the implicit grain, `[K_eff^α]^{-1} + [K_eff^β]^{-1}` on the contact DOFs (METHODS
//!   §4.4B). Why not the end-of-step gap (`d·n + max(g, 0) >= 0`, used before): with the
//!   trapezoidal rule a node stopped in position leaves the step at
//!   `v^{n+1} = 2u/Δt - v^n = -v^n`, an elastic rebound at every impact, and the FLIP
//!   transfer to the points pumped energy into colliding grains (two grains meeting at
//!   1.5 m/s left with 1.4 times their kinetic energy, `tests/mpm_packing.rs`).
//! * **Law** on walls: the end-of-step gap, `d·n + max(g, 0) >= 0` with
//!   `d = u^α - Δt V_w` (shift `s = -Δt V_w`), and Coulomb on the slip increment, as for
//!   the single grain's plates. A wall moves steadily and is where σ is measured: the
//!   velocity law there lets the contact nodes drift with the ringing of `v^n` and the
//!   plate force alternated by ±10 % from step to step on one grain, where the position
//!   law matches the single-grain driver to 1e-3 (`tests/mpm_packing.rs`).
//! * **Start-of-step collisions** at closed grain contacts (`start_collisions`): the
//!   trapezoidal rule moves a node by `Δt (v^n + v^{n+1})/2`, and P2G rebuilds an
//!   approaching `v^n` at every step, so the law above alone lets touching grains sink
//!   into each other by `Δt |v^n·n|/2` a step. A perfectly inelastic normal impulse on
//!   the start-of-step nodal velocities (momentum kept) removes the approach first.
//! * **Surface contacts** (`ContactKind::Surface`, the default): at each grain-pair contact
//!   node the contact acts on the two grains' surface layers instead of the node (the
//!   strip's points within `SURFACE_LAYER` of the gap-setting one). Its slot is the
//!   layer's mean stencil, so its force moves the points that set the gap, which a node
//!   force does not. Same law, normal and gap as the node's; its collisions act on the
//!   slots' pattern velocities.
//! * **Slots.** A contact acts on a slot of each grain, a load pattern `P` of (node,
//!   weight) entries; the condensed compliance is `P^T K^{-1} P`.
//! * **NLGS.** Each contact's local problem uses its diagonal 2×2 block of `W` (projection
//!   of `f_n`, then of `f_t` onto `[-μ f_n, μ f_n]` with the normal–tangential coupling),
//!   and pushes its force change into the slot displacements of both grains through the
//!   full compliance columns, so contacts sharing a grain see each other at once.
//!   Contacts are visited grain pair by grain pair, the pairs coloured so that no two of
//!   one colour share a grain (`super::colour`): a colour's pairs touch disjoint slots and
//!   run on several threads. The order depends on the contacts alone, so a run's bits do
//!   not depend on the thread count. Without friction a pair's contacts are first swept on
//!   the pair's own Delassus block at each visit (block Gauss–Seidel over pairs,
//!   `NlgsParams::pair_sweeps`). Converged when a sweep changes `Σ|Δf|` by less than
//!   `tol` of `Σ|f|`.

use super::colour::Schedule;
use super::contact::{self as plate, Wall};
use super::grid::Grid;
use super::newmark::Newmark;
use super::points::Points;
use super::solve::Solver;
use crate::cd::anderson::Anderson;
use nalgebra::{Matrix2, Vector2};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The other side of a node contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Partner {
    Grain(usize),
    Wall(usize),
}

/// One node contact of the current step.
#[derive(Clone, Copy, Debug)]
pub struct NodeContact {
    /// Node id on the common grid.
    pub node: usize,
    /// Grain on the `+n` side, the node's active index in it, and the contact's slot.
    pub a: usize,
    pub node_a: usize,
    pub slot_a: usize,
    pub partner: Partner,
    /// The same in the partner grain (unused for walls).
    pub node_b: usize,
    pub slot_b: usize,
    /// Unit normal from the partner into `a`.
    pub normal: Vector2<f64>,
    /// Point-cloud gap at the start of the step (m).
    pub gap: f64,
    /// Shift `s` of the law, which holds on `d + s` (m): between grains `(c^α - c^β)/k`
    /// with `c` the part of a node's end-of-step velocity not due to its increment
    /// (`Newmark::velocity_offset`), so that `d + s = v/k`; on a wall `-Δt V_w`.
    pub shift: Vector2<f64>,
    /// The approach the gap allows over the step (m): `max(g, 0)/(k Δt)` between grains,
    /// `max(g, 0)` on a wall.
    pub open: f64,
    pub friction: f64,
    /// For a `ContactKind::Surface` contact, its surface layers (an index into this
    /// step's); `None` for a contact at the node.
    pub surface: Option<usize>,
    /// Normal and tangential force on `a` (N/m), `t = (-n_y, n_x)`; the partner feels
    /// the opposite.
    pub force_n: f64,
    pub force_t: f64,
}

impl NodeContact {
    pub fn tangent(&self) -> Vector2<f64> {
        crate::geom::perp(self.normal)
    }

    /// Force on grain `a` (N/m).
    pub fn force(&self) -> Vector2<f64> {
        self.normal * self.force_n + self.tangent() * self.force_t
    }

    /// The nearest admissible forces: f_n ≥ 0 and |f_t| ≤ μ f_n (f_t = 0 without friction).
    fn admissible(&self, f_n: f64, f_t: f64) -> (f64, f64) {
        let f_n = f_n.max(0.0);
        if self.friction > 0.0 {
            (f_n, f_t.clamp(-self.friction * f_n, self.friction * f_n))
        } else {
            (f_n, 0.0)
        }
    }

    /// Key for warm starts across steps: (node, grain, partner). A run has either node or
    /// surface contacts, so the node names the contact.
    pub fn key(&self) -> (usize, usize, Partner) {
        (self.node, self.a, self.partner)
    }
}

/// One grain as contact detection sees it, after `Solver::begin`.
pub struct GrainView<'a> {
    pub solver: &'a Solver,
    pub points: &'a Points,
    /// The window of the common grid the solver's node ids refer to.
    pub window: &'a Grid,
}

/// Load patterns `P`, one per slot: (active node, weight) entries.
#[derive(Clone, Debug, Default)]
pub struct Patterns {
    /// Slot `k`'s entries are `entries[start[k]..start[k + 1]]`.
    entries: Vec<(usize, f64)>,
    start: Vec<usize>,
}

impl Patterns {
    pub fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Slot `k`'s (active node, weight) entries.
    pub fn entries(&self, k: usize) -> &[(usize, f64)] {
        &self.entries[self.start[k]..self.start[k + 1]]
    }

    /// `P^T x` for a nodal vector `x` (2 per active node), appended to `out`.
    pub fn project(&self, x: &[f64], out: &mut Vec<f64>) {
        for k in 0..self.len() {
            let (mut px, mut py) = (0.0, 0.0);
            for &(i, w) in self.entries(k) {
                px += w * x[2 * i];
                py += w * x[2 * i + 1];
            }
            out.push(px);
            out.push(py);
        }
    }

    /// Adds a slot with this pattern and returns its number.
    fn add(&mut self, entries: impl Iterator<Item = (usize, f64)>) -> usize {
        if self.start.is_empty() {
            self.start.push(0);
        }
        self.entries.extend(entries);
        self.start.push(self.entries.len());
        self.len() - 1
    }
}

/// The contact slots of one grain and their condensed compliance. A slot is where a
/// contact force acts and where its displacement is read: a load pattern `P` of (active
/// node, weight) entries. A node contact's slot is its node with weight 1, shared by the
/// contacts at that node; a surface contact's is the mean of its layer's stencils `S_ip`.
#[derive(Clone, Debug, Default)]
pub struct Slots {
    pub patterns: Patterns,
    /// `P^T [K_eff]^{-1} P` on the slots (2 per slot), column-major, `2s × 2s`: computed in
    /// double precision, kept in single. A sweep pushes each contact's change through its
    /// grains' whole compliance columns, so it reads every grain's compliance once: on the
    /// paper's 300 grains an estimated 20-35 MB in double precision (40-60 slots a grain),
    /// against a 32 MB last-level cache here. Single precision halves that traffic. Its
    /// rounding (6e-8 of an entry) is far below the NLGS tolerance (1e-6 of Σ|f|) and the
    /// coupling's (1e-5), and the local solves and the pushes read the same rounded,
    /// symmetric operator. Measured on the last 156 steps of the 300-grain μ = 0.5
    /// case resumed from one snapshot: 957 s against 1,298 s, the NLGS 595 s against 941 s
    /// for the same sweeps, Φ, Z and σ at ε = 0.45 the same to three digits
    /// (`bench/README-packings.md`, "The compliance in single precision").
    pub compliance: Vec<f32>,
    /// Predicted displacement of each slot (`P^T u`) for the current forces.
    pub disp: Vec<f64>,
}

impl Slots {
    pub fn len(&self) -> usize {
        self.patterns.len()
    }

    pub fn is_empty(&self) -> bool {
        self.patterns.is_empty()
    }

    /// Slot `k`'s (active node, weight) entries.
    pub fn entries(&self, k: usize) -> &[(usize, f64)] {
        self.patterns.entries(k)
    }

    fn dim(&self) -> usize {
        2 * self.len()
    }

    /// The 2×2 block of the compliance between slots `s` and `r`.
    fn block(&self, s: usize, r: usize) -> Matrix2<f64> {
        let n = self.dim();
        let c = |k: usize| f64::from(self.compliance[k]);
        Matrix2::new(
            c(2 * r * n + 2 * s),
            c((2 * r + 1) * n + 2 * s),
            c(2 * r * n + 2 * s + 1),
            c((2 * r + 1) * n + 2 * s + 1),
        )
    }

    fn disp(&self, s: usize) -> Vector2<f64> {
        Vector2::new(self.disp[2 * s], self.disp[2 * s + 1])
    }

    /// `disp += C[:, slot r] f`.
    fn push(&mut self, r: usize, f: Vector2<f64>) {
        let n = self.dim();
        let (cx, cy) = (
            &self.compliance[2 * r * n..][..n],
            &self.compliance[(2 * r + 1) * n..][..n],
        );
        // (zipped slices: no bounds checks, so the loop vectorises)
        for ((d, a), b) in self.disp.iter_mut().zip(cx).zip(cy) {
            *d += f64::from(*a) * f.x + f64::from(*b) * f.y;
        }
    }
}

/// Where grain-pair contacts act (walls always act at nodes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactKind {
    /// At the contact node (the paper's Eqs. 11–12).
    Node,
    /// Instead of the node, on the two grains' surface layers there (the same candidate
    /// nodes, normals, gaps and law): the points within `SURFACE_LAYER` of the
    /// gap-setting point on each side. Its force is spread over the layer's points (equal
    /// shares, each by its `S_ip`) and its displacement is read back through the same
    /// weights, so that force and gap are work-conjugate. A node force moves the node, not
    /// the points that set the gap (`bench/README-packings.md`, "Why held nodes do not
    /// hold the points"). Until session 26 the node contact stayed beside it: the same
    /// overlap and σ within 3% on 12 grains, at 1.6-2.2 times the time (README). The
    /// default since session 33 (`config::defaults::MPM_CONTACT`).
    Surface,
}

/// Depth of a surface layer, in cells: one cell deep. With a single point (the
/// gap-setting one) the force is a point load that dents it and lets its neighbours
/// through (0.58 of Johnson's force on the two-grain stack).
pub const SURFACE_LAYER: f64 = 1.0;

/// Smallest cosine between one grain's spatial mass gradient and minus the other's for a
/// node to be a contact candidate (60°).
pub const FACING: f64 = 0.5;

/// Common-grid id of node `id` of `window` (a window of `grid`).
pub fn global_node(grid: &Grid, window: &Grid, id: usize) -> usize {
    let off = (window.origin - grid.origin) / grid.h;
    let (i0, j0) = (off.x.round() as usize, off.y.round() as usize);
    (id / window.nx + j0) * grid.nx + id % window.nx + i0
}

/// Finds this step's node contacts (grain pairs first, ordered by node, then walls by grain;
/// `super::colour::order` then orders them for the NLGS) and numbers each grain's contact
/// slots. `friction` is the inter-grain coefficient;
/// walls carry their own. `alert` drops candidates with a larger gap. `nm` and `dt` set
/// each contact's velocity law; the grain pairs' shifts are left to `start_collisions`.
/// With `ContactKind::Surface` each grain-pair contact acts on its surface layers instead
/// of its node (walls always at nodes).
#[allow(clippy::too_many_arguments)]
pub fn detect(
    grid: &Grid,
    grains: &[GrainView],
    walls: &[Wall],
    friction: f64,
    nm: Newmark,
    dt: f64,
    alert: f64,
    kind: ContactKind,
    out: &mut Vec<NodeContact>,
    slots: &mut Vec<Slots>,
) {
    out.clear();
    let k = nm.velocity_rate(dt);
    // Every (common node, grain, active index), sorted by node then grain.
    let mut entries: Vec<(usize, usize, usize)> = Vec::new();
    for (g, v) in grains.iter().enumerate() {
        for (i, &id) in v.solver.nodes().iter().enumerate() {
            entries.push((global_node(grid, v.window, id), g, i));
        }
    }
    entries.sort_unstable();
    // Shared nodes: flag them per grain, and list the points that reach them.
    let mut shared: Vec<Vec<bool>> = grains
        .iter()
        .map(|v| vec![false; v.solver.nodes().len()])
        .collect();
    let mut pairs = Vec::new();
    let mut layers: Vec<[Vec<usize>; 2]> = Vec::new();
    let mut start = 0;
    while start < entries.len() {
        let mut end = start + 1;
        while end < entries.len() && entries[end].0 == entries[start].0 {
            end += 1;
        }
        for x in start..end {
            for y in x + 1..end {
                let ((node, ga, ia), (_, gb, ib)) = (entries[x], entries[y]);
                shared[ga][ia] = true;
                shared[gb][ib] = true;
                pairs.push((node, ga, ia, gb, ib));
            }
        }
        start = end;
    }
    let reached: Vec<Vec<Vec<usize>>> = grains
        .iter()
        .zip(&shared)
        .map(|(v, flags)| {
            let mut lists = vec![Vec::new(); flags.len()];
            if flags.iter().any(|&f| f) {
                for p in 0..v.points.len() {
                    for &i in v.solver.point_nodes(p) {
                        if flags[i] {
                            lists[i].push(p);
                        }
                    }
                }
            }
            lists
        })
        .collect();
    for &(node, ga, ia, gb, ib) in &pairs {
        // Normal from grain gb into grain ga. The solver's `Σ m_p ∇S_ip` is taken with
        // respect to the point, so it is minus the spatial mass gradient at the node.
        let (ma, mb) = (
            -grains[ga].solver.mass_gradient()[ia],
            -grains[gb].solver.mass_gradient()[ib],
        );
        // The two surfaces must face each other: spatial gradients within 60° of opposite.
        // (Beside a contact both gradients point along the common tangent; the pair's
        // normal then lies in the surfaces, the clouds' projections overlap by cells and the
        // node would lock their sliding.)
        if ma.dot(&-mb) < FACING * ma.norm() * mb.norm() {
            continue;
        }
        let d = ma - mb;
        let len = d.norm();
        if len.is_nan() || len <= 0.0 {
            continue;
        }
        let n = d / len;
        // Only the points within half a cell of the node across the normal: over the
        // whole support a tilted normal adds the clouds' lateral spread to the gap.
        let (t, xi) = (crate::geom::perp(n), grid.node_position(node));
        let near = |x: &Vector2<f64>| (x - xi).dot(&t).abs() <= 0.5 * grid.h;
        // each point's face toward the other grain, along n
        let face_a = |p: usize| grains[ga].points.x[p].dot(&n) - grains[ga].points.support(p, &-n);
        let face_b = |q: usize| grains[gb].points.x[q].dot(&n) + grains[gb].points.support(q, &n);
        let (side_a, side_b) = (
            reached[ga][ia]
                .iter()
                .copied()
                .filter(|&p| near(&grains[ga].points.x[p])),
            reached[gb][ib]
                .iter()
                .copied()
                .filter(|&q| near(&grains[gb].points.x[q])),
        );
        let lo = side_a.clone().map(face_a).fold(f64::INFINITY, f64::min);
        let hi = side_b.clone().map(face_b).fold(f64::NEG_INFINITY, f64::max);
        let gap = lo - hi;
        if gap.is_finite() && gap < alert {
            let node_contact = NodeContact {
                node,
                a: ga,
                node_a: ia,
                slot_a: 0,
                partner: Partner::Grain(gb),
                node_b: ib,
                slot_b: 0,
                normal: n,
                gap,
                // set by `start_collisions`, from the start-of-step velocities it changes
                shift: Vector2::zeros(),
                open: gap.max(0.0) / (k * dt),
                friction,
                surface: None,
                force_n: 0.0,
                force_t: 0.0,
            };
            match kind {
                ContactKind::Node => out.push(node_contact),
                ContactKind::Surface => {
                    let depth = SURFACE_LAYER * grid.h;
                    layers.push([
                        side_a.filter(|&p| face_a(p) <= lo + depth).collect(),
                        side_b.filter(|&q| face_b(q) >= hi - depth).collect(),
                    ]);
                    out.push(NodeContact {
                        surface: Some(layers.len() - 1),
                        ..node_contact
                    });
                }
            }
        }
    }
    // Walls, with the single grain's detection.
    let mut found = Vec::new();
    let mut scratch = Vec::new();
    for (g, v) in grains.iter().enumerate() {
        let pos: Vec<Vector2<f64>> = v
            .solver
            .nodes()
            .iter()
            .map(|&id| v.window.node_position(id))
            .collect();
        plate::detect(
            walls,
            v.window,
            v.points,
            &pos,
            |p| v.solver.point_nodes(p),
            dt,
            &mut scratch,
            &mut found,
        );
        for c in found.iter().filter(|c| c.gap < alert) {
            let w = &walls[c.wall];
            out.push(NodeContact {
                node: global_node(grid, v.window, v.solver.nodes()[c.node]),
                a: g,
                node_a: c.node,
                slot_a: 0,
                partner: Partner::Wall(c.wall),
                node_b: 0,
                slot_b: 0,
                normal: w.normal,
                gap: c.gap,
                // position law (see the module doc): `d = u^α - Δt V_w`
                shift: -w.velocity * dt,
                open: c.gap.max(0.0),
                friction: w.friction,
                surface: None,
                force_n: 0.0,
                force_t: 0.0,
            });
        }
    }
    // Slots, per grain: one per contact node, and one per surface contact side.
    slots.clear();
    slots.resize(grains.len(), Slots::default());
    let mut by_node: Vec<Vec<usize>> = grains
        .iter()
        .map(|v| vec![usize::MAX; v.solver.nodes().len()])
        .collect();
    let mut slot_of =
        |g: usize, node: usize, layer: Option<&Vec<usize>>, slots: &mut Vec<Slots>| {
            match layer {
                Some(pts) => {
                    // equal shares of the layer's points, each spread by its stencil
                    let share = 1.0 / pts.len() as f64;
                    let mut e: Vec<(usize, f64)> = pts
                        .iter()
                        .flat_map(|&p| grains[g].solver.point_stencil(p))
                        .map(|(i, w)| (i, w * share))
                        .collect();
                    e.sort_by_key(|x| x.0);
                    // one entry per node, its shares summed in order
                    e.dedup_by(|next, last| {
                        let same = next.0 == last.0;
                        if same {
                            last.1 += next.1;
                        }
                        same
                    });
                    slots[g].patterns.add(e.into_iter())
                }
                None => {
                    if by_node[g][node] == usize::MAX {
                        by_node[g][node] = slots[g].patterns.add(std::iter::once((node, 1.0)));
                    }
                    by_node[g][node]
                }
            }
        };
    for c in out.iter_mut() {
        let layer = c.surface.map(|k| &layers[k]);
        c.slot_a = slot_of(c.a, c.node_a, layer.map(|l| &l[0]), slots);
        if let Partner::Grain(b) = c.partner {
            c.slot_b = slot_of(b, c.node_b, layer.map(|l| &l[1]), slots);
        }
    }
}

/// Start-of-step collisions at closed grain contacts (`g <= 0`). The law holds the
/// end-of-step velocity, but the trapezoidal rule moves a node by `Δt (v^n + v^{n+1})/2`,
/// and P2G rebuilds `v^n` from the points at every step, where the bulk of a grain still
/// moves toward its contact: a node already touching would sink by `Δt |v^n·n|/2` per step
/// (a ratchet, measured at 0.4-0.65 h_g over a compaction). So each closed contact whose
/// nodes approach first takes a perfectly inelastic normal impulse on the start-of-step
/// velocities, `j = -v_n m^α m^β/(m^α + m^β)` (momentum kept, energy only lost), given
/// to the points in G2P; then each grain pair's shift, which depends on `v^n`, is set.
/// Velocities and masses are the slots' (`pattern_velocity`, `pattern_mass`): a node's
/// own for a node contact.
pub fn start_collisions<G: AsRef<Solver> + AsMut<Solver>>(
    contacts: &mut [NodeContact],
    slots: &[Slots],
    grains: &mut [G],
    nm: Newmark,
    dt: f64,
) {
    for c in contacts.iter() {
        let Partner::Grain(b) = c.partner else {
            continue;
        };
        if c.gap > 0.0 {
            continue;
        }
        let (ea, eb) = (slots[c.a].entries(c.slot_a), slots[b].entries(c.slot_b));
        let (sa, sb) = (grains[c.a].as_ref(), grains[b].as_ref());
        let vn = (pattern_velocity(sa, ea) - pattern_velocity(sb, eb)).dot(&c.normal);
        if vn >= 0.0 {
            continue;
        }
        let (ma, mb) = (pattern_mass(sa, ea), pattern_mass(sb, eb));
        let j = -vn * ma * mb / (ma + mb);
        for (g, e, sign) in [(c.a, ea, 1.0), (b, eb, -1.0)] {
            let s = grains[g].as_mut();
            for &(i, w) in e {
                let m = s.node_mass()[i];
                s.kick(i, c.normal * (sign * j * w / m), dt);
            }
        }
    }
    // `c / k` at a grain's active node
    let k = nm.velocity_rate(dt);
    let free = |g: usize, slot: usize| -> Vector2<f64> {
        let s = grains[g].as_ref();
        slots[g]
            .entries(slot)
            .iter()
            .map(|&(i, w)| {
                nm.velocity_offset(s.node_velocity()[i], s.node_acceleration()[i], dt) / k * w
            })
            .sum()
    };
    for c in contacts.iter_mut() {
        if let Partner::Grain(b) = c.partner {
            c.shift = free(c.a, c.slot_a) - free(b, c.slot_b);
        }
    }
}

/// Start-of-step velocity of a slot's pattern, `Σ w v_i`.
fn pattern_velocity(s: &Solver, e: &[(usize, f64)]) -> Vector2<f64> {
    e.iter().map(|&(i, w)| s.node_velocity()[i] * w).sum()
}

/// The mass a force spread by the pattern's weights moves, `1/Σ (w²/m_i)` (a node's own
/// mass for the node contact).
fn pattern_mass(s: &Solver, e: &[(usize, f64)]) -> f64 {
    match e {
        [(i, w)] if *w == 1.0 => s.node_mass()[*i],
        _ => {
            1.0 / e
                .iter()
                .map(|&(i, w)| w * w / s.node_mass()[i])
                .sum::<f64>()
        }
    }
}

/// Sets the contacts' forces from the previous step's, matched by `NodeContact::key`
/// (`previous` sorted by key).
pub fn warm_start(contacts: &mut [NodeContact], previous: &[((usize, usize, Partner), f64, f64)]) {
    for c in contacts.iter_mut() {
        if let Ok(k) = previous.binary_search_by(|e| e.0.cmp(&c.key())) {
            (c.force_n, c.force_t) = (previous[k].1, previous[k].2);
        }
    }
}

/// The contacts carrying a force, for the next warm start (sorted by key).
pub fn remember(contacts: &[NodeContact], out: &mut Vec<((usize, usize, Partner), f64, f64)>) {
    out.clear();
    out.extend(
        contacts
            .iter()
            .filter(|c| c.force_n > 0.0)
            .map(|c| (c.key(), c.force_n, c.force_t)),
    );
    out.sort_unstable_by_key(|x| x.0);
}

/// NLGS stopping rule and acceleration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NlgsParams {
    /// Converged when a sweep changes the forces by less than `tol Σ|f|`.
    pub tol: f64,
    pub max_sweeps: usize,
    /// Anderson acceleration's history depth (`crate::cd::anderson`), one sweep per block;
    /// 0 = plain NLGS.
    pub anderson: usize,
    /// Stop, unconverged, when a window of this many sweeps has not halved the best
    /// convergence ratio (change over Σ|f|): frictional contacts trading stick for slip
    /// keep it near 1e-5 for as long as one lets them. An accelerated solve that stalls
    /// first goes on with plain sweeps, judged by the next windows: Anderson can cycle
    /// where plain sweeps converge (the unit test below). 0 = never.
    pub stall_window: usize,
    /// Sweeps over one frictionless grain pair's contacts on their own Delassus block at each
    /// visit of the pair, before its force changes reach the rest of its grains' slots
    /// (block Gauss–Seidel over pairs, `Pair::sweep`); 1 = plain NLGS. Neighbouring slots of
    /// one pair push on nearly the same rigid motion, so their block is close to singular
    /// and plain sweeps crawl along it.
    pub pair_sweeps: usize,
}

impl Default for NlgsParams {
    fn default() -> Self {
        NlgsParams {
            tol: 1e-6,
            max_sweeps: 20_000,
            anderson: 0,
            stall_window: 0,
            pair_sweeps: 1,
        }
    }
}

impl NlgsParams {
    /// The packings' NLGS for each contact kind. The node contact's is plain. The surface
    /// contact's spends half or more of a step in the NLGS (51% on the paper's 300 grains
    /// without friction), whose solves need a median of 31 sweeps but a tenth of them over
    /// 850 (16 grains, μ = 0.5): Anderson acceleration (depth 8) cuts that tenth to 175. With
    /// friction the plain solve also hits `max_sweeps` (20,000) in 2% of the solves, its
    /// change per sweep stuck near 1e-5 of Σ|f| as contacts trade stick for slip, and
    /// Anderson, restarting at every such trade, in 4%: a stall window of 500 sweeps stops
    /// them. On `mpm-packing-small.yaml` (16 grains to ε = 0.35, one run each) this takes
    /// the sweeps from 1.49 M to 0.13 M (μ = 0.5) and the time from 32.5 to 17.7 s; without
    /// friction, Anderson alone, from 29.2 to 22.4 s, and over three more seeds from 179 to
    /// 138 s in all. The results move within the runs' scatter: σ(0.35) 1.074 against 1.088
    /// MPa at μ = 0.5; without friction -6, 0 and -2% on the three seeds, whose σ spans
    /// 0.70-0.85 MPa. On the 300 grains past ε = 0.37 (μ = 0) one ten-minute comparison
    /// showed no clear gain per CPU second (`bench/README-packings.md`). Going on with plain
    /// sweeps once the accelerated ones stall (session 36) took the 16 grains' stopped
    /// solves at μ = 0.5 from 24 to 9 over four seeds, in the same time (97.0 s against
    /// 96.2 s in all).
    pub fn for_packing(kind: ContactKind, friction: f64) -> Self {
        match kind {
            ContactKind::Node => NlgsParams::default(),
            ContactKind::Surface => NlgsParams {
                anderson: 8,
                stall_window: if friction > 0.0 { 500 } else { 0 },
                pair_sweeps: if friction > 0.0 { 1 } else { PAIR_SWEEPS },
                ..NlgsParams::default()
            },
        }
    }
}

/// `NlgsParams::pair_sweeps` of the frictionless surface contact. Measured on
/// `mpm-packing-small.yaml` without friction (16 grains to ε = 0.35, seeds 1, 2, 3, 7, 8, 9,
/// 10): 3.0-4.5 times fewer sweeps, a third less NLGS time, 0.91 of the wall time (mean),
/// σ(0.35) within the seeds' spread (ratio 0.96-1.14); 50 sweeps did no better than 20. The
/// deepest point pair comes out a few hundredths of a cell deeper, as with plain sweeps run
/// to 1e-8: it is the converged contact problem's (plain sweeps at 1e-6 stop short along a
/// pair's near-singular direction and leave its force spread over the pair's slots). With
/// friction the pair's own sweeps, which need not converge (stick and slip trade between
/// its contacts), made the solves stall: 41 stopped against 2 (seed 7, 20 sweeps), so
/// frictional packings sweep plainly (`bench/README-packings.md`, "Sweeping a grain pair on
/// its own block").
pub const PAIR_SWEEPS: usize = 20;

/// How an NLGS solve ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NlgsOutcome {
    pub sweeps: usize,
    pub converged: bool,
    /// The last sweep's change over `tol Σ|f|`: at most 1 when converged, and how far from
    /// the tolerance a solve stopped by the stall window or the cap was.
    pub residual: f64,
}

/// Adds the current contact forces into `slots[g].disp` (`disp = free + C f`); call once
/// after the slots' free displacements and compliances are set.
pub fn load_slots(contacts: &[NodeContact], slots: &mut [Slots]) {
    for c in contacts {
        Sides::of(slots, c).push(c, c.force());
    }
}

/// Solves the contact laws for the displacements `slots[g].disp` (loaded with the current
/// forces, see `load_slots`). `floor` is a force below which `Σ|f|` counts as zero.
/// With `params.anderson > 0` each sweep is a block of Anderson's fixed-point acceleration
/// (`anderson` keeps its buffers between calls); the stopping test is still a plain sweep's.
/// Contacts are swept in `schedule`'s order (`super::colour::order`), the grain pairs of
/// one colour on several threads when there are enough of them.
pub fn nlgs(
    contacts: &mut [NodeContact],
    slots: &mut [Slots],
    schedule: &Schedule,
    params: NlgsParams,
    floor: f64,
    anderson: &mut Anderson,
) -> NlgsOutcome {
    if contacts.is_empty() {
        return NlgsOutcome {
            sweeps: 0,
            converged: true,
            residual: 0.0,
        };
    }
    let mut accelerate = params.anderson > 0;
    if accelerate {
        // residual weights: the diagonal compliances along n and t (a displacement)
        anderson.reset(
            params.anderson,
            contacts.iter().map(|c| {
                let w = Sides::of(slots, c).diagonal(c);
                let (n, t) = (c.normal, c.tangent());
                (n.dot(&(w * n)), t.dot(&(w * t)), c.friction > 0.0)
            }),
        );
    }
    // the best convergence ratio so far, and at the start of the current window
    let (mut best, mut window_start) = (f64::INFINITY, f64::INFINITY);
    let mut residual = f64::INFINITY;
    let mut parts = Vec::new();
    let mut block = Block::default();
    for sweep in 1..=params.max_sweeps {
        if accelerate {
            anderson.begin(forces(contacts));
        }
        let (mut change, mut total) = (0.0, 0.0);
        for (bounds, disjoint) in schedule.colours() {
            for (dc, dt) in sweep_colour(
                contacts, slots, bounds, disjoint, params, &mut block, &mut parts,
            ) {
                change += dc;
                total += dt;
            }
        }
        let ratio = change / total.max(floor);
        residual = ratio / params.tol;
        if change <= params.tol * total.max(floor) {
            return NlgsOutcome {
                sweeps: sweep,
                converged: true,
                residual,
            };
        }
        best = best.min(ratio);
        if params.stall_window > 0 && sweep % params.stall_window == 0 {
            if best > 0.5 * window_start {
                if !accelerate {
                    return NlgsOutcome {
                        sweeps: sweep,
                        converged: false,
                        residual,
                    };
                }
                // Anderson caught in a cycle of restarts (each extrapolation turning a
                // contact between stick and slip, as two neighbouring contacts of one pair
                // can): plain sweeps from here, stopped by the same window
                accelerate = false;
            }
            window_start = best;
        }
        if accelerate && let Some(next) = anderson.next(forces(contacts)) {
            // the extrapolated forces, brought back onto each contact's admissible set
            for (k, c) in contacts.iter_mut().enumerate() {
                let (f_n, f_t) = next(k);
                let (f_n, f_t) = c.admissible(f_n, f_t);
                Sides::of(slots, c).set_force(c, f_n, f_t);
            }
        }
    }
    NlgsOutcome {
        sweeps: params.max_sweeps,
        converged: false,
        residual,
    }
}

/// (slot, f_n, f_t) of every contact, for Anderson's vectors.
fn forces(contacts: &[NodeContact]) -> impl Iterator<Item = (usize, f64, f64)> + '_ {
    contacts
        .iter()
        .enumerate()
        .map(|(k, c)| (k, c.force_n, c.force_t))
}

/// Colours with fewer contacts are swept on one thread (the same order and bits either
/// way; below it the threads' hand-over costs more than the sweep).
const PARALLEL_MIN: usize = 256;

/// One sweep over the grain pairs of one colour (group boundaries `bounds`, disjoint in
/// their grains if `disjoint`): each pair's contacts in order, their (Σ|Δf|, Σ|f|) per
/// pair in `parts`, returned.
fn sweep_colour<'p>(
    contacts: &mut [NodeContact],
    slots: &mut [Slots],
    bounds: &[usize],
    disjoint: bool,
    params: NlgsParams,
    block: &mut Block,
    parts: &'p mut Vec<(f64, f64)>,
) -> &'p [(f64, f64)] {
    parts.clear();
    let threads = rayon::current_num_threads() > 1;
    let contacts_here = bounds[bounds.len() - 1] - bounds[0];
    if disjoint && threads && contacts_here >= PARALLEL_MIN && bounds.len() > 2 {
        // every pair takes its grains' slots out first (no two share a grain here)
        let mut work: Vec<Pair> = pairs(contacts, bounds)
            .map(|own| Pair::take(own, slots))
            .collect();
        work.par_iter_mut()
            .map_init(Block::default, |b, p| {
                p.sweep(params.pair_sweeps, params.tol, b)
            })
            .collect_into_vec(parts);
        work.into_iter().for_each(|pair| pair.give_back(slots));
    } else {
        // one pair at a time, its slots given back before the next takes its own
        for own in pairs(contacts, bounds) {
            let mut pair = Pair::take(own, slots);
            parts.push(pair.sweep(params.pair_sweeps, params.tol, block));
            pair.give_back(slots);
        }
    }
    parts
}

/// Each pair's contacts, for group boundaries `bounds` (`sweep_colour`).
fn pairs<'c>(
    contacts: &'c mut [NodeContact],
    bounds: &'c [usize],
) -> impl Iterator<Item = &'c mut [NodeContact]> + 'c {
    let mut rest = &mut contacts[bounds[0]..bounds[bounds.len() - 1]];
    bounds.windows(2).map(move |w| {
        let (own, tail) = std::mem::take(&mut rest).split_at_mut(w[1] - w[0]);
        rest = tail;
        own
    })
}

/// A pair visit's buffers (`Pair::sweep`), kept from visit to visit so that a sweep does
/// not allocate: the pair's cross-compliances, relative displacements and starting forces.
#[derive(Default)]
struct Block {
    w: Vec<Matrix2<f64>>,
    d: Vec<Vector2<f64>>,
    start: Vec<Vector2<f64>>,
}

/// A grain pair's contacts with its grains' slots, taken out of the packing's so that the
/// pairs of one colour can be swept on any thread.
struct Pair<'c> {
    contacts: &'c mut [NodeContact],
    a: Slots,
    b: Option<Slots>,
}

impl<'c> Pair<'c> {
    fn take(contacts: &'c mut [NodeContact], slots: &mut [Slots]) -> Self {
        let c = &contacts[0];
        let a = std::mem::take(&mut slots[c.a]);
        let b = match c.partner {
            Partner::Grain(b) => Some(std::mem::take(&mut slots[b])),
            Partner::Wall(_) => None,
        };
        Pair { contacts, a, b }
    }

    /// One visit of the pair; returns (Σ|Δf|, Σ|f|) over it. A frictionless pair of several
    /// contacts with `inner > 1` is swept up to `inner` times (until a sweep changes its
    /// forces by at most `tol` of theirs) on its own Delassus block, each contact's change
    /// moving the pair's relative displacements alone; the visit's changes then reach all
    /// slots of its grains. The fixed point is the plain NLGS's.
    fn sweep(&mut self, inner: usize, tol: f64, block: &mut Block) -> (f64, f64) {
        let mut sides = Sides {
            a: &mut self.a,
            b: self.b.as_mut(),
        };
        let k = self.contacts.len();
        if inner <= 1 || k == 1 || self.contacts.iter().any(|c| c.friction > 0.0) {
            let mut part = (0.0, 0.0);
            for c in self.contacts.iter_mut() {
                let df = local(c, sides.disp(c), &sides.diagonal(c));
                if df != Vector2::zeros() {
                    sides.push(c, df);
                }
                part.0 += df.x.abs() + df.y.abs();
                part.1 += c.force_n.abs() + c.force_t.abs();
            }
            return part;
        }
        // w[i k + j]: contact i's relative displacement per unit force on contact j
        let cs = &mut *self.contacts;
        let Block { w, d, start } = block;
        w.clear();
        for ci in cs.iter() {
            for cj in cs.iter() {
                w.push(sides.cross(ci, cj));
            }
        }
        d.clear();
        d.extend(cs.iter().map(|c| sides.disp(c)));
        start.clear();
        start.extend(cs.iter().map(|c| c.force()));
        for _ in 0..inner {
            let (mut change, mut total) = (0.0, 0.0);
            for i in 0..k {
                let df = local(&mut cs[i], d[i], &w[i * k + i]);
                if df != Vector2::zeros() {
                    for (j, dj) in d.iter_mut().enumerate() {
                        *dj += w[j * k + i] * df;
                    }
                }
                change += df.x.abs() + df.y.abs();
                total += cs[i].force_n.abs() + cs[i].force_t.abs();
            }
            if change <= tol * total {
                break;
            }
        }
        let mut part = (0.0, 0.0);
        for (c, f0) in cs.iter().zip(start.iter()) {
            let df = c.force() - f0;
            if df != Vector2::zeros() {
                sides.push(c, df);
            }
            part.0 += df.x.abs() + df.y.abs();
            part.1 += c.force_n.abs() + c.force_t.abs();
        }
        part
    }

    fn give_back(self, slots: &mut [Slots]) {
        let c = &self.contacts[0];
        slots[c.a] = self.a;
        if let (Partner::Grain(g), Some(b)) = (c.partner, self.b) {
            slots[g] = b;
        }
    }
}

/// The local solve at one contact: the projection of `f_n`, then of `f_t` onto
/// `[-μ f_n, μ f_n]`, on its diagonal Delassus block `w` with its slots' relative
/// displacement `d`; sets its forces and returns the change of the force on `a`.
fn local(c: &mut NodeContact, d: Vector2<f64>, w: &Matrix2<f64>) -> Vector2<f64> {
    let (n, t) = (c.normal, c.tangent());
    // grains: the end-of-step relative velocity over k; walls: the increment relative to
    // the wall's
    let d = d + c.shift;
    let (wn, wt, wtn) = (n.dot(&(w * n)), t.dot(&(w * t)), t.dot(&(w * n)));
    let fn_new = (c.force_n - (d.dot(&n) + c.open) / wn).max(0.0);
    let slip = d.dot(&t) + wtn * (fn_new - c.force_n);
    let (fn_new, ft_new) = c.admissible(fn_new, c.force_t - slip / wt);
    let df = n * (fn_new - c.force_n) + t * (ft_new - c.force_t);
    (c.force_n, c.force_t) = (fn_new, ft_new);
    df
}

/// The slots of a contact's two grains (no partner's for a wall).
struct Sides<'s> {
    a: &'s mut Slots,
    b: Option<&'s mut Slots>,
}

impl<'s> Sides<'s> {
    fn of(slots: &'s mut [Slots], c: &NodeContact) -> Self {
        match c.partner {
            Partner::Wall(_) => Sides {
                a: &mut slots[c.a],
                b: None,
            },
            Partner::Grain(b) => {
                let (a, b) = if c.a < b {
                    let (lo, hi) = slots.split_at_mut(b);
                    (&mut lo[c.a], &mut hi[0])
                } else {
                    let (lo, hi) = slots.split_at_mut(c.a);
                    (&mut hi[0], &mut lo[b])
                };
                Sides { a, b: Some(b) }
            }
        }
    }

    /// The contact's Delassus block: the sum of its two slots' diagonal compliances.
    fn diagonal(&self, c: &NodeContact) -> Matrix2<f64> {
        self.cross(c, c)
    }

    /// The relative displacement of contact `c`'s slots per unit force on contact `e`'s
    /// (both of this pair): the sum of the two grains' compliance blocks.
    fn cross(&self, c: &NodeContact, e: &NodeContact) -> Matrix2<f64> {
        let w = self.a.block(c.slot_a, e.slot_a);
        match &self.b {
            Some(b) => w + b.block(c.slot_b, e.slot_b),
            None => w,
        }
    }

    /// The slots' relative displacement, `a`'s less the partner's (zero for a wall).
    fn disp(&self, c: &NodeContact) -> Vector2<f64> {
        let ua = self.a.disp(c.slot_a);
        match &self.b {
            Some(b) => ua - b.disp(c.slot_b),
            None => ua,
        }
    }

    /// Moves the slots' displacements by a force `f` on `a` (and `-f` on the partner).
    fn push(&mut self, c: &NodeContact, f: Vector2<f64>) {
        self.a.push(c.slot_a, f);
        if let Some(b) = &mut self.b {
            b.push(c.slot_b, -f);
        }
    }

    /// Sets the contact's forces and moves its slots' displacements by the change;
    /// returns it.
    fn set_force(&mut self, c: &mut NodeContact, f_n: f64, f_t: f64) -> Vector2<f64> {
        let df = c.normal * (f_n - c.force_n) + c.tangent() * (f_t - c.force_t);
        (c.force_n, c.force_t) = (f_n, f_t);
        if df != Vector2::zeros() {
            self.push(c, df);
        }
        df
    }
}

/// Adds each contact's force into its grains' nodal force vectors `fc[g]` (2 per active node).
pub fn scatter(contacts: &[NodeContact], slots: &[Slots], fc: &mut [Vec<f64>]) {
    let mut add = |g: usize, slot: usize, f: Vector2<f64>| {
        for &(i, w) in slots[g].entries(slot) {
            fc[g][2 * i] += f.x * w;
            fc[g][2 * i + 1] += f.y * w;
        }
    };
    for c in contacts {
        let f = c.force();
        add(c.a, c.slot_a, f);
        if let Partner::Grain(b) = c.partner {
            add(b, c.slot_b, -f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two grains touching at two neighbouring surface slots, both sides' 2×2 compliance
    /// blocks `[[b00, b01], [b10, b11]]` by slot pair (00, 01, 10, 11), as recorded in the
    /// 300-grain paper-mpm run at μ = 0.5 (grains 211 and 222 colliding in flight at
    /// ε = 0.0226, session 36). The two contacts push on nearly the same rigid motion, so
    /// their Delassus matrix is close to singular: plain sweeps contract by about 1% a
    /// sweep, and Anderson's extrapolations turned the sticking contact's neighbour from
    /// slip to stick and back in a cycle of four sweeps that never halved its best ratio.
    fn colliding_pair() -> (Vec<NodeContact>, Vec<Slots>) {
        let grain = |blocks: [[f64; 4]; 4], disp: [f64; 4]| {
            let mut patterns = Patterns::default();
            patterns.add([(0, 1.0)].into_iter());
            patterns.add([(1, 1.0)].into_iter());
            // column-major 4×4: entry (2s + i, 2r + j) is block (s, r)'s (i, j)
            let mut compliance = vec![0.0; 16];
            for (k, b) in blocks.iter().enumerate() {
                let (s, r) = (k / 2, k % 2);
                for (e, v) in b.iter().enumerate() {
                    let (i, j) = (e / 2, e % 2);
                    compliance[(2 * r + j) * 4 + 2 * s + i] = *v as f32;
                }
            }
            Slots {
                patterns,
                compliance,
                disp: disp.to_vec(),
            }
        };
        let slots = vec![
            grain(
                [
                    [
                        4.769138569557262e-7,
                        1.6629954861663033e-7,
                        1.6629954861663025e-7,
                        6.895098516234757e-7,
                    ],
                    [
                        4.911734488831231e-7,
                        1.709804943316696e-7,
                        1.8203948653646945e-7,
                        6.999276908128114e-7,
                    ],
                    [
                        4.911734488831229e-7,
                        1.8203948653646956e-7,
                        1.709804943316697e-7,
                        6.999276908128113e-7,
                    ],
                    [
                        5.09494765125317e-7,
                        1.875498673583982e-7,
                        1.8754986735839825e-7,
                        7.129804393026727e-7,
                    ],
                ],
                [
                    4.536566556873676e-6,
                    -3.467757969284278e-6,
                    4.597675768601397e-6,
                    -3.5002596376700105e-6,
                ],
            ),
            grain(
                [
                    [
                        3.8245781344218683e-7,
                        1.2866103105537343e-7,
                        1.2866103105537345e-7,
                        5.092317666114207e-7,
                    ],
                    [
                        3.7641585528692466e-7,
                        1.334047651046086e-7,
                        1.2531729242962603e-7,
                        5.122967060258102e-7,
                    ],
                    [
                        3.7641585528692466e-7,
                        1.2531729242962597e-7,
                        1.334047651046087e-7,
                        5.122967060258101e-7,
                    ],
                    [
                        3.730801585836364e-7,
                        1.2896625741880374e-7,
                        1.2896625741880377e-7,
                        5.172970439961504e-7,
                    ],
                ],
                [
                    4.629498113011669e-6,
                    -3.485091275719956e-6,
                    4.610161746144242e-6,
                    -3.4610095429460618e-6,
                ],
            ),
        ];
        let contact = |slot, normal: [f64; 2], shift: [f64; 2], open, f_n, f_t| NodeContact {
            node: slot,
            a: 0,
            node_a: slot,
            slot_a: slot,
            partner: Partner::Grain(1),
            node_b: slot,
            slot_b: slot,
            normal: Vector2::from(normal),
            gap: 0.0,
            shift: Vector2::from(shift),
            open,
            friction: 0.5,
            surface: Some(slot),
            force_n: f_n,
            force_t: f_t,
        };
        let contacts = vec![
            contact(
                0,
                [0.8046250662896817, -0.5937832118697239],
                [2.493773293916307e-8, 3.379267823370392e-8],
                0.0,
                2.4456916072103816,
                1.2228458036051908,
            ),
            contact(
                1,
                [0.7635115600814726, -0.6457941604117801],
                [-9.363510213982344e-8, 1.2900953929391443e-7],
                5.40291168688381e-8,
                9.590392158850866,
                0.20006778962461336,
            ),
        ];
        (contacts, slots)
    }

    /// The packings' accelerated solve (`for_packing`) on the recorded pair converges (in
    /// 1000 accelerated and 480 plain sweeps), to the forces of a plain NLGS run to 1e-12.
    /// Until session 36 its stall window stopped it after the 1000, the last sweep
    /// changing the forces by 3.4% of Σ|f| in the full packing.
    #[test]
    fn an_accelerated_solve_caught_in_a_cycle_goes_on_with_plain_sweeps() {
        let floor = 1.8e-3; // E h_g 1e-6 of that run
        let solve = |params| {
            let (mut contacts, mut slots) = colliding_pair();
            let mut schedule = Schedule::default();
            crate::mpm::colour::order(&mut contacts, slots.len(), &mut schedule);
            let out = nlgs(
                &mut contacts,
                &mut slots,
                &schedule,
                params,
                floor,
                &mut Anderson::default(),
            );
            (out, contacts)
        };
        let (fast, f) = solve(NlgsParams::for_packing(ContactKind::Surface, 0.5));
        let tight = NlgsParams {
            tol: 1e-12,
            max_sweeps: 1_000_000,
            ..NlgsParams::default()
        };
        let (exact, e) = solve(tight);
        assert!(exact.converged, "{exact:?}");
        assert!(fast.converged, "{fast:?}");
        let total: f64 = e.iter().map(|c| c.force_n + c.force_t.abs()).sum();
        let miss: f64 = f
            .iter()
            .zip(&e)
            .map(|(a, b)| (a.force_n - b.force_n).abs() + (a.force_t - b.force_t).abs())
            .sum();
        // The stopping rule bounds a sweep's change, not the error: plain sweeps contract
        // by ρ ≈ 0.99 here (2061 of them from 3e-4 to 1e-12), so the forces are within
        // about tol/(1 - ρ) ≈ 1e-4 of Σ|f| (measured 1.3e-4).
        assert!(miss < 3e-4 * total, "{fast:?}: {f:?} against {e:?}");
    }

    /// A chain of grains, each touching the next at two contacts and the first a wall:
    /// the grain pairs alternate between two colours of about 600 pairs each, enough for
    /// the parallel sweep. Each grain's compliance is `a I + b 1 1^T` on its slots (SPD),
    /// `a = 1e-6`; the closer `b` to `a`, the more nearly a pair's two contacts push on
    /// one motion.
    fn chain(grains: usize, friction: f64, b: f64) -> (Vec<NodeContact>, Vec<Slots>) {
        let mut rng = crate::rng::Rng::new(3);
        let mut slots: Vec<Slots> = (0..grains).map(|_| Slots::default()).collect();
        let mut contacts = Vec::new();
        let contact = |a, slot_a, partner, slot_b, angle: f64| NodeContact {
            node: 0,
            a,
            node_a: 0,
            slot_a,
            partner,
            node_b: 0,
            slot_b,
            normal: Vector2::new(angle.cos(), angle.sin()),
            gap: 0.0,
            shift: Vector2::zeros(),
            open: 0.0,
            friction,
            surface: None,
            force_n: 0.0,
            force_t: 0.0,
        };
        let s0 = slots[0].patterns.add(std::iter::once((0, 1.0)));
        contacts.push(contact(0, s0, Partner::Wall(0), 0, 0.3));
        for g in 0..grains - 1 {
            for k in 0..2 {
                let sa = slots[g].patterns.add(std::iter::once((k, 1.0)));
                let sb = slots[g + 1].patterns.add(std::iter::once((k, 1.0)));
                let angle = std::f64::consts::PI + 0.4 * (rng.uniform() - 0.5);
                contacts.push(contact(g, sa, Partner::Grain(g + 1), sb, angle));
            }
        }
        for s in &mut slots {
            let n = 2 * s.len();
            s.compliance = (0..n * n)
                .map(|k| (b + if k % (n + 1) == 0 { 1e-6 } else { 0.0 }) as f32)
                .collect();
            s.disp = (0..n).map(|_| 2e-6 * (rng.uniform() - 0.5)).collect();
        }
        (contacts, slots)
    }

    /// Orders `contacts` for the NLGS (`super::colour`), loads their slots with their
    /// forces and solves; floor 1e-3 N/m.
    fn ordered_solve(
        mut contacts: Vec<NodeContact>,
        mut slots: Vec<Slots>,
        params: NlgsParams,
    ) -> (NlgsOutcome, Vec<NodeContact>) {
        let mut schedule = Schedule::default();
        crate::mpm::colour::order(&mut contacts, slots.len(), &mut schedule);
        load_slots(&contacts, &mut slots);
        let out = nlgs(
            &mut contacts,
            &mut slots,
            &schedule,
            params,
            1e-3,
            &mut Anderson::default(),
        );
        (out, contacts)
    }

    /// The coloured sweep gives the same forces to the bit on one thread and on two, with
    /// friction and without (each pair swept on its own block first).
    #[test]
    fn the_coloured_sweep_does_not_depend_on_the_thread_count() {
        for friction in [0.5, 0.0] {
            thread_count_leaves_the_bits(friction);
        }
    }

    fn thread_count_leaves_the_bits(friction: f64) {
        let (contacts, slots) = chain(1200, friction, 2e-7);
        // a colour large enough for the parallel sweep
        let mut schedule = Schedule::default();
        crate::mpm::colour::order(&mut contacts.clone(), slots.len(), &mut schedule);
        let large = |(b, disjoint): (&[usize], bool)| {
            disjoint && b.len() > 2 && b[b.len() - 1] - b[0] >= PARALLEL_MIN
        };
        assert!(schedule.colours().any(large));
        let solve = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let params = NlgsParams::for_packing(ContactKind::Surface, friction);
            let (out, contacts) =
                pool.install(|| ordered_solve(contacts.clone(), slots.clone(), params));
            let forces: Vec<(u64, u64)> = contacts
                .iter()
                .map(|c| (c.force_n.to_bits(), c.force_t.to_bits()))
                .collect();
            (out, forces, contacts)
        };
        let (one, f1, contacts) = solve(1);
        let (two, f2, _) = solve(2);
        assert!(one.converged, "{one:?}");
        assert_eq!(one, two);
        assert_eq!(f1, f2);
        let closed = contacts.iter().filter(|c| c.force_n > 0.0).count();
        assert!(closed > 300 && closed < contacts.len(), "{closed} closed");
    }

    /// Without friction, sweeping each grain pair on its own Delassus block before its
    /// changes reach the other pairs (`NlgsParams::pair_sweeps`) finds the plain NLGS's
    /// forces in fewer sweeps where a pair's contacts push on nearly one motion: a chain
    /// of grains, each pressed against the next at two contacts 0.05 rad apart, a grain's
    /// compliance `a I + c_near` between the slots of one pair and `c_far` between pairs
    /// (`a = 1e-7`, `c_near = 1e-6`, `c_far = 1e-7`, each times the 2×2 identity: SPD).
    #[test]
    fn sweeping_each_frictionless_pair_on_its_own_block_takes_fewer_sweeps() {
        let grains = 30;
        let mut contacts = Vec::new();
        let mut groups: Vec<Vec<usize>> = vec![Vec::new(); grains];
        let mut slots: Vec<Slots> = (0..grains).map(|_| Slots::default()).collect();
        for g in 0..grains - 1 {
            for k in 0..2 {
                let angle = std::f64::consts::PI + 0.05 * k as f64;
                let normal = Vector2::new(angle.cos(), angle.sin());
                let sa = slots[g].patterns.add(std::iter::once((k, 1.0)));
                let sb = slots[g + 1].patterns.add(std::iter::once((2 + k, 1.0)));
                groups[g].push(2 * g + 1);
                groups[g + 1].push(2 * g);
                contacts.push(NodeContact {
                    node: 0,
                    a: g,
                    node_a: 0,
                    slot_a: sa,
                    partner: Partner::Grain(g + 1),
                    node_b: 0,
                    slot_b: sb,
                    normal,
                    gap: 0.0,
                    // the pair approaches by 1e-6 m along its normal
                    shift: -1e-6 * normal,
                    open: 0.0,
                    friction: 0.0,
                    surface: None,
                    force_n: 0.0,
                    force_t: 0.0,
                });
            }
        }
        for (s, group) in slots.iter_mut().zip(&groups) {
            let n = 2 * s.len();
            s.compliance = vec![0.0; n * n];
            for (r, gr) in group.iter().enumerate() {
                for (q, gq) in group.iter().enumerate() {
                    let c = if r == q {
                        1.1e-6
                    } else if gr == gq {
                        1e-6
                    } else {
                        1e-7
                    };
                    for i in 0..2 {
                        s.compliance[(2 * q + i) * n + 2 * r + i] = c as f32;
                    }
                }
            }
            s.disp = vec![0.0; n];
        }
        let solve = |pair_sweeps, tol| {
            let params = NlgsParams {
                tol,
                max_sweeps: 1_000_000,
                pair_sweeps,
                ..NlgsParams::default()
            };
            ordered_solve(contacts.clone(), slots.clone(), params)
        };
        let (exact, e) = solve(1, 1e-13);
        let (plain, p) = solve(1, 1e-6);
        let (block, b) = solve(PAIR_SWEEPS, 1e-6);
        let total: f64 = e.iter().map(|c| c.force_n).sum();
        let miss = |f: &[NodeContact]| -> f64 {
            f.iter()
                .zip(&e)
                .map(|(a, b)| (a.force_n - b.force_n).abs())
                .sum::<f64>()
                / total
        };
        assert!(exact.converged && plain.converged && block.converged);
        assert_eq!(e.iter().filter(|c| c.force_n > 0.0).count(), e.len());
        // measured: 64 plain sweeps against 5, both within 5e-6 of Σ f_n
        assert!(
            5 * block.sweeps < plain.sweeps,
            "{block:?} against {plain:?}"
        );
        for f in [&p, &b] {
            assert!(miss(f) < 2e-5, "{}", miss(f));
        }
    }
}
