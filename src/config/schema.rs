//! The pipeline file: one struct per YAML section, unknown keys rejected, SI units.

use super::defaults as d;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pipeline {
    /// Output folder name under `--out`.
    pub name: String,
    #[serde(default = "seed")]
    pub seed: u64,
    pub prepare: Prepare,
    #[serde(default)]
    pub solver: Solver,
    #[serde(default)]
    pub output: Output,
    #[serde(default)]
    pub discretise: Option<Discretise>,
    #[serde(default)]
    pub compact: Option<Compact>,
    #[serde(default)]
    pub analyse: Option<Analyse>,
    /// Other pipeline files (paths relative to this one) whose stages join this graph, their
    /// cases prefixed by their name: `paper.yaml` includes the single-grain pipelines, so its
    /// analyse stage sees them. They keep their own seed and settings (and so their hashes
    /// and checkpoints); `--set` applies to this file only.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub include: Vec<String>,
}

fn seed() -> u64 {
    d::SEED
}

/// How the rigid disks of the prepare stage are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// `grains` disks deposited under gravity in a box.
    Packing,
    /// One grain of `radius` (single-grain tests).
    Single,
    /// The disks and walls listed under `bodies` and `walls`, run for `duration`.
    Explicit,
}

pub use crate::cd::SleepParams;
pub use crate::packing::Distribution;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Prepare {
    #[serde(default = "layout")]
    pub layout: Layout,
    /// Packing: number of grains.
    #[serde(default)]
    pub grains: Option<usize>,
    /// Packing: [min, max] grain diameter (m).
    #[serde(default)]
    pub diameter: Option<[f64; 2]>,
    #[serde(default = "distribution")]
    pub distribution: Distribution,
    /// Single: grain radius (m).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Packing: box width (m); by default the deposit comes out about as high as wide.
    #[serde(default)]
    pub box_width: Option<f64>,
    /// Disk-disk friction coefficient.
    #[serde(default = "deposit_friction")]
    pub friction: f64,
    /// Disk-wall friction coefficient.
    #[serde(default = "wall_friction")]
    pub wall_friction: f64,
    /// Gravity magnitude (m/s²), acting along -y.
    #[serde(default = "gravity")]
    pub gravity: f64,
    /// Disk density (kg/m³).
    #[serde(default = "density")]
    pub density: f64,
    /// Time step (s); by default 0.02 sqrt(<d>/g).
    #[serde(default)]
    pub time_step: Option<f64>,
    /// Packing: at rest when the translational kinetic energy / Σ m g <d> falls below this.
    #[serde(default = "rest_tolerance")]
    pub rest_tolerance: f64,
    /// Packing: the deposit fails if not at rest by this time (s).
    #[serde(default = "max_time")]
    pub max_time: f64,
    /// Packing: move overlapping disks apart once (`cd::separate`) as the pile comes to
    /// rest, then settle to rest again; absent: never. It lets a looser solver tolerance
    /// keep overlaps small (README, "One separation at rest").
    #[serde(default)]
    pub separation: Option<SeparationParams>,
    /// Put groups of touching disks to sleep once each of their disks has moved slower
    /// than `speed` (m/s, |v| + r|ω|) for `time` (s), as rapier and Box2D do
    /// (`cd/sleep.rs`); absent: no disk sleeps.
    #[serde(default)]
    pub sleep: Option<SleepParams>,
    /// Explicit: angle (degrees) by which the listed scene is tilted; gravity stays along -y.
    #[serde(default)]
    pub incline_angle: f64,
    /// Explicit: the disks.
    #[serde(default)]
    pub bodies: Vec<DiskSpec>,
    /// Explicit: the walls.
    #[serde(default)]
    pub walls: Vec<WallSpec>,
    /// Explicit: simulated time (s).
    #[serde(default)]
    pub duration: Option<f64>,
}

/// `prepare.separation`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeparationParams {
    /// Separate the first time the rest measure (translational kinetic energy over
    /// Σ m g <d>) falls below this, or at rest if it never does.
    pub at: f64,
    /// NLGS tolerance from the separation on (the pile's last settling, whose errors are
    /// the overlaps left at rest); absent: `solver.tolerance` throughout.
    #[serde(default)]
    pub tolerance: Option<f64>,
}

fn layout() -> Layout {
    Layout::Packing
}
fn distribution() -> Distribution {
    Distribution::EqualAreaPerSize
}
fn deposit_friction() -> f64 {
    d::DEPOSIT_FRICTION
}
fn wall_friction() -> f64 {
    d::WALL_FRICTION
}
fn gravity() -> f64 {
    d::GRAVITY
}
fn density() -> f64 {
    d::DENSITY
}
fn rest_tolerance() -> f64 {
    d::REST_TOLERANCE
}
fn max_time() -> f64 {
    d::MAX_TIME
}

/// A disk of the explicit layout.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiskSpec {
    /// Centre (m).
    pub position: [f64; 2],
    /// Radius (m).
    pub radius: f64,
    /// Initial velocity (m/s).
    #[serde(default)]
    pub velocity: [f64; 2],
}

/// A wall segment of the explicit layout: grains on the left of `from` -> `to`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    pub from: [f64; 2],
    pub to: [f64; 2],
    /// Imposed velocity (m/s).
    #[serde(default)]
    pub velocity: [f64; 2],
}

/// Contact-dynamics solver settings, shared by every CD stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Solver {
    /// θ of the Moreau-Jean scheme, in [0.5, 1].
    pub theta: f64,
    /// NLGS tolerance (QM/16 norms).
    pub tolerance: f64,
    /// Sweeps between convergence checks.
    pub check_every: u32,
    /// Maximum sweeps per step.
    pub max_iterations: u32,
    /// Relaxation ω of each local solve, in (0, 2): 1 is plain NLGS.
    pub relaxation: f64,
    /// Anderson acceleration's history depth over blocks of `check_every` sweeps, 0-16:
    /// 0 is off. Not with rolling resistance.
    pub anderson: u32,
    /// Solve each connected component of the contact graph apart, with its own
    /// convergence test (off by default: it changes the bits of every multi-island run).
    pub islands: bool,
    /// Alert distance in units of the smallest diameter.
    pub alert: f64,
    /// Verlet skin in units of the smallest diameter.
    pub skin: f64,
}

impl Default for Solver {
    fn default() -> Self {
        Solver {
            theta: d::THETA,
            tolerance: d::NLGS_TOLERANCE,
            check_every: d::NLGS_CHECK_EVERY,
            max_iterations: d::NLGS_MAX_ITERATIONS,
            relaxation: d::NLGS_RELAXATION,
            anderson: d::NLGS_ANDERSON,
            islands: d::NLGS_ISLANDS,
            alert: d::ALERT,
            skin: d::SKIN,
        }
    }
}

/// What the stages write besides checkpoints.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Output {
    /// Steps between VTK frames and recorded rows (0: final frame only).
    pub every: u64,
    /// The same for MPM compactions (packings and single grains), whose steps are few and
    /// long: a pipeline with both methods records each at its own pace. Absent: `every`.
    pub mpm_every: Option<u64>,
    /// Steps between resumable snapshots of long stages (0: none).
    pub snapshot_every: u64,
    /// Write VTK frames at all.
    pub vtk: bool,
}

impl Default for Output {
    fn default() -> Self {
        Output {
            every: d::OUTPUT_EVERY,
            mpm_every: None,
            snapshot_every: d::SNAPSHOT_EVERY,
            vtk: true,
        }
    }
}

impl Output {
    /// Steps between frames and rows of a compaction by `method`.
    pub fn every_for(&self, method: Method) -> u64 {
        match method {
            Method::Mpm => self.mpm_every.unwrap_or(self.every),
            Method::Bpm => self.every,
        }
    }
}

/// Method of the discretise stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    Bpm,
    Mpm,
}

/// Turning rigid disks into soft grains (BPM aggregates or MPM points).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Discretise {
    /// One case per method.
    pub method: OneOrMany<Method>,
    #[serde(default)]
    pub bpm: Option<Bpm>,
    #[serde(default)]
    pub mpm: Option<Mpm>,
}

/// Bonded particle model: primary disks and the attraction of Eq. (1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bpm {
    /// [min, max] primary-particle diameter (m), each particle's area uniform; a list of
    /// pairs makes one case each (paper Fig. 7).
    pub particle_diameter: OneOrMany<[f64; 2]>,
    /// F0 of Eq. (1) (N/m).
    pub f0: f64,
    /// γ of Eq. (1).
    #[serde(default = "gamma")]
    pub gamma: f64,
    /// Cut-off gap in units of a0 = r_i + r_j.
    #[serde(default = "cutoff")]
    pub cutoff: f64,
    /// Rolling resistance μ_r between particles of one grain (METHODS.md §1.10): a moment up
    /// to μ_r ℓ F_n, ℓ = r_i r_j/(r_i + r_j), resists their relative rotation. The paper: 0.
    #[serde(default = "rolling")]
    pub rolling_resistance: f64,
    /// Primary-particle density (kg/m³); the paper gives none, its grains' 990 is used.
    #[serde(default = "density")]
    pub density: f64,
}

fn gamma() -> f64 {
    d::BPM_GAMMA
}
fn cutoff() -> f64 {
    d::BPM_CUTOFF
}
fn rolling() -> f64 {
    d::BPM_ROLLING
}

/// Material point method: linear elastic grains in plane strain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mpm {
    /// Young's modulus (Pa).
    pub young: f64,
    /// Poisson's ratio.
    pub poisson: f64,
    /// Density (kg/m³).
    pub density: f64,
    /// Material-point spacing over grain radius, Δr/R (paper: 0.029).
    pub resolution: f64,
    /// Shape functions: `bspline` (quadratic B-spline, default: converges to the elastic
    /// solution), `bilinear` (the paper's) or `gimp`.
    #[serde(default = "shape")]
    pub shape: Shape,
    /// Grain law: `linear_elastic` (the paper's, objective update) or `neo_hookean`.
    #[serde(default = "model")]
    pub model: Model,
    /// B-bar against volumetric locking.
    #[serde(default = "yes")]
    pub bbar: bool,
    /// Where contacts between grains act in packings: `surface` (default: on the two
    /// grains' surface layers at each contact node, which keeps the grains' points out of
    /// each other but for a few in ten thousand under the heaviest load) or `node` (at the
    /// node, the paper's Eqs. 11-12, through which grains pass under load; README, "MPM
    /// packings").
    #[serde(default = "contact")]
    pub contact: ContactKind,
}

pub use crate::mpm::node_contact::ContactKind;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    Bspline,
    Bilinear,
    Gimp,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Model {
    LinearElastic,
    NeoHookean,
}

fn shape() -> Shape {
    Shape::Bspline
}
fn model() -> Model {
    Model::LinearElastic
}
fn yes() -> bool {
    true
}
fn contact() -> ContactKind {
    d::MPM_CONTACT
}

/// Compression by a moving top wall.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Compact {
    /// Top wall speed (m/s).
    pub wall_velocity: f64,
    /// Cumulative strain ln(h0/h) at which to stop.
    pub final_strain: f64,
    /// Inter-grain friction: one case per value.
    #[serde(default = "no_friction")]
    pub friction: OneOrMany<f64>,
    /// Wall friction coefficient (the paper: frictionless walls).
    #[serde(default = "wall_friction")]
    pub wall_friction: f64,
    /// Gravity (m/s², along -y) during compaction; none by default (section 5 of METHODS.md).
    #[serde(default)]
    pub gravity: f64,
    /// Time step (s). BPM default: 0.1 t0, t0 = sqrt(m a0 / F0) of the smallest particle.
    #[serde(default)]
    pub time_step: Option<f64>,
    /// Packings: packing fraction at ε = 0, which places the top wall (the paper: 0.65).
    #[serde(default = "initial_phi")]
    pub initial_phi: f64,
    /// MPM: Newton's residual tolerance, relative to the step's force scale
    /// (`mpm::solve::NewtonParams::tol_residual`): a packing's coupling iteration stops below
    /// it (default `mpm::packing::COUPLING_TOLERANCE`, 1e-5), a single grain's Newton
    /// iteration too (default 1e-6). Hashed only when set (`pipeline::plan`).
    #[serde(default)]
    pub newton_tolerance: Option<f64>,
    /// Contact-dynamics settings of this stage only, each key over `solver`'s: e.g.
    /// `{anderson: 8}` accelerates the compaction and leaves the deposit and the
    /// discretisation (and their checkpoints) as they are. BPM only: the MPM grain contact
    /// has its own solver.
    #[serde(default)]
    pub solver: Option<SolverOverride>,
}

/// Keys of `Solver` set for one stage; an absent key keeps the pipeline's `solver` value.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverOverride {
    pub theta: Option<f64>,
    pub tolerance: Option<f64>,
    pub check_every: Option<u32>,
    pub max_iterations: Option<u32>,
    pub relaxation: Option<f64>,
    pub anderson: Option<u32>,
    pub islands: Option<bool>,
    pub alert: Option<f64>,
    pub skin: Option<f64>,
}

impl SolverOverride {
    /// `base` with the keys set here replaced.
    pub fn over(&self, base: &Solver) -> Solver {
        Solver {
            theta: self.theta.unwrap_or(base.theta),
            tolerance: self.tolerance.unwrap_or(base.tolerance),
            check_every: self.check_every.unwrap_or(base.check_every),
            max_iterations: self.max_iterations.unwrap_or(base.max_iterations),
            relaxation: self.relaxation.unwrap_or(base.relaxation),
            anderson: self.anderson.unwrap_or(base.anderson),
            islands: self.islands.unwrap_or(base.islands),
            alert: self.alert.unwrap_or(base.alert),
            skin: self.skin.unwrap_or(base.skin),
        }
    }
}

impl Pipeline {
    /// The solver settings of the compact stage: `solver` with `compact.solver` over it.
    pub fn compact_solver(&self) -> Solver {
        match self.compact.as_ref().and_then(|c| c.solver.as_ref()) {
            Some(o) => o.over(&self.solver),
            None => self.solver.clone(),
        }
    }
}

fn initial_phi() -> f64 {
    d::INITIAL_PHI
}

fn no_friction() -> OneOrMany<f64> {
    OneOrMany::One(0.0)
}

/// Post-processing of the compaction and single-grain runs (METHODS.md §5): measures and
/// fit ranges. Only the analyse node hashes these, so changing one recomputes only analyse.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Analyse {
    /// Φ0 of Eqs. 14 and 16; σ0 = σ(Φ = Φ0) (the paper: 0.8).
    pub phi0: f64,
    /// Φ range of the Eq. 14 fit of BPM packings (the paper: [0.8, 0.98]).
    pub eq14_phi: [f64; 2],
    /// Φ range of the Eq. 16 fit of MPM packings.
    pub eq16_phi: [f64; 2],
    /// Jamming: the first row from which σ stays above this fraction of its final value.
    pub jamming_fraction: f64,
    /// Single grains: the small-strain slope is fitted on 0 < ε <= this.
    pub small_strain: f64,
    /// Single BPM grains: the plateau σ<a0>/F0 is the mean over this strain range.
    pub plateau_strain: [f64; 2],
    /// Packings: the final σ is the mean over this much strain before the end.
    pub final_window: f64,
}

impl Default for Analyse {
    fn default() -> Self {
        Analyse {
            phi0: d::ANALYSE_PHI0,
            eq14_phi: d::ANALYSE_EQ14_PHI,
            eq16_phi: d::ANALYSE_EQ16_PHI,
            jamming_fraction: d::ANALYSE_JAMMING_FRACTION,
            small_strain: d::ANALYSE_SMALL_STRAIN,
            plateau_strain: d::ANALYSE_PLATEAU_STRAIN,
            final_window: d::ANALYSE_FINAL_WINDOW,
        }
    }
}

/// A key that takes one value or a list of values (one case each).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    untagged,
    expecting = "expected one value or a list of values (one case each)"
)]
pub enum OneOrMany<T> {
    One(T),
    Many(Vec<T>),
}

impl<T: Clone> OneOrMany<T> {
    pub fn to_vec(&self) -> Vec<T> {
        match self {
            OneOrMany::One(x) => vec![x.clone()],
            OneOrMany::Many(v) => v.clone(),
        }
    }
}
