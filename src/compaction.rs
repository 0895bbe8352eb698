//! What the two methods share when a packing is compacted: the box and the unjammed initial
//! layout at Φ0, the recorded row of the time series, and the grain coordination numbers.
//! Engine-neutral: the BPM and MPM compact stages fill the same `Row`, and the analyse
//! stage reads nothing else.

use crate::geom::V2;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// Version of a packing's compaction (`plan::version`), hashed into its nodes' names so that
/// checkpoints made by an earlier version are not reused: 1 lays the deposit out with each
/// grain's true extents and lifts it out of the floor (`unjammed_layout`); 2: the MPM
/// `surface` contact acts on the surface layers instead of beside the node contact; 3: the
/// surface contact's NLGS is Anderson-accelerated, with a stall window under friction
/// (`NlgsParams::for_packing`); 4: the MPM stage records its first row at ε = 0, as the BPM
/// stage does (before, the first was at ε ≈ 0.012 on `paper-mpm.yaml` and analyse read
/// Φ(0) = 0.658 off it), and its `points_inside` tests a point the seeded circle clipped at
/// the centre of the whole point with the same faces (`mpm::overlap`); 5: a surface-contact
/// NLGS whose acceleration stalls goes on with plain sweeps (`NlgsParams::stall_window`); 6:
/// the MPM NLGS sweeps its contacts grouped by grain pair and coloured (`mpm::colour`), and
/// `PackingFigures` counts its sweeps; 7: the MPM coupling's residual tolerance is 1e-5
/// instead of 1e-6 (`mpm::packing::COUPLING_TOLERANCE`; BPM packings are renamed with it
/// and recompute to the same bits); 8: an MPM packing keeps its contact compliance in single
/// precision (`mpm::node_contact::Slots::compliance`), which moves its results at round-off
/// (BPM packings are renamed with it and recompute to the same bits).
pub const PACKING_VERSION: u32 = 8;

/// The confining box: floor at y = 0, side walls at x = 0 and x = `width`, top wall at
/// `h0` at ε = 0 moving down.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoxGeometry {
    pub width: f64,
    pub h0: f64,
}

impl BoxGeometry {
    /// Height of the box at cumulative strain ε = ln(h0/h).
    pub fn height(&self, strain: f64) -> f64 {
        self.h0 * (-strain).exp()
    }
}

/// The paper starts compaction from an unjammed state at Φ0 = 0.65 (Fig. 8a), looser than any
/// rigid-disk deposit (≈ 0.80). Decision: the top wall is placed at h0 = `area` / (Φ0 L), with
/// `area` the grains' total area in the convention Φ is reported in, and the deposited
/// centres are stretched vertically (x unchanged), so the grains fill the box with the
/// deposit's neighbourhoods but no vertical contact. Grain k reaches `below[k]` under its
/// centre and `above[k]` over it (a relaxed BPM aggregate is not a disk: use its particles'
/// extents). With lo the lowest point of the deposit (clamped to ≤ 0: a deposit that sinks
/// into the floor by a solver tolerance is lifted out) and hi its highest, y ↦ (y − lo) h0 /
/// (hi − lo). Returns the new centres and the box; an error if the deposit is already
/// looser than Φ0.
pub fn unjammed_layout(
    centres: &[V2],
    below: &[f64],
    above: &[f64],
    area: f64,
    width: f64,
    phi0: f64,
) -> Result<(Vec<V2>, BoxGeometry), String> {
    let h0 = area / (phi0 * width);
    let extreme = |f: fn(f64, f64) -> f64, start: f64, side: &[f64], sign: f64| {
        (centres.iter().zip(side)).fold(start, |m, (c, e)| f(m, c.y + sign * e))
    };
    let lo = extreme(f64::min, 0.0, below, -1.0);
    let hi = extreme(f64::max, 0.0, above, 1.0);
    if h0 < hi - lo {
        return Err(format!(
            "compact.initial_phi = {phi0} asks for a box of height {h0:.4e} m, lower than the deposit ({:.4e} m, Φ = {:.3}): choose a smaller value",
            hi - lo,
            area / (width * (hi - lo))
        ));
    }
    // with s = h0 / (hi − lo) ≥ 1 and c.y − lo ≥ below ≥ 0: (c.y − lo) s − below ≥ 0 and
    // (c.y − lo) s + above ≤ s (hi − lo) = h0, so every grain stays inside the box
    let s = h0 / (hi - lo);
    let moved = centres
        .iter()
        .map(|c| V2::new(c.x, (c.y - lo) * s))
        .collect();
    Ok((moved, BoxGeometry { width, h0 }))
}

/// A compaction's summary line, saying so when it continued a shorter run that ended at
/// strain `from` (`StageCtx::load_continuation`).
pub fn continued(summary: String, from: Option<f64>) -> String {
    match from {
        Some(e) => format!("{summary} (continued from a finished run at ε = {e:.4})"),
        None => summary,
    }
}

/// One recorded row of a packing's compaction. Stresses are N/m over the wall length (Pa per
/// unit thickness), compression positive, each the mean over the recording interval.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub time: f64,
    /// ε = ln(h0/h).
    pub strain: f64,
    /// Grain area (BPM: the closing convention; MPM: Σ v_p) over the box area L h.
    pub phi: f64,
    /// 2 × (grain pairs in contact) / N_g, wall contacts excluded.
    pub z: f64,
    /// The same after removing rattlers iteratively.
    pub z_star: f64,
    /// Vertical stress on the bottom wall, F/L: the paper's σ.
    pub sigma: f64,
    pub sigma_top: f64,
    pub sigma_left: f64,
    pub sigma_right: f64,
    /// Grain pairs in contact.
    pub grain_contacts: usize,
    pub rattlers: usize,
    /// Mean solver iterations per step over the interval (NLGS sweeps, or contact-coupling
    /// iterations for MPM, failed attempts included).
    pub iterations: f64,
    /// Kinetic energy over a reference energy (quasi-static: ≪ 1). BPM: the work the walls
    /// have done since ε = 0 (NaN before they have done any); MPM: the grains' elastic
    /// energy.
    pub kinetic_ratio: f64,
    /// Worst interpenetration between grains (BPM: particle overlap over the smallest particle
    /// diameter; MPM: node gap over the cell size), ≥ 0.
    pub overlap: f64,
    /// Share of the grains' area that lies under two grains. MPM: the points drawn as
    /// squares of their area (`mpm::overlap::shared_area`); BPM: the lens areas of the
    /// particle overlaps between grains over the grains' area.
    pub overlap_area: f64,
    /// Share of the particles (BPM) or material points (MPM) whose centre lies inside another
    /// grain: inside one of its particles, or one of its points' domains carried by F
    /// (`mpm::overlap::points_inside`; a point the seeded circle clipped is tested at the
    /// centre of the whole point with its faces). Each marks an overlap deeper than the
    /// particle's radius or the point's half-size there; grains that only touch have none.
    pub points_inside: f64,
    /// MPM: the deepest overlap of two points of different grains at the recording step,
    /// their ellipses along the line joining their centres, over h_g
    /// (`mpm::overlap::deepest_pair`): the material's counterpart of the node gap in
    /// `overlap`, with a ceiling of about h_g/2 (two points with one centre). BPM: NaN (its
    /// `overlap` is the particles').
    pub point_overlap: f64,
    /// Inertial number I = ε̇ d sqrt(ρ/p) (`inertial_number`): the time to rearrange a grain
    /// under the confining pressure over the time the wall takes to strain the packing.
    /// Quasi-static flow has I ≲ 1e-3 (GDR MiDi 2004). NaN while the walls carry no load.
    pub inertial: f64,
    /// MPM: the grains' vertical stress over the box, -Σ_p v_p σ_yy,p / (L h), mean over the
    /// interval (compression positive); BPM: NaN. In quasi-static equilibrium it is
    /// `sigma_top - sigma_lever` (`Packing::contact_moments`).
    pub sigma_box: f64,
    /// MPM: the grain pairs' contact moment Σ (x_a - x_b) ⊗ f, its yy part over L h, mean
    /// over the interval: 0 for the node contact, whose pair forces act at one node; the
    /// surface contact's act on two surface layers about a cell apart. BPM: NaN.
    pub sigma_lever: f64,
    /// The contact solver over the interval (`SolveTally`): the largest residual, over its
    /// tolerance, of the solve whose forces a step kept (≤ 1 when all converged) ...
    pub residual: f64,
    /// ... and the steps whose kept forces stopped short of the tolerance.
    pub unconverged: u64,
}

/// Where a packing's worst interpenetration between two grains was, in `Row::overlap`'s
/// measure (BPM: particle overlap over d_min; MPM: node gap over h_g) or, for the MPM
/// points, in `Row::point_overlap`'s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OverlapSite {
    pub overlap: f64,
    pub strain: f64,
    /// BPM: the midpoint of the two particles' centres; MPM: the contact node (m).
    pub at: [f64; 2],
    pub grains: [u32; 2],
}

impl OverlapSite {
    /// Keeps the deeper of the two sites.
    pub fn deepest(self, other: OverlapSite) -> OverlapSite {
        if other.overlap > self.overlap {
            other
        } else {
            self
        }
    }

    /// For a summary line: " at (x, y) mm, grains a and b, ε = …", or nothing without one.
    pub fn note(&self) -> String {
        if self.overlap <= 0.0 {
            return String::new();
        }
        format!(
            " at ({:.2}, {:.2}) mm between grains {} and {}, ε = {:.3}",
            1e3 * self.at[0],
            1e3 * self.at[1],
            self.grains[0],
            self.grains[1],
            self.strain
        )
    }
}

/// How close the contact solves that set each step's forces came to their tolerance, over a
/// recording interval. BPM: a step's one NLGS; MPM: the last NLGS of the step's coupling
/// iterations (earlier ones only steer Newton's iterate).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SolveTally {
    pub residual: f64,
    pub unconverged: u64,
}

impl SolveTally {
    /// Adds a step whose kept solve ended at `residual` (its norm over the tolerance).
    pub fn add(&mut self, residual: f64, converged: bool) {
        self.residual = self.residual.max(residual);
        self.unconverged += u64::from(!converged);
    }
}

impl Row {
    /// "ε = …: Φ = …, Z = …, σ = … Pa", for summary lines.
    pub fn state(&self) -> String {
        format!(
            "ε = {:.3}: Φ = {:.3}, Z = {:.2}, σ = {:.3e} Pa",
            self.strain, self.phi, self.z, self.sigma
        )
    }

    /// Mean of the four wall stresses: the pressure of the packing as the walls see it.
    pub fn pressure(&self) -> f64 {
        0.25 * (self.sigma + self.sigma_top + self.sigma_left + self.sigma_right)
    }
}

/// The grains' mean size and density for the inertial number, fixed at ε = 0: the diameter
/// of the disk of the mean grain area, sqrt(4 A / (π N)), and mass over area, M / A.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrainScale {
    pub diameter: f64,
    pub density: f64,
}

impl GrainScale {
    pub fn new(grains: usize, area: f64, mass: f64) -> Self {
        GrainScale {
            diameter: (4.0 * area / (std::f64::consts::PI * grains as f64)).sqrt(),
            density: mass / area,
        }
    }

    /// I = ε̇ d sqrt(ρ/p) at strain rate ε̇ and pressure p; NaN for p ≤ 0.
    pub fn inertial_number(&self, strain_rate: f64, pressure: f64) -> f64 {
        if pressure > 0.0 {
            strain_rate * self.diameter * (self.density / pressure).sqrt()
        } else {
            f64::NAN
        }
    }
}

/// The time series as CSV, the contract's `time,strain,phi,z,sigma` first.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "time,strain,phi,z,sigma,z_star,sigma_top,sigma_left,sigma_right,grain_contacts,rattlers,iterations,kinetic_ratio,overlap,inertial,overlap_area,residual,unconverged,sigma_box,sigma_lever,points_inside,point_overlap\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.time,
            r.strain,
            r.phi,
            r.z,
            r.sigma,
            r.z_star,
            r.sigma_top,
            r.sigma_left,
            r.sigma_right,
            r.grain_contacts,
            r.rattlers,
            r.iterations,
            r.kinetic_ratio,
            r.overlap,
            r.inertial,
            r.overlap_area,
            r.residual,
            r.unconverged,
            r.sigma_box,
            r.sigma_lever,
            r.points_inside,
            r.point_overlap
        );
    }
    s
}

impl PackingFigures {
    /// Folds a recorded row into the run's worst figures, for both methods: `site` is where
    /// the row's worst overlap was and `pair` where its deepest point pair was (MPM; None
    /// for BPM), each with its depth and strain taken from the row, and `area_ratio` the
    /// grains' area over their area at the start.
    pub fn fold(
        &mut self,
        row: &Row,
        site: OverlapSite,
        pair: Option<OverlapSite>,
        area_ratio: f64,
    ) {
        self.overlap_max = self.overlap_max.max(row.overlap);
        self.overlap_site = self.overlap_site.deepest(OverlapSite {
            overlap: row.overlap,
            strain: row.strain,
            ..site
        });
        self.overlap_area_max = self.overlap_area_max.max(row.overlap_area);
        self.points_inside_max = self.points_inside_max.max(row.points_inside);
        if row.point_overlap.is_finite() {
            let v = row.point_overlap;
            self.point_overlap_max = Some(self.point_overlap_max.map_or(v, |m| m.max(v)));
        }
        if let Some(pair) = pair.filter(|_| row.point_overlap > 0.0) {
            let pair = OverlapSite {
                overlap: row.point_overlap,
                strain: row.strain,
                ..pair
            };
            self.point_overlap_site =
                Some(self.point_overlap_site.map_or(pair, |s| s.deepest(pair)));
        }
        self.area_change = self.area_change.max((area_ratio - 1.0).abs());
        self.residual_max = self.residual_max.max(row.residual);
    }

    /// For a summary line: nothing when every step's contact solve converged.
    pub fn unconverged_note(&self) -> String {
        if self.unconverged_steps == 0 {
            return String::new();
        }
        format!(
            ", contact solve short of its tolerance in {} of {} steps (at worst {:.1} times it)",
            self.unconverged_steps, self.steps, self.residual_max
        )
    }
}

/// Largest value of `f` once the packing carries load: over the rows whose floor stress is
/// at least a tenth of the run's largest. Before that the grains are a gas pushed by the
/// wall, with a kinetic energy of the order of the work done (nothing to check).
pub fn max_after_jamming(rows: &[Row], f: impl Fn(&Row) -> f64) -> f64 {
    let top = rows.iter().map(|r| r.sigma).fold(0.0, f64::max);
    rows.iter()
        .filter(|r| r.sigma >= 0.1 * top && top > 0.0)
        .map(f)
        .filter(|x| x.is_finite())
        .fold(0.0, f64::max)
}

/// What the compact stage of a packing keeps (its checkpoint payload), either method: the
/// time series, the final configuration for pictures, and the run's key figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PackingCompacted {
    pub method: crate::config::Method,
    /// Inter-grain friction of this case.
    pub friction: f64,
    pub geometry: BoxGeometry,
    pub grains: usize,
    pub rows: Vec<Row>,
    /// Final particles (BPM primary disks; MPM material points with their half-size).
    pub particles: Vec<Particle>,
    /// Final force network: BPM particle-particle contacts, MPM contact nodes.
    pub network: Vec<ForceLine>,
    pub figures: PackingFigures,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Particle {
    pub pos: [f64; 2],
    /// Radius (BPM) or half-size l_p (MPM) (m).
    pub size: f64,
    pub grain: u32,
}

/// A segment carrying a normal force (N/m): between two particle centres (BPM), or a short
/// segment across a contact node along its normal (MPM).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ForceLine {
    pub a: [f64; 2],
    pub b: [f64; 2],
    pub force: f64,
    /// Whether the two ends belong to different grains.
    pub between_grains: bool,
}

/// Key figures of a packing compaction, for `stage.json` and the report.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PackingFigures {
    pub steps: u64,
    pub time_step: f64,
    /// Mean and largest solver iterations per step (MPM: failed attempts included, so a
    /// halved step counts its failed attempt's iterations too).
    pub iterations_mean: f64,
    pub iterations_max: u64,
    /// Steps whose kept contact solve stopped short of its tolerance (`SolveTally`).
    pub unconverged_steps: u64,
    /// The largest `Row::residual` of the run.
    pub residual_max: f64,
    /// Contact solves stopped short of the tolerance: BPM, the unconverged steps; MPM, also
    /// those of a step's earlier coupling iterations and of failed attempts.
    pub stopped_solves: u64,
    /// Largest `Row::overlap` of the run ...
    pub overlap_max: f64,
    /// ... where and when it was ...
    pub overlap_site: OverlapSite,
    /// ... and the largest once loaded (`max_after_jamming`): before, grains of the gas the
    /// wall drives collide (100 MPM grains: 1.83 h_g at ε = 0.134, against 1.06 under load).
    pub overlap_max_loaded: f64,
    /// Largest `Row::overlap_area` of the run.
    pub overlap_area_max: f64,
    /// Largest `Row::points_inside` of the run.
    pub points_inside_max: f64,
    /// MPM: largest `Row::point_overlap` of the run (over h_g). BPM: None (not measured).
    pub point_overlap_max: Option<f64>,
    /// MPM: where and when it was (the midpoint of the two points); None if no two points
    /// overlapped. BPM: None.
    pub point_overlap_site: Option<OverlapSite>,
    /// MPM: the largest once loaded (`max_after_jamming`): on 100 grains at μ = 0.5 the
    /// deepest pair of the run (0.37 h_g) was two grains colliding before jamming. BPM: None.
    pub point_overlap_max_loaded: Option<f64>,
    /// Largest relative change of the total grain area over the run: the closed areas of
    /// the aggregates (BPM), Σ v_p of the points (MPM).
    pub area_change: f64,
    /// MPM: relative change of the total point mass at the end (the points carry the mass,
    /// so it must be 0). BPM: None (rigid particles of fixed mass).
    pub mass_change: Option<f64>,
    /// Largest `Row::kinetic_ratio` once loaded (BPM: `max_after_jamming`; MPM: once the
    /// top wall has touched a grain).
    pub kinetic_ratio_max: f64,
    /// Largest `Row::inertial` once loaded (`max_after_jamming`).
    pub inertial_max: f64,
    /// MPM: sub-steps split in two before they were tried (`mpm::packing::rotation_ratio`).
    /// BPM: 0.
    pub splits: u64,
    /// MPM: sub-steps redone as two halves after a failed attempt (coupling not converged,
    /// a point inverted, a factorisation failed). BPM: 0.
    pub halvings: u64,
    /// MPM: grain factorisations of the run (failed attempts included), and those whose
    /// consistent tangent was indefinite, so that the elastic one was factorised instead
    /// (modified Newton for that grain). BPM: 0.
    pub factorisations: u64,
    pub indefinite: u64,
    /// MPM: NLGS sweeps of the run, over all coupling iterations and failed attempts.
    /// BPM: 0 (its sweeps per step are `iterations_mean`).
    pub sweeps: u64,
}

/// Grain coordination from the list of grain pairs in contact (each pair once, any order,
/// duplicates allowed).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Coordination {
    pub pairs: usize,
    /// 2 pairs / N_g over all grains.
    pub z: f64,
    /// 2 pairs / N over the non-rattlers after iterative removal (0 when none is left).
    pub z_star: f64,
    pub rattlers: usize,
}

/// Z and Z*. Z counts grain pairs only (the paper's Z is between grains). A rattler has fewer
/// than `min_contacts` contacts (2 with friction, 3 without: the fewest that can hold a disk
/// in 2D), counting its `wall_contacts` and its grain contacts among the remaining grains;
/// removing one can make others rattlers, so removal repeats until none is left.
pub fn coordination(
    n_grains: usize,
    pairs: &[(usize, usize)],
    wall_contacts: &[usize],
    min_contacts: usize,
) -> Coordination {
    let mut unique: Vec<(usize, usize)> = pairs
        .iter()
        .filter(|(a, b)| a != b)
        .map(|&(a, b)| (a.min(b), a.max(b)))
        .collect();
    unique.sort_unstable();
    unique.dedup();
    let walls = |g: usize| wall_contacts.get(g).copied().unwrap_or(0);
    let mut degree: Vec<usize> = (0..n_grains).map(walls).collect();
    for &(a, b) in &unique {
        degree[a] += 1;
        degree[b] += 1;
    }
    let mut alive = vec![true; n_grains];
    let mut live_pairs = unique.len();
    loop {
        let out: Vec<usize> = (0..n_grains)
            .filter(|&g| alive[g] && degree[g] < min_contacts)
            .collect();
        if out.is_empty() {
            break;
        }
        for &g in &out {
            alive[g] = false;
        }
        // recount from scratch: simple and exact
        degree
            .iter_mut()
            .enumerate()
            .for_each(|(g, d)| *d = walls(g));
        live_pairs = 0;
        for &(a, b) in &unique {
            if alive[a] && alive[b] {
                degree[a] += 1;
                degree[b] += 1;
                live_pairs += 1;
            }
        }
    }
    let kept = alive.iter().filter(|&&a| a).count();
    Coordination {
        pairs: unique.len(),
        z: 2.0 * unique.len() as f64 / n_grains.max(1) as f64,
        z_star: if kept > 0 {
            2.0 * live_pairs as f64 / kept as f64
        } else {
            0.0
        },
        rattlers: n_grains - kept,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// n × n square lattice of grains, each touching its 4 neighbours.
    fn lattice(n: usize) -> Vec<(usize, usize)> {
        let id = |i: usize, j: usize| i * n + j;
        let mut p = Vec::new();
        for i in 0..n {
            for j in 0..n {
                if i + 1 < n {
                    p.push((id(i, j), id(i + 1, j)));
                }
                if j + 1 < n {
                    p.push((id(i, j), id(i, j + 1)));
                }
            }
        }
        p
    }

    #[test]
    fn inertial_number_of_disks_of_known_size_and_density() {
        // 10 disks of diameter 2 mm and density 1000 kg/m³
        let (n, d, rho) = (10, 2e-3, 1000.0);
        let area = n as f64 * std::f64::consts::PI * d * d / 4.0;
        let s = GrainScale::new(n, area, rho * area);
        assert!((s.diameter - d).abs() < 1e-15 && (s.density - rho).abs() < 1e-9);
        // ε̇ = 5 /s under p = 10 kPa: I = 5 · 2e-3 · sqrt(1000 / 1e4)
        let row = Row {
            sigma: 1.2e4,
            sigma_top: 1.0e4,
            sigma_left: 0.9e4,
            sigma_right: 0.9e4,
            ..Default::default()
        };
        assert!((row.pressure() - 1e4).abs() < 1e-9);
        let i = s.inertial_number(5.0, row.pressure());
        assert!((i - 1e-2 * 0.1f64.sqrt()).abs() < 1e-15, "I = {i}");
        // undefined before the walls carry load
        assert!(s.inertial_number(5.0, 0.0).is_nan());
    }

    #[test]
    fn square_lattice_has_z_4_in_the_bulk() {
        let n = 10;
        let c = coordination(n * n, &lattice(n), &[], 2);
        // 2 n (n-1) pairs: Z = 4 (n-1)/n exactly, → 4 in the bulk
        assert_eq!(c.pairs, 2 * n * (n - 1));
        assert!((c.z - 4.0 * 9.0 / 10.0).abs() < 1e-12);
        assert_eq!(c.rattlers, 0);
        assert!((c.z_star - c.z).abs() < 1e-12);
        // frictionless and no walls: the corners (2 contacts) go, then their neighbours, and
        // the lattice peels ring by ring down to nothing
        assert_eq!(coordination(n * n, &lattice(n), &[], 3).rattlers, n * n);
        // in a box every boundary grain also touches a wall (corners two): nothing is a rattler
        let walls: Vec<usize> = (0..n * n)
            .map(|g| {
                usize::from(g / n == 0 || g / n == n - 1)
                    + usize::from(g % n == 0 || g % n == n - 1)
            })
            .collect();
        let boxed = coordination(n * n, &lattice(n), &walls, 3);
        assert_eq!(boxed.rattlers, 0);
        assert!((boxed.z - c.z).abs() < 1e-12);
    }

    #[test]
    fn a_chain_is_all_rattlers_and_duplicates_count_once() {
        let pairs = [(0, 1), (1, 0), (1, 2), (2, 3), (3, 3)];
        let c = coordination(5, &pairs, &[], 2);
        assert_eq!(c.pairs, 3);
        assert!((c.z - 6.0 / 5.0).abs() < 1e-12);
        // ends go first, then their neighbours: nothing is left
        assert_eq!(c.rattlers, 5);
        assert_eq!(c.z_star, 0.0);
    }

    #[test]
    fn unjammed_layout_gives_phi0_and_keeps_grains_inside() {
        let radii = [1.0, 1.0, 0.5];
        let centres = [V2::new(1.0, 1.0), V2::new(3.0, 1.0), V2::new(2.0, 2.2)];
        let width = 4.0;
        let area: f64 = radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
        let (moved, b) = unjammed_layout(&centres, &radii, &radii, area, width, 0.3).unwrap();
        assert!((area / (b.width * b.h0) - 0.3).abs() < 1e-12);
        for (c, r) in moved.iter().zip(radii) {
            assert!(c.y - r >= -1e-12 && c.y + r <= b.h0 + 1e-12);
        }
        // horizontal neighbours keep their distance
        assert!(((moved[1] - moved[0]).norm() - 2.0).abs() < 1e-12);
        assert!(unjammed_layout(&centres, &radii, &radii, area, width, 0.9).is_err());
    }

    /// Grains that are not disks: the first reaches 0.2 past the floor, the third only 0.3
    /// above its centre. At the deposit's own Φ the box is exactly the deposit's extent, lifted
    /// out of the floor; a disk check (below = above = reach) would have refused it.
    #[test]
    fn unjammed_layout_lifts_a_deposit_out_of_the_floor_and_uses_true_extents() {
        let centres = [V2::new(1.0, 1.0), V2::new(3.0, 1.0), V2::new(2.0, 2.2)];
        let below = [1.2, 1.0, 0.5];
        let above = [1.0, 1.0, 0.3];
        let (width, area) = (4.0, 3.0);
        let (lo, hi) = (-0.2, 2.5);
        let phi_deposit = area / (width * (hi - lo));
        let (moved, b) =
            unjammed_layout(&centres, &below, &above, area, width, phi_deposit).unwrap();
        assert!((b.h0 - (hi - lo)).abs() < 1e-12);
        let bottom = (moved.iter().zip(below)).map(|(c, e)| c.y - e);
        let top = (moved.iter().zip(above)).map(|(c, e)| c.y + e);
        assert!(bottom.fold(f64::INFINITY, f64::min).abs() < 1e-12);
        assert!((top.fold(0.0, f64::max) - b.h0).abs() < 1e-12);
        let reach = [1.2, 1.0, 0.5];
        assert!(unjammed_layout(&centres, &reach, &reach, area, width, phi_deposit).is_err());
        assert!(
            unjammed_layout(&centres, &below, &above, area, width, 1.01 * phi_deposit).is_err()
        );
    }
}
