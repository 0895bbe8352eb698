//! Many MPM grains in a box: each grain its own nodal field on the common grid, coupled
//! through node contacts solved by contact dynamics (`super::node_contact`, METHODS §4).
//!
//! One step, condensed-Delassus scheme (METHODS §4.4B), all grains together:
//! 1. P2G of every grain on its window of the common grid, Newmark predictor (parallel);
//!    node contacts detected at the start-of-step configuration and warm-started.
//! 2. Coupling (Newton) iteration `k`: every grain evaluates its residual without contact
//!    forces `R^α(u)` (parallel). Converged when, for every grain,
//!    `‖R^α + f_c^α‖ <= tol_residual · max(‖f_int‖, ‖M a‖, ‖f_c‖)` and `k >= 1` (so the
//!    contact forces have been solved for at least once this step).
//! 3. Otherwise each grain whose residual is not converged factorises its effective
//!    stiffness; every grain with contact slots solves for its free increment
//!    `K^{-1} R` and (after a new factorisation) the condensed compliance `[K^{-1}]_cc`
//!    from unit loads along its slots' patterns, by the forward solve and a Gram product
//!    (`SymSystem::inverse_gram`; parallel).
//! 4. NLGS over all contacts on the linearised relation `u_c = u_c^k + K^{-1}(R + f_c)`.
//! 5. Each grain takes `u += K^{-1}(R + f_c)` with the new forces (parallel).
//!
//! With the small-strain law the step is linear apart from contact, so one iteration
//! solves it and the second only confirms the residual; grains without contact and without
//! load converge at `k = 0` and are never factorised. Grains not yet converged get a fresh
//! factorisation per iteration (full Newton); converged grains that still carry contacts
//! keep theirs while their neighbours converge.
//! The contact forces are exact for the factorised operator, not the mass-only `W` of the
//! staggered scheme A, whose contraction `ρ = (ωΔt/2)²/(1+(ωΔt/2)²)` is close to 1 at
//! these steps (`ωΔt ≈ 30`).
//!
//! A step whose iteration fails is redone as two half steps, and a step whose inertia cannot
//! hold the grains' rigid rotations against their pressure (`rotation_ratio` above
//! `ROTATION_LIMIT`: the tangent is then indefinite and the coupling stalls) is split in
//! two before it is tried; both at most `MAX_HALVINGS` levels deep.
//!
//! # Decisions the paper leaves open (METHODS §7.3, §7.5)
//! * **Coupling**: the condensed-Delassus scheme B above, not the staggered scheme A.
//!   Residual tolerance `COUPLING_TOLERANCE` (1e-5 of the force scale, ten times the
//!   single grain's Newton tolerance; key `compact.newton_tolerance`); from the Newmark
//!   predictor the residual of an early step falls like 5e-2, 1e-3, 1e-5, 1e-7 (the wall
//!   travels 0.05 h_g per step, and the first linearisation errs by about that
//!   fraction). NLGS tolerance 1e-6 (`NlgsParams`); the
//!   forces agree with those at 1e-10 to 1e-3 (tested). Under load the convergence is
//!   linear, by 6-50 times per iteration (5-8 per sub-step on 16 grains past ε = 0.3):
//!   the tangent is symmetrised for Cholesky (`super::material`: the `σ ⊗ 1` term), which
//!   leaves out a part of order `|σ_dev|/E` (`super::solve`'s tangent test) and errs by
//!   1.5-5% along the Newton increments there (finite differences, session 40). The
//!   NLGS's accuracy is not what limits it: at 1e-8 the same run took 9.7 iterations per
//!   step against 9.0. Correcting the grains' increments for the left-out part (one or two
//!   sweeps with the symmetric factor) while the compliances stay symmetric made it worse
//!   (`bench/README-packings.md`, "Why the coupling converges linearly").
//! * **Grids**: one common grid; each grain's "proper mesh" is the window of it covering
//!   its points plus 3 cells, so the meshes coincide (METHODS §4.1). The cell is
//!   `h_g = 2 Δr` with `Δr = resolution × mean grain radius` (the packing's grid is not
//!   given); every grain is seeded 2×2 per cell on the same lattice and its point areas
//!   rescaled to `π R²` (as for the single grain).
//! * **Where contacts act**: on the surface layers at the contact nodes (the default), or
//!   at the nodes, as in the paper (`ContactKind`, key `discretise.mpm.contact`).
//! * **Contact nodes, normal, gap, law**: see `super::node_contact` (nodes where two grains
//!   have non-light mass, one contact per pair; mass-gradient normals; point-cloud gap in a
//!   strip of one cell; the paper's velocity Signorini and Coulomb with restitution 0 and
//!   gap anticipation, overlaps left alone, and a perfectly inelastic start-of-step
//!   collision at closed contacts against the trapezoidal ratchet; alert distance `h_g`).
//!   Walls: infinite mass, frictionless by default, detected as for the single grain's
//!   plates.
//! * **Warm start** of the node forces by (common node, grain, partner).
//! * **Start**: grains at rest in the unjammed layout, no quasi-static velocity field (they
//!   carry no load until the top wall or a neighbour reaches them).
//! * **Known limit**: node contact holds nodes, not points, so the point clouds can overlap
//!   where a grain's surface is coarse: 0.06–0.08 h_g for two grains of R = 5 cells, up to
//!   0.44 h_g in the wedge of three grains of R = 3.3 cells at 5 % strain (tests). Seeded
//!   disks that touch in the deposit already show −0.2 to −0.3 h_g.
//! * **The node contact's interpenetration** (`pipelines/mpm-packing-small.yaml` with
//!   `discretise.mpm.contact: node`, 16 grains, Δr/R = 0.12, to ε = 0.3): the point
//!   clouds overlap. The worst node gap reaches -1.8 h_g without
//!   friction and -0.74 h_g with μ = 0.5 (-1.2 before the start-of-step collisions), a
//!   length that does not shrink as the grid is refined. The deep node contacts carry
//!   force (307 of 340 with g < -0.5 h_g), so the nodes hold and the points still cross.
//!   Part of it was the trapezoidal ratchet (`super::node_contact::start_collisions`);
//!   the rest comes in jumps of the gap measure of up to 0.4 h_g in a step. Earlier
//!   suspects: nodes at a contact's edges, whose mass gradients lie more than 60° from
//!   opposite and are skipped, and nodes where one grain has almost no mass.
//!   - Tried: one normal per pair (the gradients summed over the pair's nodes, so the
//!     edge nodes are held too). The overlap grew to 6.4 % of the area; not kept.
//!   - Tried before: pushing back 30 % of an overlap per step, with the earlier
//!     position law. The overlap halved, but σ rose 70 %.
//!   - Measured: at loaded contacts where both grains have mass, the points that set the
//!     gap approach 2-3e-3 h_g per step more than the held nodes. A node force moves the
//!     node, not those points (`bench/README-packings.md`, "Why held nodes do not hold
//!     the points"). Tried: the position law with anticipating collisions (worse), and
//!     that law corrected by the points' approach (the coupling diverged).
//!   - The default since session 33: `ContactKind::Surface` puts each grain-pair
//!     contact on the two grains' surface layers at its node, so its force moves the
//!     points that set the gap. The area under two grains then falls with the cell size
//!     (0.60, 0.36, 0.24 % at Δr/R = 0.12, 0.08, 0.06, μ = 0, measured with the node
//!     contact kept beside it) where the node contact's stays near 2 %; about twice the
//!     cost on 12 grains, 1.4 times on the paper's 300 without friction (README,
//!     "Surface contact", "MPM packings").
//!   - Measured on the material (`super::overlap::points_inside`, session 30): with the
//!     node contact 4-13 % of the points lie inside another grain under load (12.6 % of
//!     100 grains at ε = 0.45). With the surface contact none once loaded on 12 grains
//!     (four seeds, μ = 0 and 0.5) since session 34's measure tests the points the seeded
//!     circle clipped at their whole point's centre; at their own, which lies on the
//!     grain's face, it had counted overlaps of a few hundredths of a cell.
//!   - Fixed: two defects that had made it far worse. The position law between grains
//!     pumped energy (`super::node_contact`). The linear-elastic law saw no strain in a
//!     linearised rotation, so rocking grains swelled by 15 % (`super::material`). The
//!     coupling now takes 5–9 iterations per step instead of 22–28.
//!
//! # Cost (measured, one thread, 30 grains from Φ0 = 0.672 to ε = 0.02, μ = 0.5, Z ≈ 2)
//! | Δr/R | points | steps | CPU s/step | ms per grain-step | peak RSS |
//! | --- | --- | --- | --- | --- | --- |
//! | 0.1 | 9,652 | 27 | 0.082 | 2.7 | 53 MB |
//! | 0.05 | 38,589 | 53 | 0.37 | 12.3 | 187 MB |
//! | 0.029 | 114,724 | 90 | 1.46 | 48.6 | 555 MB |
//!
//! About 4.5 coupling iterations per step at this stage; later in the compaction it rises
//! to 9–28 (small pipeline), so the figures above are lower bounds. Profile: NLGS 22 %
//! (sequential), triangular solves 15 %, assembly 19 %. The paper's scene (300 grains,
//! L ≈ h0 ≈ 36 mm, ε = 0.5: 14 mm of wall travel at 0.05 h_g per step) would need, per
//! case on one core, ≥ 21 h at Δr/R = 0.029 (5,300 steps; ~5.5 GB), ≥ 3.1 h at 0.05
//! (3,100 steps; ~1.9 GB) and ≥ 21 min at 0.1 (1,540 steps; ~0.5 GB); two cores gave at
//! most 1.6× while the NLGS was sequential (since session 38 it runs the grain pairs of one
//! colour in parallel, `super::colour`; the paper's μ = 0 case then took 70 min on two
//! threads against 92-95 CPU-min on one). Only Δr/R ≈ 0.1 fits memory and comes near the
//! time budget, and even it exceeds 60 min for the two MPM cases once the later
//! iteration counts are included. The small pipeline uses 0.12. Each run's split of its
//! time over the parts of the step is in its `stage.json` (`Phases`, `timings_s`).

use super::colour::{Schedule, order};
use super::contact::Wall;
use super::error::MpmError;
use super::grid::Grid;
use super::material::Material;
use super::node_contact::{self as nc, GrainView, NlgsParams, NodeContact, Partner, Slots};
use super::points::Points;
use super::solve::{Solver, SolverParams};
use crate::cd::anderson::Anderson;
use crate::timing::lap;
use nalgebra::{Matrix2, Vector2};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Most levels of halving of a step (the smallest sub-step is `Δt/2^MAX_HALVINGS`). Splits
/// before a try and halvings after a failure share them: a step split twice for its
/// rotation ratio can be halved once more after a failure.
pub const MAX_HALVINGS: u32 = 3;

/// Largest `rotation_ratio` a step is tried with; above it the step is split in two first.
pub const ROTATION_LIMIT: f64 = 1.0;

/// The coupling's residual tolerance, relative to each grain's force scale (module doc),
/// where `compact.newton_tolerance` does not set it: ten times the single grain's 1e-6.
/// The coupling converges linearly under load, so 1e-6 costs its last one or two
/// iterations per sub-step; measured (`bench/README-packings.md`, "Why the coupling
/// converges linearly"): on 100 grains to ε = 0.45, 9% and 19% less time with Φ within 1e-3,
/// Z within 0.1, σ within -3 to +8% and the points inside unchanged; on 16 grains σ within
/// the seeds' spread.
pub const COUPLING_TOLERANCE: f64 = 1e-5;

/// How far a step's inertia falls short of holding the grains' rigid rotations against
/// their own pressure: the largest over the grains of `β Δt² (-Σ_p v_p tr σ_p) / J` with
/// `J = Σ_p m_p |x_p - x_c|²` about the grain's centre of mass.
///
/// Within a step the contacts keep their normals and act on fixed slots, while a grain
/// turned by θ turns its internal forces with it (stencils frozen at the start-of-step
/// points, stress rotated: `f_i → Q f_i`). The consistent tangent therefore gives the rigid
/// rotation `u_i = θ x_i^⊥` (`x_i` turned by 90°) the stiffness
/// `θ² Σ_i x_i·f_i = θ² ∫ tr σ dA`, negative under pressure, and only the inertia term
/// `θ² J/(βΔt²)` holds it: above a ratio of about 1 the step's tangent is indefinite
/// (1.01-1.04 on a disk while p ≤ E/20; at E/10 another mode goes first, at 0.57:
/// `tests/mpm_packing.rs`). Cholesky then falls back to the elastic tangent
/// (`Solver::factorize`, counted in `StepReport::indefinite`) and the coupling can stall.
/// Measured on 100 grains (surface contact, μ = 0) at ε = 0.35:
/// ratio 3.9-4.1, 95 of the 100 tangents indefinite, the coupling cycling between two
/// states at a residual of 5e-3 until the 40-iteration cap, then the step redone as two
/// halves (ratio 1.0, 8 indefinite) in about 10 iterations each. Splitting first spares the
/// failed attempt: the whole run to ε = 0.45 took 519 s instead of 1,316 s (limits of 0.5
/// and 2 gave the same time as 1 over 50 steps from ε = 0.35). With the node contact the
/// grains' pressure stays ten times lower (σ 0.11 against 1.24 MPa at ε = 0.45, the grains
/// passing into each other) and no step is split.
pub fn rotation_ratio(grains: &[Points], dt: f64, beta: f64) -> f64 {
    grains
        .iter()
        .map(|pts| {
            let centre = pts.centre_of_mass();
            let inertia: f64 = pts
                .x
                .iter()
                .zip(&pts.mass)
                .map(|(x, m)| m * (x - centre).norm_squared())
                .sum();
            let pressure: f64 = -pts
                .vol
                .iter()
                .zip(&pts.stress)
                .map(|(v, s)| v * (s.xx + s.yy))
                .sum::<f64>();
            beta * dt * dt * pressure / inertia
        })
        .fold(0.0, f64::max)
}

/// Parameters of a packing compaction (SI units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PackingParams {
    pub material: Material,
    pub solver: SolverParams,
    /// Cell size of the common grid `h_g` (m); points are seeded 2×2 per cell.
    pub cell: f64,
    /// Inter-grain Coulomb friction.
    pub friction: f64,
    /// Where grain-pair contacts act.
    pub contact: nc::ContactKind,
    /// Grain–wall friction (the paper: frictionless walls).
    pub wall_friction: f64,
    /// Gravity along -y (m/s²).
    pub gravity: f64,
    /// Top wall speed, moving down (m/s).
    pub wall_velocity: f64,
    /// Top wall travel per step over `h_g` (METHODS §6: 0.05–0.1).
    pub travel_per_step: f64,
    pub nlgs: NlgsParams,
}

/// What one step did, for the time series.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepReport {
    /// Coupling (Newton) iterations, summed over sub-steps, failed attempts included.
    pub iterations: usize,
    /// Factorisations over all grains, and NLGS sweeps; both, like `nlgs_unconverged`,
    /// include failed attempts.
    pub factorisations: usize,
    pub sweeps: usize,
    /// NLGS solves, over all coupling iterations and sub-steps, stopped by the stall window
    /// or the sweep cap. One in an early coupling iteration is harmless (an inexact Newton
    /// step); the step's own forces are those of its last solve (`residual`).
    pub nlgs_unconverged: usize,
    /// The last NLGS solve's residual over its tolerance (`NlgsOutcome::residual`), the
    /// largest over sub-steps: above 1 when the forces the step keeps stopped short of it.
    pub residual: f64,
    /// Sub-steps whose last NLGS solve stopped short of its tolerance.
    pub kept_unconverged: usize,
    /// Sub-steps redone as two halves after a failed attempt (coupling not converged, a
    /// point inverted, a factorisation failed).
    pub halvings: u64,
    /// Sub-steps split in two before they were tried (`rotation_ratio`).
    pub splits: u64,
    /// Of `factorisations`, those whose consistent tangent was indefinite, so that the
    /// elastic one was factorised instead (`Solver::factorize`).
    pub indefinite: usize,
    /// Node contacts carrying a force at the end of the step.
    pub active: usize,
    /// Most negative point-cloud gap between two grains at a contact node (m, <= 0), that
    /// node's position and the two grains.
    pub min_gap: f64,
    pub min_gap_at: [f64; 2],
    pub min_gap_grains: [usize; 2],
    /// Nodes where three or more grains meet (contacts of two or more grain pairs).
    pub multi_grain_nodes: usize,
}

/// A node contact at the end of the last step (for Z and the force network).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactRecord {
    pub position: Vector2<f64>,
    pub normal: Vector2<f64>,
    pub grain: usize,
    pub partner: Partner,
    /// Normal and tangential force on `grain` (N/m).
    pub force_n: f64,
    pub force_t: f64,
    /// Where the force acts on `grain` and (opposite) on a partner grain: the centroids of
    /// the two load patterns on the grid (`Slots::entries`), both the node for the node
    /// contact, a grain's surface layer for the surface contact; for a wall, the first twice.
    pub applied: [Vector2<f64>; 2],
}

impl ContactRecord {
    /// The force on `grain` (N/m).
    pub fn force(&self) -> Vector2<f64> {
        self.normal * self.force_n + crate::geom::perp(self.normal) * self.force_t
    }
}

/// Per-grain solver workspace (never checkpointed).
#[derive(Default)]
struct GrainWork {
    solver: Solver,
    window: Grid,
    /// Contact forces at the active nodes.
    fc: Vec<f64>,
    rhs: Vec<f64>,
    scale: f64,
    rel: f64,
    factored: bool,
    /// Whether this iteration solves for the grain's increment.
    updating: bool,
}

impl AsRef<Solver> for GrainWork {
    fn as_ref(&self) -> &Solver {
        &self.solver
    }
}

impl AsMut<Solver> for GrainWork {
    fn as_mut(&mut self) -> &mut Solver {
        &mut self.solver
    }
}

#[derive(Default)]
struct Workspace {
    grains: Vec<GrainWork>,
    contacts: Vec<NodeContact>,
    slots: Vec<Slots>,
    schedule: Schedule,
    backup: Vec<Points>,
    anderson: Anderson,
    phases: Phases,
}

/// Wall seconds this process's steps spent in each part of the scheme (module doc), failed
/// attempts included: where a run's time goes, for `stage.json`. Not checkpointed (it
/// differs from run to run), so a resumed run counts its own steps only.
#[derive(Clone, Copy, Debug, Default)]
pub struct Phases {
    /// 1: windows, P2G and the Newmark predictor.
    pub begin: f64,
    /// 1: contact detection, the colour order, start-of-step collisions, warm start.
    pub detect: f64,
    /// 2: the grains' residuals (internal forces) and the convergence test.
    pub residual: f64,
    /// 3: factorisations, free increments and condensed compliances.
    pub factorise: f64,
    /// 4: the NLGS over all contacts.
    pub contact: f64,
    /// 5: the increments with the new contact forces.
    pub update: f64,
    /// G2P, wall forces and the contact records.
    pub finish: f64,
}

impl Phases {
    /// The parts by name, in the scheme's order.
    pub fn named(&self) -> [(&'static str, f64); 7] {
        [
            ("begin", self.begin),
            ("detect", self.detect),
            ("residual", self.residual),
            ("factorise", self.factorise),
            ("contact", self.contact),
            ("update", self.update),
            ("finish", self.finish),
        ]
    }
}

impl Clone for Workspace {
    fn clone(&self) -> Self {
        Workspace::default()
    }
}

impl std::fmt::Debug for Workspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Workspace")
    }
}

/// A resumable packing compaction: serialise it between steps to checkpoint.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Packing {
    pub params: PackingParams,
    /// The common grid, covering the box with a margin of 4 cells.
    pub grid: Grid,
    pub width: f64,
    pub h0: f64,
    pub grains: Vec<Points>,
    /// Floor, left, right and top walls.
    pub walls: Vec<Wall>,
    pub time: f64,
    pub dt: f64,
    pub steps: u64,
    /// Forces of the last step's loaded contacts, for the warm start.
    warm: Vec<((usize, usize, Partner), f64, f64)>,
    /// The last step's contacts with a force.
    pub contacts: Vec<ContactRecord>,
    #[serde(skip)]
    workspace: Workspace,
}

/// Index of the top wall in `Packing::walls`.
pub const TOP: usize = 3;

impl Packing {
    /// Seeds one disk grain per `(centre, radius)` in the box `[0, width] × [0, h0]`.
    pub fn new(
        params: PackingParams,
        centres: &[Vector2<f64>],
        radii: &[f64],
        width: f64,
        h0: f64,
    ) -> Result<Packing, MpmError> {
        let h = params.cell;
        if !(h > 0.0 && width > 0.0 && h0 > 0.0 && params.wall_velocity > 0.0) {
            return Err(MpmError::InvalidParameter {
                name: "packing",
                reason: "cell, box and wall velocity must be > 0".into(),
            });
        }
        let grid = Grid {
            origin: Vector2::new(-4.0 * h, -4.0 * h),
            h,
            nx: (width / h).ceil() as usize + 9,
            ny: (h0 / h).ceil() as usize + 9,
        };
        let mut grains = Vec::with_capacity(centres.len());
        for (c, &r) in centres.iter().zip(radii) {
            let window = window(&grid, *c - Vector2::repeat(r), *c + Vector2::repeat(r));
            let pts = Points::seed_disk(&window, *c, r, params.material.density);
            if pts.is_empty() {
                return Err(MpmError::InvalidParameter {
                    name: "cell",
                    reason: format!("a grain of radius {r:e} m gets no point at h = {h:e} m"),
                });
            }
            grains.push(pts);
        }
        let mut walls = vec![
            Wall::new(Vector2::zeros(), Vector2::new(0.0, 1.0), Vector2::zeros()),
            Wall::new(Vector2::zeros(), Vector2::new(1.0, 0.0), Vector2::zeros()),
            Wall::new(
                Vector2::new(width, 0.0),
                Vector2::new(-1.0, 0.0),
                Vector2::zeros(),
            ),
            Wall::new(
                Vector2::new(0.0, h0),
                Vector2::new(0.0, -1.0),
                Vector2::new(0.0, -params.wall_velocity),
            ),
        ];
        for w in walls.iter_mut() {
            w.friction = params.wall_friction;
        }
        Ok(Packing {
            dt: params.travel_per_step * h / params.wall_velocity,
            params,
            grid,
            width,
            h0,
            grains,
            walls,
            time: 0.0,
            steps: 0,
            warm: Vec::new(),
            contacts: Vec::new(),
            workspace: Workspace::default(),
        })
    }

    /// The single-grain scene of `driver::SingleGrain` (the grain on the floor, the top
    /// plate at 2R moving down, the same grid cell and step) built in this engine, with
    /// side walls a radius clear of the grain: what the packing machinery would cost a
    /// single grain (`benches/single_grain.rs`), and that it gives the same force
    /// (`tests/mpm_packing.rs`).
    pub fn single_grain(p: &super::driver::SingleGrainParams) -> Result<Packing, MpmError> {
        let r = p.radius;
        let h = 2.0 * r / (1.0 / p.resolution).round().max(4.0);
        // the centre on a node column, as in the driver's grid
        let width = 2.0 * (2.0 * r / h).ceil() * h;
        let params = PackingParams {
            material: p.material,
            solver: p.solver,
            cell: h,
            friction: 0.0,
            contact: nc::ContactKind::Node,
            wall_friction: p.wall_friction,
            gravity: 0.0,
            wall_velocity: p.wall_velocity,
            travel_per_step: p.travel_per_step,
            nlgs: NlgsParams::default(),
        };
        let mut pk = Packing::new(
            params,
            &[Vector2::new(0.5 * width, r)],
            &[r],
            width,
            2.0 * r,
        )?;
        if p.quasi_static_start {
            // the driver's start: the velocity field of a uniform compression
            let (v, h0) = (p.wall_velocity, pk.h0);
            let g = &mut pk.grains[0];
            for (x, vp) in g.x.iter().zip(g.v.iter_mut()) {
                vp.y = -v * x.y / h0;
            }
        }
        Ok(pk)
    }

    /// Box height `h` (m).
    pub fn height(&self) -> f64 {
        self.walls[TOP].origin.y - self.walls[0].origin.y
    }

    /// `ε = ln(h0/h)`.
    pub fn strain(&self) -> f64 {
        (self.h0 / self.height()).ln()
    }

    /// `Φ = Σ v_p / (L h)`.
    pub fn phi(&self) -> f64 {
        self.grain_area() / (self.width * self.height())
    }

    /// Σ v_p over every grain (m² per unit thickness).
    pub fn grain_area(&self) -> f64 {
        self.grains.iter().flat_map(|g| g.vol.iter()).sum()
    }

    pub fn total_mass(&self) -> f64 {
        self.grains.iter().map(Points::total_mass).sum()
    }

    /// Material points over every grain.
    pub fn point_count(&self) -> usize {
        self.grains.iter().map(Points::len).sum()
    }

    pub fn momentum(&self) -> Vector2<f64> {
        self.grains.iter().map(Points::momentum).sum()
    }

    /// Where this process's steps spent their time so far.
    pub fn phases(&self) -> Phases {
        self.workspace.phases
    }

    pub fn kinetic_energy(&self) -> f64 {
        self.grains.iter().map(Points::kinetic_energy).sum()
    }

    /// `Σ_p v_p σ_p`, the in-plane stress integrated over every grain (N m/m), the box's
    /// mean stress times its area.
    pub fn stress_integral(&self) -> Matrix2<f64> {
        self.grains
            .iter()
            .flat_map(|g| g.stress.iter().zip(&g.vol))
            .map(|(s, v)| s.matrix() * *v)
            .sum()
    }

    /// The moments `Σ x ⊗ f` of the last step's contact forces on the grains, where they act
    /// on the grid: (walls, grain pairs). A pair adds `(x_a - x_b) ⊗ f`, zero for the node
    /// contact (both act at the node) but not for the surface contact, whose two forces act
    /// on surface layers about a cell apart. With linear-complete shape functions
    /// `Σ_i x_i ⊗ ∇S_ip = I`, so the internal nodal forces' moment is `Σ_p v_p σ_p`: in
    /// equilibrium, without gravity, `stress_integral` is the sum of the two.
    pub fn contact_moments(&self) -> (Matrix2<f64>, Matrix2<f64>) {
        let (mut walls, mut pairs) = (Matrix2::zeros(), Matrix2::zeros());
        for c in &self.contacts {
            let f = c.force();
            match c.partner {
                Partner::Wall(_) => walls += c.applied[0] * f.transpose(),
                Partner::Grain(_) => pairs += (c.applied[0] - c.applied[1]) * f.transpose(),
            }
        }
        (walls, pairs)
    }

    /// Elastic energy `Σ v_p w(σ_p)`, with the linear-elastic complementary energy density
    /// including `σzz` (exact for the small-strain law, an estimate for neo-Hookean) (J/m).
    pub fn elastic_energy(&self) -> f64 {
        let (e, nu) = (self.params.material.young, self.params.material.poisson);
        self.grains
            .iter()
            .flat_map(|g| g.stress.iter().zip(&g.vol))
            .map(|(s, v)| {
                let sq = s.xx * s.xx + s.yy * s.yy + s.zz * s.zz;
                let cross = s.xx * s.yy + s.yy * s.zz + s.zz * s.xx;
                v * ((sq - 2.0 * nu * cross) / (2.0 * e) + (1.0 + nu) / e * s.xy * s.xy)
            })
            .sum()
    }

    /// Advances one time step: split in two before it is tried while `rotation_ratio`
    /// exceeds `ROTATION_LIMIT`, halved after a failed attempt, both within `MAX_HALVINGS`
    /// levels (the smallest sub-step is `Δt/8`).
    pub fn step(&mut self) -> Result<StepReport, MpmError> {
        let step = self.steps;
        let mut report = StepReport::default();
        self.advance(self.dt, step, 0, &mut report)?;
        self.time += self.dt;
        self.steps += 1;
        if !self.kinetic_energy().is_finite() {
            return Err(MpmError::NonFinite {
                step,
                quantity: "kinetic energy",
            });
        }
        Ok(report)
    }

    fn advance(
        &mut self,
        dt: f64,
        step: u64,
        depth: u32,
        report: &mut StepReport,
    ) -> Result<(), MpmError> {
        if depth < MAX_HALVINGS
            && rotation_ratio(&self.grains, dt, self.params.solver.newmark.beta) > ROTATION_LIMIT
        {
            report.splits += 1;
            self.advance(0.5 * dt, step, depth + 1, report)?;
            return self.advance(0.5 * dt, step, depth + 1, report);
        }
        let mut ws = std::mem::take(&mut self.workspace);
        ws.backup.clone_from(&self.grains);
        let walls = self.walls.clone();
        let warm = self.warm.clone();
        let result = self.solve_step(&mut ws, dt, step, report);
        let failed = matches!(
            result,
            Err(MpmError::NotConverged { .. }
                | MpmError::Inverted { .. }
                | MpmError::LinearSolve { .. })
        );
        if failed && depth < MAX_HALVINGS {
            std::mem::swap(&mut self.grains, &mut ws.backup);
            self.walls = walls;
            self.warm = warm;
            self.workspace = ws;
            report.halvings += 1;
            self.advance(0.5 * dt, step, depth + 1, report)?;
            return self.advance(0.5 * dt, step, depth + 1, report);
        }
        self.workspace = ws;
        result
    }

    /// One step of `dt` by the scheme of the module doc.
    fn solve_step(
        &mut self,
        ws: &mut Workspace,
        dt: f64,
        step: u64,
        report: &mut StepReport,
    ) -> Result<(), MpmError> {
        let mut clock = Instant::now();
        let p = &self.params;
        let (grid, grains) = (&self.grid, &self.grains);
        ws.grains.resize_with(grains.len(), GrainWork::default);
        let gravity = Vector2::new(0.0, -p.gravity);
        ws.grains
            .par_iter_mut()
            .zip(grains.par_iter())
            .try_for_each(|(w, pts)| {
                let (lo, hi) = bounds(pts);
                w.window = window(grid, lo, hi);
                w.solver.gravity = gravity;
                w.factored = false;
                w.solver.begin(&p.solver, &w.window, pts, dt, step)
            })?;
        ws.phases.begin += lap(&mut clock);
        {
            let views: Vec<GrainView> = ws
                .grains
                .iter()
                .zip(grains)
                .map(|(w, pts)| GrainView {
                    solver: &w.solver,
                    points: pts,
                    window: &w.window,
                })
                .collect();
            nc::detect(
                grid,
                &views,
                &self.walls,
                p.friction,
                p.solver.newmark,
                dt,
                grid.h,
                p.contact,
                &mut ws.contacts,
                &mut ws.slots,
            );
        }
        order(&mut ws.contacts, grains.len(), &mut ws.schedule);
        nc::start_collisions(
            &mut ws.contacts,
            &ws.slots,
            &mut ws.grains,
            p.solver.newmark,
            dt,
        );
        if crate::shortcuts::get().warm_start {
            nc::warm_start(&mut ws.contacts, &self.warm);
        }
        for c in &ws.contacts {
            if let Partner::Grain(b) = c.partner
                && c.gap < report.min_gap
            {
                report.min_gap = c.gap;
                let x = grid.node_position(c.node);
                report.min_gap_at = [x.x, x.y];
                report.min_gap_grains = [c.a, b];
            }
        }
        let mut pair_nodes: Vec<usize> = ws
            .contacts
            .iter()
            .filter(|c| matches!(c.partner, Partner::Grain(_)))
            .map(|c| c.node)
            .collect();
        pair_nodes.sort_unstable();
        report.multi_grain_nodes = pair_nodes
            .chunk_by(|a, b| a == b)
            .filter(|run| run.len() > 1)
            .count();
        ws.phases.detect += lap(&mut clock);

        let tol = p.solver.newton.tol_residual;
        let floor = p.material.young * grid.h * 1e-6;
        let mut converged = false;
        let mut worst = f64::INFINITY;
        let mut last_solve = nc::NlgsOutcome {
            sweeps: 0,
            converged: true,
            residual: 0.0,
        };
        for it in 0..=p.solver.newton.max_iterations {
            ws.grains
                .par_iter_mut()
                .zip(grains.par_iter())
                .try_for_each(|(w, pts)| -> Result<(), MpmError> {
                    w.scale = w
                        .solver
                        .evaluate_residual(&p.solver, &p.material, pts, dt, step)?;
                    w.fc.clear();
                    w.fc.resize(w.solver.residual_vector().len(), 0.0);
                    Ok(())
                })?;
            {
                let mut fc: Vec<Vec<f64>> = ws
                    .grains
                    .iter_mut()
                    .map(|w| std::mem::take(&mut w.fc))
                    .collect();
                nc::scatter(&ws.contacts, &ws.slots, &mut fc);
                for (w, f) in ws.grains.iter_mut().zip(fc) {
                    w.fc = f;
                }
            }
            worst = 0.0;
            for w in ws.grains.iter_mut() {
                let r = w.solver.residual_vector();
                let (mut rs, mut fs) = (0.0, 0.0);
                for (a, b) in r.iter().zip(&w.fc) {
                    rs += (a + b) * (a + b);
                    fs += b * b;
                }
                w.rel = rs.sqrt() / w.scale.max(fs.sqrt()).max(floor);
                worst = worst.max(w.rel);
            }
            ws.phases.residual += lap(&mut clock);
            if worst <= tol && (it > 0 || ws.contacts.is_empty()) {
                report.residual = report.residual.max(last_solve.residual);
                report.kept_unconverged += usize::from(!last_solve.converged);
                converged = true;
                break;
            }
            if it == p.solver.newton.max_iterations {
                break;
            }
            // Free increments and compliances.
            let (factorised, indefinite) = ws
                .grains
                .par_iter_mut()
                .zip(ws.slots.par_iter_mut())
                .map_init(LoadColumns::default, |cols, (w, s)| {
                    let consistent = grain_free(w, s, cols, p, dt, step, tol)?;
                    Ok((
                        usize::from(consistent.is_some()),
                        usize::from(consistent == Some(false)),
                    ))
                })
                .try_reduce(|| (0, 0), |a, b| Ok((a.0 + b.0, a.1 + b.1)))?;
            report.factorisations += factorised;
            report.indefinite += indefinite;
            ws.phases.factorise += lap(&mut clock);
            nc::load_slots(&ws.contacts, &mut ws.slots);
            let solve = nc::nlgs(
                &mut ws.contacts,
                &mut ws.slots,
                &ws.schedule,
                p.nlgs,
                floor,
                &mut ws.anderson,
            );
            report.sweeps += solve.sweeps;
            report.nlgs_unconverged += usize::from(!solve.converged);
            last_solve = solve;
            ws.phases.contact += lap(&mut clock);
            // Update with the new forces.
            {
                let mut fc: Vec<Vec<f64>> = ws
                    .grains
                    .iter_mut()
                    .map(|w| {
                        let mut f = std::mem::take(&mut w.fc);
                        f.iter_mut().for_each(|x| *x = 0.0);
                        f
                    })
                    .collect();
                nc::scatter(&ws.contacts, &ws.slots, &mut fc);
                for (w, f) in ws.grains.iter_mut().zip(fc) {
                    w.fc = f;
                }
            }
            ws.grains
                .par_iter_mut()
                .try_for_each(|w| -> Result<(), MpmError> {
                    if !w.updating {
                        return Ok(());
                    }
                    w.rhs.clear();
                    w.rhs.extend(
                        w.solver
                            .residual_vector()
                            .iter()
                            .zip(&w.fc)
                            .map(|(r, f)| r + f),
                    );
                    let mut rhs = std::mem::take(&mut w.rhs);
                    w.solver.solve(&mut rhs, 1, step)?;
                    if rhs.iter().any(|x| !x.is_finite()) {
                        return Err(MpmError::NonFinite {
                            step,
                            quantity: "displacement increment",
                        });
                    }
                    w.solver.add_increment(&rhs);
                    w.rhs = rhs;
                    Ok(())
                })?;
            // counted as done, so that a failed attempt's iterations count too
            report.iterations += 1;
            ws.phases.update += lap(&mut clock);
        }
        if !converged {
            return Err(MpmError::NotConverged {
                step,
                iterations: p.solver.newton.max_iterations,
                residual: worst,
                active_set_changing: false,
            });
        }
        let nm = p.solver.newmark;
        ws.grains
            .par_iter_mut()
            .zip(self.grains.par_iter_mut())
            .for_each(|(w, pts)| w.solver.finish(nm, pts, dt));
        // Wall forces (force on the wall = minus the force on the grains), records.
        for w in self.walls.iter_mut() {
            w.force = Vector2::zeros();
            w.contacts = 0;
        }
        self.contacts.clear();
        for c in ws.contacts.iter().filter(|c| c.force_n > 0.0) {
            if let Partner::Wall(k) = c.partner {
                self.walls[k].force -= c.force();
                self.walls[k].contacts += 1;
            }
            let w = &ws.grains[c.a];
            let id = w.solver.nodes()[c.node_a];
            let at = |g: usize, slot: usize| -> Vector2<f64> {
                let w = &ws.grains[g];
                ws.slots[g]
                    .entries(slot)
                    .iter()
                    .map(|&(i, weight)| w.window.node_position(w.solver.nodes()[i]) * weight)
                    .sum()
            };
            let on_a = at(c.a, c.slot_a);
            let on_b = match c.partner {
                Partner::Grain(b) => at(b, c.slot_b),
                Partner::Wall(_) => on_a,
            };
            self.contacts.push(ContactRecord {
                position: w.window.node_position(id),
                normal: c.normal,
                grain: c.a,
                partner: c.partner,
                force_n: c.force_n,
                force_t: c.force_t,
                applied: [on_a, on_b],
            });
        }
        report.active = self.contacts.len();
        nc::remember(&ws.contacts, &mut self.warm);
        for w in self.walls.iter_mut() {
            w.origin += w.velocity * dt;
        }
        ws.phases.finish += lap(&mut clock);
        Ok(())
    }

    /// Grain pairs with at least one loaded contact node, and the number of walls each
    /// grain touches.
    pub fn contact_pairs(&self) -> (Vec<(usize, usize)>, Vec<usize>) {
        let mut pairs = Vec::new();
        let mut touch: Vec<(usize, usize)> = Vec::new();
        for c in &self.contacts {
            match c.partner {
                Partner::Grain(b) => pairs.push((c.grain, b)),
                Partner::Wall(k) => touch.push((c.grain, k)),
            }
        }
        touch.sort_unstable();
        touch.dedup();
        let mut walls = vec![0; self.grains.len()];
        for (g, _) in touch {
            walls[g] += 1;
        }
        (pairs, walls)
    }
}

/// Scratch of `grain_free`'s compliance, one per thread of the parallel loop: the unit load
/// columns and their forward solve (`n × 2 slots` each), and the compliance in double
/// precision before it is rounded (`2 slots` square). Kept per grain the first two cost a
/// 100-grain packing a fifth more memory; allocated per grain and iteration they were an
/// allocation in the time step's inner loop.
#[derive(Default)]
struct LoadColumns {
    loads: Vec<f64>,
    solved: Vec<f64>,
    /// The compliance in double precision, before it is rounded into the slots'.
    gram: Vec<f64>,
}

/// Factorises grain `w` if it needs it, then sets its slots' free displacement
/// `u_c + [K^{-1} R]_c` and (after a factorisation) its compliance. Returns `None` when the
/// grain kept its factorisation, otherwise whether the consistent tangent was the one
/// factorised (`Solver::factorize`).
fn grain_free(
    w: &mut GrainWork,
    s: &mut Slots,
    cols: &mut LoadColumns,
    p: &PackingParams,
    dt: f64,
    step: u64,
    tol: f64,
) -> Result<Option<bool>, MpmError> {
    let converged = w.rel <= tol;
    w.updating = !(converged && s.is_empty());
    if !w.updating {
        return Ok(None);
    }
    let mut consistent = None;
    if !(converged && w.factored) {
        w.solver.assemble_stiffness(&p.solver, &p.material, dt);
        consistent = Some(w.solver.factorize(&p.solver, &p.material, dt, step)?);
        w.factored = true;
    }
    let n = w.solver.residual_vector().len();
    let mut rhs = std::mem::take(&mut w.rhs);
    rhs.clear();
    rhs.extend_from_slice(w.solver.residual_vector());
    w.solver.solve(&mut rhs, 1, step)?;
    let u = w.solver.displacement();
    for (r, x) in rhs.iter_mut().zip(u) {
        *r += x;
    }
    s.disp.clear();
    s.patterns.project(&rhs, &mut s.disp);
    w.rhs = rhs;
    if consistent.is_some() && !s.is_empty() {
        // unit loads along each slot's pattern, and from them the compliance `Pᵀ K⁻¹ P`
        let m = 2 * s.len();
        let loads = &mut cols.loads;
        loads.clear();
        loads.resize(n * m, 0.0);
        for k in 0..s.len() {
            for &(i, wt) in s.entries(k) {
                loads[(2 * k) * n + 2 * i] = wt;
                loads[(2 * k + 1) * n + 2 * i + 1] = wt;
            }
        }
        cols.gram.clear();
        cols.gram.resize(m * m, 0.0);
        w.solver
            .compliance(loads, m, &mut cols.gram, &mut cols.solved, step)?;
        s.compliance.clear();
        s.compliance.extend(cols.gram.iter().map(|&c| c as f32));
    }
    Ok(consistent)
}

/// Bounding box of the points' centres.
fn bounds(pts: &Points) -> (Vector2<f64>, Vector2<f64>) {
    pts.x.iter().fold(
        (
            Vector2::repeat(f64::INFINITY),
            Vector2::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), x| (lo.inf(x), hi.sup(x)),
    )
}

/// The window of `grid` covering `[lo, hi]` plus 3 cells (a B-spline stencil reaches 1.5),
/// clipped to the grid.
fn window(grid: &Grid, lo: Vector2<f64>, hi: Vector2<f64>) -> Grid {
    let a = ((lo - grid.origin) / grid.h).map(|v| (v.floor() - 3.0).max(0.0) as usize);
    let b = ((hi - grid.origin) / grid.h).map(|v| (v.ceil() + 3.0).max(0.0) as usize);
    let (i1, j1) = (b.x.min(grid.nx - 1), b.y.min(grid.ny - 1));
    let (i0, j0) = (a.x.min(i1), a.y.min(j1));
    Grid {
        origin: grid.origin + Vector2::new(i0 as f64, j0 as f64) * grid.h,
        h: grid.h,
        nx: i1 - i0 + 1,
        ny: j1 - j0 + 1,
    }
}
