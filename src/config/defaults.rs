//! Every default of the pipeline files, with its unit and where it comes from. The YAML
//! keys that are left out take these values; `softgrain validate` prints the result.

/// Seed of every random choice.
pub const SEED: u64 = 1;

// ---- prepare (rigid-disk deposit) ----
/// Gravity during the deposit (m/s²).
pub const GRAVITY: f64 = 9.81;
/// Disk density (kg/m³); the paper's grain density (section 3).
pub const DENSITY: f64 = 990.0;
/// Disk-disk friction of the deposit; the paper does not give its protocol (METHODS.md §7).
pub const DEPOSIT_FRICTION: f64 = 0.3;
/// Wall friction: frictionless walls, as in the paper's compaction (section 4).
pub const WALL_FRICTION: f64 = 0.0;
/// Rest criterion: translational kinetic energy over Σ m g <d> (dimensionless).
pub const REST_TOLERANCE: f64 = 1e-9;
/// The rest criterion must hold this many consecutive steps: with zero restitution a
/// packing can stop dead for an instant between two collapses.
pub const REST_STEPS: u64 = 50;
/// `prepare.separation`: the separation stops once no overlap is deeper than this
/// fraction of the mean radius, within this many Gauss-Seidel sweeps per linearisation.
pub const SEPARATION_TOLERANCE: f64 = 1e-6;
pub const SEPARATION_MAX_SWEEPS: u32 = 10_000;
/// Give up a deposit that is not at rest after this much simulated time (s).
pub const MAX_TIME: f64 = 20.0;
/// Deposit time step in units of sqrt(<d>/g): a disk falling one box height moves a few
/// hundredths of a diameter per step (METHODS.md §6).
pub const DEPOSIT_STEP: f64 = 0.02;
/// Packing fraction assumed when the box width is chosen so that the deposit is about as
/// high as wide (dense random disk packings: 0.80-0.84).
pub const SQUARE_BOX_PHI: f64 = 0.82;

// ---- discretise ----
/// γ of Eq. (1): the Lennard-Jones value the paper uses.
pub const BPM_GAMMA: f64 = 7.0;
/// Cut-off of Eq. (1) in units of a0: the paper's δ = a0.
pub const BPM_CUTOFF: f64 = 1.0;
/// Rolling resistance between particles of one grain: none, as in the paper.
pub const BPM_ROLLING: f64 = 0.0;

/// BPM time step in units of t0 = sqrt(m a0/F0) of the smallest particle: the explicit
/// attraction is stable below about 0.53 t0 (METHODS.md §1.9).
pub const BPM_STEP: f64 = 0.1;
/// Steps of relaxation of freshly built aggregates under their own attraction.
pub const BPM_RELAX_STEPS: u64 = 400;
/// Where MPM grain-pair contacts act: on the grains' surface layers. With the paper's node
/// contact 9.8% of the material points of its 300 grains lie inside another grain at
/// ε = 0.45 (the grains pass into each other under 0.16 MPa); with this one 0.10-0.15% by
/// the measure of session 33 (which counted clipped surface points at their own centre),
/// and the walls carry about 1 MPa, the grains losing the area the box's Φ asks for
/// (about 0.8 MPa of mean stress), at 1.4 times the node contact's CPU time without friction
/// in session 31's builds (README, "MPM packings"; decision of session 33).
pub const MPM_CONTACT: super::schema::ContactKind = super::schema::ContactKind::Surface;

// ---- compact ----
/// Packing fraction at the start of a packing's compaction: the paper's unjammed 0.65
/// (Fig. 8a). The deposit is stretched vertically to fill the box (`compaction.rs`).
pub const INITIAL_PHI: f64 = 0.65;

// ---- analyse (METHODS.md §5) ----
/// Φ0 of Eqs. 14 and 16, where σ0 is read: the paper's consolidation point Φ ≈ 0.8.
pub const ANALYSE_PHI0: f64 = 0.8;
/// Φ range of the Eq. 14 fit: the paper fits "up to a packing fraction ≃ 0.98".
pub const ANALYSE_EQ14_PHI: [f64; 2] = [0.8, 0.98];
/// Φ range of the Eq. 16 fit: the paper's MPM data are linear "until very high" Φ; the
/// same range as Eq. 14 so the two fits compare.
pub const ANALYSE_EQ16_PHI: [f64; 2] = [0.8, 0.98];
/// Jamming: σ stays above 1% of its final value (a few % of σ0 for the paper's curves,
/// above the noise of the unjammed rows).
pub const ANALYSE_JAMMING_FRACTION: f64 = 0.01;
/// Single grains: the linear regime, ε <= 2% (the paper's BPM "of the order of 2%"; Eq. 13
/// holds below 5%).
pub const ANALYSE_SMALL_STRAIN: f64 = 0.02;
/// Single BPM grains: the plateau is read from ε = 0.1 on (as `compact` does).
pub const ANALYSE_PLATEAU_STRAIN: [f64; 2] = [0.1, 1.0];
/// Packings: the final σ is the mean over the last 1% of strain. A row's σ is a mean over
/// its recording interval, and the last row's interval is whatever is left (a few steps),
/// so alone it is noisier (961 → 1029 kPa over the last six steps of the 300-grain
/// surface-contact run, while the grains' own stress moved as before). Where σ rises
/// steeply the window lags the end: `quick.yaml`'s BPM μ = 0 gives 1.21 MPa against 0.86 on
/// the last full row and 2.31 on the short one after it, both walls alike.
pub const ANALYSE_FINAL_WINDOW: f64 = 0.01;

// ---- contact-dynamics solver ----
/// θ of the Moreau-Jean scheme: 1 closes contacts exactly (METHODS.md §1.1).
pub const THETA: f64 = 1.0;
/// NLGS tolerance of the QM/16 norms (LMGC90 examples, METHODS.md §1.6).
pub const NLGS_TOLERANCE: f64 = 1.666e-4;
/// Sweeps between convergence checks.
pub const NLGS_CHECK_EVERY: u32 = 10;
/// Relaxation ω of the local solves: 1 is plain NLGS (see `NlgsParams::relax`).
pub const NLGS_RELAXATION: f64 = 1.0;
/// Anderson acceleration's history depth (`NlgsParams::anderson`): 0 is off.
pub const NLGS_ANDERSON: u32 = 0;
/// Islands of the contact graph solved apart (`NlgsParams::islands`): off.
pub const NLGS_ISLANDS: bool = false;
/// Sweeps after which a step is reported unconverged.
pub const NLGS_MAX_ITERATIONS: u32 = 5000;
/// Alert distance in units of the smallest disk diameter (METHODS.md §1.7: 0.05 d_min
/// suffices quasi-statically).
pub const ALERT: f64 = 0.05;
/// Verlet skin in units of the smallest disk diameter.
pub const SKIN: f64 = 0.2;

// ---- output ----
/// Steps between VTK frames and recorded rows.
pub const OUTPUT_EVERY: u64 = 100;
/// Steps between resumable snapshots of a long stage.
pub const SNAPSHOT_EVERY: u64 = 2000;
