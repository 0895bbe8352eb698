use super::detect::Neighbours;
use super::guard::EnergyGuard;
use super::nlgs::{self, NlgsParams, NlgsReport};
use super::sleep::{Sleep, SleepParams};
use super::{Bodies, Contact, InteractionLaw, LawTable, PAR_MIN, Partner};
use crate::geom::{V2, Wall};
use crate::rng::Rng;
use crate::timing::lap;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Time-stepping settings of the contact-dynamics engine.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CdParams {
    /// Time step h (s).
    pub dt: f64,
    /// θ of the Moreau-Jean scheme, in [1/2, 1]; 1 closes contacts exactly (METHODS.md §1.4).
    pub theta: f64,
    /// Gravity vector (m/s²).
    pub gravity: V2,
    /// Alert distance (m): pairs closer than this enter the contact solve. Each step uses at
    /// least twice the largest approach possible within the step.
    pub alert: f64,
    /// Verlet skin (m): the pair list is rebuilt when a disk has moved skin/2.
    pub skin: f64,
    pub nlgs: NlgsParams,
    /// Put groups of slow touching disks to sleep (`sleep.rs`); `None`: every disk stays
    /// awake.
    pub sleep: Option<SleepParams>,
}

/// A numerical fault the engine detected; the state that produced it is not returned as good.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CdError {
    #[error("step {step}: velocity of disk {body} is not finite")]
    NonFinite { step: u64, body: usize },
    #[error(
        "step {step}: kinetic energy {kinetic:.3e} J/m exceeds 1000 times the energy the loads, walls and cohesion can have supplied ({budget:.3e} J/m): the run is unstable (time step too large for an explicit force?)"
    )]
    EnergyGrowth {
        step: u64,
        kinetic: f64,
        budget: f64,
    },
    #[error(
        "step {step}: disks {i} and {j} overlap by {overlap:.3e} m, more than half the smaller radius: the contacts have failed (a bad initial packing, or a step far too large)"
    )]
    Penetration {
        step: u64,
        i: usize,
        j: usize,
        overlap: f64,
    },
    #[error(
        "step {step}: disk {body} is {depth:.3e} m past wall {wall}, more than half its radius: the wall contact has failed (a step far too large?)"
    )]
    WallPenetration {
        step: u64,
        body: usize,
        wall: usize,
        depth: f64,
    },
}

/// What one step did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    pub nlgs: NlgsReport,
    /// Contacts that entered the solve.
    pub contacts: usize,
    /// Local solves done: Σ sweeps × contacts in the solve, over every resumed solve.
    pub updates: u64,
    /// Times the solve was resumed with contacts the local alert had left out.
    pub resumed: u32,
}

/// Disks, walls and laws, with the state carried from step to step (time, the previous
/// step's impulses for the warm start, the shuffling generator). Serialising a scene and
/// loading it back continues the run bit for bit: the pair list is rebuilt on load, and
/// contacts are ordered by their key, not by the list.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Scene<L> {
    pub bodies: Bodies,
    pub walls: Vec<Wall>,
    pub laws: LawTable<L>,
    pub params: CdParams,
    pub time: f64,
    pub steps: u64,
    /// The last step's contacts with their impulses, sorted by (i, partner).
    pub contacts: Vec<Contact>,
    /// Force each wall exerted on the disks over the last step (N/m).
    pub wall_force: Vec<V2>,
    rng: Rng,
    sleep: Sleep,
    #[serde(skip)]
    neighbours: Neighbours,
    #[serde(skip)]
    order: Vec<u32>,
    /// Per contact of the step: whether it is in `order` (kept to spare an allocation).
    #[serde(skip)]
    in_solve: Vec<bool>,
    /// The walls' imposed velocities this step (kept to spare an allocation).
    #[serde(skip)]
    wall_vel: Vec<V2>,
    #[serde(skip)]
    scratch: nlgs::Scratch,
    #[serde(skip)]
    detection: Detection,
    #[serde(skip)]
    pub(super) energy: EnergyGuard,
    #[serde(skip)]
    phases: Phases,
}

/// Wall seconds this process's steps spent in each part of a step, for `stage.json`'s
/// `timings_s`. Not serialised (it differs from run to run): a resumed run counts its own
/// steps only.
#[derive(Clone, Copy, Debug, Default)]
pub struct Phases {
    /// 3: the Verlet list, the narrow phase, the warm start and waking sleepers.
    pub detect: f64,
    /// 1-2: free velocities (gravity, the laws' smooth forces), the warm-start impulses
    /// applied and the contacts chosen for the solve.
    pub free: f64,
    /// 4: the NLGS (Anderson, islands), resumed where left-out contacts would close.
    pub solve: f64,
    /// 5: positions, walls, wall forces, the overlap guard, sleep and the energy check.
    pub finish: f64,
}

impl Phases {
    /// The parts by name, in the step's order.
    pub fn named(&self) -> [(&'static str, f64); 4] {
        [
            ("detect", self.detect),
            ("free", self.free),
            ("solve", self.solve),
            ("finish", self.finish),
        ]
    }
}

impl<L: InteractionLaw> Scene<L> {
    pub fn new(
        bodies: Bodies,
        walls: Vec<Wall>,
        laws: LawTable<L>,
        params: CdParams,
        seed: u64,
    ) -> Self {
        let n_walls = walls.len();
        Scene {
            bodies,
            walls,
            laws,
            params,
            time: 0.0,
            steps: 0,
            contacts: Vec::new(),
            wall_force: vec![V2::zeros(); n_walls],
            rng: Rng::stream(seed, "cd-nlgs-order"),
            sleep: Sleep::default(),
            neighbours: Neighbours::default(),
            order: Vec::new(),
            in_solve: Vec::new(),
            wall_vel: Vec::new(),
            scratch: nlgs::Scratch::default(),
            detection: Detection::default(),
            energy: EnergyGuard::default(),
            phases: Phases::default(),
        }
    }

    /// Where this process's steps spent their time.
    pub fn phases(&self) -> Phases {
        self.phases
    }

    /// Advances one time step.
    pub fn step(&mut self) -> Result<StepReport, CdError> {
        let mut clock = Instant::now();
        let h = self.params.dt;
        let theta = self.params.theta;
        self.energy.start(&self.bodies);
        let pred = (1.0 - theta) * h;
        // 3. Geometry at q_TT = q⁻ + (1-θ) h V⁻, frozen for the step.
        // (θ = 1, the default: q_TT = q⁻, so the positions are used as they are, not copied)
        let pos_tt: std::borrow::Cow<[V2]> = if pred == 0.0 {
            std::borrow::Cow::Borrowed(&self.bodies.pos)
        } else {
            (self.bodies.pos.iter().zip(&self.bodies.vel))
                .map(|(p, v)| p + pred * v)
                .collect()
        };
        // Every pair that can close within the step must be seen: the alert distance grows
        // to twice the largest approach in one step (METHODS.md §1.7).
        let vel = &self.bodies.vel;
        let v_max = if vel.len() < PAR_MIN {
            vel.iter().map(|v| v.norm()).fold(0.0, f64::max)
        } else {
            (vel.par_iter().with_min_len(PAR_MIN))
                .map(|v| v.norm())
                .reduce(|| 0.0, f64::max)
        };
        let w_max = self
            .walls
            .iter()
            .map(|w| w.velocity.norm())
            .fold(0.0, f64::max);
        let approach = h * (2.0 * v_max.max(w_max) + h * self.params.gravity.norm());
        let alert = self.params.alert.max(2.0 * approach);
        let r_max = self.bodies.max_radius();
        let range = alert + self.laws.max_range(2.0 * r_max);
        let shortcuts = crate::shortcuts::get();
        // Without the Verlet shortcut a zero skin rebuilds the list at every step.
        let skin = if shortcuts.verlet {
            self.params.skin
        } else {
            0.0
        };
        self.neighbours
            .update(&pos_tt, &self.bodies.radius, range, skin);
        let mut detection = std::mem::take(&mut self.detection);
        let mut contacts = self.detect(&pos_tt, pred, alert, &mut detection);
        if shortcuts.warm_start {
            warm_start(&mut contacts, &self.contacts);
        }
        let mut wall_vel = std::mem::take(&mut self.wall_vel);
        wall_vel.clear();
        wall_vel.extend(self.walls.iter().map(|w| w.velocity));
        if self.params.sleep.is_some() {
            // A sleeping group wakes when an awake disk or a moving wall can reach it within
            // the step: the global alert's margin, 2h (|v_i| + |v_j| + h|g|).
            let (b, hg) = (&self.bodies, h * self.params.gravity.norm());
            let reach = |c: &Contact| {
                let vj = match c.j {
                    Partner::Body(j) => b.vel[j as usize].norm(),
                    Partner::Wall(w) => wall_vel[w as usize].norm(),
                };
                c.p_n > 0.0 || c.gap <= 2.0 * h * (b.vel[c.i as usize].norm() + vj + hg)
            };
            self.sleep.wake(&contacts, reach, &wall_vel);
        }
        self.phases.detect += lap(&mut clock);
        let sleep = &self.sleep;

        // 1-2. Smooth forces (gravity, explicit law forces) and free velocities.
        let v_minus = (theta < 1.0).then(|| (self.bodies.vel.clone(), self.bodies.omega.clone()));
        let g = self.params.gravity;
        let b = &mut self.bodies;
        for i in (0..b.len()).filter(|&i| !sleep.asleep(i)) {
            b.vel[i] += h * (g + b.inv_mass[i] * b.force[i]);
        }
        for c in &contacts {
            let a0 = a0(&self.bodies, c);
            let f = self.laws.get(c.law).smooth_force(c.gap, a0);
            if f != 0.0 {
                let i = c.i as usize;
                if !sleep.asleep(i) {
                    self.bodies.vel[i] += h * self.bodies.inv_mass[i] * f * c.n;
                }
                if let Partner::Body(j) = c.j
                    && !sleep.asleep(j as usize)
                {
                    let j = j as usize;
                    self.bodies.vel[j] -= h * self.bodies.inv_mass[j] * f * c.n;
                }
            }
        }

        // 4. Impulses. Only candidates within the alert distance enter the solve; with the
        // local alert, only those whose own two bodies can close them within the step, or
        // that carry a warm-start impulse. The others are checked after the solve and added,
        // and the solve resumed, wherever the solution would close them.
        // (a sleeping group's contacts keep their impulses but are neither applied nor solved)
        nlgs::apply_all(
            contacts.iter().filter(|c| !sleep.dormant(c)),
            &mut self.bodies,
        );
        let mut in_solve = std::mem::take(&mut self.in_solve);
        in_solve.clear();
        in_solve.extend(contacts.iter().map(|c| {
            c.gap <= alert
                && !sleep.dormant(c)
                && (!shortcuts.local_alert
                    || c.p_n != 0.0
                    || c.gap <= self.local_alert(c, &wall_vel))
        }));
        self.order.clear();
        self.order
            .extend((0..contacts.len() as u32).filter(|&k| in_solve[k as usize]));
        self.phases.free += lap(&mut clock);
        let data = nlgs::StepData {
            laws: &self.laws,
            wall_vel: &wall_vel,
            gap_rate: 1.0 / (theta * h),
            skip_frictionless: shortcuts.frictionless,
        };
        let mut report = NlgsReport::default();
        let (mut updates, mut resumed) = (0, 0);
        loop {
            let r = nlgs::solve(
                &mut contacts,
                &mut self.bodies,
                &data,
                &self.params.nlgs,
                &mut self.order,
                &mut self.rng,
                &mut self.scratch,
            );
            updates += r.updates;
            report.iterations += r.iterations;
            report.converged = r.converged;
            report.residual = r.residual;
            if !shortcuts.local_alert {
                break;
            }
            let before = self.order.len();
            for (k, c) in contacts.iter().enumerate() {
                if !in_solve[k]
                    && c.gap <= alert
                    && !self.sleep.dormant(c)
                    && self.closes(c, &wall_vel, data.gap_rate)
                {
                    in_solve[k] = true;
                    self.order.push(k as u32);
                }
            }
            if self.order.len() == before {
                break;
            }
            resumed += 1;
        }
        self.phases.solve += lap(&mut clock);

        // 5. q⁺ = q⁻ + h [(1-θ) V⁻ + θ V⁺].
        let b = &mut self.bodies;
        for i in 0..b.len() {
            let (v, w) = match &v_minus {
                Some((v0, w0)) => (
                    (1.0 - theta) * v0[i] + theta * b.vel[i],
                    (1.0 - theta) * w0[i] + theta * b.omega[i],
                ),
                None => (b.vel[i], b.omega[i]),
            };
            if !(v.x.is_finite() && v.y.is_finite() && w.is_finite()) {
                return Err(CdError::NonFinite {
                    step: self.steps,
                    body: i,
                });
            }
            b.pos[i] += h * v;
            b.angle[i] += h * w;
        }
        for w in self.walls.iter_mut() {
            let d = h * w.velocity;
            w.translate(d);
        }
        self.wall_force.iter_mut().for_each(|f| *f = V2::zeros());
        for c in &contacts {
            if let Partner::Wall(w) = c.j {
                self.wall_force[w as usize] += (c.p_n * c.n + c.p_t * crate::geom::perp(c.n)) / h;
            }
        }
        // Guard: a deep overlap (disk-disk or disk-wall) means the contact solution has
        // failed; stop before the state is used or saved. Contacts only ever close to zero
        // gap (METHODS.md §1.4).
        let b = &self.bodies;
        for c in &contacts {
            let i = c.i as usize;
            match c.j {
                Partner::Body(j) => {
                    let j = j as usize;
                    let overlap = b.radius[i] + b.radius[j] - (b.pos[i] - b.pos[j]).norm();
                    if overlap > 0.5 * b.radius[i].min(b.radius[j]) {
                        return Err(CdError::Penetration {
                            step: self.steps,
                            i,
                            j,
                            overlap,
                        });
                    }
                }
                Partner::Wall(w) => {
                    let wall = &self.walls[w as usize];
                    // a centre behind the wall has no gap: its depth is r + the distance behind
                    let depth = wall
                        .gap(V2::zeros(), b.pos[i], b.radius[i])
                        .map_or(b.radius[i] - (b.pos[i] - wall.a).dot(&wall.normal()), |g| {
                            -g.0
                        });
                    if depth > 0.5 * b.radius[i] {
                        return Err(CdError::WallPenetration {
                            step: self.steps,
                            body: i,
                            wall: w as usize,
                            depth,
                        });
                    }
                }
            }
        }
        if let Some(p) = &self.params.sleep {
            // groups are joined by the contacts that carry load (a disk spinning on the
            // floor next to a resting pile does not keep it awake)
            let joined = |k: usize, c: &Contact| in_solve[k] && c.p_n > 0.0;
            self.sleep.settle(p, h, &mut self.bodies, &contacts, joined);
        }
        self.in_solve = in_solve;
        self.wall_vel = wall_vel;
        // the last step's list becomes the next step's buffer
        detection.spare = std::mem::replace(&mut self.contacts, contacts);
        self.detection = detection;
        self.check_energy()?;
        self.time += h;
        self.steps += 1;
        self.phases.finish += lap(&mut clock);
        let n_solved = self.order.len();
        Ok(StepReport {
            nlgs: report,
            contacts: n_solved,
            updates,
            resumed,
        })
    }

    /// Gap that contact `c`'s own bodies can close within the step: the alert distance plus
    /// twice h times the sum of their speeds as the solve starts (free velocity and warm
    /// start), the same margin as the global alert.
    fn local_alert(&self, c: &Contact, wall_vel: &[V2]) -> f64 {
        let b = &self.bodies;
        let other = match c.j {
            Partner::Body(j) => b.vel[j as usize].norm(),
            Partner::Wall(w) => wall_vel[w as usize].norm(),
        };
        self.params.alert + 2.0 * self.params.dt * (b.vel[c.i as usize].norm() + other)
    }

    /// Whether contact `c`, left out of the solve, would close (or overlap) by the end of the
    /// step at the bodies' current velocities: u_n + max(g, 0)/(θh) < 0, the condition the
    /// solve enforces on its own contacts.
    fn closes(&self, c: &Contact, wall_vel: &[V2], gap_rate: f64) -> bool {
        let b = &self.bodies;
        let vj = match c.j {
            Partner::Body(j) => b.vel[j as usize],
            Partner::Wall(w) => wall_vel[w as usize],
        };
        (b.vel[c.i as usize] - vj).dot(&c.n) + c.gap.max(0.0) * gap_rate < 0.0
    }

    /// Disks asleep now (`sleep.rs`).
    pub fn sleeping(&self) -> usize {
        self.sleep.sleeping()
    }

    /// Narrow phase: disk pairs from the Verlet list and disk-wall pairs within range.
    fn detect(&self, pos: &[V2], pred: f64, alert: f64, buffers: &mut Detection) -> Vec<Contact> {
        let b = &self.bodies;
        let laws = &self.laws;
        let pair = |&(i, j): &(u32, u32)| {
            let (iu, ju) = (i as usize, j as usize);
            let d = pos[iu] - pos[ju];
            let dist = d.norm();
            let a0 = b.radius[iu] + b.radius[ju];
            let gap = dist - a0;
            let law = if b.group[iu] == b.group[ju] {
                LawTable::<L>::SAME_GROUP
            } else {
                LawTable::<L>::OTHER_GROUP
            };
            if gap > alert.max(laws.get(law).range(a0)) {
                return None;
            }
            let (mi, mj) = (b.inv_mass[iu], b.inv_mass[ju]);
            let (ri, rj) = (b.radius[iu], b.radius[ju]);
            Some(Contact {
                i,
                j: Partner::Body(j),
                law,
                n: d / dist,
                gap,
                w_nn: mi + mj,
                w_tt: mi + mj + ri * ri * b.inv_inertia[iu] + rj * rj * b.inv_inertia[ju],
                p_n: 0.0,
                p_t: 0.0,
                p_r: 0.0,
            })
        };
        let wall = |i: usize| {
            self.walls.iter().enumerate().filter_map(move |(w, wall)| {
                let (gap, n) = wall.gap(pred * wall.velocity, pos[i], b.radius[i])?;
                (gap <= alert).then(|| {
                    let (mi, ri) = (b.inv_mass[i], b.radius[i]);
                    Contact {
                        i: i as u32,
                        j: Partner::Wall(w as u32),
                        law: LawTable::<L>::wall_law(w),
                        n,
                        gap,
                        w_nn: mi,
                        w_tt: mi + ri * ri * b.inv_inertia[i],
                        p_n: 0.0,
                        p_t: 0.0,
                        p_r: 0.0,
                    }
                })
            })
        };
        // Both lists come out sorted by key (the pair list is sorted, the walls go by disk),
        // so merging them gives the step's contact order without a sort. A small scene
        // merges them as they are produced; a large one fills fixed chunks in parallel. Every
        // list reuses the memory of the last step's (fresh lists of 10⁵ contacts cost page
        // faults and copies at every step).
        let pairs = &self.neighbours.pairs;
        let mut contacts = std::mem::take(&mut buffers.spare);
        contacts.clear();
        if pairs.len().max(b.len()) < PAR_MIN {
            merge_sorted(
                &mut contacts,
                pairs.iter().filter_map(pair),
                (0..b.len()).flat_map(wall),
            );
        } else {
            let Detection { disks, walls, .. } = buffers;
            disks.resize_with(pairs.len().div_ceil(PAR_MIN), Vec::new);
            (disks.par_iter_mut().zip(pairs.par_chunks(PAR_MIN))).for_each(|(out, chunk)| {
                out.clear();
                out.extend(chunk.iter().filter_map(pair));
            });
            walls.resize_with(b.len().div_ceil(PAR_MIN), Vec::new);
            walls.par_iter_mut().enumerate().for_each(|(k, out)| {
                out.clear();
                out.extend((k * PAR_MIN..((k + 1) * PAR_MIN).min(b.len())).flat_map(wall));
            });
            merge_sorted(
                &mut contacts,
                disks.iter().flatten().copied(),
                walls.iter().flatten().copied(),
            );
        }
        contacts
    }

    /// Current gap of each stored contact (after the step's position update).
    pub fn current_gaps(&self) -> Vec<f64> {
        self.contacts
            .iter()
            .map(|c| {
                super::separate::gap(&self.bodies, &self.walls, c).map_or(f64::INFINITY, |(g, _)| g)
            })
            .collect()
    }
}

/// The equilibrium distance a0 of a contact's law: r_i + r_j, or r_i against a wall.
fn a0(b: &Bodies, c: &Contact) -> f64 {
    match c.j {
        Partner::Body(j) => b.radius[c.i as usize] + b.radius[j as usize],
        Partner::Wall(_) => b.radius[c.i as usize],
    }
}

/// Detection's lists, kept from step to step for their memory: the disk pairs' and the
/// disk-wall contacts' chunks of a large scene, and the last step's contact list, which the
/// next step's merge fills.
#[derive(Clone, Debug, Default)]
struct Detection {
    disks: Vec<Vec<Contact>>,
    walls: Vec<Vec<Contact>>,
    spare: Vec<Contact>,
}

/// Appends to `contacts` one list sorted by key from two sorted by key (contact keys are
/// unique).
fn merge_sorted(
    contacts: &mut Vec<Contact>,
    disks: impl Iterator<Item = Contact>,
    walls: impl Iterator<Item = Contact>,
) {
    let mut walls = walls.peekable();
    for c in disks {
        while let Some(w) = walls.next_if(|w| w.key() < c.key()) {
            contacts.push(w);
        }
        contacts.push(c);
    }
    contacts.extend(walls);
    debug_assert!(contacts.is_sorted_by_key(Contact::key));
}

/// Copies each previous impulse onto the new contact with the same key (both lists sorted).
fn warm_start(new: &mut [Contact], old: &[Contact]) {
    let mut k = 0;
    for c in new.iter_mut() {
        while k < old.len() && old[k].key() < c.key() {
            k += 1;
        }
        if k < old.len() && old[k].key() == c.key() {
            c.p_n = old[k].p_n;
            c.p_t = old[k].p_t;
            c.p_r = old[k].p_r;
        }
    }
}
