//! One implicit MPM step after Guilkey & Weiss (2003) (METHODS §3.3):
//! P2G with lumped mass, Newton on the nodal displacement increment with the (nearly)
//! consistent tangent over the active nodes, sparse Cholesky, node contact by active set,
//! then G2P.
//!
//! Optional B-bar (METHODS §6): the dilatation of each point's increment is replaced by
//! the volume-weighted average over the points of its grid cell (for B-splines, the cell
//! centred on its nearest node, so that a group shares one stencil), taken in the
//! start-of-step configuration: `L̄ = L + ½ (tr L̄_cell - tr L) I` (2D dilatation, so plane
//! strain `ε_zz = 0` is kept). The internal force is the derivative of these kinematics,
//! `f_i = Σ v (σ ∇S_i + ½ tr(σ ΔF̄^{-T}) h_i)` with `h = d̄ - ∇S` at `x^n`, and the tangent
//! carries the matching geometric terms.

use super::connect::Connectivity;
use super::contact::{self, NodeContact, Wall};
use super::error::MpmError;
use super::grid::Grid;
use super::material::Material;
use super::newmark::Newmark;
use super::points::{Points, Stress};
use super::shape::ShapeKind;
use super::sparse::SymSystem;
use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector2};
use serde::{Deserialize, Serialize};

/// Newton tolerances (METHODS §3.3 step 7). Converged when the active set is unchanged,
/// `‖R‖ <= tol_residual · max(‖f_int‖, ‖M a‖, ‖f_c‖)` and either
/// `‖δu‖ <= tol_increment · ‖u‖` or `|δu·R| <= tol_energy · |δu₀·R₀|`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NewtonParams {
    pub max_iterations: usize,
    pub tol_residual: f64,
    pub tol_increment: f64,
    pub tol_energy: f64,
}

impl Default for NewtonParams {
    fn default() -> Self {
        NewtonParams {
            max_iterations: 40,
            // METHODS asks 1e-8 for both. The residual stalls near 1e-8 of the force scale
            // in round-off with uGIMP, and with B-bar at large strain the tangent misses
            // the linearisation of the cell-averaged dilatation, so Newton converges
            // linearly (rate up to 0.7); forces are good to 1e-6 with these values.
            tol_residual: 1e-6,
            tol_increment: 1e-5,
            tol_energy: 1e-12,
        }
    }
}

/// Numerical choices of the implicit step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SolverParams {
    pub shape: ShapeKind,
    pub bbar: bool,
    pub newmark: Newmark,
    pub newton: NewtonParams,
}

impl Default for SolverParams {
    fn default() -> Self {
        SolverParams {
            // Bilinear (the paper's) loses accuracy with refinement and at large strain
            // (cell crossing); the quadratic B-spline converges to Johnson's solution.
            shape: ShapeKind::BSpline2,
            bbar: true,
            newmark: Newmark::default(),
            newton: NewtonParams::default(),
        }
    }
}

/// What one step cost and found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepStats {
    pub iterations: usize,
    pub active_nodes: usize,
    pub contacts: usize,
    /// Final residual over its tolerance scale.
    pub residual: f64,
    /// Whether the symbolic factorisation had to be redone.
    pub new_symbolic: bool,
}

/// Workspace of the implicit step; allocated once and reused (not part of any checkpoint).
#[derive(Default)]
pub struct Solver {
    /// Body force per unit mass on every node (m/s²; zero unless set).
    pub gravity: Vector2<f64>,
    conn: Connectivity,
    pt_g: Vec<Vector2<f64>>,
    dbar0: Vec<Vector2<f64>>,
    /// `tr(σ ΔF̄^{-T})`, the pressure-like factor of the B-bar internal force.
    trial_tr: Vec<f64>,
    m: Vec<f64>,
    /// Start-of-step nodal mass gradient `Σ_p m_p ∇S_ip` (contact normals, METHODS §4.2).
    mgrad: Vec<Vector2<f64>>,
    vn: Vec<Vector2<f64>>,
    an: Vec<Vector2<f64>>,
    /// Start-of-step velocity changes from contact (`kick`), passed on to the points in G2P.
    kicks: Vec<Vector2<f64>>,
    u: Vec<f64>,
    du: Vec<f64>,
    res: Vec<f64>,
    fint: Vec<f64>,
    kfix: Vec<f64>,
    dfix: Vec<f64>,
    fixed: Vec<bool>,
    trial_stress: Vec<Stress>,
    trial_f: Vec<Matrix2<f64>>,
    trial_vol: Vec<f64>,
    tangent: Vec<Matrix3<f64>>,
    sys: SymSystem,
    pairs: Vec<(usize, usize)>,
    /// For B-bar group `g` of `m` nodes, `grp_blk[grp_blk_off[g] + k m + l]`: the block
    /// of node pair (k, l) in `sys` when node k ≥ node l, else `usize::MAX` (looked up once
    /// per pattern instead of once per point in every assembly).
    grp_blk: Vec<usize>,
    grp_blk_off: Vec<usize>,
    contacts: Vec<NodeContact>,
    prev_active: Vec<(usize, usize)>,
    gap: Vec<f64>,
    /// The assembly's per-node terms of the point being assembled (`stiffness`).
    terms: Vec<NodeTerms>,
    /// One B-bar group's blocks, summed over its points before they go into `sys`.
    group_blocks: Vec<Matrix2<f64>>,
}

/// The factors of one point's stiffness at one node of its group (`Solver::stiffness`).
#[derive(Clone, Copy, Default)]
struct NodeTerms {
    /// `B̄` and `v D B̄`.
    b: Matrix3x2<f64>,
    db: Matrix3x2<f64>,
    /// `∇S`, `σ ∇S` and `h = d̄ - ∇S`.
    g: Vector2<f64>,
    sg: Vector2<f64>,
    h: Vector2<f64>,
    /// `v σ ∇S`, `½ v h` and `v (½ σ ∇S + ¼ tr σ h)`: the geometric block of the pair
    /// (k, l) is `(g_k · sv_l) I + sg_k hv_lᵀ + h_k q_lᵀ`.
    sv: Vector2<f64>,
    hv: Vector2<f64>,
    q: Vector2<f64>,
}

fn vec2(u: &[f64], i: usize) -> Vector2<f64> {
    Vector2::new(u[2 * i], u[2 * i + 1])
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl Solver {
    /// Advances `points` by `dt` against `walls` (their forces are set on return).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        params: &SolverParams,
        grid: &Grid,
        material: &Material,
        points: &mut Points,
        walls: &mut [Wall],
        dt: f64,
        step: u64,
    ) -> Result<StepStats, MpmError> {
        self.conn
            .build(params.shape, params.bbar, grid, points, step)?;
        self.resize(points.len());
        self.p2g(points);
        let n = self.conn.act_grid.len();
        let nm = params.newmark;

        // Wall contact candidates for this step.
        {
            let (own_act, own_off) = (&self.conn.own_act, &self.conn.own_off);
            contact::detect(
                walls,
                grid,
                points,
                &self.conn.node_pos,
                |p| &own_act[own_off[p]..own_off[p + 1]],
                dt,
                &mut self.gap,
                &mut self.contacts,
            );
            if crate::shortcuts::get().warm_start {
                contact::warm_start(&mut self.contacts, &self.conn.act_grid, &self.prev_active);
            }
        }

        self.pattern_and_predictor(nm, dt);

        let c1 = nm.mass_factor(dt);
        let tol = params.newton;
        let tol_gap = 1e-9 * grid.h;
        let (mut energy0, mut last_energy, mut last_inc) = (0.0_f64, f64::INFINITY, f64::INFINITY);
        let mut stats = StepStats {
            new_symbolic: self.sys.new_symbolic,
            ..StepStats::default()
        };
        let mut converged = false;
        let mut changed = false;
        let mut rel_res = f64::INFINITY;
        for it in 0..=tol.max_iterations {
            // Backtracking: an iterate that inverts a point is pulled halfway back
            // toward the previous one (up to 8 times) before giving up.
            let mut cuts = 0;
            while let Err(err) = self.evaluate(params, material, points, step) {
                if it == 0 || cuts == 8 {
                    return Err(err);
                }
                cuts += 1;
                for (u, d) in self.u.iter_mut().zip(self.du.iter_mut()) {
                    *d *= 0.5;
                    *u -= *d;
                }
            }
            self.internal_force(points);
            let scale0 = self.residual(nm, dt);
            changed = contact::update_active_set(
                &mut self.contacts,
                &self.u,
                &self.res,
                tol_gap,
                1e-10 * scale0.max(f64::MIN_POSITIVE),
                // Releases are allowed after the first iteration (whose residual is not
                // yet meaningful) and frozen in the last third, so a cycling set can
                // only grow and must settle.
                it > 0 && it < 2 * tol.max_iterations / 3,
            );
            let fc_sq = contact::constrain(
                &self.contacts,
                &self.u,
                &mut self.res,
                &mut self.fixed,
                &mut self.dfix,
            );
            let res_free: f64 = self
                .res
                .iter()
                .zip(&self.fixed)
                .filter(|(_, f)| !**f)
                .map(|(r, _)| r * r)
                .sum::<f64>()
                .sqrt();
            let floor = material.young * grid.h * 1e-6;
            let scale = scale0.max(fc_sq.sqrt()).max(floor);
            rel_res = res_free / scale;
            let u_norm = norm(&self.u).max(1e-12 * grid.h);
            let res_ok = rel_res <= tol.tol_residual;
            let inc_ok = last_inc <= tol.tol_increment * u_norm;
            let energy_ok = last_energy <= tol.tol_energy * energy0;
            let first_ok = it == 0 && self.contacts.iter().all(|c| !c.active);
            if !changed && res_ok && (first_ok || inc_ok || energy_ok) {
                stats.iterations = it;
                converged = true;
                break;
            }
            if it == tol.max_iterations {
                break;
            }
            self.stiffness(material, c1, true);
            if self.solve_increment().is_err() {
                // The geometric and stress-dependent parts of the tangent of a pre-stressed
                // grain can make it indefinite (supports inactive, or stresses of order μ
                // at large strain): retry this iteration with the initial elastic tangent
                // (a modified Newton step).
                self.stiffness(material, c1, false);
                self.solve_increment()
                    .map_err(|reason| MpmError::LinearSolve { step, reason })?;
            }
            let e: f64 = self
                .du
                .iter()
                .zip(&self.res)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                .abs();
            if it == 0 {
                energy0 = e;
            }
            last_energy = e;
            last_inc = norm(&self.du);
            if !last_inc.is_finite() {
                return Err(MpmError::NonFinite {
                    step,
                    quantity: "displacement increment",
                });
            }
            for (u, d) in self.u.iter_mut().zip(&self.du) {
                *u += d;
            }
        }
        if !converged {
            return Err(MpmError::NotConverged {
                step,
                iterations: tol.max_iterations,
                residual: rel_res,
                active_set_changing: changed,
            });
        }
        stats.residual = rel_res;
        stats.active_nodes = n;
        stats.contacts = self.contacts.iter().filter(|c| c.active).count();
        contact::commit(&self.contacts, walls);
        contact::active_pairs(&self.contacts, &self.conn.act_grid, &mut self.prev_active);
        self.g2p(nm, points, dt);
        Ok(stats)
    }
}

/// The phases of one step, for a driver that couples several grains through their contact
/// nodes (`super::packing`): `begin`, then per coupling iteration `evaluate_residual`,
/// `assemble_stiffness` and `factorize` (when the grain needs a new factorisation) and
/// `solve`s with `add_increment`, and `finish` at convergence.
impl Solver {
    /// P2G of `points` on `grid` (a window of the common grid), the sparsity pattern and
    /// the Newmark predictor.
    pub fn begin(
        &mut self,
        params: &SolverParams,
        grid: &Grid,
        points: &Points,
        dt: f64,
        step: u64,
    ) -> Result<(), MpmError> {
        self.conn
            .build(params.shape, params.bbar, grid, points, step)?;
        self.resize(points.len());
        self.p2g(points);
        self.contacts.clear();
        self.pattern_and_predictor(params.newmark, dt);
        Ok(())
    }

    /// Stresses, internal force and tangent at the current iterate; leaves the residual
    /// without contact forces, `f_ext - f_int - M a`, in `residual()`. Returns its force
    /// scale `max(‖f_int‖, ‖M a‖)`.
    pub fn evaluate_residual(
        &mut self,
        params: &SolverParams,
        material: &Material,
        points: &Points,
        dt: f64,
        step: u64,
    ) -> Result<f64, MpmError> {
        self.evaluate(params, material, points, step)?;
        self.internal_force(points);
        Ok(self.residual(params.newmark, dt))
    }

    /// Assembles the effective stiffness (consistent tangent) at the iterate of the last
    /// `evaluate_residual`, for `factorize` or `solve_iterative`.
    pub fn assemble_stiffness(&mut self, params: &SolverParams, material: &Material, dt: f64) {
        self.stiffness(material, params.newmark.mass_factor(dt), true);
    }

    /// Factorises the stiffness of the last `assemble_stiffness`; if the consistent
    /// tangent is not positive definite, the initial elastic one is assembled and used
    /// instead (modified Newton, as in `step`). Returns true if the consistent tangent was
    /// positive definite and factorised, false if the elastic one was factorised instead.
    pub fn factorize(
        &mut self,
        params: &SolverParams,
        material: &Material,
        dt: f64,
        step: u64,
    ) -> Result<bool, MpmError> {
        self.fixed.iter_mut().for_each(|f| *f = false);
        if self.sys.factorize(&self.fixed).is_ok() {
            return Ok(true);
        }
        self.stiffness(material, params.newmark.mass_factor(dt), false);
        self.sys
            .factorize(&self.fixed)
            .map_err(|reason| MpmError::LinearSolve { step, reason })?;
        Ok(false)
    }

    /// `out = Bᵀ K⁻¹ B` (`cols × cols`) for `cols` columns of `b` of length
    /// `2 × nodes().len()`, with the last factorisation (`y`: scratch, see
    /// `SymSystem::inverse_gram`).
    pub fn compliance(
        &mut self,
        b: &[f64],
        cols: usize,
        out: &mut [f64],
        y: &mut Vec<f64>,
        step: u64,
    ) -> Result<(), MpmError> {
        self.sys
            .inverse_gram(b, cols, out, y)
            .map_err(|reason| MpmError::LinearSolve { step, reason })
    }

    /// Solves `K X = B` in place for `cols` columns of length `2 × nodes().len()`.
    pub fn solve(&mut self, rhs: &mut [f64], cols: usize, step: u64) -> Result<(), MpmError> {
        self.sys
            .solve_factored(rhs, cols)
            .map_err(|reason| MpmError::LinearSolve { step, reason })
    }

    /// Solves `K x = rhs` for one column by block-Jacobi conjugate gradients instead of
    /// the factorisation, to relative residual `tol`; returns the iterations (the measured
    /// alternative, `benches/linear_solver.rs`).
    pub fn solve_iterative(&self, rhs: &mut [f64], tol: f64, step: u64) -> Result<usize, MpmError> {
        self.sys
            .solve_pcg(&self.fixed, rhs, tol, 20 * rhs.len())
            .map_err(|reason| MpmError::LinearSolve { step, reason })
    }

    /// `u += du`.
    pub fn add_increment(&mut self, du: &[f64]) {
        for (u, d) in self.u.iter_mut().zip(du) {
            *u += d;
        }
    }

    /// G2P with the current iterate (METHODS §3.3 step 8).
    pub fn finish(&mut self, nm: Newmark, points: &mut Points, dt: f64) {
        self.g2p(nm, points, dt);
    }

    /// Active nodes as ids of the grid passed to `begin`.
    pub fn nodes(&self) -> &[usize] {
        &self.conn.act_grid
    }

    pub fn node_mass(&self) -> &[f64] {
        &self.m
    }

    /// Nodal velocities and accelerations of the start of the step (P2G).
    pub fn node_velocity(&self) -> &[Vector2<f64>] {
        &self.vn
    }

    pub fn node_acceleration(&self) -> &[Vector2<f64>] {
        &self.an
    }

    /// Changes the start-of-step velocity of active node `i` by `dv` (an impulse at the
    /// start of the step, `node_contact::start_collisions`): the predictor moves with it and
    /// G2P gives the points their share, so nodes and points stay consistent.
    pub fn kick(&mut self, i: usize, dv: Vector2<f64>, dt: f64) {
        self.vn[i] += dv;
        self.kicks[i] += dv;
        self.u[2 * i] += dt * dv.x;
        self.u[2 * i + 1] += dt * dv.y;
    }

    /// Point `p`'s stencil: (active node, weight `S_ip > 0`).
    pub fn point_stencil(&self, p: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (g, off) = (self.conn.pt_grp[p], self.conn.pt_off[p]);
        let (a, b) = (self.conn.grp_off[g], self.conn.grp_off[g + 1]);
        (0..b - a)
            .map(move |k| (self.conn.grp_nodes[a + k], self.conn.pt_w[off + k]))
            .filter(|&(_, w)| w > 0.0)
    }

    /// `Σ_p m_p ∇S_ip` at the start of the step, per active node.
    pub fn mass_gradient(&self) -> &[Vector2<f64>] {
        &self.mgrad
    }

    /// The active nodes point `p` reaches with a positive weight.
    pub fn point_nodes(&self, p: usize) -> &[usize] {
        &self.conn.own_act[self.conn.own_off[p]..self.conn.own_off[p + 1]]
    }

    /// Residual of the last `evaluate_residual` (2 per active node).
    pub fn residual_vector(&self) -> &[f64] {
        &self.res
    }

    /// Current displacement increment `u` (2 per active node).
    pub fn displacement(&self) -> &[f64] {
        &self.u
    }
}

impl Solver {
    /// Sparsity pattern (every pair of nodes sharing a point or a B-bar cell) and the
    /// predictor `u = Δt v + Δt²/2 a`.
    fn pattern_and_predictor(&mut self, nm: Newmark, dt: f64) {
        let n = self.conn.act_grid.len();
        self.pairs.clear();
        for g in 0..self.conn.grp_off.len() - 1 {
            let nodes = &self.conn.grp_nodes[self.conn.grp_off[g]..self.conn.grp_off[g + 1]];
            for &a in nodes {
                for &b in nodes {
                    if a < b {
                        self.pairs.push((a, b));
                    }
                }
            }
        }
        self.sys.set_pattern(n, &mut self.pairs);
        self.grp_blk.clear();
        self.grp_blk_off.clear();
        for g in 0..self.conn.grp_off.len() - 1 {
            self.grp_blk_off.push(self.grp_blk.len());
            let nodes = &self.conn.grp_nodes[self.conn.grp_off[g]..self.conn.grp_off[g + 1]];
            for &i in nodes {
                for &j in nodes {
                    self.grp_blk.push(if i >= j {
                        self.sys.lower_block(i, j)
                    } else {
                        usize::MAX
                    });
                }
            }
        }
        for i in 0..n {
            let u0 = nm.predictor(self.vn[i], self.an[i], dt);
            self.u[2 * i] = u0.x;
            self.u[2 * i + 1] = u0.y;
        }
    }

    /// `res = m g - f_int - M a(u)` without contact forces; returns `max(‖f_int‖, ‖M a‖)`.
    fn residual(&mut self, nm: Newmark, dt: f64) -> f64 {
        let mut inertia_sq = 0.0;
        for i in 0..self.m.len() {
            let a = nm.accel(vec2(&self.u, i), self.vn[i], self.an[i], dt);
            let ma = a * self.m[i];
            inertia_sq += ma.norm_squared();
            let fe = self.gravity * self.m[i];
            self.res[2 * i] = fe.x - self.fint[2 * i] - ma.x;
            self.res[2 * i + 1] = fe.y - self.fint[2 * i + 1] - ma.y;
        }
        norm(&self.fint).max(inertia_sq.sqrt())
    }

    /// Sizes the per-node and per-point buffers after `Connectivity::build`.
    fn resize(&mut self, np: usize) {
        let n = self.conn.act_grid.len();
        for v in [
            &mut self.u,
            &mut self.du,
            &mut self.res,
            &mut self.fint,
            &mut self.kfix,
            &mut self.dfix,
        ] {
            v.clear();
            v.resize(2 * n, 0.0);
        }
        self.fixed.clear();
        self.fixed.resize(2 * n, false);
        self.pt_g.clear();
        self.pt_g.resize(self.conn.pt_g0.len(), Vector2::zeros());
        self.dbar0.clear();
        self.dbar0
            .resize(self.conn.grp_nodes.len(), Vector2::zeros());
        self.trial_tr.resize(np, 0.0);
        self.trial_stress.resize(np, Stress::default());
        self.trial_f.resize(np, Matrix2::identity());
        self.trial_vol.resize(np, 0.0);
        self.tangent.resize(np, Matrix3::zeros());
    }

    /// Lumped mass, velocity and acceleration on the active nodes; start-of-step `d̄`.
    fn p2g(&mut self, points: &Points) {
        let n = self.conn.act_grid.len();
        self.m.clear();
        self.m.resize(n, 0.0);
        self.vn.clear();
        self.vn.resize(n, Vector2::zeros());
        self.an.clear();
        self.an.resize(n, Vector2::zeros());
        self.kicks.clear();
        self.kicks.resize(n, Vector2::zeros());
        self.mgrad.clear();
        self.mgrad.resize(n, Vector2::zeros());
        for p in 0..points.len() {
            let (g, off) = (self.conn.pt_grp[p], self.conn.pt_off[p]);
            let nodes = &self.conn.grp_nodes[self.conn.grp_off[g]..self.conn.grp_off[g + 1]];
            for (k, &i) in nodes.iter().enumerate() {
                let wm = self.conn.pt_w[off + k] * points.mass[p];
                self.mgrad[i] += self.conn.pt_g0[off + k] * points.mass[p];
                self.m[i] += wm;
                self.vn[i] += points.v[p] * wm;
                self.an[i] += points.a[p] * wm;
            }
        }
        for i in 0..n {
            // an empty node (numbered only without the `active_nodes` shortcut) stays at rest
            if self.m[i] > 0.0 {
                self.vn[i] /= self.m[i];
                self.an[i] /= self.m[i];
            }
        }
        self.conn
            .average(&self.conn.pt_g0, &points.vol, &mut self.dbar0);
    }

    /// Kinematics and stress at every point for the current iterate `u`.
    fn evaluate(
        &mut self,
        params: &SolverParams,
        material: &Material,
        points: &Points,
        step: u64,
    ) -> Result<(), MpmError> {
        for p in 0..points.len() {
            let (g, off) = (self.conn.pt_grp[p], self.conn.pt_off[p]);
            let (a, b) = (self.conn.grp_off[g], self.conn.grp_off[g + 1]);
            let mut l = Matrix2::zeros();
            let mut tr_bar = 0.0;
            for k in 0..b - a {
                let u = vec2(&self.u, self.conn.grp_nodes[a + k]);
                l += u * self.conn.pt_g0[off + k].transpose();
                tr_bar += u.dot(&self.dbar0[a + k]);
            }
            if params.bbar {
                l += Matrix2::identity() * (0.5 * (tr_bar - l.trace()));
            }
            let upd = material.update(&points.stress[p], &points.def_grad[p], &l);
            let det = upd.def_grad.determinant();
            if det.is_nan() || det <= 0.0 {
                return Err(if det.is_finite() {
                    MpmError::Inverted {
                        step,
                        point: p,
                        det,
                    }
                } else {
                    MpmError::NonFinite {
                        step,
                        quantity: "deformation gradient",
                    }
                });
            }
            if !upd.stress.is_finite() {
                return Err(MpmError::NonFinite {
                    step,
                    quantity: "stress",
                });
            }
            let dfit = (Matrix2::identity() + l)
                .try_inverse()
                .ok_or(MpmError::Inverted {
                    step,
                    point: p,
                    det,
                })?
                .transpose();
            for k in 0..b - a {
                self.pt_g[off + k] = dfit * self.conn.pt_g0[off + k];
            }
            self.trial_tr[p] = (upd.stress.matrix() * dfit).trace();
            self.trial_stress[p] = upd.stress;
            self.trial_f[p] = upd.def_grad;
            self.trial_vol[p] = det * points.vol0[p];
            self.tangent[p] = upd.tangent;
        }
        Ok(())
    }

    /// B-bar operator `B̄` of group node `k` of point `p` and its `h = d̄ - ∇S` (both in the
    /// start-of-step configuration, like the kinematics).
    fn bbar(&self, p: usize, k: usize) -> (Matrix3x2<f64>, Vector2<f64>) {
        let (g, off) = (self.conn.pt_grp[p], self.conn.pt_off[p]);
        let gk = self.pt_g[off + k];
        let h = self.dbar0[self.conn.grp_off[g] + k] - self.conn.pt_g0[off + k];
        let (hx, hy) = (0.5 * h.x, 0.5 * h.y);
        (Matrix3x2::new(gk.x + hx, hy, hx, gk.y + hy, gk.y, gk.x), h)
    }

    /// Internal force at the current iterate, energy-consistent with B-bar:
    /// `v (σ ΔF̄^{-T} ∇S^n + ½ tr(σ ΔF̄^{-T}) h)` at every group node of every point.
    fn internal_force(&mut self, points: &Points) {
        self.fint.iter_mut().for_each(|f| *f = 0.0);
        for p in 0..points.len() {
            let (g, off) = (self.conn.pt_grp[p], self.conn.pt_off[p]);
            let (a, b) = (self.conn.grp_off[g], self.conn.grp_off[g + 1]);
            let (v, sm) = (self.trial_vol[p], self.trial_stress[p].matrix());
            for k in 0..b - a {
                let (_, h) = self.bbar(p, k);
                let f = (sm * self.pt_g[off + k] + h * (0.5 * self.trial_tr[p])) * v;
                let i = self.conn.grp_nodes[a + k];
                self.fint[2 * i] += f.x;
                self.fint[2 * i + 1] += f.y;
            }
        }
    }

    /// Effective stiffness `c1 M + Σ v (B̄ᵀ D B̄ + geometric)` at the current iterate; with
    /// `consistent = false`, `D` is the initial elastic matrix and the geometric part is
    /// left out, which is always positive definite. Only a step that solves needs it: a
    /// converged iterate, or a grain the coupling leaves alone, skips it.
    fn stiffness(&mut self, material: &Material, c1: f64, consistent: bool) {
        let elastic = material.elastic_matrix();
        self.sys.zero();
        // group by group: its points' blocks summed first, then added to `sys` once
        for g in 0..self.conn.grp_off.len() - 1 {
            let m = self.conn.grp_off[g + 1] - self.conn.grp_off[g];
            let blk = &self.grp_blk[self.grp_blk_off[g]..][..m * m];
            self.group_blocks.clear();
            self.group_blocks.resize(m * m, Matrix2::zeros());
            let pts = &self.conn.order[self.conn.grp_pts_off[g]..self.conn.grp_pts_off[g + 1]];
            for &p in pts {
                let off = self.conn.pt_off[p];
                let v = self.trial_vol[p];
                let d = if consistent { self.tangent[p] } else { elastic };
                let sm = self.trial_stress[p].matrix();
                let tr = sm.trace();
                self.terms.clear();
                for k in 0..m {
                    let (b, h) = self.bbar(p, k);
                    let g = self.pt_g[off + k];
                    let sg = sm * g;
                    self.terms.push(NodeTerms {
                        b,
                        db: d * b * v,
                        g,
                        sg,
                        h,
                        sv: sg * v,
                        hv: h * (0.5 * v),
                        q: (sg * 0.5 + h * (0.25 * tr)) * v,
                    });
                }
                for (k, tk) in self.terms.iter().enumerate() {
                    for (l, tl) in self.terms.iter().enumerate() {
                        if blk[k * m + l] == usize::MAX {
                            continue;
                        }
                        let mut kij = tk.b.transpose() * tl.db;
                        if consistent {
                            // Geometric stiffness tr(G_k σ G_lᵀ), G = e ⊗ ∇S + ½ (e·h) I.
                            kij += Matrix2::identity() * tk.g.dot(&tl.sv)
                                + tk.sg * tl.hv.transpose()
                                + tk.h * tl.q.transpose();
                        }
                        self.group_blocks[k * m + l] += kij;
                    }
                }
            }
            for (&block, kij) in blk.iter().zip(&self.group_blocks) {
                if block != usize::MAX {
                    self.sys.add_block(block, kij);
                }
            }
        }
        for i in 0..self.m.len() {
            self.sys.add_diag(i, c1 * self.m[i]);
        }
        // Round-off guard for nodes reached with small weights (mass and stiffness both
        // ~S²): a diagonal shift of the Newton matrix only; the residual is exact, so the
        // converged state does not depend on it.
        let shift = 1e-10
            * (0..2 * self.m.len())
                .map(|d| self.sys.diag(d))
                .fold(0.0, f64::max);
        for i in 0..self.m.len() {
            self.sys.add_diag(i, shift);
        }
    }

    /// Newton increment `du` from the residual `res`, with the DOFs of active contacts
    /// prescribed to `dfix` (their coupling moved to the right-hand side).
    fn solve_increment(&mut self) -> Result<(), String> {
        self.sys.matvec(&self.dfix, &mut self.kfix);
        for d in 0..self.du.len() {
            self.du[d] = if self.fixed[d] {
                self.sys.diag(d) * self.dfix[d]
            } else {
                self.res[d] - self.kfix[d]
            };
        }
        self.sys.solve(&self.fixed, &mut self.du)
    }

    /// Grid to points at convergence (METHODS §3.3 step 8, FLIP-type Newmark update).
    fn g2p(&mut self, nm: Newmark, points: &mut Points, dt: f64) {
        for p in 0..points.len() {
            let (mut du, mut acc, mut kick) =
                (Vector2::zeros(), Vector2::zeros(), Vector2::zeros());
            for (i, w) in self.point_stencil(p) {
                let u = vec2(&self.u, i);
                du += u * w;
                acc += nm.accel(u, self.vn[i], self.an[i], dt) * w;
                kick += self.kicks[i] * w;
            }
            points.x[p] += du;
            points.v[p] = nm.velocity(points.v[p] + kick, points.a[p], acc, dt);
            points.a[p] = acc;
            points.stress[p] = self.trial_stress[p];
            points.def_grad[p] = self.trial_f[p];
            points.vol[p] = self.trial_vol[p];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mpm::material::MaterialKind;

    /// `out += K_a d`: the antisymmetric half of the `σ ⊗ 1` term of the spatial tangent
    /// (`c ∋ σ_ij δ_kl`, from the Kirchhoff stress's volume change), which the assembled
    /// tangent symmetrises so that Cholesky applies (`crate::mpm::material`).
    fn unsymmetric_part(s: &Solver, points: &Points, d: &[f64], out: &mut [f64]) {
        for p in 0..points.len() {
            let g = s.conn.pt_grp[p];
            let nodes = &s.conn.grp_nodes[s.conn.grp_off[g]..s.conn.grp_off[g + 1]];
            let st = s.trial_stress[p];
            let mut e = nalgebra::Vector3::zeros();
            for (k, &i) in nodes.iter().enumerate() {
                e += s.bbar(p, k).0 * Vector2::new(d[2 * i], d[2 * i + 1]);
            }
            // (σ ⊗ 1 - sym(σ ⊗ 1)) e in Voigt form with engineering shear
            let (h, q) = (0.5 * (st.xx - st.yy), 0.5 * st.xy);
            let t = nalgebra::Vector3::new(h * e.y - q * e.z, -h * e.x - q * e.z, q * (e.x + e.y))
                * s.trial_vol[p];
            for (k, &i) in nodes.iter().enumerate() {
                let f = s.bbar(p, k).0.transpose() * t;
                out[2 * i] += f.x;
                out[2 * i + 1] += f.y;
            }
        }
    }

    /// `|K d + ∂R/∂u d| / |∂R/∂u d|` at an iterate `amp` times a fixed smooth one (a strain
    /// of about `2e-3 amp` with a turn of `2e-3 amp`) of a disk whose start-of-step stress
    /// is `stress` at every point; `∂R/∂u d` by central differences. `d`: 0 a random
    /// field, 1 a rigid rotation, 2 a dilation. With `whole`, `K` includes the part that
    /// the assembly symmetrises away (`unsymmetric_part`).
    fn tangent_error(stress: Stress, amp: f64, d: usize, whole: bool) -> f64 {
        let r = 1e-3;
        let grid = Grid {
            origin: Vector2::new(-2.0 * r, -2.0 * r),
            h: 0.2 * r,
            nx: 21,
            ny: 21,
        };
        let material = Material {
            kind: MaterialKind::LinearElastic,
            young: 1e7,
            poisson: 0.45,
            density: 990.0,
        };
        let mut pts = Points::seed_disk(&grid, Vector2::zeros(), r, 990.0);
        pts.stress.iter_mut().for_each(|s| *s = stress);
        let (params, dt) = (SolverParams::default(), 1e-5);
        let mut s = Solver::default();
        s.begin(&params, &grid, &pts, dt, 0).unwrap();
        let mut seed = 12345u64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 10_000) as f64 / 10_000.0 - 0.5
        };
        let x: Vec<Vector2<f64>> = s.nodes().iter().map(|&id| grid.node_position(id)).collect();
        let u: Vec<f64> = x
            .iter()
            .flat_map(|x| [-1e-3 * x.x - 2e-3 * x.y, 2e-3 * x.x - 2e-3 * x.y])
            .map(|v| amp * v)
            .collect();
        let dir: Vec<f64> = x
            .iter()
            .flat_map(|x| match d {
                0 => [r * rnd(), r * rnd()],
                1 => [-x.y, x.x],
                _ => [x.x, x.y],
            })
            .collect();
        s.add_increment(&u);
        s.evaluate_residual(&params, &material, &pts, dt, 0)
            .unwrap();
        s.assemble_stiffness(&params, &material, dt);
        let mut kd = vec![0.0; dir.len()];
        s.sys.matvec(&dir, &mut kd);
        if whole {
            unsymmetric_part(&s, &pts, &dir, &mut kd);
        }
        let eps = 1e-7;
        let mut residual_at = |shift: f64| {
            let du: Vec<f64> = dir.iter().map(|v| v * shift).collect();
            s.add_increment(&du);
            s.evaluate_residual(&params, &material, &pts, dt, 0)
                .unwrap();
            let res = s.residual_vector().to_vec();
            s.add_increment(&du.iter().map(|v| -v).collect::<Vec<_>>());
            res
        };
        let (plus, minus) = (residual_at(eps), residual_at(-eps));
        let (mut err, mut norm) = (0.0, 0.0);
        for ((p, m), k) in plus.iter().zip(&minus).zip(&kd) {
            let fd = -(p - m) / (2.0 * eps);
            err += (fd - k) * (fd - k);
            norm += fd * fd;
        }
        (err / norm).sqrt()
    }

    /// The Newton matrix is the residual's derivative up to terms of the order of the
    /// increment (Hughes–Winget's midpoint map differs from its linearisation by O(L))
    /// when the start-of-step stress is a pressure (E/10 here): the geometric stiffness is
    /// the exact one (without it this fails). With a deviatoric start-of-step stress
    /// (deviator 0.04 E) the assembled matrix errs by 5.5e-3 along a random or a dilating
    /// direction at any increment (session 40): the part of the tangent that the
    /// assembly symmetrises away for Cholesky, `σ ⊗ 1 - sym(σ ⊗ 1)`, of order
    /// `|σ_dev|/E`. With that part added the derivative is again exact to O(L), so it is
    /// the whole of the difference. In a loaded packing the difference is 1.5-5% along
    /// the Newton increments, and the coupling converges linearly
    /// (`crate::mpm::packing`, module doc).
    #[test]
    fn the_tangent_is_the_residuals_derivative_up_to_the_increment_and_its_symmetrised_part() {
        let p = 1e6;
        let pressure = Stress {
            xx: -p,
            yy: -p,
            xy: 0.0,
            zz: -p,
        };
        let deviatoric = Stress {
            xx: -p,
            yy: -0.3 * p,
            xy: 0.2 * p,
            zz: -0.65 * p,
        };
        let cases = [(pressure, false), (deviatoric, true)];
        for (stress, whole) in cases {
            for d in 0..3 {
                let big = tangent_error(stress, 1.0, d, whole);
                let small = tangent_error(stress, 0.1, d, whole);
                assert!(big < 1e-3, "{stress:?}, direction {d}: {big:e}");
                // O(L): a tenth of the increment, a tenth of the error (round-off allowed)
                assert!(
                    small < 0.15 * big,
                    "{stress:?}, direction {d}: {big:e} then {small:e}"
                );
            }
        }
    }
}
