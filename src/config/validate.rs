//! Range checks that the types cannot express. The first failure is returned as
//! (dotted key, value, what is allowed).

use super::schema::*;

type Failure = (String, String, String);

fn fail(key: &str, value: impl std::fmt::Debug, allowed: &str) -> Result<(), Failure> {
    Err((key.to_string(), format!("{value:?}"), allowed.to_string()))
}

fn positive(key: &str, v: f64) -> Result<(), Failure> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        fail(key, v, "must be a finite number > 0")
    }
}

fn non_negative(key: &str, v: f64) -> Result<(), Failure> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        fail(key, v, "must be a finite number >= 0")
    }
}

fn range(key: &str, r: [f64; 2]) -> Result<(), Failure> {
    if r.iter().all(|x| x.is_finite() && *x > 0.0) && r[0] <= r[1] {
        Ok(())
    } else {
        fail(key, r, "must be [min, max] with 0 < min <= max")
    }
}

fn required<T>(key: &str, v: &Option<T>, layout: &str) -> Result<(), Failure> {
    if v.is_some() {
        Ok(())
    } else {
        Err((
            key.into(),
            "missing".into(),
            format!("required by layout {layout}"),
        ))
    }
}

pub fn check(p: &Pipeline) -> Result<(), Failure> {
    if p.name.is_empty() || p.name.contains(['/', '\\']) || p.name.starts_with('.') {
        fail(
            "name",
            &p.name,
            "must be a non-empty folder name without / or a leading dot",
        )?;
    }
    prepare(&p.prepare)?;
    solver(&p.solver, "solver")?;
    if p.compact.as_ref().is_some_and(|c| c.solver.is_some()) {
        let methods = p.discretise.as_ref().map(|d| d.method.to_vec());
        if !methods.as_ref().is_some_and(|m| m.contains(&Method::Bpm)) {
            fail(
                "compact.solver",
                methods.unwrap_or_default(),
                "applies to BPM compactions only (discretise.method has no bpm; the MPM grain contact has its own solver)",
            )?;
        }
        solver(&p.compact_solver(), "compact.solver")?;
    }
    if let Some(d) = &p.discretise {
        discretise(d)?;
        bpm_fits(p, d)?;
        // the rolling impulse is not in Anderson's accelerated vector (`cd/anderson.rs`)
        if d.bpm.as_ref().is_some_and(|b| b.rolling_resistance > 0.0) {
            for (key, s) in [
                ("solver", &p.solver),
                ("compact.solver", &p.compact_solver()),
            ] {
                if s.anderson > 0 {
                    fail(
                        &format!("{key}.anderson"),
                        s.anderson,
                        "must be 0 with discretise.bpm.rolling_resistance > 0",
                    )?;
                }
            }
        }
    }
    if let Some(c) = &p.compact {
        positive("compact.wall_velocity", c.wall_velocity)?;
        if !(c.initial_phi > 0.0 && c.initial_phi < 1.0) {
            fail("compact.initial_phi", c.initial_phi, "must be in (0, 1)")?;
        }
        if !(c.final_strain > 0.0 && c.final_strain < 1.0) {
            fail("compact.final_strain", c.final_strain, "must be in (0, 1)")?;
        }
        for mu in c.friction.to_vec() {
            non_negative("compact.friction", mu)?;
        }
        non_negative("compact.wall_friction", c.wall_friction)?;
        non_negative("compact.gravity", c.gravity)?;
        if let Some(dt) = c.time_step {
            positive("compact.time_step", dt)?;
        }
        if let Some(t) = c.newton_tolerance {
            if !(t > 0.0 && t < 1.0) {
                fail("compact.newton_tolerance", t, "must be in (0, 1)")?;
            }
            let has_mpm = p
                .discretise
                .as_ref()
                .is_some_and(|d| d.method.to_vec().contains(&Method::Mpm));
            if !has_mpm {
                fail(
                    "compact.newton_tolerance",
                    t,
                    "applies to MPM grains only (discretise.method has no mpm)",
                )?;
            }
        }
    }
    if let Some(a) = &p.analyse {
        analyse(a)?;
    }
    Ok(())
}

/// A [min, max] range inside (lo, hi).
fn within(key: &str, r: [f64; 2], lo: f64, hi: f64) -> Result<(), Failure> {
    if r.iter().all(|x| (lo..=hi).contains(x)) && r[0] < r[1] {
        Ok(())
    } else {
        fail(
            key,
            r,
            &format!("must be [min, max] with {lo} <= min < max <= {hi}"),
        )
    }
}

fn analyse(a: &Analyse) -> Result<(), Failure> {
    if !(a.phi0 > 0.0 && a.phi0 < 1.0) {
        fail("analyse.phi0", a.phi0, "must be in (0, 1)")?;
    }
    within("analyse.eq14_phi", a.eq14_phi, 0.0, 1.0)?;
    within("analyse.eq16_phi", a.eq16_phi, 0.0, 1.0)?;
    if !(a.jamming_fraction > 0.0 && a.jamming_fraction < 1.0) {
        fail(
            "analyse.jamming_fraction",
            a.jamming_fraction,
            "must be in (0, 1)",
        )?;
    }
    if !(a.small_strain > 0.0 && a.small_strain < 1.0) {
        fail("analyse.small_strain", a.small_strain, "must be in (0, 1)")?;
    }
    within("analyse.plateau_strain", a.plateau_strain, 0.0, 10.0)?;
    if !(a.final_window > 0.0 && a.final_window < 1.0) {
        fail("analyse.final_window", a.final_window, "must be in (0, 1)")?;
    }
    Ok(())
}

fn prepare(p: &Prepare) -> Result<(), Failure> {
    non_negative("prepare.friction", p.friction)?;
    non_negative("prepare.wall_friction", p.wall_friction)?;
    non_negative("prepare.gravity", p.gravity)?;
    positive("prepare.density", p.density)?;
    positive("prepare.rest_tolerance", p.rest_tolerance)?;
    positive("prepare.max_time", p.max_time)?;
    if let Some(s) = &p.separation {
        positive("prepare.separation.at", s.at)?;
        if let Some(t) = s.tolerance {
            positive("prepare.separation.tolerance", t)?;
        }
        if p.layout != Layout::Packing {
            fail(
                "prepare.separation.at",
                s.at,
                "applies to the packing layout only",
            )?;
        }
    }
    if let Some(s) = &p.sleep {
        positive("prepare.sleep.speed", s.speed)?;
        non_negative("prepare.sleep.time", s.time)?;
    }
    if let Some(dt) = p.time_step {
        positive("prepare.time_step", dt)?;
    }
    match p.layout {
        Layout::Packing => {
            required("prepare.grains", &p.grains, "packing")?;
            required("prepare.diameter", &p.diameter, "packing")?;
            let n = p.grains.unwrap_or(0);
            if !(1..=1_000_000).contains(&n) {
                fail("prepare.grains", n, "must be between 1 and 1000000")?;
            }
            let dia = p.diameter.unwrap_or([0.0; 2]);
            range("prepare.diameter", dia)?;
            if let Some(w) = p.box_width {
                positive("prepare.box_width", w)?;
                if w < dia[1] {
                    fail(
                        "prepare.box_width",
                        w,
                        "must be wider than the largest diameter",
                    )?;
                }
            }
            if p.gravity == 0.0 {
                fail("prepare.gravity", p.gravity, "must be > 0 for a deposit")?;
            }
        }
        Layout::Single => {
            required("prepare.radius", &p.radius, "single")?;
            positive("prepare.radius", p.radius.unwrap_or(0.0))?;
        }
        Layout::Explicit => {
            if p.bodies.is_empty() {
                fail(
                    "prepare.bodies",
                    "[]",
                    "the explicit layout needs at least one disk",
                )?;
            }
            for (k, b) in p.bodies.iter().enumerate() {
                positive(&format!("prepare.bodies.{k}.radius"), b.radius)?;
            }
            for (k, w) in p.walls.iter().enumerate() {
                if w.from == w.to {
                    fail(
                        &format!("prepare.walls.{k}.to"),
                        w.to,
                        "must differ from `from`",
                    )?;
                }
            }
            required("prepare.duration", &p.duration, "explicit")?;
            positive("prepare.duration", p.duration.unwrap_or(0.0))?;
            if p.incline_angle.is_nan() || p.incline_angle.abs() >= 90.0 {
                fail(
                    "prepare.incline_angle",
                    p.incline_angle,
                    "must be in (-90, 90) degrees",
                )?;
            }
        }
    }
    Ok(())
}

/// The solver settings `s`, named `<section>.<key>` in errors (`solver`, or a stage's
/// override with the pipeline's `solver` under it).
fn solver(s: &Solver, section: &str) -> Result<(), Failure> {
    let key = |k: &str| format!("{section}.{k}");
    if !(0.5..=1.0).contains(&s.theta) {
        fail(&key("theta"), s.theta, "must be in [0.5, 1]")?;
    }
    positive(&key("tolerance"), s.tolerance)?;
    if s.check_every == 0 {
        fail(&key("check_every"), s.check_every, "must be >= 1")?;
    }
    if s.max_iterations < s.check_every {
        fail(
            &key("max_iterations"),
            s.max_iterations,
            &format!("must be >= {}", key("check_every")),
        )?;
    }
    if !(s.relaxation > 0.0 && s.relaxation < 2.0) {
        fail(&key("relaxation"), s.relaxation, "must be in (0, 2)")?;
    }
    if s.anderson > 16 {
        fail(&key("anderson"), s.anderson, "must be in 0..=16")?;
    }
    positive(&key("alert"), s.alert)?;
    non_negative(&key("skin"), s.skin)
}

/// The BPM particles must fit their grains, and the compaction step must be below the
/// stability limit of the explicit attraction (0.5 t0, METHODS.md §1.9).
fn bpm_fits(p: &Pipeline, d: &Discretise) -> Result<(), Failure> {
    let Some(b) = d
        .bpm
        .as_ref()
        .filter(|_| d.method.to_vec().contains(&Method::Bpm))
    else {
        return Ok(());
    };
    let ranges = b.particle_diameter.to_vec();
    let d_max = ranges.iter().map(|r| r[1]).fold(0.0, f64::max);
    let d_min = ranges.iter().map(|r| r[0]).fold(f64::INFINITY, f64::min);
    let smallest_grain = match p.prepare.layout {
        Layout::Single => p.prepare.radius.unwrap_or(0.0),
        Layout::Packing => 0.5 * p.prepare.diameter.map_or(0.0, |r| r[0]),
        Layout::Explicit => p
            .prepare
            .bodies
            .iter()
            .map(|b| b.radius)
            .fold(f64::INFINITY, f64::min),
    };
    if smallest_grain < 2.0 * d_max {
        fail(
            "discretise.bpm.particle_diameter",
            ranges,
            &format!(
                "particles up to {d_max} m do not fit the smallest grain (radius {smallest_grain} m): need grain radius >= 2 d_max"
            ),
        )?;
    }
    if let Some(dt) = p.compact.as_ref().and_then(|c| c.time_step) {
        let r = 0.5 * d_min;
        let t0 = (b.density * std::f64::consts::PI * r * r * 2.0 * r / b.f0).sqrt();
        if dt > 0.5 * t0 {
            fail(
                "compact.time_step",
                dt,
                &format!(
                    "must be <= 0.5 t0 = {:.3e} s, the stability limit of the BPM attraction (t0 = sqrt(m a0/F0) of the smallest particle)",
                    0.5 * t0
                ),
            )?;
        }
    }
    Ok(())
}

fn discretise(d: &Discretise) -> Result<(), Failure> {
    let methods = d.method.to_vec();
    if methods.contains(&Method::Bpm) {
        let Some(b) = &d.bpm else {
            return fail("discretise.bpm", "missing", "required by method bpm");
        };
        for r in b.particle_diameter.to_vec() {
            range("discretise.bpm.particle_diameter", r)?;
        }
        positive("discretise.bpm.f0", b.f0)?;
        positive("discretise.bpm.gamma", b.gamma)?;
        positive("discretise.bpm.cutoff", b.cutoff)?;
        non_negative("discretise.bpm.rolling_resistance", b.rolling_resistance)?;
        positive("discretise.bpm.density", b.density)?;
    }
    if methods.contains(&Method::Mpm) {
        let Some(m) = &d.mpm else {
            return fail("discretise.mpm", "missing", "required by method mpm");
        };
        positive("discretise.mpm.young", m.young)?;
        if !(m.poisson > -1.0 && m.poisson < 0.5) {
            fail("discretise.mpm.poisson", m.poisson, "must be in (-1, 0.5)")?;
        }
        positive("discretise.mpm.density", m.density)?;
        if !(m.resolution > 0.0 && m.resolution <= 0.5) {
            fail(
                "discretise.mpm.resolution",
                m.resolution,
                "must be in (0, 0.5]",
            )?;
        }
    }
    Ok(())
}
