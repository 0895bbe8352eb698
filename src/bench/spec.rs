//! The bench file (`pipelines/bench.yaml`): which families to sweep, the base setting of
//! each and the values of each knob. Unknown keys are rejected; errors name the file, the
//! key, the value and, for YAML, the line and column.

use crate::config::{InputError, apply_set, first_line, locate};
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BenchSpec {
    /// Output folder name under `--out`.
    pub name: String,
    /// Runs of each setting; the median wall time is reported.
    #[serde(default = "repeats")]
    pub repeats: usize,
    #[serde(default)]
    pub mpm: Option<MpmFamily>,
    #[serde(default)]
    pub cd: Option<CdFamily>,
    #[serde(default)]
    pub bpm: Option<BpmFamily>,
    #[serde(default)]
    pub mpm_stability: Option<MpmStability>,
    #[serde(default)]
    pub bpm_stability: Option<BpmStability>,
    #[serde(default)]
    pub compaction: Option<CompactionFamily>,
    #[serde(default)]
    pub skips: Option<Vec<SkipScene>>,
}

fn repeats() -> usize {
    3
}

/// Shape functions of the MPM grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    Bilinear,
    Bspline,
    Gimp,
}

/// The single MPM grain between two plates (METHODS §5), to `final_strain`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MpmFamily {
    #[serde(default = "radius")]
    pub radius: f64,
    #[serde(default = "young")]
    pub young: f64,
    #[serde(default = "poisson")]
    pub poisson: f64,
    #[serde(default = "density")]
    pub density: f64,
    #[serde(default = "wall_velocity")]
    pub wall_velocity: f64,
    /// Must pass 0.05: the force is compared with Johnson's at ε = 0.02 and 0.05.
    pub final_strain: f64,
    pub base: MpmSetting,
    #[serde(default)]
    pub resolution: Vec<f64>,
    #[serde(default)]
    pub travel_per_step: Vec<f64>,
    #[serde(default)]
    pub newton_tolerance: Vec<f64>,
    #[serde(default)]
    pub shape: Vec<Shape>,
}

/// One MPM setting: Δr/R, plate travel per step over h_g (sets Δt), Newton's residual
/// tolerance (the increment tolerance is ten times it, as in the defaults), shape functions.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MpmSetting {
    pub resolution: f64,
    pub travel_per_step: f64,
    pub newton_tolerance: f64,
    pub shape: Shape,
}

/// A small rigid-disk deposit (weight on the floor, overlaps) and the incline checks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CdFamily {
    pub grains: usize,
    #[serde(default = "diameter")]
    pub diameter: [f64; 2],
    #[serde(default = "friction")]
    pub friction: f64,
    /// A deposit still moving after this long is measured as it is (s).
    #[serde(default = "max_time")]
    pub max_time: f64,
    pub base: CdSetting,
    #[serde(default)]
    pub tolerance: Vec<f64>,
    #[serde(default)]
    pub time_step: Vec<f64>,
    #[serde(default)]
    pub alert: Vec<f64>,
}

/// One CD setting: NLGS tolerance, time step in units of sqrt(<d>/g), alert distance in
/// units of the smallest diameter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CdSetting {
    pub tolerance: f64,
    pub time_step: f64,
    pub alert: f64,
}

/// One small BPM grain between two plates; its plateau needs `final_strain` above 0.1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BpmFamily {
    #[serde(default = "bpm_radius")]
    pub radius: f64,
    #[serde(default = "particle_diameter")]
    pub particle_diameter: [f64; 2],
    #[serde(default = "wall_velocity")]
    pub wall_velocity: f64,
    pub final_strain: f64,
    pub base: BpmSetting,
    #[serde(default)]
    pub tolerance: Vec<f64>,
    #[serde(default)]
    pub time_step: Vec<f64>,
}

/// One BPM setting: NLGS tolerance, time step in units of t0 = sqrt(m a0/F0) (smallest particle).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BpmSetting {
    pub tolerance: f64,
    pub time_step: f64,
}

/// The MPM stability map: for each resolution and material, every plate travel per step is
/// run; the largest whose run completes with a force curve within `accuracy` (relative RMS)
/// of the smallest step's is marked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MpmStability {
    #[serde(default = "radius")]
    pub radius: f64,
    #[serde(default = "density")]
    pub density: f64,
    #[serde(default = "wall_velocity")]
    pub wall_velocity: f64,
    pub final_strain: f64,
    pub accuracy: f64,
    pub resolution: Vec<f64>,
    pub young: Vec<f64>,
    pub poisson: Vec<f64>,
    pub travel_per_step: Vec<f64>,
}

/// The BPM stability map: for each particle size range, F0 and plate speed, every time
/// step (units of t0) is run on one grain; the largest step up to which every run completes
/// with its particles, area and force as at the smallest step (force within `accuracy`) is
/// marked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BpmStability {
    #[serde(default = "bpm_radius")]
    pub radius: f64,
    pub final_strain: f64,
    /// Largest force difference to the smallest step's (relative RMS of the means over five
    /// strain windows) of a stable run: a grain that fell apart carries no force (1.0), and
    /// two correct runs of a 150-particle grain differ by up to about 0.5 (its scatter).
    pub accuracy: f64,
    pub particle_diameter: Vec<[f64; 2]>,
    pub f0: Vec<f64>,
    pub wall_velocity: Vec<f64>,
    pub time_step: Vec<f64>,
}

/// A reduced BPM packing compacted from `initial_phi` to `final_strain`, inter-grain
/// friction `friction`; σ(ε) and Φ(ε) are compared with the knob's finest value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompactionFamily {
    pub grains: usize,
    #[serde(default = "packing_particle_diameter")]
    pub particle_diameter: [f64; 2],
    #[serde(default = "packing_initial_phi")]
    pub initial_phi: f64,
    #[serde(default)]
    pub friction: f64,
    pub final_strain: f64,
    pub base: CompactionSetting,
    #[serde(default)]
    pub tolerance: Vec<f64>,
    #[serde(default)]
    pub time_step: Vec<f64>,
    #[serde(default)]
    pub wall_velocity: Vec<f64>,
}

/// One compaction setting: NLGS tolerance, time step in units of t0, top-wall speed (m/s;
/// the slowest is the finest, the nearest to quasi-static).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompactionSetting {
    pub tolerance: f64,
    pub time_step: f64,
    pub wall_velocity: f64,
}

/// A scene for the `skips` section: a pipeline (path relative to the bench file) run with
/// every shortcut on (the reference), then once per variant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkipScene {
    pub name: String,
    pub pipeline: std::path::PathBuf,
    /// `--set KEY=VALUE` overrides of the scene, for the reference and every variant.
    #[serde(default)]
    pub set: Vec<String>,
    /// The last stage to run (`--until`), e.g. `prepare` for a deposit alone.
    #[serde(default)]
    pub until: Option<String>,
    /// The `timeseries.csv` column compared with the reference's: its means over `windows`
    /// equal strain windows (a BPM run's single-step forces jump by tens of percent, so a
    /// shortcut that changes the solver's path is judged on means over wide windows).
    pub compare: String,
    #[serde(default = "windows")]
    pub windows: usize,
    /// Threads of the reference run (`--jobs`).
    #[serde(default = "jobs")]
    pub jobs: usize,
    pub variants: Vec<SkipVariant>,
}

/// What a variant changes: shortcuts turned off (`SOFTGRAIN_WITHOUT`), more `--set`s, or
/// the thread count.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkipVariant {
    pub name: String,
    #[serde(default)]
    pub without: Vec<String>,
    #[serde(default)]
    pub set: Vec<String>,
    #[serde(default)]
    pub jobs: Option<usize>,
}

fn windows() -> usize {
    10
}
fn jobs() -> usize {
    2
}
fn packing_particle_diameter() -> [f64; 2] {
    [2.0e-4, 3.4e-4]
}
fn packing_initial_phi() -> f64 {
    0.55
}
fn radius() -> f64 {
    5e-3
}
fn young() -> f64 {
    10e6
}
fn poisson() -> f64 {
    0.45
}
fn density() -> f64 {
    990.0
}
fn wall_velocity() -> f64 {
    0.2
}
fn bpm_radius() -> f64 {
    1.5e-3
}
fn particle_diameter() -> [f64; 2] {
    [1.6e-4, 2.6e-4]
}
fn diameter() -> [f64; 2] {
    [1.4e-3, 2.4e-3]
}
fn friction() -> f64 {
    0.3
}
fn max_time() -> f64 {
    5.0
}

/// (key, value, what is allowed)
type Failure = (String, String, String);

/// Reads, overrides (`--set KEY=VALUE`) and validates a bench file.
pub fn load(file: &Path, sets: &[String]) -> Result<BenchSpec, Box<InputError>> {
    let err = |key: &str, value: &str, message: String, at, from_set| {
        Box::new(InputError {
            file: file.to_path_buf(),
            key: key.to_string(),
            value: value.to_string(),
            message,
            at,
            from_set,
        })
    };
    let text = std::fs::read_to_string(file)
        .map_err(|e| err("", "", format!("cannot read the file: {e}"), None, false))?;
    let mut spec: BenchSpec = serde_saphyr::from_str(&text).map_err(|e| {
        let at = e.location().map(|l| (l.line(), l.column()));
        let (key, value) = at
            .and_then(|(line, _)| locate::key_at(&text, line))
            .unwrap_or_default();
        err(&key, &value, first_line(&e.to_string()), at, false)
    })?;
    let mut set_keys = Vec::new();
    for s in sets {
        let (key, value) = s
            .split_once('=')
            .ok_or_else(|| err(s, "", "expected KEY=VALUE".into(), None, true))?;
        spec = apply_set(&spec, key.trim(), value.trim())
            .map_err(|m| err(key, value, m, None, true))?;
        set_keys.push(key.trim().to_string());
    }
    check(&spec).map_err(|(key, value, message)| {
        let from_set = set_keys.contains(&key);
        let at = (!from_set)
            .then(|| locate::key_position(&text, &key))
            .flatten();
        err(&key, &value, message, at, from_set)
    })?;
    Ok(spec)
}

fn check(s: &BenchSpec) -> Result<(), Failure> {
    let fail = |key: &str, value: String, msg: &str| Err((key.to_string(), value, msg.to_string()));
    if s.name.is_empty() || s.name.contains(['/', '\\']) {
        return fail("name", s.name.clone(), "must be a non-empty folder name");
    }
    if s.repeats == 0 {
        return fail("repeats", "0".into(), "must be >= 1");
    }
    if s.mpm.is_none()
        && s.cd.is_none()
        && s.bpm.is_none()
        && s.mpm_stability.is_none()
        && s.bpm_stability.is_none()
        && s.compaction.is_none()
        && s.skips.is_none()
    {
        return fail(
            "mpm",
            "".into(),
            "give at least one family: mpm, cd, bpm, mpm_stability, bpm_stability, compaction, skips",
        );
    }
    if let Some(m) = &s.bpm_stability {
        if !(m.final_strain > 0.0 && m.final_strain < 0.6) {
            return fail(
                "bpm_stability.final_strain",
                m.final_strain.to_string(),
                "must lie in (0, 0.6)",
            );
        }
        positive("bpm_stability.accuracy", m.accuracy)?;
        for (key, n) in [
            ("bpm_stability.particle_diameter", m.particle_diameter.len()),
            ("bpm_stability.f0", m.f0.len()),
            ("bpm_stability.wall_velocity", m.wall_velocity.len()),
            ("bpm_stability.time_step", m.time_step.len()),
        ] {
            if n == 0 {
                return fail(key, "[]".into(), "must list at least one value");
            }
        }
        for d in &m.particle_diameter {
            if !(d[0] > 0.0 && d[1] >= d[0]) || m.radius.is_nan() || m.radius < 2.0 * d[1] {
                return fail(
                    "bpm_stability.particle_diameter",
                    format!("{d:?}"),
                    "each must be [min, max] with 0 < min <= max <= radius / 2",
                );
            }
        }
        m.f0.iter()
            .try_for_each(|&x| positive("bpm_stability.f0", x))?;
        m.wall_velocity
            .iter()
            .try_for_each(|&x| positive("bpm_stability.wall_velocity", x))?;
        m.time_step
            .iter()
            .try_for_each(|&x| positive("bpm_stability.time_step", x))?;
    }
    if let Some(c) = &s.compaction {
        if c.grains < 2 {
            return fail("compaction.grains", c.grains.to_string(), "must be >= 2");
        }
        let [d0, d1] = c.particle_diameter;
        if !(d0 > 0.0 && d1 >= d0 && d1 < 0.7e-3) {
            return fail(
                "compaction.particle_diameter",
                format!("{:?}", c.particle_diameter),
                "must be [min, max] with 0 < min <= max < 0.7 mm (grains are 1.4-2.4 mm)",
            );
        }
        if !(c.initial_phi > 0.0 && c.initial_phi < 1.0) {
            return fail(
                "compaction.initial_phi",
                c.initial_phi.to_string(),
                "must lie in (0, 1)",
            );
        }
        if c.friction.is_nan() || c.friction < 0.0 {
            return fail(
                "compaction.friction",
                c.friction.to_string(),
                "must be >= 0",
            );
        }
        if !(c.final_strain > 0.0 && c.final_strain < 1.0) {
            return fail(
                "compaction.final_strain",
                c.final_strain.to_string(),
                "must lie in (0, 1)",
            );
        }
        let b = c.base;
        positive("compaction.base.tolerance", b.tolerance)?;
        bpm_step("compaction.base.time_step", b.time_step)?;
        positive("compaction.base.wall_velocity", b.wall_velocity)?;
        c.tolerance
            .iter()
            .try_for_each(|&x| positive("compaction.tolerance", x))?;
        c.time_step
            .iter()
            .try_for_each(|&x| bpm_step("compaction.time_step", x))?;
        c.wall_velocity
            .iter()
            .try_for_each(|&x| positive("compaction.wall_velocity", x))?;
    }
    for (k, scene) in s.skips.iter().flatten().enumerate() {
        let key = |field: &str| format!("skips[{k}].{field}");
        if scene.name.is_empty() || scene.name.contains(['/', '\\']) {
            return fail(
                &key("name"),
                scene.name.clone(),
                "must be a non-empty folder name",
            );
        }
        if scene.compare.is_empty() {
            return fail(
                &key("compare"),
                "".into(),
                "must name a timeseries.csv column",
            );
        }
        if scene.windows == 0 {
            return fail(&key("windows"), "0".into(), "must be >= 1");
        }
        if scene.jobs == 0 {
            return fail(&key("jobs"), "0".into(), "must be >= 1");
        }
        if scene.variants.is_empty() {
            return fail(
                &key("variants"),
                "[]".into(),
                "must list at least one variant",
            );
        }
        for v in &scene.variants {
            for w in &v.without {
                if !crate::shortcuts::NAMES.contains(&w.as_str()) {
                    return fail(
                        &key("variants.without"),
                        w.clone(),
                        &format!("must be one of {}", crate::shortcuts::NAMES.join(", ")),
                    );
                }
            }
            if v.jobs == Some(0) {
                return fail(&key("variants.jobs"), "0".into(), "must be >= 1");
            }
        }
    }
    if let Some(b) = &s.bpm {
        positive("bpm.wall_velocity", b.wall_velocity)?;
        let [d0, d1] = b.particle_diameter;
        if !(d0 > 0.0 && d1 >= d0) {
            return fail(
                "bpm.particle_diameter",
                format!("{:?}", b.particle_diameter),
                "must be [min, max] with 0 < min <= max",
            );
        }
        if b.radius.is_nan() || b.radius < 2.0 * d1 {
            return fail("bpm.radius", b.radius.to_string(), "must be >= 2 d_max");
        }
        if !(b.final_strain > 0.1 && b.final_strain < 0.6) {
            return fail(
                "bpm.final_strain",
                b.final_strain.to_string(),
                "must lie in (0.1, 0.6): the plateau is the mean over ε >= 0.1",
            );
        }
        positive("bpm.base.tolerance", b.base.tolerance)?;
        bpm_step("bpm.base.time_step", b.base.time_step)?;
        b.tolerance
            .iter()
            .try_for_each(|&x| positive("bpm.tolerance", x))?;
        b.time_step
            .iter()
            .try_for_each(|&x| bpm_step("bpm.time_step", x))?;
    }
    if let Some(m) = &s.mpm {
        positive("mpm.radius", m.radius)?;
        positive("mpm.young", m.young)?;
        poisson_ok("mpm.poisson", m.poisson)?;
        positive("mpm.density", m.density)?;
        positive("mpm.wall_velocity", m.wall_velocity)?;
        if !(m.final_strain > 0.05 && m.final_strain < 0.5) {
            return fail(
                "mpm.final_strain",
                m.final_strain.to_string(),
                "must lie in (0.05, 0.5): the force is compared at ε = 0.02 and 0.05",
            );
        }
        resolution("mpm.base.resolution", m.base.resolution)?;
        travel("mpm.base.travel_per_step", m.base.travel_per_step)?;
        positive("mpm.base.newton_tolerance", m.base.newton_tolerance)?;
        m.resolution
            .iter()
            .try_for_each(|&x| resolution("mpm.resolution", x))?;
        m.travel_per_step
            .iter()
            .try_for_each(|&x| travel("mpm.travel_per_step", x))?;
        m.newton_tolerance
            .iter()
            .try_for_each(|&x| positive("mpm.newton_tolerance", x))?;
    }
    if let Some(c) = &s.cd {
        if c.grains < 2 {
            return fail("cd.grains", c.grains.to_string(), "must be >= 2");
        }
        if !(c.diameter[0] > 0.0 && c.diameter[1] >= c.diameter[0]) {
            return fail(
                "cd.diameter",
                format!("{:?}", c.diameter),
                "must be [min, max] with 0 < min <= max",
            );
        }
        if c.friction.is_nan() || c.friction < 0.0 {
            return fail("cd.friction", c.friction.to_string(), "must be >= 0");
        }
        positive("cd.max_time", c.max_time)?;
        let b = c.base;
        positive("cd.base.tolerance", b.tolerance)?;
        positive("cd.base.time_step", b.time_step)?;
        positive("cd.base.alert", b.alert)?;
        c.tolerance
            .iter()
            .try_for_each(|&x| positive("cd.tolerance", x))?;
        c.time_step
            .iter()
            .try_for_each(|&x| positive("cd.time_step", x))?;
        c.alert.iter().try_for_each(|&x| positive("cd.alert", x))?;
    }
    if let Some(m) = &s.mpm_stability {
        positive("mpm_stability.radius", m.radius)?;
        positive("mpm_stability.density", m.density)?;
        positive("mpm_stability.wall_velocity", m.wall_velocity)?;
        positive("mpm_stability.accuracy", m.accuracy)?;
        if !(m.final_strain > 0.0 && m.final_strain < 0.5) {
            return fail(
                "mpm_stability.final_strain",
                m.final_strain.to_string(),
                "must lie in (0, 0.5)",
            );
        }
        for (key, list) in [
            ("mpm_stability.resolution", &m.resolution),
            ("mpm_stability.young", &m.young),
            ("mpm_stability.poisson", &m.poisson),
            ("mpm_stability.travel_per_step", &m.travel_per_step),
        ] {
            if list.is_empty() {
                return fail(key, "[]".into(), "must list at least one value");
            }
        }
        m.resolution
            .iter()
            .try_for_each(|&x| resolution("mpm_stability.resolution", x))?;
        m.young
            .iter()
            .try_for_each(|&x| positive("mpm_stability.young", x))?;
        m.poisson
            .iter()
            .try_for_each(|&x| poisson_ok("mpm_stability.poisson", x))?;
        m.travel_per_step
            .iter()
            .try_for_each(|&x| travel("mpm_stability.travel_per_step", x))?;
    }
    Ok(())
}

fn positive(key: &str, x: f64) -> Result<(), Failure> {
    if x > 0.0 && x.is_finite() {
        Ok(())
    } else {
        Err((
            key.into(),
            x.to_string(),
            "must be a finite number > 0".into(),
        ))
    }
}

fn poisson_ok(key: &str, x: f64) -> Result<(), Failure> {
    if x > -1.0 && x < 0.5 {
        Ok(())
    } else {
        Err((key.into(), x.to_string(), "must lie in (-1, 0.5)".into()))
    }
}

/// The compact stage's range for the BPM step (units of t0: the explicit attraction).
fn bpm_step(key: &str, x: f64) -> Result<(), Failure> {
    if x > 0.0 && x <= 0.5 {
        Ok(())
    } else {
        Err((
            key.into(),
            x.to_string(),
            "must lie in (0, 0.5] (units of t0)".into(),
        ))
    }
}

/// The MPM driver's own range for Δr/R.
fn resolution(key: &str, x: f64) -> Result<(), Failure> {
    if x > 0.0 && x <= 0.25 {
        Ok(())
    } else {
        Err((key.into(), x.to_string(), "must lie in (0, 0.25]".into()))
    }
}

/// The MPM driver's own range for the plate travel per step (units of h_g).
fn travel(key: &str, x: f64) -> Result<(), Failure> {
    if x > 0.0 && x <= 0.5 {
        Ok(())
    } else {
        Err((key.into(), x.to_string(), "must lie in (0, 0.5]".into()))
    }
}
