//! Sleeping: a group of touching disks that has stayed slow for a while is frozen and left
//! out of the steps until an awake disk or a moving wall touches it, as Box2D and rapier
//! put islands to sleep. A deposit's last steps are mostly disks creeping at a fraction of
//! a millimetre per second along a frictionless floor while the pile waits, solved again
//! at every step; asleep, neither costs anything and the creep stops.
//!
//! A sleeping disk has zero velocity and no smooth force; its contacts with other sleeping
//! disks and with fixed walls keep their last impulses (so the floor still carries the
//! group's weight in `Scene::wall_force`) but are neither applied nor solved. A contact
//! between an awake disk and a sleeper that the wake test did not catch (pushed faster
//! than predicted) is solved like any other, so the sleeper is moved, not passed through,
//! and its load-carrying contact wakes its group at the next step. Off unless
//! `CdParams::sleep` is set.

use super::{Bodies, Contact, Partner, find};
use crate::geom::V2;
use serde::{Deserialize, Serialize};

/// When a group falls asleep.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SleepParams {
    /// A disk is still while its fastest point moves slower than this, |v| + r|ω| (m/s).
    pub speed: f64,
    /// A group of touching disks sleeps once every one of them has been still this long (s).
    pub time: f64,
}

const AWAKE: u32 = u32::MAX;

/// Each disk's still time and sleeping group, carried from step to step (and in snapshots,
/// so that a resumed run sleeps as the uninterrupted one does).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sleep {
    /// Time each disk has been still (s).
    still: Vec<f64>,
    /// The group a sleeping disk fell asleep with; `AWAKE` for an awake disk.
    group: Vec<u32>,
    /// Label of the next group to fall asleep.
    next: u32,
    /// Scratch: union-find forest over the disks, each root's shortest still time and the
    /// label its group falls asleep with.
    #[serde(skip)]
    parent: Vec<u32>,
    #[serde(skip)]
    least: Vec<f64>,
    #[serde(skip)]
    label: Vec<u32>,
}

impl Sleep {
    /// Whether disk `i` sleeps (always false before the first `settle`).
    #[inline]
    pub fn asleep(&self, i: usize) -> bool {
        self.group.get(i).is_some_and(|&g| g != AWAKE)
    }

    /// Whether contact `c` is between sleeping disks, or a sleeping disk and a wall: it is
    /// left out of the step.
    #[inline]
    pub fn dormant(&self, c: &Contact) -> bool {
        self.asleep(c.i as usize)
            && match c.j {
                Partner::Body(j) => self.asleep(j as usize),
                Partner::Wall(_) => true,
            }
    }

    /// Wakes every sleeping group touched by an awake disk or a moving wall (`wall_vel`, the
    /// walls' imposed velocities) through one of the contacts `touching` accepts, and the
    /// groups those touch in turn.
    pub fn wake(
        &mut self,
        contacts: &[Contact],
        touching: impl Fn(&Contact) -> bool,
        wall_vel: &[V2],
    ) {
        if self.next == 0 {
            return; // nothing has ever slept
        }
        loop {
            let mut woke = false;
            for c in contacts {
                let i = c.i as usize;
                let sleeper = match c.j {
                    Partner::Body(j) => {
                        let j = j as usize;
                        match (self.asleep(i), self.asleep(j)) {
                            (true, false) => Some(i),
                            (false, true) => Some(j),
                            _ => None,
                        }
                    }
                    Partner::Wall(w) => {
                        (self.asleep(i) && wall_vel[w as usize] != V2::zeros()).then_some(i)
                    }
                };
                if let Some(k) = sleeper
                    && touching(c)
                {
                    let g = self.group[k];
                    for (s, t) in self.group.iter_mut().zip(self.still.iter_mut()) {
                        if *s == g {
                            (*s, *t) = (AWAKE, 0.0);
                        }
                    }
                    woke = true;
                }
            }
            if !woke {
                break;
            }
        }
    }

    /// After a step of length `h`: updates each awake disk's still time, then puts to sleep
    /// every group of awake disks joined by the `joined` contacts whose disks have all been
    /// still for `p.time`, setting their velocities to zero.
    pub fn settle(
        &mut self,
        p: &SleepParams,
        h: f64,
        b: &mut Bodies,
        contacts: &[Contact],
        joined: impl Fn(usize, &Contact) -> bool,
    ) {
        let n = b.len();
        self.still.resize(n, 0.0);
        self.group.resize(n, AWAKE);
        for i in 0..n {
            if self.asleep(i) {
                continue;
            }
            let still = b.vel[i].norm() + (b.omega[i] * b.radius[i]).abs() < p.speed;
            self.still[i] = if still { self.still[i] + h } else { 0.0 };
        }
        self.parent.clear();
        self.parent.extend(0..n as u32);
        for (k, c) in contacts.iter().enumerate() {
            if let Partner::Body(j) = c.j
                && joined(k, c)
            {
                let a = find(&mut self.parent, c.i);
                let r = find(&mut self.parent, j);
                self.parent[a.max(r) as usize] = a.min(r);
            }
        }
        // The group's shortest still time, kept at its root (roots are the smallest index).
        self.least.clear();
        self.least.resize(n, f64::INFINITY);
        for i in 0..n {
            if !self.asleep(i) && !b.is_fixed(i) {
                let r = find(&mut self.parent, i as u32) as usize;
                self.least[r] = self.least[r].min(self.still[i]);
            }
        }
        self.label.clear();
        self.label.resize(n, AWAKE);
        for i in 0..n {
            if self.asleep(i) || b.is_fixed(i) {
                continue;
            }
            let r = find(&mut self.parent, i as u32) as usize;
            if self.least[r] >= p.time {
                if self.label[r] == AWAKE {
                    self.label[r] = self.next;
                    self.next += 1;
                }
                self.group[i] = self.label[r];
                b.vel[i] = Default::default();
                b.omega[i] = 0.0;
            }
        }
    }

    /// Number of sleeping disks.
    pub fn sleeping(&self) -> usize {
        self.group.iter().filter(|&&g| g != AWAKE).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contact(i: u32, j: Partner) -> Contact {
        Contact {
            i,
            j,
            law: 0,
            n: V2::new(0.0, 1.0),
            gap: 0.0,
            w_nn: 1.0,
            w_tt: 1.0,
            p_n: 1.0,
            p_t: 0.0,
            p_r: 0.0,
        }
    }

    fn bodies(n: usize) -> Bodies {
        let mut b = Bodies::default();
        for k in 0..n {
            b.push(V2::new(k as f64, 0.0), 0.5, 1.0, 0);
        }
        b
    }

    #[test]
    fn a_group_sleeps_only_when_all_its_disks_have_been_still_long_enough() {
        let p = SleepParams {
            speed: 1e-3,
            time: 0.25,
        };
        let mut b = bodies(3);
        // 0-1 touch; 2 is alone and moving
        let cs = [contact(0, Partner::Body(1)), contact(2, Partner::Wall(0))];
        b.vel[1] = V2::new(5e-4, 0.0);
        b.vel[2] = V2::new(0.0, 2e-3);
        let mut s = Sleep::default();
        for _ in 0..2 {
            s.settle(&p, 0.1, &mut b, &cs, |_, _| true);
            assert_eq!(s.sleeping(), 0);
        }
        s.settle(&p, 0.1, &mut b, &cs, |_, _| true);
        assert!(s.asleep(0) && s.asleep(1) && !s.asleep(2));
        assert_eq!(b.vel[1], V2::zeros());
        assert!(s.dormant(&cs[0]) && !s.dormant(&cs[1]));
        // a touch from the awake disk 2 wakes the pair
        s.wake(&[contact(1, Partner::Body(2))], |_| true, &[V2::zeros()]);
        assert_eq!(s.sleeping(), 0);
    }

    #[test]
    fn a_moving_wall_wakes_its_sleepers_and_a_fixed_one_does_not() {
        let p = SleepParams {
            speed: 1.0,
            time: 0.0,
        };
        let mut b = bodies(2);
        let cs = [contact(0, Partner::Wall(0)), contact(1, Partner::Wall(1))];
        let mut s = Sleep::default();
        s.settle(&p, 0.1, &mut b, &cs, |_, _| true);
        assert_eq!(s.sleeping(), 2);
        s.wake(&cs, |_| true, &[V2::zeros(), V2::new(0.0, -1.0)]);
        assert!(s.asleep(0) && !s.asleep(1));
        // groups are woken whole, and a woken group wakes the sleepers it touches
        let mut b = bodies(4);
        let cs = [contact(0, Partner::Body(1)), contact(2, Partner::Body(3))];
        let mut s = Sleep::default();
        s.settle(&p, 0.1, &mut b, &cs, |_, _| true);
        assert_eq!(s.sleeping(), 4);
        s.wake(&cs, |_| true, &[]);
        assert_eq!(s.sleeping(), 4, "sleepers touching sleepers stay asleep");
        let chain = [contact(1, Partner::Body(2)), contact(3, Partner::Wall(0))];
        s.wake(&chain, |_| true, &[V2::new(0.0, -1.0)]);
        assert_eq!(
            s.sleeping(),
            0,
            "the wall wakes 2-3, which wakes 0-1 through 1-2"
        );
    }
}
