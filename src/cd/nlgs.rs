//! Nonlinear Gauss-Seidel over the contacts (METHODS.md §1.5-1.6). Body velocities are kept
//! equal to V_free + M⁻¹ Σ Hᵀ P at all times, so one contact update costs O(1) and no
//! off-diagonal Delassus block is ever stored.

use super::{Bodies, Contact, InteractionLaw, LawTable, Partner};
use crate::geom::{V2, perp};
use crate::rng::Rng;
use serde::{Deserialize, Serialize};

/// Convergence settings. The norms are LMGC90's "QM/16": the quadratic norms below `tol`
/// and the max norms below 16.67 `tol`, checked every `check_every` sweeps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NlgsParams {
    pub tol: f64,
    pub check_every: u32,
    pub max_iter: u32,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NlgsReport {
    pub iterations: u32,
    pub converged: bool,
    /// The largest of the scaled norms at the last check (≤ 1 when converged).
    pub residual: f64,
}

/// Local velocity of contact `c` (normal, tangential) from the current body velocities.
#[inline]
fn local_velocity(c: &Contact, b: &Bodies, wall_vel: &[V2]) -> (f64, f64) {
    let i = c.i as usize;
    let t = perp(c.n);
    let (vj, spin_j) = match c.j {
        Partner::Body(j) => (
            b.vel[j as usize],
            b.radius[j as usize] * b.omega[j as usize],
        ),
        Partner::Wall(w) => (wall_vel[w as usize], 0.0),
    };
    let dv = b.vel[i] - vj;
    (dv.dot(&c.n), dv.dot(&t) - b.radius[i] * b.omega[i] - spin_j)
}

/// Applies the impulse increment (dp_n, dp_t) of contact `c` to its bodies.
#[inline]
fn apply(c: &Contact, b: &mut Bodies, dp_n: f64, dp_t: f64) {
    let i = c.i as usize;
    let p = dp_n * c.n + dp_t * perp(c.n);
    b.vel[i] += b.inv_mass[i] * p;
    b.omega[i] -= b.inv_inertia[i] * b.radius[i] * dp_t;
    if let Partner::Body(j) = c.j {
        let j = j as usize;
        b.vel[j] -= b.inv_mass[j] * p;
        b.omega[j] -= b.inv_inertia[j] * b.radius[j] * dp_t;
    }
}

/// Applies every contact's current impulse (the warm start) to the free velocities.
pub fn apply_all(contacts: &[Contact], b: &mut Bodies) {
    for c in contacts {
        apply(c, b, c.p_n, c.p_t);
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
}

/// One local solve; returns the impulse before and after.
#[inline]
fn update<L: InteractionLaw>(
    c: &mut Contact,
    b: &mut Bodies,
    data: &StepData<L>,
) -> ([f64; 2], [f64; 2]) {
    let (u_n, u_t) = local_velocity(c, b, data.wall_vel);
    let hat_n = u_n - c.w_nn * c.p_n + c.gap.max(0.0) * data.gap_rate;
    let hat_t = u_t - c.w_tt * c.p_t;
    let (p_n, p_t) = data.laws.get(c.law).solve(hat_n, hat_t, c.w_nn, c.w_tt);
    let old = [c.p_n, c.p_t];
    apply(c, b, p_n - c.p_n, p_t - c.p_t);
    c.p_n = p_n;
    c.p_t = p_t;
    (old, [p_n, p_t])
}

/// Solves for the impulses of the contacts listed in `order` (the others keep theirs),
/// sweeping them in an order shuffled before each check block.
pub fn solve<L: InteractionLaw>(
    contacts: &mut [Contact],
    b: &mut Bodies,
    data: &StepData<L>,
    params: &NlgsParams,
    order: &mut [u32],
    rng: &mut Rng,
) -> NlgsReport {
    let mut report = NlgsReport::default();
    if order.is_empty() {
        report.converged = true;
        return report;
    }
    loop {
        rng.shuffle(order);
        for _ in 1..params.check_every.max(1) {
            for &k in order.iter() {
                update(&mut contacts[k as usize], b, data);
            }
        }
        let mut norms = Norms::default();
        for &k in order.iter() {
            let c = &mut contacts[k as usize];
            let (old, new) = update(c, b, data);
            norms.add(old, new, c.w_nn, c.w_tt);
        }
        report.iterations += params.check_every.max(1);
        report.residual = norms.residual(params.tol);
        if report.residual <= 1.0 {
            report.converged = true;
            return report;
        }
        if report.iterations >= params.max_iter {
            return report;
        }
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
    fn add(&mut self, old: [f64; 2], new: [f64; 2], w_nn: f64, w_tt: f64) {
        if old == [0.0, 0.0] && new == [0.0, 0.0] {
            return;
        }
        self.active += 1;
        let du = [w_nn * (new[0] - old[0]), w_tt * (new[1] - old[1])];
        let pm = [0.5 * (new[0] + old[0]), 0.5 * (new[1] + old[1])];
        let du2 = du[0] * du[0] + du[1] * du[1];
        let pm2 = pm[0] * pm[0] + pm[1] * pm[1];
        let wp = |p: [f64; 2]| [w_nn * p[0], w_tt * p[1]];
        let (wn, wo) = (wp(new), wp(old));
        self.sum_du2 += du2;
        self.max_du = self.max_du.max(du2.sqrt());
        self.sum_wp2 += 0.5 * (wn[0] * wn[0] + wn[1] * wn[1] + wo[0] * wo[0] + wo[1] * wo[1]);
        self.sum_du2_p2 += du2 * pm2;
        self.max_du_p = self.max_du_p.max((du2 * pm2).sqrt());
        self.sum_du_p += du[0] * pm[0] + du[1] * pm[1];
        self.sum_e += 0.5 * (new[0] * wn[0] + new[1] * wn[1] + old[0] * wo[0] + old[1] * wo[1]);
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
