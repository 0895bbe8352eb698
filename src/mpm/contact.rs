//! Node contact: every contact that acts on a grain through its grid nodes lives here.
//!
//! Today: rigid walls (plates) as partners of infinite mass with an imposed velocity
//! (METHODS §3.4, §4.5). A node takes part when it carries grain mass and lies behind the
//! wall plane or less than half a cell in front of it: the row nearest the wall and every
//! row behind it. (With the rows behind only, the material between the plate and the
//! first row inside, up to a cell thick, was held by small weights alone; Newton cycled
//! and points were crushed after 0.9 h_g of plate travel.) Its gap is measured
//! from the material points it sees, `g_i = min_{p: S_ip > 0} ((x_p - x_w)·n - l_p)`, with
//! `l_p` the point's face toward the wall (`Points::support`: clipped by the seeded circle,
//! carried by `F`).
//! Signorini is imposed on the end-of-step gap with existing overlaps left alone,
//! `max(g_i, 0) + n·(u_i - Δt V_w) >= 0  ⊥  f_n >= 0`,
//! i.e. the gap-anticipated velocity Signorini of METHODS §1.4/§4.3 written on the
//! increment. Correcting overlaps (`g_i` instead of `max(g_i, 0)`) was tried and is
//! unstable: a node sees the overlap of one point but moves it only by its weight
//! `S_ip < 1`, so the correction feeds back with a gain `1/S_ip`. For a single grain the
//! node conditions are solved exactly inside Newton by a primal–dual active set: an active
//! node has its normal displacement prescribed and its force read from the residual; it is
//! released when that force turns tensile, and activated when its gap would close. This is
//! the condensed (exact Delassus) solution of §4.4B rather than the mass-only `W = Δt/(2m)`
//! fixed point, which converges slowly at the large steps used here.
//! Walls are axis-aligned (normals `±e_x`, `±e_y`). Coulomb friction (optional, off by
//! default) uses the same active set on the tangential DOF: a sticking node has its
//! tangential displacement prescribed to the wall's and its force read from the residual;
//! when that force exceeds `μ f_n` the node slides, loaded by `μ f_n` (lagged by one
//! Newton iteration) against its slip, and sticks again if the slip reverses.
//!
//! Packings use the same detection and solve every node contact, walls included, by
//! contact dynamics on the condensed compliance (`super::node_contact`).

use super::grid::Grid;
use super::points::Points;
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

/// A rigid, axis-aligned wall moving at an imposed velocity, with Coulomb friction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wall {
    /// A point of the wall plane (m).
    pub origin: Vector2<f64>,
    /// Unit normal pointing to the grain side: `±e_x` or `±e_y`.
    pub normal: Vector2<f64>,
    /// Imposed velocity (m/s).
    pub velocity: Vector2<f64>,
    /// Coulomb friction coefficient with the grain (0: frictionless, the paper's
    /// assumption for the single grain, METHODS §2.3).
    pub friction: f64,
    /// Force exerted by the grain on the wall over the last step (N/m).
    pub force: Vector2<f64>,
    /// Nodes in contact at the end of the last step.
    pub contacts: usize,
}

impl Wall {
    /// A frictionless wall.
    pub fn new(origin: Vector2<f64>, normal: Vector2<f64>, velocity: Vector2<f64>) -> Wall {
        Wall {
            origin,
            normal,
            velocity,
            friction: 0.0,
            force: Vector2::zeros(),
            contacts: 0,
        }
    }

    /// Compressive normal force on the wall, `-F·n >= 0` (N/m).
    pub fn normal_force(&self) -> f64 {
        -self.force.dot(&self.normal)
    }

    /// Index (0 = x, 1 = y) of the normal axis and its sign.
    fn axis(&self) -> (usize, f64) {
        if self.normal.x.abs() > 0.5 {
            (0, self.normal.x.signum())
        } else {
            (1, self.normal.y.signum())
        }
    }

    pub fn is_axis_aligned(&self) -> bool {
        let n = self.normal;
        ((n.x.abs() - 1.0).abs() < 1e-12 && n.y == 0.0)
            || ((n.y.abs() - 1.0).abs() < 1e-12 && n.x == 0.0)
    }
}

/// One node–wall contact for the current step.
#[derive(Clone, Copy, Debug)]
pub struct NodeContact {
    pub wall: usize,
    /// Active node index and the constrained DOF `2 node + axis`.
    pub node: usize,
    pub dof: usize,
    /// `n` along the DOF axis (±1).
    pub sign: f64,
    /// Gap `g_i` from the points at the start of the step (m).
    pub gap: f64,
    /// Lower bound on `sign · u_dof`: `Δt V_w·n - max(g_i, 0)`.
    pub bound: f64,
    pub active: bool,
    /// Normal force on the grain (N/m), valid while active.
    pub force: f64,
    /// Tangential DOF `2 node + (1 - axis)`, its target `Δt V_w·t` while sticking.
    pub tdof: usize,
    pub tbound: f64,
    pub friction: f64,
    /// Stick (tangential DOF prescribed) or slip in direction `slip` (±1).
    pub stick: bool,
    pub slip: f64,
    /// Tangential force on the grain along `+e_(1-axis)` (N/m).
    pub tforce: f64,
}

/// Finds the wall contact candidates of this step.
///
/// `node_pos` are the active nodes' positions, `point_nodes(p)` the active nodes a point
/// reaches with a positive weight. `gap` is scratch of length `node_pos.len()`.
#[allow(clippy::too_many_arguments)]
pub fn detect<'a>(
    walls: &[Wall],
    grid: &Grid,
    points: &Points,
    node_pos: &[Vector2<f64>],
    point_nodes: impl Fn(usize) -> &'a [usize],
    dt: f64,
    gap: &mut Vec<f64>,
    out: &mut Vec<NodeContact>,
) {
    out.clear();
    let reach = 0.5 * grid.h;
    for (w, wall) in walls.iter().enumerate() {
        let (axis, sign) = wall.axis();
        gap.clear();
        gap.resize(node_pos.len(), f64::INFINITY);
        for p in 0..points.len() {
            let gp =
                (points.x[p] - wall.origin).dot(&wall.normal) - points.support(p, &-wall.normal);
            for &i in point_nodes(p) {
                gap[i] = gap[i].min(gp);
            }
        }
        for (i, xi) in node_pos.iter().enumerate() {
            if (xi - wall.origin).dot(&wall.normal) <= reach && gap[i].is_finite() {
                out.push(NodeContact {
                    wall: w,
                    node: i,
                    dof: 2 * i + axis,
                    sign,
                    gap: gap[i],
                    bound: dt * wall.velocity.dot(&wall.normal) - gap[i].max(0.0),
                    active: false,
                    force: 0.0,
                    tdof: 2 * i + 1 - axis,
                    tbound: dt * wall.velocity[1 - axis],
                    friction: wall.friction,
                    stick: true,
                    slip: 0.0,
                    tforce: 0.0,
                });
            }
        }
    }
}

/// One primal–dual active-set update from the displacement `u` and the residual `res`
/// (which excludes contact forces). Returns whether the set changed.
/// With `allow_release = false` active contacts are kept and sticking ones do not start
/// to slide (see `Solver::step`).
pub fn update_active_set(
    contacts: &mut [NodeContact],
    u: &[f64],
    res: &[f64],
    tol_gap: f64,
    tol_force: f64,
    allow_release: bool,
) -> bool {
    let mut changed = false;
    for c in contacts.iter_mut() {
        if c.active {
            // R + f_c = 0 on the prescribed DOF.
            c.force = -c.sign * res[c.dof];
            if allow_release && c.force < -tol_force {
                c.active = false;
                c.force = 0.0;
                changed = true;
            }
        } else if c.sign * u[c.dof] < c.bound - tol_gap {
            c.active = true;
            c.stick = true;
            changed = true;
        }
        if !c.active || c.friction == 0.0 {
            c.tforce = 0.0;
            continue;
        }
        // Coulomb: stick while |f_t| <= μ f_n, else slide against the force.
        let limit = c.friction * c.force.max(0.0);
        if c.stick {
            c.tforce = -res[c.tdof];
            if allow_release && c.tforce.abs() > limit + tol_force {
                c.stick = false;
                c.slip = -c.tforce.signum();
                changed = true;
            }
        } else if (u[c.tdof] - c.tbound) * c.slip < -tol_gap {
            // The slip reversed: stick again.
            c.stick = true;
            changed = true;
        }
        if !c.stick {
            c.tforce = -limit * c.slip;
        }
    }
    changed
}

/// Prescribes the DOFs of the active contacts (normal, and tangential while sticking):
/// `fixed[d]` and the increment `dfix[d]` still needed to reach the target; adds the
/// sliding friction forces to `res`. Returns the squared norm of the contact forces.
pub fn constrain(
    contacts: &[NodeContact],
    u: &[f64],
    res: &mut [f64],
    fixed: &mut [bool],
    dfix: &mut [f64],
) -> f64 {
    fixed.iter_mut().for_each(|f| *f = false);
    dfix.iter_mut().for_each(|d| *d = 0.0);
    let mut sq = 0.0;
    for c in contacts.iter().filter(|c| c.active) {
        fixed[c.dof] = true;
        dfix[c.dof] = c.sign * c.bound - u[c.dof];
        if c.friction > 0.0 {
            if c.stick {
                fixed[c.tdof] = true;
                dfix[c.tdof] = c.tbound - u[c.tdof];
            } else {
                res[c.tdof] += c.tforce;
            }
        }
        sq += c.force * c.force + c.tforce * c.tforce;
    }
    sq
}

/// Warm start: activates the contacts whose (grid node, wall) pair was active at the end
/// of the previous step (`previous` sorted); `grid_id` maps active to grid nodes.
pub fn warm_start(contacts: &mut [NodeContact], grid_id: &[usize], previous: &[(usize, usize)]) {
    for c in contacts.iter_mut() {
        c.active = previous.binary_search(&(grid_id[c.node], c.wall)).is_ok();
    }
}

/// The (grid node, wall) pairs active at the end of this step, sorted.
pub fn active_pairs(contacts: &[NodeContact], grid_id: &[usize], out: &mut Vec<(usize, usize)>) {
    out.clear();
    out.extend(
        contacts
            .iter()
            .filter(|c| c.active)
            .map(|c| (grid_id[c.node], c.wall)),
    );
    out.sort_unstable();
}

/// Sums the converged contact forces into the walls (force on the wall = minus force on the grain).
pub fn commit(contacts: &[NodeContact], walls: &mut [Wall]) {
    for w in walls.iter_mut() {
        w.force = Vector2::zeros();
        w.contacts = 0;
    }
    for c in contacts.iter().filter(|c| c.active) {
        let w = &mut walls[c.wall];
        let mut t = Vector2::zeros();
        t[c.tdof % 2] = 1.0;
        w.force -= w.normal * c.force + t * c.tforce;
        w.contacts += 1;
    }
}
