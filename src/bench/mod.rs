//! `softgrain bench FILE.yaml`: the work-precision sweep of the engines (issue #7).
//!
//! For each family (`mpm`, `cd`, `bpm`) and each value of each knob, the base setting with that one
//! value changed is run `repeats` times by the engines' library calls (no checkpoints), in a
//! child process `softgrain bench FILE --one INDEX` so that the peak resident memory
//! (`VmHWM`, a process high-water mark) belongs to that setting alone. The child prints one
//! JSON line: the median wall time, the peak memory and what the run measured. The parent
//! judges each setting by its error (`table.rs`), names the Pareto-best settings, and writes
//! `DIR/<name>/bench/work_precision.csv` and `work_precision_<family>.png`; with an
//! `mpm_stability` section also `mpm_stability.csv` and `mpm_stability.png` (run in the
//! parent: the map reports steps, not memory), and the same for `bpm_stability`; with a
//! `skips` section `skips.csv`, each
//! run a child `softgrain pipeline run` (`skips.rs`).

pub mod bpm;
pub mod cd;
pub mod compaction;
pub mod mpm;
mod plot;
pub mod skips;
pub mod spec;
mod table;

pub use spec::{BenchSpec, load};

use serde::{Deserialize, Serialize};
use spec::{BpmSetting, CdSetting, CompactionSetting, MpmSetting, Shape};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One point of a sweep: the family's base setting with one knob changed.
#[derive(Clone, Debug)]
pub struct Setting {
    pub family: &'static str,
    pub knob: &'static str,
    /// The knob's value as written in the CSV.
    pub value: String,
    /// The value when it is a number (orders the runs; the smallest is the finest).
    pub number: Option<f64>,
    engine: Engine,
}

#[derive(Clone, Debug)]
enum Engine {
    Mpm(MpmSetting),
    Cd(CdSetting),
    Bpm(BpmSetting),
    Compaction(CompactionSetting),
}

/// Every setting of the sweep, in a fixed order (a child finds its own by index).
pub fn settings(spec: &BenchSpec) -> Vec<Setting> {
    let mut out = Vec::new();
    if let Some(m) = &spec.mpm {
        let num = |knob: &'static str, values: &[f64], set: fn(&mut MpmSetting, f64)| {
            values
                .iter()
                .map(move |&x| {
                    let mut s = m.base;
                    set(&mut s, x);
                    Setting {
                        family: "mpm",
                        knob,
                        value: x.to_string(),
                        number: Some(x),
                        engine: Engine::Mpm(s),
                    }
                })
                .collect::<Vec<_>>()
        };
        out.extend(num("resolution", &m.resolution, |s, x| s.resolution = x));
        out.extend(num("travel_per_step", &m.travel_per_step, |s, x| {
            s.travel_per_step = x
        }));
        out.extend(num("newton_tolerance", &m.newton_tolerance, |s, x| {
            s.newton_tolerance = x
        }));
        out.extend(m.shape.iter().map(|&shape| {
            Setting {
                family: "mpm",
                knob: "shape",
                value: match shape {
                    Shape::Bilinear => "bilinear",
                    Shape::Bspline => "bspline",
                    Shape::Gimp => "gimp",
                }
                .into(),
                number: None,
                engine: Engine::Mpm(MpmSetting { shape, ..m.base }),
            }
        }));
    }
    if let Some(c) = &spec.cd {
        let num = |knob: &'static str, values: &[f64], set: fn(&mut CdSetting, f64)| {
            values
                .iter()
                .map(move |&x| {
                    let mut s = c.base;
                    set(&mut s, x);
                    Setting {
                        family: "cd",
                        knob,
                        value: x.to_string(),
                        number: Some(x),
                        engine: Engine::Cd(s),
                    }
                })
                .collect::<Vec<_>>()
        };
        out.extend(num("tolerance", &c.tolerance, |s, x| s.tolerance = x));
        out.extend(num("time_step", &c.time_step, |s, x| s.time_step = x));
        out.extend(num("alert", &c.alert, |s, x| s.alert = x));
    }
    if let Some(b) = &spec.bpm {
        let num = |knob: &'static str, values: &[f64], set: fn(&mut BpmSetting, f64)| {
            values
                .iter()
                .map(move |&x| {
                    let mut s = b.base;
                    set(&mut s, x);
                    Setting {
                        family: "bpm",
                        knob,
                        value: x.to_string(),
                        number: Some(x),
                        engine: Engine::Bpm(s),
                    }
                })
                .collect::<Vec<_>>()
        };
        out.extend(num("tolerance", &b.tolerance, |s, x| s.tolerance = x));
        out.extend(num("time_step", &b.time_step, |s, x| s.time_step = x));
    }
    if let Some(c) = &spec.compaction {
        let num = |knob: &'static str, values: &[f64], set: fn(&mut CompactionSetting, f64)| {
            values
                .iter()
                .map(move |&x| {
                    let mut s = c.base;
                    set(&mut s, x);
                    Setting {
                        family: "compaction",
                        knob,
                        value: x.to_string(),
                        number: Some(x),
                        engine: Engine::Compaction(s),
                    }
                })
                .collect::<Vec<_>>()
        };
        out.extend(num("tolerance", &c.tolerance, |s, x| s.tolerance = x));
        out.extend(num("time_step", &c.time_step, |s, x| s.time_step = x));
        out.extend(num("wall_velocity", &c.wall_velocity, |s, x| {
            s.wall_velocity = x
        }));
    }
    out
}

/// What one setting measured, as the child reports it.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Outcome {
    /// Median over the repeats (s).
    pub wall_s: f64,
    /// Peak resident memory of the process that ran the setting (MB), where /proc has it.
    pub peak_rss_mb: Option<f64>,
    /// MPM: F/F_Johnson - 1 at ε = 0.02 and 0.05, and (strain, force in N/m) per step;
    /// compaction: (strain, σ in Pa) per recorded row.
    pub johnson: Option<[f64; 2]>,
    pub curve: Vec<[f64; 2]>,
    /// Compaction: (strain, Φ) per recorded row.
    #[serde(default)]
    pub phi_curve: Vec<[f64; 2]>,
    /// CD: floor balance, max overlap over <r>, incline acceleration error.
    pub floor_balance: Option<f64>,
    pub max_overlap: Option<f64>,
    pub incline: Option<f64>,
    /// BPM: the plateau σ<a0>/F0.
    pub plateau: Option<f64>,
    /// Why the run stopped, if it failed.
    pub failure: Option<String>,
}

/// Runs setting `index` `repeats` times in this process (the `--one` child).
pub fn run_one(spec: &BenchSpec, index: usize) -> Result<Outcome, String> {
    let all = settings(spec);
    let s = all
        .get(index)
        .ok_or_else(|| format!("--one {index}: the file has {} settings", all.len()))?;
    let mut times = Vec::new();
    let mut out = Outcome::default();
    for _ in 0..spec.repeats {
        let t = Instant::now();
        let result = match &s.engine {
            Engine::Mpm(m) => {
                mpm::measure(spec.mpm.as_ref().expect("an mpm setting"), m).map(|r| {
                    out.johnson = Some(r.johnson);
                    out.curve = r.curve;
                })
            }
            Engine::Bpm(b) => {
                let scratch = scratch("bpm");
                let r = bpm::measure(spec.bpm.as_ref().expect("a bpm setting"), b, &scratch);
                let _ = std::fs::remove_dir_all(&scratch);
                r.map(|plateau| out.plateau = Some(plateau))
            }
            Engine::Compaction(c) => {
                let scratch = scratch("compaction");
                let f = spec.compaction.as_ref().expect("a compaction setting");
                let r = compaction::measure(f, c, &scratch);
                let _ = std::fs::remove_dir_all(&scratch);
                r.map(|m| {
                    out.curve = m.sigma;
                    out.phi_curve = m.phi;
                })
            }
            Engine::Cd(c) => cd::measure(spec.cd.as_ref().expect("a cd setting"), c).map(|r| {
                out.floor_balance = Some(r.floor_balance);
                out.max_overlap = Some(r.max_overlap);
                out.incline = Some(r.incline);
            }),
        };
        times.push(t.elapsed().as_secs_f64());
        if let Err(e) = result {
            out.failure = Some(e);
            break;
        }
    }
    times.sort_by(f64::total_cmp);
    out.wall_s = times[times.len() / 2];
    out.peak_rss_mb = peak_rss_mb();
    Ok(out)
}

/// A scratch folder for the stage functions, private to this process.
fn scratch(family: &str) -> PathBuf {
    std::env::temp_dir().join(format!("softgrain-bench-{family}-{}", std::process::id()))
}

/// `VmHWM` of this process from /proc/self/status (MB).
pub fn peak_rss_mb() -> Option<f64> {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
            let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kb / 1024.0)
        })
}

/// Runs the sweep, each setting in a child `exe bench FILE --set ... --one INDEX`, and
/// writes the CSV and plots under `out/<name>/bench/`. Returns that folder.
pub fn run(
    spec: &BenchSpec,
    file: &Path,
    sets: &[String],
    out: &Path,
    exe: &Path,
) -> Result<PathBuf, String> {
    let dir = out.join(&spec.name).join("bench");
    std::fs::create_dir_all(&dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    let all = settings(spec);
    let mut outcomes = Vec::new();
    for (k, s) in all.iter().enumerate() {
        let o = child(exe, file, sets, k)?;
        println!(
            "{:<4} {:<17} {:<10} {:>9.3} s  {:>7.1} MB  {}",
            s.family,
            s.knob,
            s.value,
            o.wall_s,
            o.peak_rss_mb.unwrap_or(f64::NAN),
            o.failure.as_deref().unwrap_or("")
        );
        outcomes.push(o);
    }
    let rows = table::rows(&all, outcomes);
    if !rows.is_empty() {
        write(
            &dir.join("work_precision.csv"),
            table::csv(&rows).as_bytes(),
        )?;
        let mut families: Vec<&str> = rows.iter().map(|r| r.family).collect();
        families.dedup();
        for f in families {
            let mine: Vec<&table::Row> = rows.iter().filter(|r| r.family == f).collect();
            let name = format!("work_precision_{f}.png");
            let tmp = dir.join(format!(".{name}.part.png"));
            plot::work_precision(&tmp, f, &mine)?;
            rename(&tmp, &dir.join(&name))?;
        }
        println!("Pareto-best settings:");
        for r in rows.iter().filter(|r| r.pareto) {
            println!(
                "  {} {} = {}: {:.3} s, error {:.2e} ({}), {:.0} MB",
                r.family,
                r.knob,
                r.value,
                r.wall_s,
                r.error.unwrap_or(f64::NAN),
                r.error_kind,
                r.outcome.peak_rss_mb.unwrap_or(f64::NAN)
            );
        }
    }
    if let Some(scenes) = &spec.skips {
        let base = file.parent().unwrap_or(Path::new("."));
        let runs = skips::run(scenes, base, spec.repeats, exe, &dir)?;
        write(&dir.join("skips.csv"), skips::csv(&runs).as_bytes())?;
    }
    if let Some(m) = &spec.bpm_stability {
        let runs = bpm::stability(m, &scratch("bpm-stability"), |r| {
            println!(
                "bpm_stability d {:?} F0 {} v {} Δt {} t0: {}, {} escaped, area {:+.3}, error {:.2e}, {:.3} s",
                r.particle_diameter,
                r.f0,
                r.wall_velocity,
                r.time_step,
                r.failure.as_deref().unwrap_or("completed"),
                r.escaped,
                r.area_change,
                r.error,
                r.wall_s
            )
        });
        write(
            &dir.join("bpm_stability.csv"),
            table::bpm_stability_csv(&runs).as_bytes(),
        )?;
        let tmp = dir.join(".bpm_stability.part.png");
        plot::bpm_stability(&tmp, &runs)?;
        rename(&tmp, &dir.join("bpm_stability.png"))?;
    }
    if let Some(m) = &spec.mpm_stability {
        let runs = mpm::stability(m, |r| {
            println!(
                "mpm_stability Δr/R {} E {:.0e} ν {} travel {}: {}, error {:.2e}, {:.3} s",
                r.resolution,
                r.young,
                r.poisson,
                r.travel_per_step,
                r.failure.as_deref().unwrap_or("completed"),
                r.error,
                r.wall_s
            )
        });
        write(
            &dir.join("mpm_stability.csv"),
            table::stability_csv(&runs).as_bytes(),
        )?;
        let tmp = dir.join(".mpm_stability.part.png");
        plot::stability(&tmp, &runs)?;
        rename(&tmp, &dir.join("mpm_stability.png"))?;
    }
    Ok(dir)
}

/// One setting in a child process; a child that dies is reported as the setting's failure.
fn child(exe: &Path, file: &Path, sets: &[String], index: usize) -> Result<Outcome, String> {
    let mut cmd = std::process::Command::new(exe);
    cmd.arg("bench").arg(file);
    for s in sets {
        cmd.arg("--set").arg(s);
    }
    cmd.arg("--one").arg(index.to_string());
    let out = cmd
        .output()
        .map_err(|e| format!("starting {}: {e}", exe.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let last = stdout.lines().rev().find(|l| !l.trim().is_empty());
    let failure = match last.map(serde_json::from_str::<Outcome>) {
        Some(Ok(o)) if out.status.success() => return Ok(o),
        Some(Err(e)) if out.status.success() => format!("unreadable child report: {e}"),
        _ => format!(
            "child exited with {}: {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ),
    };
    Ok(Outcome {
        wall_s: f64::NAN,
        failure: Some(failure),
        ..Outcome::default()
    })
}

/// Writes through a temporary name, so no half-written file has the final name.
fn write(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let tmp = path.with_extension("part");
    std::fs::write(&tmp, bytes).map_err(|e| format!("writing {}: {e}", tmp.display()))?;
    rename(&tmp, path)
}

fn rename(from: &Path, to: &Path) -> Result<(), String> {
    std::fs::rename(from, to).map_err(|e| format!("writing {}: {e}", to.display()))
}
