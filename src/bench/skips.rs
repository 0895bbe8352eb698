//! The `skips` section: what each shortcut of `crate::shortcuts` (and each output or thread
//! setting) costs or saves, on a real pipeline. Every scene runs as a child
//! `softgrain pipeline run` with all shortcuts on (the reference) and once per variant;
//! the runs of one repeat follow each other (reference, variant 1, variant 2, ...), so a
//! change of machine load hits them alike. For each variant: the median wall time over the
//! reference's (the speed-up of the shortcut it turns off, or the cost of what it adds),
//! whether every `timeseries.csv` came out byte-identical, and the largest relative RMS
//! difference of the compared column's means over the scene's strain windows.

use super::spec::SkipScene;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// One variant's result (the reference is the row with `variant` "reference").
pub struct SkipRun {
    pub scene: String,
    pub variant: String,
    pub without: String,
    pub set: String,
    pub jobs: usize,
    /// Median wall time of the child process (s).
    pub wall_s: f64,
    /// Median wall time of the scene's reference (s).
    pub reference_s: f64,
    /// Every `timeseries.csv` equal byte for byte to the reference's.
    pub identical: bool,
    /// Largest relative RMS difference of the compared column over the cases.
    pub difference: f64,
    pub failure: Option<String>,
}

struct Plan<'a> {
    name: &'a str,
    without: String,
    sets: Vec<String>,
    jobs: usize,
}

/// Runs every scene `repeats` times; `base` is the bench file's folder (scene paths are
/// relative to it), `dir` the bench output folder (runs go to `dir/skips-runs`, removed after).
pub fn run(
    scenes: &[SkipScene],
    base: &Path,
    repeats: usize,
    exe: &Path,
    dir: &Path,
) -> Result<Vec<SkipRun>, String> {
    let work = dir.join("skips-runs");
    let mut out = Vec::new();
    for scene in scenes {
        let file = base.join(&scene.pipeline);
        let mut plans = vec![Plan {
            name: "reference",
            without: String::new(),
            sets: scene.set.clone(),
            jobs: scene.jobs,
        }];
        for v in &scene.variants {
            let mut sets = scene.set.clone();
            sets.extend(v.set.iter().cloned());
            plans.push(Plan {
                name: &v.name,
                without: v.without.join(","),
                sets,
                jobs: v.jobs.unwrap_or(scene.jobs),
            });
        }
        let mut times = vec![Vec::new(); plans.len()];
        let mut series: Vec<Option<Vec<(PathBuf, String)>>> = vec![None; plans.len()];
        let mut failure: Vec<Option<String>> = vec![None; plans.len()];
        for rep in 0..repeats {
            for (k, plan) in plans.iter().enumerate() {
                if failure[k].is_some() {
                    continue;
                }
                let folder = work.join(&scene.name).join(format!("{}-{rep}", plan.name));
                let _ = std::fs::remove_dir_all(&folder);
                let t = Instant::now();
                let result = child(exe, &file, scene, plan, &folder);
                times[k].push(t.elapsed().as_secs_f64());
                match result {
                    Ok(()) if series[k].is_none() => series[k] = Some(timeseries(&folder)?),
                    Ok(()) => {}
                    Err(e) => failure[k] = Some(e),
                }
                let _ = std::fs::remove_dir_all(&folder);
            }
        }
        let medians: Vec<f64> = times.iter_mut().map(|t| median(t)).collect();
        for (k, plan) in plans.iter().enumerate() {
            let (identical, difference) = match (&series[0], &series[k]) {
                (Some(r), Some(v)) => compare(r, v, &scene.compare, scene.windows)?,
                _ => (false, f64::NAN),
            };
            let run = SkipRun {
                scene: scene.name.clone(),
                variant: plan.name.to_string(),
                without: plan.without.clone(),
                set: plan.sets[scene.set.len()..].join(" "),
                jobs: plan.jobs,
                wall_s: medians[k],
                reference_s: medians[0],
                identical,
                difference,
                failure: failure[k].clone(),
            };
            println!(
                "skips {:<14} {:<14} {:>8.3} s  × {:.2} of reference  {}  {}",
                run.scene,
                run.variant,
                run.wall_s,
                run.wall_s / run.reference_s,
                if run.identical {
                    "identical".to_string()
                } else {
                    format!("RMS difference {:.2e}", run.difference)
                },
                run.failure.as_deref().unwrap_or("")
            );
            out.push(run);
        }
    }
    let _ = std::fs::remove_dir_all(&work);
    Ok(out)
}

fn median(t: &mut [f64]) -> f64 {
    if t.is_empty() {
        return f64::NAN;
    }
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// One `pipeline run` of a plan into `folder`.
fn child(
    exe: &Path,
    file: &Path,
    scene: &SkipScene,
    plan: &Plan,
    folder: &Path,
) -> Result<(), String> {
    let mut cmd = Command::new(exe);
    cmd.args(["pipeline", "run"])
        .arg(file)
        .arg("--out")
        .arg(folder)
        .arg("--quiet")
        .arg("--jobs")
        .arg(plan.jobs.to_string())
        .env(crate::shortcuts::ENV, &plan.without);
    for s in &plan.sets {
        cmd.arg("--set").arg(s);
    }
    if let Some(stage) = &scene.until {
        cmd.arg("--until").arg(stage);
    }
    let out = cmd
        .output()
        .map_err(|e| format!("starting {}: {e}", exe.display()))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "exited with {}: {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// Every `timeseries.csv` under `folder`, by its path inside it, with its text.
fn timeseries(folder: &Path) -> Result<Vec<(PathBuf, String)>, String> {
    let mut found = Vec::new();
    let mut stack = vec![folder.to_path_buf()];
    while let Some(d) = stack.pop() {
        let entries = std::fs::read_dir(&d).map_err(|e| format!("{}: {e}", d.display()))?;
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().is_some_and(|n| n == "timeseries.csv") {
                let text =
                    std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?;
                let rel = p.strip_prefix(folder).unwrap_or(&p).to_path_buf();
                found.push((rel, text));
            }
        }
    }
    found.sort();
    Ok(found)
}

/// (all files identical, largest windowed RMS difference of `column` against `strain`).
fn compare(
    reference: &[(PathBuf, String)],
    variant: &[(PathBuf, String)],
    column: &str,
    windows: usize,
) -> Result<(bool, f64), String> {
    if reference.len() != variant.len() {
        return Ok((false, f64::NAN));
    }
    let mut identical = true;
    let mut worst = 0.0f64;
    for ((rp, rt), (vp, vt)) in reference.iter().zip(variant) {
        if rp != vp {
            return Ok((false, f64::NAN));
        }
        identical &= rt == vt;
        let (r, v) = (curve(rt, column, rp)?, curve(vt, column, vp)?);
        worst = worst.max(windowed_difference(&v, &r, windows));
    }
    Ok((identical, worst))
}

/// Mean of the values in each of `windows` equal strain windows of [0, top] (NaN if empty).
fn window_means(curve: &[[f64; 2]], top: f64, windows: usize) -> Vec<f64> {
    let mut sum = vec![(0.0, 0usize); windows];
    for &[e, x] in curve.iter().filter(|p| p[0] <= top) {
        let k = ((e / top * windows as f64) as usize).min(windows - 1);
        sum[k].0 += x;
        sum[k].1 += 1;
    }
    sum.iter().map(|&(s, n)| s / n as f64).collect()
}

/// RMS over `windows` equal strain windows of the reference's range of the difference of
/// the window means, over the RMS of the reference's means.
pub fn windowed_difference(curve: &[[f64; 2]], reference: &[[f64; 2]], windows: usize) -> f64 {
    let top = reference.last().map_or(0.0, |p| p[0]);
    let (r, v) = (
        window_means(reference, top, windows),
        window_means(curve, top, windows),
    );
    let (mut diff, mut norm) = (0.0, 0.0);
    for (r, v) in r.iter().zip(&v) {
        if r.is_finite() && v.is_finite() {
            diff += (v - r).powi(2);
            norm += r * r;
        }
    }
    (diff / norm).sqrt()
}

/// (strain, column) of a `timeseries.csv`.
fn curve(text: &str, column: &str, path: &Path) -> Result<Vec<[f64; 2]>, String> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let find = |name: &str| {
        header.iter().position(|h| *h == name).ok_or_else(|| {
            format!(
                "{}: no column `{name}` (it has {})",
                path.display(),
                header.join(", ")
            )
        })
    };
    let (e, c) = (find("strain")?, find(column)?);
    Ok(lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter_map(|f| Some([f.get(e)?.parse().ok()?, f.get(c)?.parse().ok()?]))
        .collect())
}

/// `skips.csv`.
pub fn csv(runs: &[SkipRun]) -> String {
    let mut out = String::from(
        "scene,variant,without,set,jobs,wall_s,reference_s,ratio_to_reference,identical,rms_difference,failure\n",
    );
    for r in runs {
        out += &format!(
            "{},{},{},{},{},{:.4},{:.4},{:.4},{},{:.3e},{}\n",
            r.scene,
            r.variant,
            r.without.replace(',', " "),
            r.set.replace(',', ";"),
            r.jobs,
            r.wall_s,
            r.reference_s,
            r.wall_s / r.reference_s,
            r.identical,
            r.difference,
            r.failure
                .as_deref()
                .unwrap_or("")
                .replace([',', '\n', '"'], " ")
        );
    }
    out
}
