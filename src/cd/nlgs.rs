//! Nonlinear Gauss-Seidel over the contacts (METHODS.md §1.5-1.6). Body velocities are kept
//! equal to V_free + M⁻¹ Σ Hᵀ P at all times, so one contact update costs O(1) and no
//! off-diagonal Delassus block is ever stored.

use super::anderson::Anderson;
use super::find;
use super::{Bodies, Contact, InteractionLaw, LawTable, PAR_MIN, Partner};
use crate::geom::{V2, perp};
use crate::rng::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Convergence settings. The norms are LMGC90's "QM/16": the quadratic norms below `tol`
/// and the max norms below 16.67 `tol`, checked every `check_every` sweeps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NlgsParams {
    pub tol: f64,
    pub check_every: u32,
    pub max_iter: u32,
    /// Relaxation ω of each local solve (projected SOR): the impulse moves ω times the
    /// Gauss-Seidel step from its old value and is projected back onto the law's admissible
    /// set. 1 is plain NLGS; the fixed point, hence the solution, is the same for any ω.
    pub relax: f64,
    /// Anderson acceleration's history depth m over blocks of `check_every` sweeps
    /// (`anderson.rs`); 0 = off, plain (or over-relaxed) NLGS.
    pub anderson: u32,
    /// Solve each connected component of the contact graph apart, with its own
    /// convergence test (`Islands`).
    pub islands: bool,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NlgsReport {
    /// Sweeps; with islands, local solves over contacts (each island sweeps until its own
    /// test passes), rounded up.
    pub iterations: u32,
    pub converged: bool,
    /// The largest of the scaled norms at the last check (≤ 1 when converged).
    pub residual: f64,
    /// Local solves done: Σ sweeps × contacts, over the islands.
    pub updates: u64,
}

/// Lever ℓ of the rolling impulse of a contact between disks of radii `ri` and `rj`
/// (`rj` = 0: a wall, ℓ = r_i).
#[inline(always)]
fn lever(ri: f64, rj: f64) -> f64 {
    if rj > 0.0 { ri * rj / (ri + rj) } else { ri }
}

/// 1/w, and 0 for w = 0 (`Row::m_nn`).
#[inline]
fn inverse(w: f64) -> f64 {
    debug_assert!(w >= 0.0, "a diagonal Delassus term {w}");
    if w > 0.0 { 1.0 / w } else { 0.0 }
}

/// Applies the impulse increment (dp_n, dp_t, dp_r) of contact `c` to its bodies.
#[inline]
fn apply(c: &Contact, b: &mut Bodies, dp_n: f64, dp_t: f64, dp_r: f64) {
    let i = c.i as usize;
    let p = dp_n * c.n + dp_t * perp(c.n);
    let rj = match c.j {
        Partner::Body(j) => b.radius[j as usize],
        Partner::Wall(_) => 0.0,
    };
    let m_r = lever(b.radius[i], rj) * dp_r;
    // (the moment in a separate sum: without rolling resistance it adds an exact zero)
    b.vel[i] += b.inv_mass[i] * p;
    b.omega[i] -= b.inv_inertia[i] * b.radius[i] * dp_t;
    b.omega[i] += b.inv_inertia[i] * m_r;
    if let Partner::Body(j) = c.j {
        let j = j as usize;
        b.vel[j] -= b.inv_mass[j] * p;
        b.omega[j] -= b.inv_inertia[j] * b.radius[j] * dp_t;
        b.omega[j] -= b.inv_inertia[j] * m_r;
    }
}

/// Applies the contacts' current impulses (the warm start) to the free velocities.
pub fn apply_all<'a>(contacts: impl IntoIterator<Item = &'a Contact>, b: &mut Bodies) {
    for c in contacts {
        apply(c, b, c.p_n, c.p_t, c.p_r);
    }
}

/// What the local solves share within one step.
pub struct StepData<'a, L> {
    pub laws: &'a LawTable<L>,
    /// Imposed wall velocities.
    pub wall_vel: &'a [V2],
    /// 1/(θh): turns an open gap into the normal velocity that closes it exactly at the
    /// end of the step (METHODS.md §1.4).
    pub gap_rate: f64,
    /// Frictionless contacts solve their normal impulse only (`shortcuts::Shortcuts`).
    pub skip_frictionless: bool,
}

/// A body as the sweeps see it, packed so that one local solve touches two cache lines:
/// velocity, spin, 1/m, r/I and r. Walls follow the disks as bodies with 1/m = r/I = r = 0
/// and their imposed velocity; they are read, never written.
#[derive(Clone, Copy, Debug)]
struct Dof {
    v: V2,
    w: f64,
    im: f64,
    ir: f64,
    r: f64,
}

/// A contact as the sweeps see it: its bodies in the packed array (`j` ≥ the number of disks
/// for a wall), its frame and diagonal Delassus terms, the gap shift max(g, 0)/(θh), its
/// impulses, and its index in the step's contact list for the write-back.
#[derive(Clone, Copy, Debug)]
struct Row {
    i: u32,
    j: u32,
    k: u32,
    /// Its slot in Anderson's vectors (its position when its solve started).
    slot: u32,
    law: u16,
    /// false: a frictionless contact whose tangential solve is skipped (p_t stays 0).
    frictional: bool,
    /// true: the law has rolling resistance (a third impulse, p_r).
    rolling: bool,
    n: V2,
    shift: f64,
    w_nn: f64,
    w_tt: f64,
    /// 1/W_nn and 1/W_tt, so that the local solve multiplies where it would divide; 0 where
    /// W is 0 (two bodies held fixed: the contact cannot move them and keeps its impulse).
    m_nn: f64,
    m_tt: f64,
    p_n: f64,
    p_t: f64,
    p_r: f64,
}

/// One local solve's impulses (p_n, p_t, p_r) before and after, and its diagonal Delassus
/// terms, for the convergence norms.
struct Update {
    old: [f64; 3],
    new: [f64; 3],
    w: [f64; 3],
}

/// What every local solve of a sweep reads besides its row: the packed bodies (a raw
/// pointer, so that the coloured sweep can run rows of one colour on several threads), the
/// number of disks (higher indices are walls), the laws and the relaxation ω.
struct Sweep<'a, L> {
    dofs: Shared,
    n_bodies: u32,
    laws: &'a LawTable<L>,
    relax: f64,
}

impl<L> Clone for Sweep<'_, L> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<L> Copy for Sweep<'_, L> {}

/// One local solve (METHODS.md §1.5) on packed data: (p_n, p_t), then the rolling impulse.
/// The caller guarantees that no other thread writes bodies `r.i`, `r.j` meanwhile.
///
/// # Safety
/// `s.dofs` points to at least max(r.i, r.j) + 1 valid bodies, and bodies `r.i` and (when
/// `r.j < s.n_bodies`) `r.j` are not accessed by another thread during the call.
#[inline(always)]
unsafe fn update_row<L: InteractionLaw>(r: &mut Row, s: Sweep<L>) -> Update {
    let old = [r.p_n, r.p_t, r.p_r];
    let (dofs, n_bodies) = (s.dofs.get(), s.n_bodies);
    // SAFETY: per the contract above.
    unsafe { update_contact(r, dofs, n_bodies, s.laws, s.relax) };
    let w_rr = if r.rolling {
        // SAFETY: as above.
        unsafe { update_rolling(r, s.laws.get(r.law).rolling(), dofs, n_bodies) }
    } else {
        0.0
    };
    Update {
        old,
        new: [r.p_n, r.p_t, r.p_r],
        w: [r.w_nn, r.w_tt, w_rr],
    }
}

/// Signorini and Coulomb together: the law's projection of the Gauss-Seidel trial impulse.
///
/// # Safety
/// As `update_row`.
#[inline(always)]
unsafe fn update_contact<L: InteractionLaw>(
    r: &mut Row,
    dofs: *mut Dof,
    n_bodies: u32,
    laws: &LawTable<L>,
    relax: f64,
) {
    // SAFETY: per the contract of `update_row`.
    let (bi, bj) = unsafe { (&mut *dofs.add(r.i as usize), *dofs.add(r.j as usize)) };
    let dv = bi.v - bj.v;
    // The Gauss-Seidel trial impulse p − W⁻¹ u (diagonal W, W_tn = 0 for disks), with the
    // gap-augmented normal velocity, projected onto the law's admissible set.
    let trial_n = r.p_n - r.m_nn * (dv.dot(&r.n) + r.shift);
    let law = laws.get(r.law);
    // p_old + ω (p_GS - p_old), projected; skipped at ω = 1.
    let relaxed = |new: (f64, f64), old: (f64, f64)| {
        if relax == 1.0 {
            new
        } else {
            law.project(
                old.0 + relax * (new.0 - old.0),
                old.1 + relax * (new.1 - old.1),
            )
        }
    };
    if !r.frictional {
        // μ = 0: p_t stays 0 and no spin changes, so only the normal row is solved.
        let p_n = law.project(trial_n, 0.0).0;
        let p_n = relaxed((p_n, 0.0), (r.p_n, 0.0)).0;
        let p = (p_n - r.p_n) * r.n;
        bi.v += bi.im * p;
        if r.j < n_bodies {
            // SAFETY: as above; j != i (a disk never touches itself).
            unsafe { (*dofs.add(r.j as usize)).v -= bj.im * p };
        }
        r.p_n = p_n;
        return;
    }
    let t = perp(r.n);
    let u_t = dv.dot(&t) - bi.r * bi.w - bj.r * bj.w;
    let gs = law.project(trial_n, r.p_t - r.m_tt * u_t);
    let (p_n, p_t) = relaxed(gs, (r.p_n, r.p_t));
    // SAFETY: per the contract of `update_row`.
    unsafe { move_impulse(r, dofs, n_bodies, p_n, p_t) };
}

/// Sets the contact's impulses to (p_n, p_t) and moves its bodies' velocities with them,
/// keeping V = V_free + M⁻¹ Σ Hᵀ P.
///
/// # Safety
/// As `update_row`.
#[inline(always)]
unsafe fn move_impulse(r: &mut Row, dofs: *mut Dof, n_bodies: u32, p_n: f64, p_t: f64) {
    let (dp_n, dp_t) = (p_n - r.p_n, p_t - r.p_t);
    let p = dp_n * r.n + dp_t * perp(r.n);
    // SAFETY: per the contract of `update_row`.
    let bi = unsafe { &mut *dofs.add(r.i as usize) };
    bi.v += bi.im * p;
    bi.w -= bi.ir * dp_t;
    if r.j < n_bodies {
        // SAFETY: as above; j != i (a disk never touches itself).
        let bj = unsafe { &mut *dofs.add(r.j as usize) };
        bj.v -= bj.im * p;
        bj.w -= bj.ir * dp_t;
    }
    r.p_n = p_n;
    r.p_t = p_t;
}

/// Rolling resistance (METHODS.md §1.10), solved after (p_n, p_t) as its own clamped
/// component: the rolling velocity u_r = ℓ (ω_i − ω_j) is stopped by an impulse p_r with
/// |p_r| ≤ μ_r p_n, i.e. a moment up to μ_r ℓ p_n/h. Returns W_rr = ℓ² (1/I_i + 1/I_j).
///
/// # Safety
/// As `update_row`.
#[inline(always)]
unsafe fn update_rolling(r: &mut Row, mu_r: f64, dofs: *mut Dof, n_bodies: u32) -> f64 {
    // SAFETY: per the contract of `update_row`; a wall (r.j ≥ n_bodies) is never written.
    let (bi, bj) = unsafe { (&mut *dofs.add(r.i as usize), *dofs.add(r.j as usize)) };
    // 1/I = (r/I)/r; a wall has r = 0 and does not turn.
    let inv_i = bi.ir / bi.r;
    let inv_j = if r.j < n_bodies { bj.ir / bj.r } else { 0.0 };
    let l = lever(bi.r, bj.r);
    let w_rr = l * l * (inv_i + inv_j);
    let hat_r = l * (bi.w - bj.w) - w_rr * r.p_r;
    let bound = mu_r * r.p_n;
    // W_rr = 0: neither body can turn (held fixed, or a fixed disk on a wall); the impulse
    // cannot act and stays as it is.
    let p_r = if w_rr > 0.0 {
        (-hat_r / w_rr).clamp(-bound, bound)
    } else {
        r.p_r
    };
    let m = l * (p_r - r.p_r);
    bi.w += inv_i * m;
    if r.j < n_bodies {
        // SAFETY: as above.
        let bj = unsafe { &mut *dofs.add(r.j as usize) };
        bj.w -= inv_j * m;
    }
    r.p_r = p_r;
    w_rr
}

/// A pointer to the packed bodies that may cross threads; see `update_row`.
#[derive(Clone, Copy)]
struct Shared(*mut Dof);
// SAFETY: the coloured sweep only hands rows of one colour (pairwise body-disjoint) to
// concurrent threads, and the islands' solves rows of different islands (no body in
// common), so no body is written by two threads or read while written.
unsafe impl Send for Shared {}
unsafe impl Sync for Shared {}

impl Shared {
    /// A method, not a field access: closures then capture the whole (Send) wrapper.
    #[inline(always)]
    fn get(self) -> *mut Dof {
        self.0
    }
}

/// Contacts solved at or above this count use the coloured sweep: rows are ordered by colour
/// of the contact conflict graph (contacts sharing a disk get different colours) and the
/// rows of one colour are solved in parallel (METHODS.md §1.11). The order depends only on
/// the data and the seeded shuffle, never on the thread count, so results are deterministic.
/// On two cores it pays only for large solves: half the sequential sweep's updates per second
/// at 11,000 contacts (a 3000-disk deposit), 0.67 at about 20,000 (a `paper-coarse.yaml`
/// compaction, which also needs more sweeps in colour order), 1.3 times at 60,000-80,000 (a
/// 30,000-disk deposit); `bench/README-performance.md`.
pub const COLOURED_MIN: usize = 32768;
/// Rows per parallel task, and per partial sum of the convergence norms (a fixed chunking
/// keeps the sums' rounding independent of the thread count).
const CHUNK: usize = 1024;

/// The solve's working arrays, kept by the scene from step to step so that a step
/// allocates none of them (their contents are rebuilt by every solve).
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    dofs: Vec<Dof>,
    rows: Vec<Row>,
    anderson: Anderson,
    islands: Islands,
}

/// Solves for the impulses of the contacts listed in `order` (the others keep theirs),
/// sweeping them in an order shuffled before each check block (coloured: once per step).
/// With `params.islands`, each connected component of the contact graph is solved apart.
pub fn solve<L: InteractionLaw>(
    contacts: &mut [Contact],
    b: &mut Bodies,
    data: &StepData<L>,
    params: &NlgsParams,
    order: &mut [u32],
    rng: &mut Rng,
    scratch: &mut Scratch,
) -> NlgsReport {
    if order.is_empty() {
        return NlgsReport {
            converged: true,
            ..NlgsReport::default()
        };
    }
    let nb = b.len() as u32;
    let Scratch {
        dofs,
        rows,
        anderson,
        islands,
    } = scratch;
    dofs.clear();
    dofs.extend(
        (0..b.len())
            .map(|i| Dof {
                v: b.vel[i],
                w: b.omega[i],
                im: b.inv_mass[i],
                ir: b.inv_inertia[i] * b.radius[i],
                r: b.radius[i],
            })
            .chain(data.wall_vel.iter().map(|&v| Dof {
                v,
                w: 0.0,
                im: 0.0,
                ir: 0.0,
                r: 0.0,
            })),
    );
    rows.clear();
    rows.extend(order.iter().map(|&k| {
        let c = &contacts[k as usize];
        Row {
            i: c.i,
            j: match c.j {
                Partner::Body(j) => j,
                Partner::Wall(w) => nb + w,
            },
            k,
            slot: 0,
            law: c.law,
            frictional: !data.skip_frictionless || data.laws.get(c.law).friction() > 0.0,
            rolling: data.laws.get(c.law).rolling() > 0.0,
            n: c.n,
            shift: c.gap.max(0.0) * data.gap_rate,
            w_nn: c.w_nn,
            w_tt: c.w_tt,
            m_nn: inverse(c.w_nn),
            m_tt: inverse(c.w_tt),
            p_n: c.p_n,
            p_t: c.p_t,
            p_r: c.p_r,
        }
    }));
    let sweep = Sweep {
        dofs: Shared(dofs.as_mut_ptr()),
        n_bodies: nb,
        laws: data.laws,
        relax: params.relax,
    };
    let report = if params.islands && islands.group(rows, b.len()) > 1 {
        islands.solve(rows, sweep, params, rng)
    } else {
        solve_rows(rows, sweep, params, rng, anderson)
    };
    for (slot, r) in order.iter_mut().zip(rows.iter()) {
        *slot = r.k;
        let c = &mut contacts[r.k as usize];
        c.p_n = r.p_n;
        c.p_t = r.p_t;
        c.p_r = r.p_r;
    }
    for (i, d) in dofs[..b.len()].iter().enumerate() {
        b.vel[i] = d.v;
        b.omega[i] = d.w;
    }
    report
}

/// Blocks of `check_every` sweeps over `rows` until their QM/16 norms pass, each block
/// shuffled (coloured: once) and, with Anderson, extrapolated. The caller guarantees that no
/// other thread touches the bodies of `rows` meanwhile.
fn solve_rows<L: InteractionLaw>(
    rows: &mut [Row],
    sweep: Sweep<L>,
    params: &NlgsParams,
    rng: &mut Rng,
    anderson: &mut Anderson,
) -> NlgsReport {
    let mut report = NlgsReport::default();
    let coloured = rows.len() >= COLOURED_MIN;
    let mut colouring = Colouring::default();
    for (s, r) in rows.iter_mut().enumerate() {
        r.slot = s as u32;
    }
    // Rolling resistance's third impulse is left out of the accelerated vector, so the
    // acceleration is used only without it.
    let mut anderson = (params.anderson > 0 && !rows.iter().any(|r| r.rolling)).then(|| {
        anderson.reset(
            params.anderson as usize,
            rows.iter().map(|r| (r.w_nn, r.w_tt, r.frictional)),
        );
        anderson
    });
    let mut first = true;
    loop {
        if let Some(a) = anderson.as_mut() {
            a.begin(rows.iter().map(|r| (r.slot as usize, r.p_n, r.p_t)));
        }
        // Shuffling the rows themselves draws the same numbers as shuffling `order` and keeps
        // the sweep's reads of the rows sequential. The coloured sweep shuffles and colours
        // once per step: for 10⁵ contacts both cost more than the sweeps they would reorder.
        if !coloured || first {
            rng.shuffle(rows);
            if coloured {
                colouring.sort(rows, sweep.n_bodies as usize);
            }
        }
        first = false;
        let sweeps = params.check_every.max(1);
        for _ in 1..sweeps {
            if coloured {
                colouring.sweep(rows, sweep);
            } else {
                for r in rows.iter_mut() {
                    // SAFETY: one thread on these rows' bodies; every index is within `dofs`.
                    unsafe { update_row(r, sweep) };
                }
            }
        }
        let norms = if coloured {
            colouring.check_sweep(rows, sweep)
        } else {
            let mut norms = Norms::default();
            for r in rows.iter_mut() {
                // SAFETY: as above.
                norms.add(unsafe { update_row(r, sweep) });
            }
            norms
        };
        report.iterations += sweeps;
        report.residual = norms.residual(params.tol);
        if report.residual <= 1.0 {
            report.converged = true;
            break;
        }
        if report.iterations >= params.max_iter {
            break;
        }
        if let Some(a) = anderson.as_mut()
            && let Some(x) = a.next(rows.iter().map(|r| (r.slot as usize, r.p_n, r.p_t)))
        {
            for r in rows.iter_mut() {
                let (p_n, p_t) = x(r.slot as usize);
                let (p_n, p_t) = sweep.laws.get(r.law).project(p_n, p_t);
                let p_t = if r.frictional { p_t } else { 0.0 };
                // SAFETY: as above.
                unsafe { move_impulse(r, sweep.dofs.get(), sweep.n_bodies, p_n, p_t) };
            }
        }
    }
    report.updates = u64::from(report.iterations) * rows.len() as u64;
    report
}

/// The connected components ("islands") of the contact graph, bodies joined by their
/// contacts (walls join nothing: they are never written). Islands share no body, so each
/// is solved apart, with its own convergence test: an island at rest stops after one
/// block while another still converges, where one test over all contacts would sweep every
/// island as long as the slowest. Islands are numbered in the order of their first row and
/// each shuffles with its own generator, seeded from the step's in that order, so results
/// do not depend on the number of threads.
#[derive(Clone, Debug, Default)]
struct Islands {
    /// Union-find forest over the bodies.
    parent: Vec<u32>,
    /// Island of each root body (`u32::MAX`: none yet).
    label: Vec<u32>,
    /// Island of each row.
    of_row: Vec<u32>,
    /// `bounds[k]..bounds[k + 1]`: the rows of island k once grouped.
    bounds: Vec<usize>,
    sorted: Vec<Row>,
    anderson: Vec<Anderson>,
}

impl Islands {
    /// Groups `rows` island by island (stable within an island) and returns the number of
    /// islands.
    fn group(&mut self, rows: &mut [Row], n_bodies: usize) -> usize {
        self.parent.clear();
        self.parent.extend(0..n_bodies as u32);
        for r in rows.iter() {
            if (r.j as usize) < n_bodies {
                let a = find(&mut self.parent, r.i);
                let b = find(&mut self.parent, r.j);
                self.parent[a.max(b) as usize] = a.min(b);
            }
        }
        self.label.clear();
        self.label.resize(n_bodies, u32::MAX);
        self.of_row.clear();
        let mut count = 0u32;
        for r in rows.iter() {
            let root = find(&mut self.parent, r.i) as usize;
            if self.label[root] == u32::MAX {
                self.label[root] = count;
                count += 1;
            }
            self.of_row.push(self.label[root]);
        }
        let n = count as usize;
        if n > 1 {
            let class = self.of_row.iter().map(|&k| k as usize);
            sort_by_class(rows, n, class, &mut self.bounds, &mut self.sorted);
        }
        n
    }

    /// Solves the islands of grouped `rows`, in parallel when there are enough rows to pay
    /// for it. The report's sweeps are the work's: local solves over contacts, rounded up.
    fn solve<L: InteractionLaw>(
        &mut self,
        rows: &mut [Row],
        sweep: Sweep<L>,
        params: &NlgsParams,
        rng: &mut Rng,
    ) -> NlgsReport {
        let (n, total) = (self.bounds.len() - 1, rows.len());
        let seeds: Vec<u64> = (0..n).map(|_| rng.next_u64()).collect();
        self.anderson.resize_with(n, Anderson::default);
        let mut parts = Vec::with_capacity(n);
        let mut rest = rows;
        for k in 0..n {
            let (part, tail) = rest.split_at_mut(self.bounds[k + 1] - self.bounds[k]);
            parts.push(part);
            rest = tail;
        }
        let one = |((part, anderson), seed): ((&mut [Row], &mut Anderson), u64)| {
            solve_rows(part, sweep, params, &mut Rng::new(seed), anderson)
        };
        let work = parts.into_iter().zip(self.anderson.iter_mut()).zip(seeds);
        let reports: Vec<NlgsReport> = if total < PAR_MIN {
            work.map(one).collect()
        } else {
            work.collect::<Vec<_>>().into_par_iter().map(one).collect()
        };
        let mut report = NlgsReport {
            converged: true,
            ..NlgsReport::default()
        };
        for r in reports {
            report.converged &= r.converged;
            report.residual = report.residual.max(r.residual);
            report.updates += r.updates;
        }
        report.iterations = report.updates.div_ceil(total as u64) as u32;
        report
    }
}

/// Stable counting sort of `rows` by class (`classes` gives each row's, all below `n`):
/// `bounds[c]..bounds[c + 1]` are then the rows of class c. `scratch` holds a copy.
fn sort_by_class(
    rows: &mut [Row],
    n: usize,
    classes: impl Iterator<Item = usize> + Clone,
    bounds: &mut Vec<usize>,
    scratch: &mut Vec<Row>,
) {
    bounds.clear();
    bounds.resize(n + 1, 0);
    for c in classes.clone() {
        bounds[c + 1] += 1;
    }
    for c in 0..n {
        bounds[c + 1] += bounds[c];
    }
    let mut fill = bounds.clone();
    scratch.clear();
    scratch.extend_from_slice(rows);
    for (r, c) in scratch.iter().zip(classes) {
        rows[fill[c]] = *r;
        fill[c] += 1;
    }
}

/// Greedy colouring of the contact conflict graph in the (shuffled) row order: each row gets
/// the smallest colour not yet used at either of its disks (walls are never written, so they
/// do not conflict). Rows are then stably sorted by colour.
#[derive(Default)]
struct Colouring {
    /// Colours used at each disk, as bits; rows that find all 64 taken go to a last class
    /// swept on one thread.
    used: Vec<u64>,
    colour: Vec<u8>,
    /// `bounds[c]..bounds[c + 1]` are the rows of colour c.
    bounds: Vec<usize>,
    scratch: Vec<Row>,
}

impl Colouring {
    const SERIAL: u8 = 64;

    fn sort(&mut self, rows: &mut [Row], n_bodies: usize) {
        self.used.clear();
        self.used.resize(n_bodies, 0);
        self.colour.clear();
        for r in rows.iter() {
            let mut mask = self.used[r.i as usize];
            let j = r.j as usize;
            if j < n_bodies {
                mask |= self.used[j];
            }
            let c = (!mask).trailing_zeros().min(64) as u8;
            if c < Self::SERIAL {
                self.used[r.i as usize] |= 1 << c;
                if j < n_bodies {
                    self.used[j] |= 1 << c;
                }
            }
            self.colour.push(c);
        }
        let class = self.colour.iter().map(|&c| c as usize);
        sort_by_class(rows, 65, class, &mut self.bounds, &mut self.scratch);
    }

    fn classes(&self) -> impl Iterator<Item = (usize, std::ops::Range<usize>)> + '_ {
        (0..65)
            .map(|c| (c, self.bounds[c]..self.bounds[c + 1]))
            .filter(|(_, r)| !r.is_empty())
    }

    fn sweep<L: InteractionLaw>(&self, rows: &mut [Row], sweep: Sweep<L>) {
        for (c, range) in self.classes() {
            let class = &mut rows[range];
            if c == Self::SERIAL as usize || class.len() <= CHUNK {
                for r in class.iter_mut() {
                    // SAFETY: one thread at a time here.
                    unsafe { update_row(r, sweep) };
                }
            } else {
                class.par_chunks_mut(CHUNK).for_each(|chunk| {
                    for r in chunk.iter_mut() {
                        // SAFETY: rows of one colour share no disk.
                        unsafe { update_row(r, sweep) };
                    }
                });
            }
        }
    }

    fn check_sweep<L: InteractionLaw>(&self, rows: &mut [Row], sweep: Sweep<L>) -> Norms {
        let mut total = Norms::default();
        for (c, range) in self.classes() {
            let class = &mut rows[range];
            let partial = |chunk: &mut [Row]| {
                let mut norms = Norms::default();
                for r in chunk.iter_mut() {
                    // SAFETY: rows of one colour share no disk (or run on one thread).
                    norms.add(unsafe { update_row(r, sweep) });
                }
                norms
            };
            let parts: Vec<Norms> = if c == Self::SERIAL as usize || class.len() <= CHUNK {
                class.chunks_mut(CHUNK).map(partial).collect()
            } else {
                class.par_chunks_mut(CHUNK).map(partial).collect()
            };
            for p in parts {
                total.merge(&p);
            }
        }
        total
    }
}

/// LMGC90's scaled norms (METHODS.md §1.6), accumulated over the check sweep.
#[derive(Default)]
struct Norms {
    active: usize,
    sum_du2: f64,
    max_du: f64,
    sum_wp2: f64,
    sum_du2_p2: f64,
    max_du_p: f64,
    sum_du_p: f64,
    sum_e: f64,
}

impl Norms {
    fn merge(&mut self, o: &Norms) {
        self.active += o.active;
        self.sum_du2 += o.sum_du2;
        self.max_du = self.max_du.max(o.max_du);
        self.sum_wp2 += o.sum_wp2;
        self.sum_du2_p2 += o.sum_du2_p2;
        self.max_du_p = self.max_du_p.max(o.max_du_p);
        self.sum_du_p += o.sum_du_p;
        self.sum_e += o.sum_e;
    }

    /// Sums in the order of the two-component norms, the rolling terms after their kind:
    /// without rolling resistance they add exact zeros and the norms keep their bits.
    #[inline(always)]
    fn add(&mut self, u: Update) {
        let Update { old: o, new: n, w } = u;
        if o == [0.0; 3] && n == [0.0; 3] {
            return;
        }
        self.active += 1;
        let du = [
            w[0] * (n[0] - o[0]),
            w[1] * (n[1] - o[1]),
            w[2] * (n[2] - o[2]),
        ];
        let pm = [
            0.5 * (n[0] + o[0]),
            0.5 * (n[1] + o[1]),
            0.5 * (n[2] + o[2]),
        ];
        let du2 = du[0] * du[0] + du[1] * du[1] + du[2] * du[2];
        let pm2 = pm[0] * pm[0] + pm[1] * pm[1] + pm[2] * pm[2];
        let (wn, wo) = (
            [w[0] * n[0], w[1] * n[1], w[2] * n[2]],
            [w[0] * o[0], w[1] * o[1], w[2] * o[2]],
        );
        self.sum_du2 += du2;
        self.max_du = self.max_du.max(du2.sqrt());
        self.sum_wp2 += 0.5
            * (wn[0] * wn[0]
                + wn[1] * wn[1]
                + wn[2] * wn[2]
                + wo[0] * wo[0]
                + wo[1] * wo[1]
                + wo[2] * wo[2]);
        self.sum_du2_p2 += du2 * pm2;
        self.max_du_p = self.max_du_p.max((du2 * pm2).sqrt());
        self.sum_du_p += du[0] * pm[0] + du[1] * pm[1] + du[2] * pm[2];
        self.sum_e += 0.5
            * (n[0] * wn[0]
                + n[1] * wn[1]
                + n[2] * wn[2]
                + o[0] * wo[0]
                + o[1] * wo[1]
                + o[2] * wo[2]);
    }

    /// max(QuadDV, QuadDVR, |MeanDVoR|, MaxDV/16.67, MaxDVR/16.67), each already divided
    /// by `tol`: the QM/16 test passes when this is ≤ 1.
    fn residual(&self, tol: f64) -> f64 {
        if self.active == 0 || self.sum_e <= 0.0 {
            return 0.0;
        }
        let na = self.active as f64;
        let qwr = (self.sum_wp2 / na).sqrt();
        let e_mean = self.sum_e / na;
        let quad_dv = (self.sum_du2 / na).sqrt() / qwr;
        let max_dv = self.max_du / qwr;
        let quad_dvr = (self.sum_du2_p2 / na).sqrt() / e_mean;
        let max_dvr = self.max_du_p / e_mean;
        let mean_dvor = (self.sum_du_p / self.sum_e).abs();
        let max_factor = 16.67;
        [
            quad_dv,
            quad_dvr,
            mean_dvor,
            max_dv / max_factor,
            max_dvr / max_factor,
        ]
        .into_iter()
        .fold(0.0, f64::max)
            / tol
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(i: u32, j: u32) -> Row {
        Row {
            i,
            j,
            k: 0,
            slot: 0,
            law: 0,
            frictional: true,
            rolling: false,
            n: V2::new(0.0, 1.0),
            shift: 0.0,
            w_nn: 1.0,
            w_tt: 1.0,
            m_nn: 1.0,
            m_tt: 1.0,
            p_n: 0.0,
            p_t: 0.0,
            p_r: 0.0,
        }
    }

    /// Friction and rolling resistance, for the fixed-bodies test.
    struct Rolling;
    impl InteractionLaw for Rolling {
        fn friction(&self) -> f64 {
            0.5
        }
        fn rolling(&self) -> f64 {
            0.1
        }
    }

    #[test]
    fn a_contact_between_bodies_held_fixed_keeps_its_impulses_and_stays_finite() {
        // two disks held fixed (1/m = r/I = 0), touching: W = 0 in every component
        let fixed = Dof {
            v: V2::zeros(),
            w: 0.0,
            im: 0.0,
            ir: 0.0,
            r: 1e-3,
        };
        let mut dofs = [fixed, fixed];
        let mut r = row(0, 1);
        (r.w_nn, r.w_tt, r.m_nn, r.m_tt) = (0.0, 0.0, inverse(0.0), inverse(0.0));
        (r.rolling, r.shift, r.p_n, r.p_t, r.p_r) = (true, 0.5, 2.0, 0.3, 0.01);
        let laws = LawTable::new(Rolling, Rolling, vec![]);
        let sweep = Sweep {
            dofs: Shared(dofs.as_mut_ptr()),
            n_bodies: 2,
            laws: &laws,
            relax: 1.0,
        };
        // SAFETY: one thread; bodies 0 and 1 exist.
        let u = unsafe { update_row(&mut r, sweep) };
        assert_eq!(u.new, [2.0, 0.3, 0.01]);
        for d in dofs {
            assert_eq!((d.v, d.w), (V2::zeros(), 0.0));
        }
    }

    #[test]
    fn islands_join_bodies_through_contacts_and_never_through_walls() {
        // 8 disks, index 8 a wall: 0-1-2 a chain, 3-4 a pair, 5, 6 and 7 each on the wall
        let pairs = [(0, 1), (3, 4), (5, 8), (1, 2), (6, 8), (7, 8), (4, 3)];
        let mut rows: Vec<Row> = pairs.iter().map(|&(i, j)| row(i, j)).collect();
        let mut islands = Islands::default();
        assert_eq!(islands.group(&mut rows, 8), 5);
        // numbered by first row, each island's rows in their former order
        assert_eq!(islands.bounds, [0, 2, 4, 5, 6, 7]);
        let grouped: Vec<(u32, u32)> = rows.iter().map(|r| (r.i, r.j)).collect();
        assert_eq!(
            grouped,
            [(0, 1), (1, 2), (3, 4), (4, 3), (5, 8), (6, 8), (7, 8)]
        );
    }
}
