//! Stability stress tests (issue #7, item 2): each scenario pushes an engine beyond the
//! paper's settings and must end either with a result that obeys the physics, or with an
//! early error that names the step and the quantity that failed (never a NaN, never a bad
//! state in a checkpoint). The numbers quoted in the comments are measured on these exact
//! seeded runs; the bounds come from physics or from the solver tolerance, as each says.
//!
//! 1. deep compaction to ε = 0.7 (the paper stops at 0.3 / 0.45): an MPM grain at
//!    Δr/R = 0.1 (neo-Hookean and linear elastic) and a 150-particle BPM grain;
//! 2. a grain hit at 0.2, 2 and 20 m/s (MPM and BPM);
//! 3. disks overlapping by 10 %, 30 % and 70 % of their radius, in the library and through
//!    the pipeline command on an explicit scene;
//! 4. rigid contact dynamics at 25-100 times the default time step, and a BPM grain at time
//!    steps from 0.5 to 50 t0.

mod common;

use softgrain::bpm::BpmLaw;
use softgrain::cd::{
    Bodies, CdError, CdParams, Coulomb, InteractionLaw, LawTable, NlgsParams, Scene,
};
use softgrain::config::Pipeline;
use softgrain::geom::{V2, Wall};
use softgrain::mpm::{MaterialKind, MpmError, Row, SingleGrain, SingleGrainParams};
use softgrain::pipeline::StageCtx;
use softgrain::stages::{StageState, compact, discretise, prepare};

// ---------------------------------------------------------------------------------------
// MPM single grain
// ---------------------------------------------------------------------------------------

/// What an MPM run did: its rows, the worst excursion of a point centre beyond a plate and
/// the largest ratio of kinetic energy to the energy supplied (initial kinetic energy plus
/// the plates' work), both over every step.
struct MpmRun {
    rows: Vec<Row>,
    error: Option<MpmError>,
    strain: f64,
    mass_change: f64,
    centre_out: f64,
    cell: f64,
    halvings: u64,
    ke_over_supplied: f64,
}

fn mpm_run(kind: MaterialKind, wall_velocity: f64, final_strain: f64) -> MpmRun {
    let mut p = SingleGrainParams::paper();
    p.resolution = 0.1;
    p.material.kind = kind;
    p.wall_velocity = wall_velocity;
    p.final_strain = final_strain;
    let mut g = SingleGrain::new(p).unwrap();
    let m0 = g.points.total_mass();
    let (mut centre_out, mut ke_over_supplied) = (0.0f64, 0.0f64);
    let mut error = None;
    while !g.is_done() {
        if let Err(e) = g.step() {
            error = Some(e);
            break;
        }
        let (floor, top) = (g.walls[0].origin.y, g.walls[1].origin.y);
        for x in &g.points.x {
            centre_out = centre_out.max(floor - x.y).max(x.y - top);
        }
        ke_over_supplied = ke_over_supplied.max(g.points.kinetic_energy() / g.supplied_energy);
    }
    MpmRun {
        strain: g.strain(),
        mass_change: g.points.total_mass() - m0,
        cell: g.grid.h,
        halvings: g.stats.halvings,
        rows: g.rows,
        error,
        centre_out,
        ke_over_supplied,
    }
}

fn mean_force(r: &Row) -> f64 {
    0.5 * (r.force_top + r.force_bottom)
}

/// Checks shared by every MPM stress run. Plates: a material point stands for a square of
/// half-width l_p = Δr/2 = h_g/4 around its centre, and the plates act on grid nodes, so
/// the discretisation cannot place the surface better than that square: a centre may come
/// up to l_p past a plate, never more.
fn check_mpm_run(run: &MpmRun, what: &str) {
    assert_eq!(run.mass_change, 0.0, "{what}: mass changed");
    assert!(
        run.centre_out < 0.25 * run.cell,
        "{what}: a point centre is {:.3} h_g past a plate",
        run.centre_out / run.cell
    );
    for r in &run.rows {
        assert!(
            r.force_top.is_finite() && r.force_bottom.is_finite() && r.width.is_finite(),
            "{what}: {r:?}"
        );
        assert!(r.force_top >= 0.0 && r.force_bottom >= 0.0, "{what}: {r:?}");
    }
}

/// Deep compaction, ε = 0.7 (half the initial plate gap) on a coarse grid (Δr/R = 0.1, 10
/// cells across the grain, 5 across the final gap).
///
/// Measured: neo-Hookean completes in 101 steps with no halved step, the force rising at
/// every step to 79 kN/m, centres at most 0.12 h_g past a plate. The linear-elastic
/// (Hughes-Winget, hypoelastic, midpoint gradient) law also completes, but needs about 30
/// halved steps beyond ε = 0.54, where its force collapses (48 to 29 kN/m in one step at
/// 0.55 since session 35) and then wanders between 23 and 39 kN/m to 0.7: a rate-form law
/// at these strains is outside its range (the neo-Hookean stays smooth on the same grid).
/// So its force is required to rise only up to ε = 0.5 and to stay positive (the plates
/// still squeeze the grain) to the end. Where in that band it ends is not physics: session
/// 34's build ended at 44 kN/m, session 35's, whose wall gap takes the points' faces
/// through F with its rotation and shear, at 37 (F(0.5) 42 kN/m in both).
/// Not a time-step or grid artefact (measured outside this test with the earlier
/// start-of-step gradient, 47 halvings and drops of up to 15 %): at half the plate travel
/// per step the drops remained, and at Δr/R = 0.057 they started at ε = 0.38.
#[test]
fn an_mpm_grain_compressed_to_seventy_percent_stays_physical() {
    let nh = mpm_run(MaterialKind::NeoHookean, 0.2, 0.7);
    assert!(nh.error.is_none(), "neo-Hookean: {:?}", nh.error);
    assert!(nh.strain >= 0.7 - 1e-9);
    check_mpm_run(&nh, "neo-Hookean");
    let f: Vec<f64> = nh.rows.iter().map(mean_force).collect();
    assert!(f[0] > 0.0);
    for w in f.windows(2) {
        assert!(w[1] > w[0], "neo-Hookean force fell: {} -> {}", w[0], w[1]);
    }

    let le = mpm_run(MaterialKind::LinearElastic, 0.2, 0.7);
    match &le.error {
        // a clean stop names its step; none is expected (measured: the run completes)
        Some(e) => panic!("linear elastic stopped at ε = {:.3}: {e}", le.strain),
        None => assert!(le.strain >= 0.7 - 1e-9),
    }
    check_mpm_run(&le, "linear elastic");
    let upto: Vec<f64> = le
        .rows
        .iter()
        .filter(|r| r.strain <= 0.5)
        .map(mean_force)
        .collect();
    for w in upto.windows(2) {
        assert!(
            w[1] > w[0],
            "linear-elastic force fell: {} -> {}",
            w[0],
            w[1]
        );
    }
    let last = mean_force(le.rows.last().unwrap());
    assert!(last > 0.0, "linear elastic: no force at ε = 0.7");
    eprintln!(
        "MPM to ε = 0.7: NH {:.0} N/m ({} halvings, centre out {:.3} h_g), LE {:.0} N/m ({} halvings, centre out {:.3} h_g)",
        f.last().unwrap(),
        nh.halvings,
        nh.centre_out / nh.cell,
        last,
        le.halvings,
        le.centre_out / le.cell
    );
}

/// Plates at 0.2, 2 and 20 m/s (the p-wave speed of the grain is 196 m/s, the shear-wave
/// speed 59 m/s), to ε = 0.3. Energy: the grain's kinetic plus strain energy equals what
/// it was given (initial kinetic energy + plate work) less what the contacts dissipate, so
/// its kinetic energy can never exceed the supplied energy. The driver's own guard stops at
/// twice that; this asks the physical bound itself. Measured max K / supplied: 0.056, 0.78
/// and 0.994 (at 20 m/s nearly all the supplied energy is still motion), the final force
/// 18.7, 20.0 and 63.5 kN/m (neo-Hookean).
#[test]
fn an_mpm_grain_hit_at_up_to_twenty_metres_per_second_gains_no_energy() {
    for kind in [MaterialKind::NeoHookean, MaterialKind::LinearElastic] {
        for v in [0.2, 2.0, 20.0] {
            let what = format!("{kind:?} at {v} m/s");
            let run = mpm_run(kind, v, 0.3);
            assert!(run.error.is_none(), "{what}: {:?}", run.error);
            check_mpm_run(&run, &what);
            assert!(
                run.ke_over_supplied <= 1.0,
                "{what}: kinetic energy {:.4} of the supplied energy",
                run.ke_over_supplied
            );
            eprintln!(
                "{what}: F = {:.0} N/m, max K/supplied = {:.3}",
                mean_force(run.rows.last().unwrap()),
                run.ke_over_supplied
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// BPM single grain
// ---------------------------------------------------------------------------------------

/// The CI grain of `tests/bpm_single_grain.rs`: R = 1.5 mm, particles 0.16-0.26 mm.
fn bpm_yaml(wall_velocity: f64, final_strain: f64, tolerance: f64) -> String {
    format!(
        "name: stress-bpm\nseed: 1\nprepare:\n  layout: single\n  radius: 1.5e-3\ndiscretise:\n  method: bpm\n  bpm:\n    particle_diameter: [1.6e-4, 2.6e-4]\n    f0: 100.0\ncompact:\n  wall_velocity: {wall_velocity:e}\n  final_strain: {final_strain:e}\nsolver:\n  tolerance: {tolerance:e}\noutput:\n  every: 50\n  snapshot_every: 0\n  vtk: false\n"
    )
}

/// Prepares and discretises the grain through the stage functions in a scratch folder.
fn bpm_grain(p: &Pipeline, tag: &str) -> discretise::BpmGrains {
    let dir = common::temp_dir(tag);
    let ctx = StageCtx::scratch(dir.clone());
    let (prep, _) = prepare::run(p, &ctx).unwrap();
    let bpm = p.discretise.as_ref().and_then(|d| d.bpm.clone()).unwrap();
    let (g, _) = discretise::run_bpm(p, &bpm, [1.6e-4, 2.6e-4], &prep, &ctx).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    g
}

fn d_min(b: &Bodies) -> f64 {
    2.0 * b.radius.iter().cloned().fold(f64::INFINITY, f64::min)
}

/// Deepest overlap of any two particles (m).
fn max_overlap(b: &Bodies) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..b.len() {
        for j in i + 1..b.len() {
            worst = worst.max(b.radius[i] + b.radius[j] - (b.pos[i] - b.pos[j]).norm());
        }
    }
    worst
}

/// Cohesive potential U ≤ 0 of all same-grain pairs (J/m).
fn potential(b: &Bodies, law: &BpmLaw) -> f64 {
    let mut u = 0.0;
    for i in 0..b.len() {
        for j in i + 1..b.len() {
            let a0 = b.radius[i] + b.radius[j];
            u += law.potential((b.pos[i] - b.pos[j]).norm() - a0, a0);
        }
    }
    u
}

/// Deep compaction of the BPM grain through the compact stage, at the paper's plate speed
/// 0.2 m/s to ε = 0.7 (13,148 steps, 4.6 s). Overlaps: rigid contacts close to zero gap up
/// to the NLGS residual, a relative velocity error of the solver tolerance; existing
/// overlaps are never pushed apart, so they can accumulate at most tolerance × the plate's
/// travel (h0 (1 - e^-0.7) = 1.5 mm, i.e. 9e-3 d_min at tolerance 1e-3). Measured: 6.5e-4
/// d_min, no particle escaped, grain area within 1.7 %, σ = 77 kPa at ε = 0.7.
#[test]
fn a_bpm_grain_compressed_to_seventy_percent_keeps_its_particles() {
    let tol = 1e-3;
    let p: Pipeline = serde_saphyr::from_str(&bpm_yaml(0.2, 0.7, tol)).unwrap();
    let g = bpm_grain(&p, "stress-bpm-deep");
    let h0 = {
        let b = &g.bodies;
        let top = (0..b.len())
            .map(|i| b.pos[i].y + b.radius[i])
            .fold(f64::MIN, f64::max);
        let bot = (0..b.len())
            .map(|i| b.pos[i].y - b.radius[i])
            .fold(f64::MAX, f64::min);
        top - bot
    };
    let dir = common::temp_dir("stress-bpm-deep-compact");
    let (c, summary) = compact::run_bpm(&p, 0.0, &g, &StageCtx::scratch(dir.clone())).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let last = c.rows.last().unwrap();
    assert!(last.strain >= 0.7, "{summary}");
    for r in &c.rows {
        assert!(r.force.is_finite() && r.force_top.is_finite(), "{r:?}");
        assert!(r.force >= 0.0 && r.force_top >= 0.0, "{r:?}");
        assert_eq!(r.escaped, 0, "particles left the grain at ε = {}", r.strain);
    }
    let b = &c.final_particles;
    let travel = h0 * (1.0 - (-0.7f64).exp());
    let overlap = max_overlap(b);
    assert!(
        overlap <= tol * travel,
        "overlap {:.3e} d_min > tolerance × travel {:.3e} d_min",
        overlap / d_min(b),
        tol * travel / d_min(b)
    );
    // the grain keeps its (closed) area, as in tests/bpm_single_grain.rs
    assert!(c.figures.area_change < 0.05, "{summary}");
    eprintln!(
        "BPM to ε = 0.7: {summary}; overlap {:.2e} d_min, σ(0.7) = {:.0} Pa",
        overlap / d_min(b),
        last.sigma
    );
}

/// Two plates around the grain, the top one moving down at `v`.
fn plates(b: &Bodies, v: f64) -> Vec<Wall> {
    let top = (0..b.len())
        .map(|i| b.pos[i].y + b.radius[i])
        .fold(f64::MIN, f64::max);
    let bot = (0..b.len())
        .map(|i| b.pos[i].y - b.radius[i])
        .fold(f64::MAX, f64::min);
    let w = 10.0 * (top - bot);
    vec![
        Wall::new(V2::new(-w, bot), V2::new(w, bot)),
        Wall {
            a: V2::new(w, top),
            b: V2::new(-w, top),
            velocity: V2::new(0.0, -v),
        },
    ]
}

/// What a plate compression of the BPM grain with a scene of our own did.
struct BpmRun {
    error: Option<CdError>,
    steps: u64,
    strain: f64,
    /// Plate travel (m).
    travel: f64,
    /// Largest (K + U - K0 - U0) / W over the run, W the plates' work on the particles.
    energy_ratio: f64,
    overlap: f64,
    /// Deepest overlap of a pair over the pair's smaller radius.
    overlap_over_radius: f64,
    /// Deepest particle past a plate (m).
    outside: f64,
    escaped: usize,
    d_min: f64,
}

fn bpm_compress(g: &discretise::BpmGrains, v: f64, dt_over_t0: f64, strain: f64) -> BpmRun {
    let b = g.bodies.clone();
    let dm = d_min(&b);
    let walls = plates(&b, v);
    let h0 = walls[1].a.y - walls[0].a.y;
    let params = CdParams {
        dt: dt_over_t0 * g.figures.t0,
        theta: 1.0,
        gravity: V2::zeros(),
        alert: 0.05 * dm,
        skin: 0.2 * dm,
        nlgs: NlgsParams {
            tol: 1.666e-4,
            check_every: 10,
            max_iter: 5000,
            relax: 1.0,
            anderson: 0,
            islands: false,
        },
        sleep: None,
    };
    let wall_laws = vec![BpmLaw::Coulomb { mu: 0.0 }; 2];
    let laws = LawTable::new(g.law, BpmLaw::Coulomb { mu: 0.0 }, wall_laws);
    let mut s = Scene::new(b, walls, laws, params, 1);
    let e0 = s.bodies.kinetic_energy() + potential(&s.bodies, &g.law);
    let (mut work, mut energy_ratio) = (0.0, f64::NEG_INFINITY);
    let gap = |s: &Scene<BpmLaw>| s.walls[1].a.y - s.walls[0].a.y;
    let mut error = None;
    while (h0 / gap(&s)).ln() < strain {
        if let Err(e) = s.step() {
            error = Some(e);
            break;
        }
        work += (s.wall_force.iter().zip(&s.walls))
            .map(|(f, w)| f.dot(&w.velocity))
            .sum::<f64>()
            * s.params.dt;
        if s.steps.is_multiple_of(10) && work > 0.0 {
            let e = s.bodies.kinetic_energy() + potential(&s.bodies, &g.law);
            energy_ratio = energy_ratio.max((e - e0) / work);
        }
    }
    let b = &s.bodies;
    let outside = (0..b.len())
        .map(|i| {
            (s.walls[0].a.y - (b.pos[i].y - b.radius[i]))
                .max(b.pos[i].y + b.radius[i] - s.walls[1].a.y)
        })
        .fold(f64::MIN, f64::max);
    BpmRun {
        error,
        steps: s.steps,
        strain: (h0 / gap(&s)).ln(),
        travel: h0 - gap(&s),
        energy_ratio,
        overlap: max_overlap(b),
        overlap_over_radius: {
            let mut worst = 0.0f64;
            for i in 0..b.len() {
                for j in i + 1..b.len() {
                    let o = b.radius[i] + b.radius[j] - (b.pos[i] - b.pos[j]).norm();
                    worst = worst.max(o / b.radius[i].min(b.radius[j]));
                }
            }
            worst
        },
        outside,
        escaped: softgrain::bpm::measure::escaped(b, 1.0),
        d_min: dm,
    }
}

/// Plates at 0.2, 2 and 20 m/s onto the BPM grain (rigid particles: the plate sets its
/// contact neighbours moving at its own speed in one step), to ε = 0.15 at the default
/// step 0.1 t0 and tolerance 1.666e-4. Energy: K + U + D = K0 + U0 + W with D ≥ 0, so
/// (K + U - K0 - U0)/W ≤ 1; measured at most 0.71, 0.76 and 0.49. Overlaps and particles
/// past a plate: at most tolerance × plate travel (as for the deep compaction; 4e-4 d_min
/// here); measured overlaps 1.3e-4, 5.6e-5 and 1.1e-5 d_min, plate penetration 9e-6, 5e-6
/// and 2.8e-5 d_min. No particle leaves the grain at any speed.
#[test]
fn a_bpm_grain_hit_at_up_to_twenty_metres_per_second_gains_no_energy() {
    let p: Pipeline = serde_saphyr::from_str(&bpm_yaml(0.2, 0.3, 1e-3)).unwrap();
    let g = bpm_grain(&p, "stress-bpm-fast");
    for v in [0.2, 2.0, 20.0] {
        let r = bpm_compress(&g, v, 0.1, 0.15);
        assert!(r.error.is_none(), "{v} m/s: {:?}", r.error);
        assert!(
            r.energy_ratio <= 1.0,
            "{v} m/s: energy ratio {}",
            r.energy_ratio
        );
        let bound = 1.666e-4 * r.travel;
        assert!(r.overlap <= bound, "{v} m/s: overlap {:.3e} m", r.overlap);
        assert!(
            r.outside <= bound,
            "{v} m/s: {:.3e} m past a plate",
            r.outside
        );
        assert_eq!(r.escaped, 0, "{v} m/s");
        eprintln!(
            "BPM at {v} m/s: {} steps, energy ratio {:.3}, overlap {:.2e} d_min, past a plate {:.2e} d_min",
            r.steps,
            r.energy_ratio,
            r.overlap / r.d_min,
            r.outside / r.d_min
        );
    }
}

/// The BPM grain at time steps around its limit (0.2 m/s to ε = 0.1, tolerance 1.666e-4).
/// The explicit attraction alone is stable below 0.53 t0, and the compact stage refuses
/// more than 0.5 t0, but the grain's rigid, zero-restitution contacts absorb the energy
/// the explicit force would pump: measured (K + U - K0 - U0)/W = 0.52 at 0.5 t0, 0.19 at
/// 1 t0 and negative from 2 t0 on. What grows is the error: deepest overlap 2.5e-3 d_min
/// at 0.5 t0, 1.2e-2 at 1, 5.0e-2 at 2, 0.17 at 5, 0.29 at 10 t0 (0.1 t0: 1.3e-4; measured
/// with FORMAT_VERSION 10's build).
/// **The limit**: this relaxed grain completes the compression up to 5 t0 with no particle
/// lost. 10 t0 is the edge: its deepest overlap (0.29 d_min) is of the order of the
/// penetration guard's threshold (half the smaller radius of the pair, 0.25-0.4 d_min here)
/// and the run is chaotic, so whether it finishes depends on the build's rounding (up to
/// FORMAT_VERSION 10 it finished; since the local solve multiplies by 1/W the guard stops
/// it at step 15); either way it ends cleanly. Beyond, the run diverges at once: the
/// explicit force amplifies an error by about 4 (h/h_c)² per step (5,700 at 20 t0), so a
/// round-off error (1e-16 d) reaches the guard's threshold in about four steps. The guard
/// stops it at 20 t0 at step 3 (FORMAT_VERSION 11; step 2 before it, step 4 with Eq. 1's
/// power computed by `powi`: the step is chaotic, its bound is not), at 50 t0 at step 0. The test asks each diverging run to be stopped by the guard within
/// the first half of the steps the compression would take, and the 10 t0 run, if stopped,
/// to outlast the 20 t0 one in simulated time. (`tests/cd_stability.rs` stops at 5 t0 on
/// the unrelaxed grain straight from the builder, whose attraction starts far from
/// equilibrium.)
#[test]
fn a_bpm_grain_runs_to_five_t0_and_stops_cleanly_beyond() {
    let p: Pipeline = serde_saphyr::from_str(&bpm_yaml(0.2, 0.3, 1e-3)).unwrap();
    let g = bpm_grain(&p, "stress-bpm-dt");
    // the diverging runs first: when the guard stops each, and how many steps the
    // compression takes at that step (0.5 t0's count, scaled)
    let stop = |k: f64| match bpm_compress(&g, 0.2, k, 0.1).error {
        Some(CdError::Penetration { step, .. }) => step,
        other => panic!("{k} t0: expected the penetration guard, got {other:?}"),
    };
    let (stop20, stop50) = (stop(20.0), stop(50.0));
    let mut full_steps_at_half_t0 = None;
    for k in [0.5, 1.0, 2.0, 5.0, 10.0] {
        let r = bpm_compress(&g, 0.2, k, 0.1);
        if k == 10.0
            && let Some(CdError::Penetration { step, .. }) = r.error
        {
            // a marginal run, not the immediate stop of a diverging one
            assert!(
                step as f64 * 10.0 > stop20 as f64 * 20.0,
                "{k} t0: stopped at step {step}, 20 t0 at step {stop20}"
            );
            eprintln!("BPM at {k} t0: stopped by the penetration guard at step {step}");
            continue;
        }
        assert!(r.error.is_none(), "{k} t0: {:?}", r.error);
        assert!(r.strain >= 0.1);
        full_steps_at_half_t0.get_or_insert(r.steps);
        assert!(
            r.energy_ratio <= 1.0,
            "{k} t0: energy ratio {}",
            r.energy_ratio
        );
        assert_eq!(r.escaped, 0, "{k} t0");
        // what the penetration guard let through: no pair deeper than half its smaller radius
        assert!(
            r.overlap_over_radius <= 0.5,
            "{k} t0: {}",
            r.overlap_over_radius
        );
        eprintln!(
            "BPM at {k} t0: {} steps, energy ratio {:.3}, overlap {:.2e} d_min",
            r.steps,
            r.energy_ratio,
            r.overlap / r.d_min
        );
    }
    let full = full_steps_at_half_t0.unwrap() as f64 * 0.5;
    for (k, step) in [(20.0, stop20), (50.0, stop50)] {
        eprintln!("BPM at {k} t0: stopped by the penetration guard at step {step}");
        assert!(
            (step as f64) < 0.5 * full / k,
            "{k} t0: stopped at step {step} of about {:.0}",
            full / k
        );
    }
}

// ---------------------------------------------------------------------------------------
// Rigid contact dynamics
// ---------------------------------------------------------------------------------------

/// A badly built pile: five disks on the floor, each overlapping the next by `f r`, and
/// four nested on top overlapping both neighbours below by `f r`; side walls touch the ends
/// of the bottom row. Every disk is its own group.
fn overlapping_pile(f: f64, r: f64) -> (Vec<V2>, Vec<Wall>) {
    let d = (2.0 - f) * r;
    let mut pos: Vec<V2> = (0..5).map(|i| V2::new(r + i as f64 * d, r)).collect();
    let y = r + (0.75 * d * d).sqrt();
    pos.extend((0..4).map(|i| V2::new(r + (i as f64 + 0.5) * d, y)));
    let w = 2.0 * r + 4.0 * d;
    let walls = vec![
        Wall::new(V2::new(-r, 0.0), V2::new(w + r, 0.0)),
        Wall::new(V2::new(w, 0.0), V2::new(w, 10.0 * r)),
        Wall::new(V2::new(0.0, 10.0 * r), V2::new(0.0, 0.0)),
    ];
    (pos, walls)
}

fn overlaps(b: &Bodies) -> Vec<f64> {
    let mut v = Vec::new();
    for i in 0..b.len() {
        for j in i + 1..b.len() {
            v.push(b.radius[i] + b.radius[j] - (b.pos[i] - b.pos[j]).norm());
        }
    }
    v
}

/// |floor force / weight - 1| allowed at rest. With frictionless vertical side walls the
/// floor's vertical force over one step is W + M ΔV_cm/h exactly (momentum balance); at
/// rest K/(M g <d>) < ρ (the deposit's rest criterion, 1e-9), so |V_cm| ≤ sqrt(2 ρ g <d>)
/// and |F/W - 1| ≤ 2 sqrt(2 ρ g <d>)/(g h).
fn rest_bound(rest: f64, d_mean: f64, g: f64, h: f64) -> f64 {
    2.0 * (2.0 * rest * g * d_mean).sqrt() / (g * h)
}

/// Moreau-Jean with θ = 1 imposes velocity Signorini with the gap shifted by max(g, 0)/(θh):
/// an approaching contact closes exactly to zero gap, an overlapped one (g < 0) is only
/// kept from approaching (u_n ≥ 0), never pushed apart. So initial overlaps stay as they
/// are, and below half a radius the pile simply comes to rest on them; at 70 % the
/// penetration guard refuses the state at step 0. Measured at 10 % and 30 %: overlaps
/// grow by at most 7e-8 r and shrink by at most 2e-7 r in 500 steps, the floor carries the
/// weight to 1e-6, kinetic energy 1e-41 J/m.
#[test]
fn initial_overlaps_are_kept_not_grown_or_refused_at_step_zero() {
    let (r, g) = (1e-3, 9.81);
    for f in [0.1, 0.3, 0.7] {
        let (pos, walls) = overlapping_pile(f, r);
        let mut b = Bodies::default();
        for (k, x) in pos.iter().enumerate() {
            b.push(*x, r, 990.0, k as u32);
        }
        let h = 0.02 * (2.0 * r / g).sqrt();
        let params = CdParams {
            dt: h,
            theta: 1.0,
            gravity: V2::new(0.0, -g),
            alert: 0.05 * 2.0 * r,
            skin: 0.2 * 2.0 * r,
            nlgs: NlgsParams {
                tol: 1.666e-4,
                check_every: 10,
                max_iter: 5000,
                relax: 1.0,
                anderson: 0,
                islands: false,
            },
            sleep: None,
        };
        let wall_laws = vec![
            Coulomb { mu: 0.3 },
            Coulomb { mu: 0.0 },
            Coulomb { mu: 0.0 },
        ];
        let laws = LawTable::new(Coulomb { mu: 0.3 }, Coulomb { mu: 0.3 }, wall_laws);
        let initial = overlaps(&b);
        let mut s = Scene::new(b, walls, laws, params, 1);
        if f > 0.5 {
            match s.step() {
                Err(e @ CdError::Penetration { step: 0, .. }) => {
                    let msg = e.to_string();
                    assert!(msg.contains("step 0") && msg.contains("overlap"), "{msg}");
                }
                other => panic!("{f}: expected a penetration at step 0, got {other:?}"),
            }
            continue;
        }
        let (mut grown, mut shrunk) = (0.0f64, 0.0f64);
        for _ in 0..500 {
            s.step().unwrap();
            for (now, was) in overlaps(&s.bodies).iter().zip(&initial) {
                grown = grown.max(now - was.max(0.0));
                if *was > 0.0 {
                    shrunk = shrunk.max(was - now);
                }
            }
        }
        // the solver's relative tolerance, as a length on the radius
        assert!(
            grown <= 1.666e-4 * r,
            "{f}: an overlap grew by {:.3e} r",
            grown / r
        );
        assert!(
            shrunk <= 1.666e-4 * r,
            "{f}: an overlap was pushed out by {:.3e} r",
            shrunk / r
        );
        let b = &s.bodies;
        let (m, rest) = (b.total_mass(), 1e-9);
        assert!(
            b.translational_energy() < rest * m * g * 2.0 * r,
            "{f}: not at rest"
        );
        let floor = s.wall_force[0].y / (m * g);
        assert!(
            (floor - 1.0).abs() <= rest_bound(rest, 2.0 * r, g, h),
            "{f}: floor carries {floor} × the weight"
        );
    }
}

/// The pile of the test above as an explicit scene through the command line.
fn explicit_pile_yaml(f: f64) -> String {
    let r = 1e-3;
    let (pos, walls) = overlapping_pile(f, r);
    let mut y = String::from(
        "name: overlap\nseed: 1\nprepare:\n  layout: explicit\n  friction: 0.3\n  gravity: 9.81\n  density: 990.0\n  time_step: 2.0e-4\n  duration: 0.02\n  bodies:\n",
    );
    for x in &pos {
        y += &format!(
            "    - position: [{:e}, {:e}]\n      radius: {r:e}\n",
            x.x, x.y
        );
    }
    y += "  walls:\n";
    for w in &walls {
        y += &format!(
            "    - from: [{:e}, {:e}]\n      to: [{:e}, {:e}]\n",
            w.a.x, w.a.y, w.b.x, w.b.y
        );
    }
    y + "output:\n  every: 0\n  vtk: false\n"
}

/// Through `softgrain pipeline run`: at 30 % the explicit scene runs and its checkpoint
/// holds the overlaps as they were (to the solver tolerance); at 70 % the run exits with
/// status 1 and a message naming the stage, the case, the step and the overlap, and no
/// checkpoint is written.
#[test]
fn the_command_line_refuses_a_pile_overlapping_by_seventy_percent() {
    let dir = common::temp_dir("stress-overlap-cli");
    let out = dir.join("runs");
    let run = |f: f64, name: &str| {
        let file = common::write(&dir, name, &explicit_pile_yaml(f));
        common::softgrain(&[
            "pipeline",
            "run",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ])
    };
    let o = run(0.3, "ok.yaml");
    assert!(o.status.success(), "{}", common::stderr(&o));
    let ckpts = common::checkpoints(&out.join("overlap"));
    assert_eq!(ckpts.len(), 1, "{ckpts:?}");
    let Some(Ok(StageState::Prepared(prep))) = softgrain::pipeline::store::load(&ckpts[0]).unwrap()
    else {
        panic!("not a prepared state")
    };
    let (pos, _) = overlapping_pile(0.3, 1e-3);
    let mut b = Bodies::default();
    for x in &pos {
        b.push(*x, 1e-3, 990.0, 0);
    }
    for (now, was) in overlaps(&prep.bodies).iter().zip(&overlaps(&b)) {
        assert!(now - was.max(0.0) <= 1.666e-4 * 1e-3, "{now} vs {was}");
    }
    let _ = std::fs::remove_dir_all(&out);

    let o = run(0.7, "bad.yaml");
    assert_eq!(o.status.code(), Some(1), "{}", common::stderr(&o));
    let msg = common::stderr(&o);
    assert!(
        msg.contains("prepare [") && msg.contains("step 0") && msg.contains("overlap"),
        "{msg}"
    );
    assert!(common::checkpoints(&out.join("overlap")).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 30-disk deposit (1.4-2.4 mm, friction 0.3, frictionless side walls) at 25, 50 and 100
/// times the default step 0.02 sqrt(<d>/g). θ = 1 is stable at any step: at 0.5 and
/// 1 sqrt(<d>/g) the deposit comes to rest (902 and 377 steps) with the floor carrying the
/// weight to 2e-9 and 8e-10 (the bound from the rest criterion: 1.8e-4 and 8.8e-5), every
/// disk in the box. What the large step costs is geometry: normals frozen over a step in
/// which disks move a good part of a diameter let contacts close past zero, so the deepest
/// overlap is 0.10 <r> at 0.5 and 0.19 <r> at 1 (1.7e-5 <r> at the default). At 2
/// sqrt(<d>/g) an overlap passes half a radius at step 417 and the penetration guard stops
/// the stage with that step and pair.
#[test]
fn a_rigid_deposit_at_fifty_times_the_default_step_comes_to_rest() {
    let d_mean: f64 = 1.9e-3;
    let g = 9.81;
    for k in [0.5, 1.0, 2.0] {
        let h = k * (d_mean / g).sqrt();
        let yaml = format!(
            "name: dep\nseed: 3\nprepare:\n  layout: packing\n  grains: 30\n  diameter: [1.4e-3, 2.4e-3]\n  friction: 0.3\n  wall_friction: 0.0\n  gravity: {g}\n  density: 990.0\n  time_step: {h:e}\noutput:\n  every: 0\n  snapshot_every: 0\n  vtk: false\n"
        );
        let p: Pipeline = serde_saphyr::from_str(&yaml).unwrap();
        let dir = common::temp_dir("stress-deposit");
        let result = prepare::run(&p, &StageCtx::scratch(dir.clone()));
        let _ = std::fs::remove_dir_all(&dir);
        match result {
            Ok((prep, summary)) => {
                let f = &prep.figures;
                let b = &prep.bodies;
                let bound = rest_bound(p.prepare.rest_tolerance, 2.0 * b.mean_radius(), g, h);
                assert!(
                    (f.floor_force / f.weight - 1.0).abs() <= bound,
                    "{k}: {summary}"
                );
                assert!(f.max_overlap < 0.5, "{k}: {summary}");
                for i in 0..b.len() {
                    let (x, r) = (b.pos[i], b.radius[i]);
                    assert!(
                        x.y > 0.0 && x.x > 0.0 && x.x < prep.box_width,
                        "{k}: disk {i} at {x:?} (r {r}) left the box"
                    );
                }
                eprintln!(
                    "deposit at {k} sqrt(d/g): {summary}; floor/weight - 1 = {:.1e} (bound {bound:.1e}), max overlap {:.3} <r>",
                    f.floor_force / f.weight - 1.0,
                    f.max_overlap
                );
            }
            Err(e) => {
                // only the largest step may fail, and only cleanly
                assert!(k > 1.0, "{k}: {e}");
                assert!(e.contains("step") && e.contains("overlap"), "{e}");
                eprintln!("deposit at {k} sqrt(d/g): {e}");
            }
        }
    }
}
