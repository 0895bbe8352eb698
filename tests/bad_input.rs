//! Bad input: every entry exits with status 2 before any work starts, with one message that
//! names the file, the key (and its line:column when it comes from the file), the value and
//! what is allowed.

mod common;

use common::{softgrain, stderr, temp_dir, write};

const GRAIN: &str = "name: g
seed: 1
prepare:
  layout: single
  radius: 5.0e-3
discretise:
  method: [bpm, mpm]
  bpm:
    particle_diameter: [1.6e-4, 2.6e-4]
    f0: 100.0
  mpm:
    young: 1.0e7
    poisson: 0.45
    density: 990.0
    resolution: 0.029
compact:
  wall_velocity: 0.2
  final_strain: 0.3
";

/// `GRAIN` without its MPM half.
const BPM_GRAIN: &str = "name: b
seed: 1
prepare:
  layout: single
  radius: 5.0e-3
discretise:
  method: bpm
  bpm:
    particle_diameter: [1.6e-4, 2.6e-4]
    f0: 100.0
compact:
  wall_velocity: 0.2
  final_strain: 0.3
";

const PACKING: &str = "name: p
prepare:
  grains: 30
  diameter: [1.4e-3, 2.4e-3]
";

const EXPLICIT: &str = "name: e
prepare:
  layout: explicit
  duration: 0.1
  bodies:
    - position: [0.0, 0.01]
      radius: 0.005
  walls:
    - from: [-1.0, 0.0]
      to: [1.0, 0.0]
";

/// (base file, text to replace, replacement, expected part of the message)
const CASES: &[(&str, &str, &str, &str)] = &[
    (
        GRAIN,
        "radius: 5.0e-3",
        "radius: -1.0e-3",
        "g.yaml:5:3: prepare.radius = -0.001: must be a finite number > 0",
    ),
    (
        PACKING,
        "[1.4e-3, 2.4e-3]",
        "[2.4e-3, 1.4e-3]",
        "p.yaml:4:3: prepare.diameter = [0.0024, 0.0014]: must be [min, max] with 0 < min <= max",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  friction: -0.2",
        "p.yaml:4:3: prepare.friction = -0.2: must be a finite number >= 0",
    ),
    (
        GRAIN,
        "poisson: 0.45",
        "poisson: 0.5",
        "g.yaml:13:5: discretise.mpm.poisson = 0.5: must be in (-1, 0.5)",
    ),
    (
        GRAIN,
        "final_strain: 0.3",
        "final_strain: 1.0",
        "g.yaml:18:3: compact.final_strain = 1.0: must be in (0, 1)",
    ),
    (GRAIN, "[bpm, mpm]", "[bpm, fem]", "g.yaml:7:"),
    (
        PACKING,
        "grains: 30",
        "grains: 0",
        "p.yaml:3:3: prepare.grains = 0: must be between 1 and 1000000",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  box_width: 1.0e-3",
        "prepare.box_width = 0.001: must be wider than the largest diameter",
    ),
    (
        GRAIN,
        "final_strain: 0.3",
        "final_strain: 0.3\n  time_step: 1.0e-5",
        "g.yaml:19:3: compact.time_step = 1e-5: must be <= 0.5 t0",
    ),
    (
        GRAIN,
        "final_strain: 0.3",
        "final_strain: 0.3\n  newton_tolerance: 1.0",
        "g.yaml:19:3: compact.newton_tolerance = 1.0: must be in (0, 1)",
    ),
    (
        BPM_GRAIN,
        "  wall_velocity: 0.2",
        "  newton_tolerance: 1.0e-5\n  wall_velocity: 0.2",
        "b.yaml:12:3: compact.newton_tolerance = 1e-5: applies to MPM grains only",
    ),
    (
        GRAIN,
        "[1.6e-4, 2.6e-4]",
        "[1.6e-4, 3.0e-3]",
        "discretise.bpm.particle_diameter = [[0.00016, 0.003]]: particles up to 0.003 m do not fit",
    ),
    (
        PACKING,
        "name: p",
        "name: p\nsolver:\n  theta: 0.3",
        "p.yaml:3:3: solver.theta = 0.3: must be in [0.5, 1]",
    ),
    (
        PACKING,
        "name: p",
        "name: p\nsolver:\n  tolerance: 0.0",
        "solver.tolerance = 0.0: must be a finite number > 0",
    ),
    (
        PACKING,
        "name: p",
        "name: p\nsolver:\n  check_every: 0",
        "solver.check_every = 0: must be >= 1",
    ),
    (
        PACKING,
        "name: p",
        "name: p\nsolver:\n  check_every: 20\n  max_iterations: 10",
        "solver.max_iterations = 10: must be >= solver.check_every",
    ),
    (
        PACKING,
        "name: p",
        "name: p\nsolver:\n  relaxation: 2.0",
        "p.yaml:3:3: solver.relaxation = 2.0: must be in (0, 2)",
    ),
    (
        PACKING,
        "name: p",
        "name: p\nsolver:\n  anderson: 17",
        "p.yaml:3:3: solver.anderson = 17: must be in 0..=16",
    ),
    (
        GRAIN,
        "    f0: 100.0\n  mpm:\n    young: 1.0e7\n    poisson: 0.45\n    density: 990.0\n    resolution: 0.029\n",
        "    f0: 100.0\n    rolling_resistance: 1.0\n  mpm:\n    young: 1.0e7\n    poisson: 0.45\n    density: 990.0\n    resolution: 0.029\nsolver:\n  anderson: 8\n",
        "g.yaml:18:3: solver.anderson = 8: must be 0 with discretise.bpm.rolling_resistance > 0",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  gravity: -9.81",
        "prepare.gravity = -9.81: must be a finite number >= 0",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  density: 0.0",
        "prepare.density = 0.0: must be a finite number > 0",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  rest_tolerance: 0.0",
        "prepare.rest_tolerance = 0.0: must be a finite number > 0",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  sleep: {speed: 0.0, time: 0.02}",
        "prepare.sleep.speed = 0.0: must be a finite number > 0",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  max_time: -1.0",
        "prepare.max_time = -1.0: must be a finite number > 0",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  separation: {at: 1.0e-6, tolerance: 0.0}",
        "prepare.separation.tolerance = 0.0: must be a finite number > 0",
    ),
    (
        GRAIN,
        "  radius: 5.0e-3\n",
        "  radius: 5.0e-3\n  separation:\n    at: 1.0e-6\n",
        "g.yaml:7:5: prepare.separation.at = 1e-6: applies to the packing layout only",
    ),
    (
        PACKING,
        "grains: 30",
        "grains: 30\n  time_step: 0.0",
        "prepare.time_step = 0.0: must be a finite number > 0",
    ),
    (
        PACKING,
        "name: p",
        "name: a/b",
        "p.yaml:1:1: name = \"a/b\": must be a non-empty folder name",
    ),
    (
        PACKING,
        "prepare:\n  grains: 30\n  diameter: [1.4e-3, 2.4e-3]\n",
        "",
        "missing field `prepare`",
    ),
    (
        GRAIN,
        "  radius: 5.0e-3\n",
        "",
        "prepare.radius = missing: required by layout single",
    ),
    (
        PACKING,
        "  grains: 30\n",
        "",
        "prepare.grains = missing: required by layout packing",
    ),
    (
        EXPLICIT,
        "  bodies:\n    - position: [0.0, 0.01]\n      radius: 0.005\n",
        "",
        "prepare.bodies = \"[]\": the explicit layout needs at least one disk",
    ),
    (
        EXPLICIT,
        "  duration: 0.1\n",
        "",
        "prepare.duration = missing: required by layout explicit",
    ),
    (
        EXPLICIT,
        "duration: 0.1",
        "duration: 0.1\n  incline_angle: 90.0",
        "prepare.incline_angle = 90.0: must be in (-90, 90) degrees",
    ),
    (
        EXPLICIT,
        "to: [1.0, 0.0]",
        "to: [-1.0, 0.0]",
        "prepare.walls.0.to = [-1.0, 0.0]: must differ from `from`",
    ),
    (
        GRAIN,
        "  bpm:\n    particle_diameter: [1.6e-4, 2.6e-4]\n    f0: 100.0\n",
        "",
        "discretise.bpm = \"missing\": required by method bpm",
    ),
    (
        GRAIN,
        "f0: 100.0",
        "f0: -100.0",
        "g.yaml:10:5: discretise.bpm.f0 = -100.0: must be a finite number > 0",
    ),
    (
        GRAIN,
        "f0: 100.0",
        "f0: 100.0\n    gamma: 0.0",
        "discretise.bpm.gamma = 0.0: must be a finite number > 0",
    ),
    (
        GRAIN,
        "young: 1.0e7",
        "young: 0.0",
        "g.yaml:12:5: discretise.mpm.young = 0.0: must be a finite number > 0",
    ),
    (
        GRAIN,
        "resolution: 0.029",
        "resolution: 0.7",
        "discretise.mpm.resolution = 0.7: must be in (0, 0.5]",
    ),
    (
        GRAIN,
        "wall_velocity: 0.2",
        "wall_velocity: 0.0",
        "g.yaml:17:3: compact.wall_velocity = 0.0: must be a finite number > 0",
    ),
    (
        GRAIN,
        "final_strain: 0.3",
        "final_strain: 0.3\n  friction: [0.0, -0.1]",
        "compact.friction = -0.1: must be a finite number >= 0",
    ),
    (
        PACKING,
        "  diameter: [1.4e-3, 2.4e-3]\n",
        "  diameter: [1.4e-3, 2.4e-3]\nanalyse:\n  final_window: 0.0\n",
        "p.yaml:6:3: analyse.final_window = 0.0: must be in (0, 1)",
    ),
    (
        GRAIN,
        "final_strain: 0.3",
        "final_strain: 0.3\n  friction: [0.0, high]",
        "compact.friction = [0.0, high]: expected one value or a list of values (one case each)",
    ),
    (GRAIN, "seed: 1", "seed: one", "g.yaml:2:"),
    (PACKING, "grains: 30", "grains: 2.5", "p.yaml:3:"),
    (
        PACKING,
        "name: p",
        "name: p\nsolver:\n  sweeps: 3",
        "unknown field `sweeps`",
    ),
    (
        GRAIN,
        "mpm:\n    young",
        "mpm:\n    shape: spline\n    young",
        "unknown variant `spline`",
    ),
];

#[test]
fn every_bad_input_exits_2_with_one_clear_message_before_any_work() {
    assert!(CASES.len() >= 30);
    let dir = temp_dir("badtable");
    let mut failures = Vec::new();
    for (k, (base, from, to, expect)) in CASES.iter().enumerate() {
        assert!(
            base.contains(from),
            "case {k}: `{from}` not in its base file"
        );
        let name = if *base == GRAIN {
            "g.yaml"
        } else if *base == PACKING {
            "p.yaml"
        } else if *base == BPM_GRAIN {
            "b.yaml"
        } else {
            "e.yaml"
        };
        let file = write(&dir, name, &base.replacen(from, to, 1));
        let out = dir.join(format!("out{k}"));
        let o = softgrain(&[
            "pipeline",
            "run",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
        let err = stderr(&o);
        if o.status.code() != Some(2)
            || !err.contains(expect)
            || err.lines().count() != 1
            || out.exists()
        {
            failures.push(format!(
                "case {k}: status {:?}, wanted `{expect}`, got: {err}",
                o.status.code()
            ));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
