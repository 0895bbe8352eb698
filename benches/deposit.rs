//! Deposit benchmark: softgrain's contact-dynamics engine against rapier2d on the same scene.
//!
//! Both engines start from the same disks (sizes, positions) as the prepare stage
//! (`src/stages/prepare.rs::start`): diameters in [1.4, 2.4] mm equal-area-per-size, a loose
//! lattice layout, an open box about as high as wide, density 990 kg/m³ per unit thickness,
//! friction 0.3 between disks, frictionless walls (`--wall-friction`), g = 9.81 m/s². Each
//! runs until the prepare stage's rest test holds (translational kinetic energy /
//! (Σ m g <d>) < 1e-9, checked once the fall time sqrt(2·2H/g) has passed) or the simulated
//! time reaches `MAX_TIME`, or a wall-clock budget runs out.
//!
//! Every (engine, size, run) goes to a child process (this binary re-executed with
//! `--child`) so that its peak resident memory (VmHWM) is its own.
//!
//! Usage: `cargo bench --bench deposit -- [--sizes 300,30000] [--runs 3]
//! [--engines softgrain,rapier,rapier-froude] [--budget SECONDS] [--seed 1] [--step 0.02]
//! [--wall-friction 0] [--tolerance 1.666e-4] [--relaxation 1] [--anderson 0]
//! [--check-every 10] [--islands] [--sleep]` (disk-wall friction of both engines,
//! `prepare.wall_friction`; softgrain's NLGS: tolerance, `solver.tolerance`; relaxation ω,
//! `solver.relaxation`; Anderson depth, `solver.anderson`; sweeps between checks; islands
//! solved apart, `solver.islands`; sleeping with rapier-froude's thresholds, `prepare.sleep`)

use rapier2d::prelude::*;
use softgrain::cd::{Bodies, CdParams, Coulomb, LawTable, NlgsParams, Scene, SleepParams};
use softgrain::config::defaults;
use softgrain::geom::{V2, Wall};
use softgrain::packing::{self, Distribution};
use softgrain::rng::Rng;
use std::time::Instant;

const DIAMETER: [f64; 2] = [1.4e-3, 2.4e-3];
const DISTRIBUTION: Distribution = Distribution::EqualAreaPerSize;

/// The common initial state, built exactly as the prepare stage builds it.
struct Setup {
    diameters: Vec<f64>,
    pos: Vec<V2>,
    width: f64,
    walls: Vec<Wall>,
    settle_after: f64,
    dt: f64,
    d_mean: f64,
    /// Disk-wall friction of both engines (`prepare.wall_friction`; 0 by default).
    wall_friction: f64,
}

fn setup(n: usize, seed: u64, step: f64, wall_friction: f64) -> Setup {
    let mut rng = Rng::stream(seed, "prepare-sizes");
    let d = packing::diameters(DISTRIBUTION, DIAMETER, n, &mut rng);
    let width = packing::square_box_width(DISTRIBUTION, DIAMETER, n, defaults::SQUARE_BOX_PHI);
    let (pos, height) = packing::loose_layout(&d, width, &mut rng);
    let walls = packing::box_walls(width, 2.0 * height, DIAMETER[1]);
    let d_mean = d.iter().sum::<f64>() / n as f64;
    Setup {
        diameters: d,
        pos,
        width,
        walls,
        settle_after: (2.0 * height / defaults::GRAVITY).sqrt(),
        dt: step * (d_mean / defaults::GRAVITY).sqrt(),
        d_mean,
        wall_friction,
    }
}

/// What one engine reports for one deposit.
#[derive(Debug, Default)]
struct Outcome {
    at_rest: bool,
    wall: f64,
    steps: u64,
    sim_time: f64,
    /// Mean solver iterations (sweeps) per step.
    iterations: f64,
    contact_updates: u64,
    /// Over the contacts carrying load at the end, in units of the mean radius.
    mean_overlap: f64,
    max_overlap: f64,
    floor_over_weight: f64,
    peak_rss_kib: u64,
    contacts: usize,
}

impl Outcome {
    fn line(&self) -> String {
        format!(
            "RESULT {} {} {:.6} {} {:.6e} {:.4} {} {:.6e} {:.6e} {:.6} {}",
            self.at_rest as u8,
            self.steps,
            self.wall,
            self.contact_updates,
            self.sim_time,
            self.iterations,
            self.peak_rss_kib,
            self.mean_overlap,
            self.max_overlap,
            self.floor_over_weight,
            self.contacts,
        )
    }

    fn parse(line: &str) -> Option<Outcome> {
        let f: Vec<&str> = line.strip_prefix("RESULT ")?.split_whitespace().collect();
        Some(Outcome {
            at_rest: f[0] == "1",
            steps: f[1].parse().ok()?,
            wall: f[2].parse().ok()?,
            contact_updates: f[3].parse().ok()?,
            sim_time: f[4].parse().ok()?,
            iterations: f[5].parse().ok()?,
            peak_rss_kib: f[6].parse().ok()?,
            mean_overlap: f[7].parse().ok()?,
            max_overlap: f[8].parse().ok()?,
            floor_over_weight: f[9].parse().ok()?,
            contacts: f[10].parse().ok()?,
        })
    }
}

fn peak_rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1).map(|v| v.parse().unwrap_or(0)))
        })
        .unwrap_or(0)
}

fn rest_ratio(ke: f64, mass: f64, d_mean: f64) -> f64 {
    ke / (mass * defaults::GRAVITY * d_mean)
}

fn mean_max(overlaps: &[f64], r_mean: f64) -> (f64, f64) {
    if overlaps.is_empty() {
        return (0.0, 0.0);
    }
    let mean = overlaps.iter().sum::<f64>() / overlaps.len() as f64;
    (
        mean / r_mean,
        overlaps.iter().cloned().fold(0.0, f64::max) / r_mean,
    )
}

/// Progress line on stderr every this many steps.
const PROGRESS: u64 = 200;

// ---------------------------------------------------------------- softgrain

/// softgrain's settings besides the NLGS's (`--sleep`, `--separate-at`, `--tolerance-after`).
#[derive(Clone, Copy)]
struct Extras {
    /// Sleeping with rapier-froude's thresholds.
    sleep: bool,
    /// One position projection (`cd::separate`) once the rest ratio falls below this.
    separate_at: Option<f64>,
    /// The NLGS tolerance from the projection on.
    tolerance_after: Option<f64>,
}

fn run_softgrain(s: &Setup, seed: u64, budget: f64, nlgs: NlgsParams, extras: Extras) -> Outcome {
    let Extras {
        sleep,
        separate_at,
        tolerance_after,
    } = extras;
    let mut bodies = Bodies::default();
    for (k, (x, d)) in s.pos.iter().zip(&s.diameters).enumerate() {
        bodies.push(*x, 0.5 * d, defaults::DENSITY, k as u32);
    }
    let d_min = s.diameters.iter().cloned().fold(f64::INFINITY, f64::min);
    let params = CdParams {
        dt: s.dt,
        theta: defaults::THETA,
        gravity: V2::new(0.0, -defaults::GRAVITY),
        alert: defaults::ALERT * d_min,
        skin: defaults::SKIN * d_min,
        nlgs,
        // rapier-froude's thresholds (`run_rapier`): a body sleeps after its fastest point has
        // moved slower than 0.05 length_unit per second for 0.5 s × sqrt(<d>/1 m)
        sleep: sleep.then(|| SleepParams {
            speed: 0.05 * s.d_mean,
            time: 0.5 * s.d_mean.sqrt(),
        }),
    };
    let wall_laws = vec![
        Coulomb {
            mu: s.wall_friction
        };
        s.walls.len()
    ];
    let disk = Coulomb {
        mu: defaults::DEPOSIT_FRICTION,
    };
    let mut scene = Scene::new(
        bodies,
        s.walls.clone(),
        LawTable::new(disk, disk, wall_laws),
        params,
        seed,
    );
    let mass = scene.bodies.total_mass();
    let weight = mass * defaults::GRAVITY;
    let mut out = Outcome::default();
    let mut sweeps = 0u64;
    let mut floor = Vec::new();
    let trace = std::env::var_os("DEPOSIT_TRACE").is_some();
    let t0 = Instant::now();
    // with `separate_at`: one position projection (as the prepare stage's) the first time the
    // rest ratio falls below it, then on until the rest test holds, at `tolerance_after` if
    // given (`prepare.separation`)
    let mut separated_at = separate_at.is_none().then_some(0);
    loop {
        let ratio = rest_ratio(scene.bodies.translational_energy(), mass, s.d_mean);
        if scene.time > s.settle_after
            && separated_at.is_none()
            && separate_at.is_some_and(|at| ratio < at)
        {
            let r = scene.bodies.mean_radius();
            let sep = softgrain::cd::separate(
                &mut scene.bodies,
                &scene.walls,
                &scene.contacts,
                defaults::SEPARATION_TOLERANCE * r,
                defaults::SEPARATION_MAX_SWEEPS,
            );
            if trace {
                eprintln!("  separation at step {}: {sep:?}", scene.steps);
            }
            separated_at = Some(scene.steps);
            if let Some(t) = tolerance_after {
                scene.params.nlgs.tol = t;
            }
        }
        if scene.time > s.settle_after
            && separated_at.is_some_and(|k| scene.steps > k)
            && ratio < defaults::REST_TOLERANCE
        {
            out.at_rest = true;
            break;
        }
        if scene.time > defaults::MAX_TIME || t0.elapsed().as_secs_f64() > budget {
            break;
        }
        let r = scene.step().expect("softgrain step");
        sweeps += r.nlgs.iterations as u64;
        out.contact_updates += r.updates;
        floor.push(scene.wall_force[0].y);
        if floor.len() > 20 {
            floor.remove(0);
        }
        if trace || scene.steps.is_multiple_of(PROGRESS) {
            eprintln!(
                "  softgrain step {} t = {:.4} s, {} contacts, {} sweeps, {} resumed, {} asleep, rest ratio {:.2e}, {:.0} s wall",
                scene.steps,
                scene.time,
                r.contacts,
                r.nlgs.iterations,
                r.resumed,
                scene.sleeping(),
                rest_ratio(scene.bodies.translational_energy(), mass, s.d_mean),
                t0.elapsed().as_secs_f64()
            );
        }
    }
    out.wall = t0.elapsed().as_secs_f64();
    out.steps = scene.steps;
    out.sim_time = scene.time;
    out.iterations = sweeps as f64 / scene.steps.max(1) as f64;
    out.floor_over_weight = floor.iter().sum::<f64>() / floor.len().max(1) as f64 / weight;
    let gaps = scene.current_gaps();
    let active: Vec<f64> = (scene.contacts.iter().zip(&gaps))
        .filter(|(c, _)| c.p_n > 0.0)
        .map(|(_, g)| (-g).max(0.0))
        .collect();
    out.contacts = active.len();
    (out.mean_overlap, out.max_overlap) = mean_max(&active, scene.bodies.mean_radius());
    out
}

// ---------------------------------------------------------------- rapier2d

/// rapier2d (f32) with its default solver settings (4 substeps of 1 PGS + 1 stabilisation
/// iteration, soft contacts, warm start, sleeping) and `length_unit` = <d>, the typical
/// object size, which scales its slop, prediction distance and speed limits to the grains.
/// The time step is ours: the same h for both engines.
///
/// With `froude`, the time constants are scaled too: `length_unit` fixes rapier's lengths
/// but not its times, and its contact springs (30 Hz, 60 Hz against fixed bodies) and sleep
/// delay (0.5 s) are tuned for metre-sized bodies under g. Dynamic similarity (Froude: times
/// scale as sqrt(L/g)) maps them to frequencies × sqrt(1 m/<d>) and delays × sqrt(<d>/1 m),
/// i.e. the stiffness rapier would have on the same scene drawn at metre scale.
fn run_rapier(s: &Setup, budget: f64, froude: bool) -> Outcome {
    let n = s.pos.len();
    let mut bodies = RigidBodySet::new();
    let mut colliders = ColliderSet::new();
    let mut handles = Vec::with_capacity(n);
    for (k, (x, d)) in s.pos.iter().zip(&s.diameters).enumerate() {
        let h = bodies
            .insert(RigidBodyBuilder::dynamic().translation(Vector::new(x.x as Real, x.y as Real)));
        colliders.insert_with_parent(
            ColliderBuilder::ball((0.5 * d) as Real)
                .density(defaults::DENSITY as Real)
                .friction(defaults::DEPOSIT_FRICTION as Real)
                .user_data(k as u128),
            h,
            &mut bodies,
        );
        handles.push(h);
    }
    // The open box: three fixed cuboids whose inner faces are our wall lines (floor y = 0,
    // left x = 0, right x = width), as long as our segments with their overhang. The Min
    // combine rule gives disk-wall contacts min(0.3, wall friction): 0 by default.
    let t = DIAMETER[1];
    let top = s.walls[1].a.y;
    let o = DIAMETER[1];
    let w = s.width;
    let boxes = [
        (0.5 * w + o, 0.5 * t, 0.5 * w, -0.5 * t),
        (0.5 * t, 0.5 * (top + o), -0.5 * t, 0.5 * (top - o)),
        (0.5 * t, 0.5 * (top + o), w + 0.5 * t, 0.5 * (top - o)),
    ];
    let mut wall_handles = Vec::new();
    for (k, (hx, hy, cx, cy)) in boxes.into_iter().enumerate() {
        wall_handles.push(
            colliders.insert(
                ColliderBuilder::cuboid(hx as Real, hy as Real)
                    .translation(Vector::new(cx as Real, cy as Real))
                    .friction(s.wall_friction as Real)
                    .friction_combine_rule(CoefficientCombineRule::Min)
                    .user_data(u128::MAX - k as u128),
            ),
        );
    }
    let mut params = IntegrationParameters {
        length_unit: s.d_mean as Real,
        ..IntegrationParameters::default()
    };
    params.dt = s.dt as Real;
    let time_scale = (s.d_mean / 1.0).sqrt();
    if froude {
        params.contact_softness.natural_frequency /= time_scale as Real;
        params.static_contact_softness.natural_frequency /= time_scale as Real;
        for h in &handles {
            bodies[*h].activation_mut().time_until_sleep *= time_scale as Real;
        }
    }
    let gravity = Vector::new(0.0, -defaults::GRAVITY as Real);
    let mut pipeline = PhysicsPipeline::new();
    let mut islands = IslandManager::new();
    let mut broad = DefaultBroadPhase::default();
    let mut narrow = NarrowPhase::new();
    let mut impulse_joints = ImpulseJointSet::new();
    let mut multibody_joints = MultibodyJointSet::new();
    let mut soft_bodies = SoftBodySet::new();
    let mut ccd = CCDSolver::new();
    let masses: Vec<f64> = handles.iter().map(|h| bodies[*h].mass() as f64).collect();
    let mass: f64 = masses.iter().sum();
    let weight = mass * defaults::GRAVITY;
    let per_step = (params.num_solver_iterations
        * (params.num_internal_pgs_iterations + params.num_internal_stabilization_iterations))
        as u64;
    let mut out = Outcome::default();
    let mut steps = 0u64;
    let mut time = 0.0;
    let mut floor = Vec::new();
    let mut solve_wall = 0.0;
    loop {
        let t0 = Instant::now();
        let ke: f64 = (handles.iter().zip(&masses))
            .map(|(h, m)| {
                let v = bodies[*h].linvel();
                0.5 * m * ((v.x as f64).powi(2) + (v.y as f64).powi(2))
            })
            .sum();
        if time > s.settle_after && rest_ratio(ke, mass, s.d_mean) < defaults::REST_TOLERANCE {
            solve_wall += t0.elapsed().as_secs_f64();
            out.at_rest = true;
            break;
        }
        if time > defaults::MAX_TIME || solve_wall > budget {
            break;
        }
        pipeline.step(
            gravity,
            &params,
            &mut islands,
            &mut broad,
            &mut narrow,
            &mut bodies,
            &mut colliders,
            &mut impulse_joints,
            &mut multibody_joints,
            &mut soft_bodies,
            &mut ccd,
            &(),
            &(),
        );
        solve_wall += t0.elapsed().as_secs_f64();
        steps += 1;
        time += s.dt;
        // Bookkeeping outside the timed part: contacts seen by the solver, floor force.
        let mut contacts = 0u64;
        let mut floor_impulse = 0.0;
        for pair in narrow.contact_pairs() {
            contacts += (pair.manifolds().iter())
                .map(|m| m.data.num_active_contacts() as u64)
                .sum::<u64>();
            if pair.collider1 == wall_handles[0] || pair.collider2 == wall_handles[0] {
                floor_impulse += pair.total_impulse().y.abs() as f64;
            }
        }
        out.contact_updates += contacts * per_step;
        floor.push(floor_impulse / s.dt);
        if floor.len() > 20 {
            floor.remove(0);
        }
        if steps.is_multiple_of(PROGRESS) {
            eprintln!(
                "  rapier step {steps} t = {time:.4} s, {contacts} contacts, {solve_wall:.0} s wall"
            );
        }
    }
    out.wall = solve_wall;
    out.steps = steps;
    out.sim_time = time;
    out.iterations = per_step as f64;
    out.floor_over_weight = floor.iter().sum::<f64>() / floor.len().max(1) as f64 / weight;
    // Overlaps of the contacts carrying load, from the final positions in f64.
    let centre = |k: usize| {
        let p = bodies[handles[k]].translation();
        V2::new(p.x as f64, p.y as f64)
    };
    let mut active = Vec::new();
    for pair in narrow.contact_pairs() {
        if pair.total_impulse_magnitude() <= 0.0 {
            continue;
        }
        let (a, b) = (
            colliders[pair.collider1].user_data,
            colliders[pair.collider2].user_data,
        );
        let (a, b) = (a.min(b), a.max(b));
        let ra = 0.5 * s.diameters[a as usize];
        let pa = centre(a as usize);
        let gap = if (b as usize) < n {
            (pa - centre(b as usize)).norm() - ra - 0.5 * s.diameters[b as usize]
        } else {
            match u128::MAX - b {
                0 => pa.y - ra,
                1 => pa.x - ra,
                _ => w - pa.x - ra,
            }
        };
        active.push((-gap).max(0.0));
    }
    out.contacts = active.len();
    (out.mean_overlap, out.max_overlap) = mean_max(&active, 0.5 * s.d_mean);
    out
}

// ---------------------------------------------------------------- driver

fn child(engine: &str, s: &Setup, seed: u64, budget: f64, nlgs: NlgsParams, extras: Extras) {
    let mut out = match engine {
        "softgrain" => run_softgrain(s, seed, budget, nlgs, extras),
        "rapier" => run_rapier(s, budget, false),
        "rapier-froude" => run_rapier(s, budget, true),
        _ => panic!("unknown engine {engine}"),
    };
    out.peak_rss_kib = peak_rss_kib();
    println!("{}", out.line());
}

fn arg<'a>(args: &'a [String], key: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == key)
        .and_then(|k| args.get(k + 1))
        .map(String::as_str)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if !n.is_multiple_of(2) {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = arg(&args, "--seed").map_or(1, |s| s.parse().expect("--seed"));
    let budget: f64 = arg(&args, "--budget").map_or(3600.0, |s| s.parse().expect("--budget"));
    // Time step of both engines in units of sqrt(<d>/g); the prepare stage's default unless set.
    let step: f64 =
        arg(&args, "--step").map_or(defaults::DEPOSIT_STEP, |s| s.parse().expect("--step"));
    let wall_friction: f64 = arg(&args, "--wall-friction").map_or(defaults::WALL_FRICTION, |s| {
        s.parse().expect("--wall-friction")
    });
    // softgrain's NLGS: the defaults, with the tolerance, ω, Anderson's depth and the check
    // interval settable
    let nlgs = NlgsParams {
        tol: arg(&args, "--tolerance").map_or(defaults::NLGS_TOLERANCE, |s| {
            s.parse().expect("--tolerance")
        }),
        check_every: arg(&args, "--check-every").map_or(defaults::NLGS_CHECK_EVERY, |s| {
            s.parse().expect("--check-every")
        }),
        max_iter: defaults::NLGS_MAX_ITERATIONS,
        relax: arg(&args, "--relaxation").map_or(defaults::NLGS_RELAXATION, |s| {
            s.parse().expect("--relaxation")
        }),
        anderson: arg(&args, "--anderson")
            .map_or(defaults::NLGS_ANDERSON, |s| s.parse().expect("--anderson")),
        islands: args.iter().any(|a| a == "--islands"),
    };
    let extras = Extras {
        sleep: args.iter().any(|a| a == "--sleep"),
        separate_at: arg(&args, "--separate-at").map(|s| s.parse().expect("--separate-at")),
        tolerance_after: arg(&args, "--tolerance-after")
            .map(|s| s.parse().expect("--tolerance-after")),
    };
    if let Some(k) = args.iter().position(|a| a == "--child") {
        let engine = &args[k + 1];
        let n: usize = args[k + 2].parse().expect("size");
        child(
            engine,
            &setup(n, seed, step, wall_friction),
            seed,
            budget,
            nlgs,
            extras,
        );
        return;
    }
    let sizes: Vec<usize> = arg(&args, "--sizes")
        .unwrap_or("300,30000")
        .split(',')
        .map(|s| s.parse().expect("--sizes"))
        .collect();
    let runs: usize = arg(&args, "--runs").map_or(3, |s| s.parse().expect("--runs"));
    let engines: Vec<String> = arg(&args, "--engines")
        .unwrap_or("softgrain,rapier,rapier-froude")
        .split(',')
        .map(String::from)
        .collect();
    let exe = std::env::current_exe().expect("own path");
    println!(
        "deposit benchmark: seed {seed}, {runs} run(s) each, budget {budget} s, {} rayon threads, \
         softgrain NLGS tolerance {} (after the separation: {}), separation at rest ratio {}, \
         relaxation {}, Anderson depth {}, check every {} sweeps, islands {}, sleeping {}",
        rayon::current_num_threads(),
        nlgs.tol,
        extras
            .tolerance_after
            .map_or("unchanged".into(), |t| t.to_string()),
        extras.separate_at.map_or("none".into(), |r| r.to_string()),
        nlgs.relax,
        nlgs.anderson,
        nlgs.check_every,
        nlgs.islands,
        extras.sleep,
    );
    let mut table = Vec::new();
    for &n in &sizes {
        let s = setup(n, seed, step, wall_friction);
        println!(
            "{n} disks: box width {:.4} m, h = {:.3e} s, rest test after {:.3} s",
            s.width, s.dt, s.settle_after
        );
        let mut by_engine = Vec::new();
        for engine in &engines {
            let mut outs = Vec::new();
            for run in 0..runs {
                let o = std::process::Command::new(&exe)
                    .args(["--child", engine, &n.to_string()])
                    .args(["--seed", &seed.to_string(), "--budget", &budget.to_string()])
                    .args(["--step", &step.to_string()])
                    .args(["--wall-friction", &wall_friction.to_string()])
                    .args(["--tolerance", &nlgs.tol.to_string()])
                    .args(["--relaxation", &nlgs.relax.to_string()])
                    .args(["--anderson", &nlgs.anderson.to_string()])
                    .args(["--check-every", &nlgs.check_every.to_string()])
                    .args(nlgs.islands.then_some("--islands"))
                    .args(extras.sleep.then_some("--sleep"))
                    .args(
                        extras
                            .separate_at
                            .iter()
                            .flat_map(|r| ["--separate-at".into(), r.to_string()]),
                    )
                    .args(
                        extras
                            .tolerance_after
                            .iter()
                            .flat_map(|t| ["--tolerance-after".into(), t.to_string()]),
                    )
                    .stderr(std::process::Stdio::inherit())
                    .output()
                    .expect("child run");
                let text = String::from_utf8_lossy(&o.stdout);
                let out = text.lines().find_map(Outcome::parse).unwrap_or_else(|| {
                    panic!("{engine} {n}: no result ({})", o.status);
                });
                println!(
                    "  {engine:9} run {run}: {:.3} s, {} steps, rest {}",
                    out.wall, out.steps, out.at_rest
                );
                outs.push(out);
            }
            let wall = median(outs.iter().map(|o| o.wall).collect());
            let rss = median(outs.iter().map(|o| o.peak_rss_kib as f64).collect());
            let mut first = outs.swap_remove(0);
            first.wall = wall;
            first.peak_rss_kib = rss as u64;
            by_engine.push((engine.clone(), first));
        }
        table.push((n, by_engine));
    }
    println!();
    println!(
        "| disks | engine | at rest | wall time (s, median of {runs}) | steps | sim. time (s) | iterations/step | contact updates/s | contacts at rest | mean overlap (<r>) | max overlap (<r>) | floor force / weight | peak RSS (MiB) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (n, rows) in &table {
        for (engine, o) in rows {
            println!(
                "| {n} | {engine} | {} | {:.2} | {} | {:.3} | {:.1} | {:.3e} | {} | {:.2e} | {:.2e} | {:.4} | {:.1} |",
                if o.at_rest { "yes" } else { "no" },
                o.wall,
                o.steps,
                o.sim_time,
                o.iterations,
                o.contact_updates as f64 / o.wall,
                o.contacts,
                o.mean_overlap,
                o.max_overlap,
                o.floor_over_weight,
                o.peak_rss_kib as f64 / 1024.0
            );
        }
    }
    println!();
    for (n, rows) in &table {
        let find = |e: &str| rows.iter().find(|(x, _)| x == e).map(|(_, o)| o);
        for other in ["rapier", "rapier-froude"] {
            if let (Some(a), Some(b)) = (find("softgrain"), find(other)) {
                println!(
                    "{n} disks: softgrain/{other}: time ratio {:.3} (target ≤ 1), mean overlap ratio {:.2e} (target ≤ 1e-2)",
                    a.wall / b.wall,
                    a.mean_overlap / b.mean_overlap.max(1e-300)
                );
            }
        }
    }
}
