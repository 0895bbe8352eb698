//! One grain compressed between a fixed floor and a descending top plate (paper §3,
//! METHODS §5): a resumable stepper and a run-to-the-end driver.

use super::contact::Wall;
use super::error::MpmError;
use super::grid::Grid;
use super::material::{Material, MaterialKind};
use super::points::{Points, Stress};
use super::solve::{Solver, SolverParams};
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

/// Parameters of a single-grain compression (SI units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SingleGrainParams {
    /// Grain radius R (m).
    pub radius: f64,
    pub material: Material,
    /// Δr/R; the cell size is `h_g = 2Δr`, rounded so that a whole number
    /// `n = round(R/Δr)` of cells spans the diameter (paper: 0.029, i.e. n = 34).
    pub resolution: f64,
    /// Speed of the top plate, moving down (m/s; paper: 0.2).
    pub wall_velocity: f64,
    /// Cumulative strain `ln(h0/h)` at which the run stops.
    pub final_strain: f64,
    /// Coulomb friction between the grain and both plates (paper: not stated, assumed 0).
    pub wall_friction: f64,
    pub solver: SolverParams,
    /// Plate travel per step as a fraction of `h_g` (METHODS §6: 0.05–0.1).
    pub travel_per_step: f64,
    /// Start from the quasi-static velocity field `v_y = -V y/h0` instead of rest,
    /// which avoids the start-up wave (the trapezoidal rule does not damp it).
    pub quasi_static_start: bool,
}

impl SingleGrainParams {
    /// The paper's single MPM grain (§3): R = 5 mm, E = 10 MPa, ν = 0.45, ρ = 990 kg/m³,
    /// Δr/R = 0.029, plate at 0.2 m/s, to 30 % strain; numerical choices are ours
    /// (`SolverParams::default()`: B-spline, B-bar, trapezoidal Newmark).
    pub fn paper() -> Self {
        SingleGrainParams {
            radius: 5e-3,
            material: Material {
                kind: MaterialKind::LinearElastic,
                young: 10e6,
                poisson: 0.45,
                density: 990.0,
            },
            resolution: 0.029,
            wall_velocity: 0.2,
            final_strain: 0.3,
            wall_friction: 0.0,
            solver: SolverParams::default(),
            travel_per_step: 0.05,
            quasi_static_start: true,
        }
    }

    fn validate(&self) -> Result<(), MpmError> {
        let bad = |name, reason: &str| {
            Err(MpmError::InvalidParameter {
                name,
                reason: reason.to_string(),
            })
        };
        let m = &self.material;
        if !positive(self.radius) {
            return bad("radius", "must be > 0");
        }
        if !positive(m.young) || !positive(m.density) {
            return bad("material", "young and density must be > 0");
        }
        if !(m.poisson > -1.0 && m.poisson < 0.5) {
            return bad("poisson", "must lie in (-1, 0.5)");
        }
        if !(self.resolution > 0.0 && self.resolution <= 0.25) {
            return bad("resolution", "must lie in (0, 0.25]");
        }
        if !positive(self.wall_velocity) {
            return bad("wall_velocity", "must be > 0");
        }
        if !(self.final_strain > 0.0 && self.final_strain < 1.0) {
            return bad("final_strain", "must lie in (0, 1)");
        }
        if self.wall_friction.is_nan() || self.wall_friction < 0.0 {
            return bad("wall_friction", "must be >= 0");
        }
        if !(self.travel_per_step > 0.0 && self.travel_per_step <= 0.5) {
            return bad("travel_per_step", "must lie in (0, 0.5]");
        }
        let nm = self.solver.newmark;
        if !(nm.gamma >= 0.5 && nm.beta >= 0.25 * (nm.gamma + 0.5).powi(2) - 1e-12) {
            return bad(
                "newmark",
                "needs γ >= 1/2 and β >= (γ + 1/2)²/4 (unconditional stability)",
            );
        }
        Ok(())
    }
}

/// `x > 0`, false for NaN.
fn positive(x: f64) -> bool {
    x > 0.0
}

/// One recorded step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Time (s).
    pub time: f64,
    /// `ε = ln(h0/h)`, h the plate gap.
    pub strain: f64,
    /// Compressive normal forces on the plates (N/m).
    pub force_top: f64,
    pub force_bottom: f64,
    /// Largest horizontal extent of the points, `max(x_p + l_p) - min(x_p - l_p)` (m).
    pub width: f64,
    /// `σ = F/L` with F the mean of the two plate forces (Pa).
    pub sigma: f64,
    /// Newton iterations of this step.
    pub iterations: usize,
}

/// Mean plate force `(F_top + F_bottom)/2` at `strain` (N/m), interpolated linearly between
/// recorded steps and from the unloaded start (ε = 0, F = 0), which a coarse step may leave
/// far behind; NaN past the last row.
pub fn force_at(rows: &[Row], strain: f64) -> f64 {
    let mut prev = (0.0, 0.0);
    for r in rows {
        let next = (r.strain, 0.5 * (r.force_top + r.force_bottom));
        if prev.0 <= strain && strain <= next.0 {
            return prev.1 + (strain - prev.0) / (next.0 - prev.0) * (next.1 - prev.1);
        }
        prev = next;
    }
    f64::NAN
}

/// Mean of F/Johnson over ε = 0.010, 0.011, ..., 0.050 for a grain of `material` and
/// `radius`. The force steps by ±2-3% as grid nodes enter the contact, at strains that
/// shift with ν; the window mean averages that out (README, "ν at fixed E*").
pub fn window_mean_over_johnson(rows: &[Row], material: &Material, radius: f64) -> f64 {
    let (e, nu) = (material.young, material.poisson);
    (10..=50)
        .map(|k| {
            let strain = f64::from(k) * 1e-3;
            let johnson =
                super::analytic::johnson_force(e, nu, radius, strain).expect("a positive strain");
            force_at(rows, strain) / johnson
        })
        .sum::<f64>()
        / 41.0
}

/// Point data for output (VTK): positions, velocities, areas, stresses, von Mises.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointState {
    pub position: Vec<Vector2<f64>>,
    pub velocity: Vec<Vector2<f64>>,
    pub volume: Vec<f64>,
    pub stress: Vec<Stress>,
    pub von_mises: Vec<f64>,
}

/// Cost and step-size figures of a run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunStats {
    pub points: usize,
    /// Cell size h_g (m).
    pub cell_size: f64,
    /// Time step used (s).
    pub dt: f64,
    /// Explicit limit of the same grid, `h_g / c_p` with `c_p = sqrt((λ+2μ)/ρ)` (s).
    pub dt_cfl: f64,
    pub steps: u64,
    pub newton_iterations: u64,
    pub max_newton_iterations: usize,
    pub symbolic_factorisations: u64,
    /// Steps redone as two half steps after a failed Newton solve.
    pub halvings: u64,
    /// Wall-clock time spent in `step` (s).
    pub wall_seconds: f64,
}

/// Progress report passed to the callback.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub step: u64,
    pub time: f64,
    pub strain: f64,
    /// Fraction of the final strain reached, in [0, 1].
    pub fraction: f64,
}

/// The callback's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    Continue,
    Stop,
}

/// Output of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SingleGrainResult {
    pub rows: Vec<Row>,
    pub points: PointState,
    pub stats: RunStats,
    /// Whether the callback stopped the run before the final strain.
    pub stopped_early: bool,
}

/// Most halvings of a failed step (down to `Δt/8`).
pub const MAX_HALVINGS: u32 = 3;

/// Solver cost of one recorded step, summed over its sub-steps.
#[derive(Default)]
struct StepCost {
    iterations: usize,
    max_iterations: usize,
    symbolic: u64,
    halvings: u64,
}

/// Solver workspace and the copy of the state a failed step is restored from: rebuilt
/// after a clone or a restore, never checkpointed.
#[derive(Default)]
struct Workspace {
    solver: Solver,
    points: Points,
    walls: Vec<Wall>,
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

/// Resumable single-grain compression: serialise it between steps to checkpoint.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SingleGrain {
    pub params: SingleGrainParams,
    pub grid: Grid,
    pub points: Points,
    /// `walls[0]` the floor (y = 0), `walls[1]` the top plate.
    pub walls: Vec<Wall>,
    pub time: f64,
    pub dt: f64,
    /// Initial plate gap `h0 = 2R` (m).
    pub h0: f64,
    pub rows: Vec<Row>,
    pub stats: RunStats,
    /// Initial kinetic energy plus the work done by the plates (J/m).
    pub supplied_energy: f64,
    #[serde(skip)]
    workspace: Workspace,
}

impl SingleGrain {
    /// Seeds the grain (centre `(0, R)`, touching the floor) and places the plates.
    pub fn new(params: SingleGrainParams) -> Result<SingleGrain, MpmError> {
        params.validate()?;
        let r = params.radius;
        let n = (1.0 / params.resolution).round().max(4.0);
        let h = 2.0 * r / n;
        // Room for the widening grain: a rectangle of the grain's area at the final plate
        // gap is (π/4) R e^ε wide on each side; the bulge needs more (1.16 × 2R at 30 %).
        let half_width =
            r * (1.6_f64).max(1.5 * std::f64::consts::FRAC_PI_4 * params.final_strain.exp());
        let half = ((half_width / h).ceil() as usize) + 4;
        let grid = Grid {
            origin: Vector2::new(-(half as f64) * h, -4.0 * h),
            h,
            nx: 2 * half + 1,
            ny: n as usize + 9,
        };
        let mut points = Points::seed_disk(&grid, Vector2::new(0.0, r), r, params.material.density);
        let h0 = 2.0 * r;
        let v = params.wall_velocity;
        if params.quasi_static_start {
            for (x, vp) in points.x.iter().zip(points.v.iter_mut()) {
                vp.y = -v * x.y / h0;
            }
        }
        let mut walls = vec![
            Wall::new(Vector2::zeros(), Vector2::new(0.0, 1.0), Vector2::zeros()),
            Wall::new(
                Vector2::new(0.0, h0),
                Vector2::new(0.0, -1.0),
                Vector2::new(0.0, -v),
            ),
        ];
        for w in walls.iter_mut() {
            w.friction = params.wall_friction;
        }
        let stats = RunStats {
            points: points.len(),
            cell_size: h,
            dt: params.travel_per_step * h / v,
            dt_cfl: h / params.material.p_wave_speed(),
            ..RunStats::default()
        };
        Ok(SingleGrain {
            dt: stats.dt,
            supplied_energy: points.kinetic_energy(),
            params,
            grid,
            points,
            walls,
            time: 0.0,
            h0,
            rows: Vec::new(),
            stats,
            workspace: Workspace::default(),
        })
    }

    /// Current strain `ln(h0/h)`.
    pub fn strain(&self) -> f64 {
        (self.h0 / (self.walls[1].origin.y - self.walls[0].origin.y)).ln()
    }

    pub fn is_done(&self) -> bool {
        self.strain() >= self.params.final_strain - 1e-12
    }

    /// Advances one time step and records its row. A step whose Newton solve fails
    /// (no convergence, an inverted point, an indefinite matrix) is redone as two half
    /// steps, down to `Δt / 2^MAX_HALVINGS`, before the error is returned.
    pub fn step(&mut self) -> Result<Row, MpmError> {
        let clock = std::time::Instant::now();
        let step = self.stats.steps;
        let mut cost = StepCost::default();
        self.advance(self.dt, step, 0, &mut cost)?;
        self.time += self.dt;
        let ke = self.points.kinetic_energy();
        if !ke.is_finite() {
            return Err(MpmError::NonFinite {
                step,
                quantity: "kinetic energy",
            });
        }
        let r = self.params.radius;
        let floor = 1e-12 * self.params.material.young * r * r;
        if ke > 2.0 * self.supplied_energy + floor {
            return Err(MpmError::EnergyGrowth {
                step,
                kinetic: ke,
                supplied: self.supplied_energy,
            });
        }
        let (ft, fb) = (self.walls[1].normal_force(), self.walls[0].normal_force());
        let width = self.points.width();
        let row = Row {
            time: self.time,
            strain: self.strain(),
            force_top: ft,
            force_bottom: fb,
            width,
            sigma: 0.5 * (ft + fb) / width,
            iterations: cost.iterations,
        };
        self.rows.push(row);
        self.stats.steps += 1;
        self.stats.newton_iterations += cost.iterations as u64;
        self.stats.max_newton_iterations =
            self.stats.max_newton_iterations.max(cost.max_iterations);
        self.stats.symbolic_factorisations += cost.symbolic;
        self.stats.halvings += cost.halvings;
        self.stats.wall_seconds += clock.elapsed().as_secs_f64();
        Ok(row)
    }

    /// One solver step of `dt`, halved recursively on a failed solve.
    fn advance(
        &mut self,
        dt: f64,
        step: u64,
        depth: u32,
        cost: &mut StepCost,
    ) -> Result<(), MpmError> {
        let ws = &mut self.workspace;
        ws.points.clone_from(&self.points);
        ws.walls.clone_from(&self.walls);
        let result = ws.solver.step(
            &self.params.solver,
            &self.grid,
            &self.params.material,
            &mut self.points,
            &mut self.walls,
            dt,
            step,
        );
        match result {
            Ok(st) => {
                for w in self.walls.iter_mut() {
                    // Work done on the grain: the grain feels -force.
                    self.supplied_energy -= w.force.dot(&w.velocity) * dt;
                    w.origin += w.velocity * dt;
                }
                cost.iterations += st.iterations;
                cost.max_iterations = cost.max_iterations.max(st.iterations);
                cost.symbolic += u64::from(st.new_symbolic);
                Ok(())
            }
            Err(
                MpmError::NotConverged { .. }
                | MpmError::Inverted { .. }
                | MpmError::LinearSolve { .. },
            ) if depth < MAX_HALVINGS => {
                self.points.clone_from(&self.workspace.points);
                self.walls.clone_from(&self.workspace.walls);
                cost.halvings += 1;
                self.advance(0.5 * dt, step, depth + 1, cost)?;
                self.advance(0.5 * dt, step, depth + 1, cost)
            }
            Err(err) => Err(err),
        }
    }

    pub fn point_state(&self) -> PointState {
        let p = &self.points;
        PointState {
            position: p.x.clone(),
            velocity: p.v.clone(),
            volume: p.vol.clone(),
            stress: p.stress.clone(),
            von_mises: p.stress.iter().map(Stress::von_mises).collect(),
        }
    }

    pub fn result(&self, stopped_early: bool) -> SingleGrainResult {
        SingleGrainResult {
            rows: self.rows.clone(),
            points: self.point_state(),
            stats: self.stats.clone(),
            stopped_early,
        }
    }

    /// Steps until the final strain, reporting progress after each step.
    pub fn run(
        &mut self,
        mut callback: impl FnMut(&Progress) -> Control,
    ) -> Result<SingleGrainResult, MpmError> {
        while !self.is_done() {
            self.step()?;
            let strain = self.strain();
            let progress = Progress {
                step: self.stats.steps,
                time: self.time,
                strain,
                fraction: (strain / self.params.final_strain).clamp(0.0, 1.0),
            };
            if callback(&progress) == Control::Stop && !self.is_done() {
                return Ok(self.result(true));
            }
        }
        Ok(self.result(false))
    }
}

/// Compresses one grain to `params.final_strain`.
pub fn run_single_grain(
    params: SingleGrainParams,
    callback: impl FnMut(&Progress) -> Control,
) -> Result<SingleGrainResult, MpmError> {
    SingleGrain::new(params)?.run(callback)
}
