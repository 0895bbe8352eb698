//! One position projection of a packing at rest: overlapping disks moved apart.
//!
//! The velocity-Signorini law with gap anticipation stops a contact from closing further
//! (u_n ≥ −max(g, 0)/h) but never pushes an overlap apart, which would inject energy. So a
//! deposit keeps the overlaps its landing made, and their size is the NLGS tolerance's
//! error during the fall. Applied once, at rest, this removes them: the smallest mass-weighted
//! displacement Σ m_i |Δx_i|² with every stored contact's linearised gap
//! g + n·(Δx_i − Δx_j) ≥ 0, solved in its dual (one λ ≥ 0 per contact, Δx = M⁻¹ Σ λ n) by
//! projected Gauss-Seidel, then the gaps recomputed and the solve repeated while the
//! linearisation leaves an overlap. It is the projection step of Acary's projected
//! Moreau-Jean scheme (CMAME 2013), applied once instead of every step: every step it kept
//! lifting the pile by its threshold and gravity kept pulling it back (README, "Forty
//! seeds"). Velocities are untouched; the caller steps on until the packing is at rest again.

use super::{Bodies, Contact, Partner};
use crate::geom::{CellList, V2, Wall};

/// What a separation did: Gauss-Seidel sweeps in all, the deepest overlap before and after
/// (m), and the largest displacement (m).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Separation {
    pub sweeps: u32,
    pub deepest_before: f64,
    pub deepest_after: f64,
    pub moved: f64,
}

/// A contact's current gap and normal (from its partner into disk `i`); `None` against a
/// wall the centre has passed.
pub(super) fn gap(b: &Bodies, walls: &[Wall], c: &Contact) -> Option<(f64, V2)> {
    let i = c.i as usize;
    match c.j {
        Partner::Body(j) => {
            let d = b.pos[i] - b.pos[j as usize];
            let dist = d.norm();
            Some((dist - b.radius[i] - b.radius[j as usize], d / dist))
        }
        Partner::Wall(w) => walls[w as usize].gap(V2::zeros(), b.pos[i], b.radius[i]),
    }
}

/// A bare contact of disk `i` with `j`: all the separation reads is the pair.
fn pair(i: u32, j: Partner) -> Contact {
    Contact {
        i,
        j,
        law: 0,
        n: V2::zeros(),
        gap: 0.0,
        w_nn: 0.0,
        w_tt: 0.0,
        p_n: 0.0,
        p_t: 0.0,
        p_r: 0.0,
    }
}

/// The pairs (disk-disk by a cell list, disk-wall all) that overlap at the current positions
/// and are not in `listed` (sorted keys): a large enough displacement closes pairs the
/// caller's contact list does not hold (a 3000-disk pile solved at tolerance 4e-3 was
/// lifted by 0.6 <r>, its overlaps adding up over its height).
fn unlisted_overlaps(b: &Bodies, walls: &[Wall], listed: &[(u32, Partner)]) -> Vec<Contact> {
    let known = |i: usize, j: Partner| listed.binary_search(&(i as u32, j)).is_ok();
    let mut out = Vec::new();
    let cells = CellList::build(&b.pos, 2.0 * b.max_radius());
    for i in 0..b.len() {
        cells.for_each_near(b.pos[i], |j| {
            let (pi, pj) = (Partner::Body(i as u32), Partner::Body(j as u32));
            if j > i
                && (b.pos[i] - b.pos[j]).norm() < b.radius[i] + b.radius[j]
                && !known(i, pj)
                && !known(j, pi)
            {
                out.push(pair(i as u32, pj));
            }
        });
        for w in 0..walls.len() as u32 {
            let c = pair(i as u32, Partner::Wall(w));
            if gap(b, walls, &c).is_some_and(|(g, _)| g < 0.0) && !known(i, c.j) {
                out.push(c);
            }
        }
    }
    out
}

/// Moves the disks of `b` apart along `contacts` until no overlap is deeper than `tol` (m),
/// in at most `max_sweeps` Gauss-Seidel sweeps per linearisation and three linearisations.
/// Each linearisation also holds every other pair found overlapping at its start.
pub fn separate(
    b: &mut Bodies,
    walls: &[Wall],
    contacts: &[Contact],
    tol: f64,
    max_sweeps: u32,
) -> Separation {
    let inv_m = |k: Partner| match k {
        Partner::Body(j) => b.inv_mass[j as usize],
        Partner::Wall(_) => 0.0,
    };
    let mut rows: Vec<(usize, Partner, f64, V2, f64)> = Vec::new();
    let mut out = Separation::default();
    let start = b.pos.clone();
    let mut listed: Vec<(u32, Partner)> = contacts.iter().map(Contact::key).collect();
    listed.sort_unstable();
    let mut extra: Vec<Contact> = Vec::new();
    for round in 0..4 {
        rows.clear();
        let mut deepest = 0.0f64;
        let found = unlisted_overlaps(b, walls, &listed);
        listed.extend(found.iter().map(Contact::key));
        listed.sort_unstable();
        extra.extend(found);
        for c in contacts.iter().chain(&extra) {
            let Some((g, n)) = gap(b, walls, c) else {
                continue;
            };
            let w = b.inv_mass[c.i as usize] + inv_m(c.j);
            deepest = deepest.max(-g);
            if w > 0.0 {
                rows.push((c.i as usize, c.j, g, n, 1.0 / w));
            }
        }
        if round == 0 {
            out.deepest_before = deepest;
        }
        out.deepest_after = deepest;
        if deepest <= tol || round == 3 {
            break;
        }
        let mut dx = vec![V2::zeros(); b.len()];
        let mut lambda = vec![0.0; rows.len()];
        for _ in 0..max_sweeps {
            out.sweeps += 1;
            let mut worst = 0.0f64;
            for (&(i, j, g, n, m), l) in rows.iter().zip(lambda.iter_mut()) {
                let dj = match j {
                    Partner::Body(j) => dx[j as usize],
                    Partner::Wall(_) => V2::zeros(),
                };
                let r = g + n.dot(&(dx[i] - dj));
                worst = worst.max(-r);
                let new = (*l - m * r).max(0.0);
                let dl = new - *l;
                *l = new;
                dx[i] += b.inv_mass[i] * dl * n;
                if let Partner::Body(j) = j {
                    dx[j as usize] -= b.inv_mass[j as usize] * dl * n;
                }
            }
            if worst <= 0.5 * tol {
                break;
            }
        }
        for (p, d) in b.pos.iter_mut().zip(&dx) {
            *p += d;
        }
    }
    out.moved = (b.pos.iter().zip(&start))
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_column_on_the_floor_is_lifted_to_touching_in_the_mass_metric() {
        // three equal disks of radius 1 stacked on the floor y = 0, each overlapping the one
        // below by 0.01 (the bottom one the floor too): only lifting removes the overlaps
        let mut b = Bodies::default();
        for k in 0..3 {
            b.push(V2::new(0.0, 0.99 + 1.99 * k as f64), 1.0, 1.0, k);
        }
        // a heavy disk beside, touching nothing: it must not move
        b.push(V2::new(5.0, 3.0), 1.0, 100.0, 3);
        let floor = Wall::new(V2::new(-10.0, 0.0), V2::new(10.0, 0.0));
        let contacts = [
            pair(0, Partner::Wall(0)),
            pair(1, Partner::Body(0)),
            pair(2, Partner::Body(1)),
            pair(3, Partner::Wall(0)),
        ];
        let s = separate(&mut b, &[floor], &contacts, 1e-12, 10_000);
        assert!((s.deepest_before - 0.01).abs() < 1e-12, "{s:?}");
        assert!(s.deepest_after <= 1e-12, "{s:?}");
        for (k, y) in [1.0, 3.0, 5.0].into_iter().enumerate() {
            assert!((b.pos[k].y - y).abs() < 1e-9, "disk {k} at {}", b.pos[k].y);
            assert_eq!(b.pos[k].x, 0.0);
        }
        assert_eq!(b.pos[3], V2::new(5.0, 3.0));
        assert!((s.moved - 0.03).abs() < 1e-9);
    }

    #[test]
    fn pairs_the_list_leaves_out_are_held_once_they_overlap() {
        // a disk resting on the floor, overlapping it, and a second one just above it that
        // the list does not hold: lifting the first makes them overlap, and the separation
        // must push the second up as well
        let mut b = Bodies::default();
        b.push(V2::new(0.0, 0.9), 1.0, 1.0, 0);
        b.push(V2::new(0.0, 2.95), 1.0, 1.0, 1);
        let floor = Wall::new(V2::new(-10.0, 0.0), V2::new(10.0, 0.0));
        let s = separate(
            &mut b,
            &[floor],
            &[pair(0, Partner::Wall(0))],
            1e-12,
            10_000,
        );
        assert!(s.deepest_after <= 1e-12, "{s:?}");
        assert!((b.pos[0].y - 1.0).abs() < 1e-9, "{:?}", b.pos[0]);
        assert!(
            (b.pos[1].y - b.pos[0].y - 2.0).abs() < 1e-9,
            "{:?}",
            b.pos[1]
        );
    }

    #[test]
    fn two_free_disks_move_apart_inversely_to_their_masses() {
        // the least Σ m |Δx|²: the light disk takes the larger share, momentum-like m Δx
        // balance holds
        let mut b = Bodies::default();
        b.push(V2::new(0.0, 0.0), 1.0, 1.0, 0);
        b.push(V2::new(1.9, 0.0), 1.0, 3.0, 1);
        let before: Vec<V2> = b.pos.clone();
        let s = separate(&mut b, &[], &[pair(1, Partner::Body(0))], 1e-12, 100);
        let (d0, d1) = (b.pos[0] - before[0], b.pos[1] - before[1]);
        assert!(((b.pos[1] - b.pos[0]).norm() - 2.0).abs() < 1e-12, "{s:?}");
        assert!((d0 / b.inv_mass[0] + d1 / b.inv_mass[1]).norm() < 1e-12);
        assert!((d0.x + 0.075).abs() < 1e-12 && (d1.x - 0.025).abs() < 1e-12);
    }
}
