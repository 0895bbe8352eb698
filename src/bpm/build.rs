//! Building one grain: an advancing-front packing of primary disks inside the grain's
//! circle (METHODS.md §2.2 A; Feng, Han & Owen 2003). Radii are drawn in advance with each
//! particle's area uniform; each new disk is placed tangent to two disks already placed, at
//! the candidate position nearest the grain centre that overlaps nothing and stays inside
//! the circle. A radius that fits nowhere is skipped (so the realised distribution is
//! slightly poorer in large disks; `tests/bpm_grain.rs` checks it); the grain is full after
//! `MAX_FAILURES` consecutive skips.

use crate::geom::V2;
use crate::packing::Distribution;
use crate::rng::Rng;

/// Consecutive radii that fit nowhere before the grain is declared full.
const MAX_FAILURES: usize = 200;

/// Centres (relative to the grain centre) and radii of the primary particles of a grain of
/// radius `radius` with particle diameters in `diameter` (area-uniform).
/// `radius` must exceed the two seed disks (2 d_max).
pub fn build_grain(radius: f64, diameter: [f64; 2], rng: &mut Rng) -> (Vec<V2>, Vec<f64>) {
    let r_min = 0.5 * diameter[0];
    let r_max = 0.5 * diameter[1];
    let mut pos: Vec<V2> = Vec::new();
    let mut rad: Vec<f64> = Vec::new();
    let mut grid = Grid::new(radius, 2.0 * r_max);
    let rng_angle = rng.uniform();
    let mut next_radius = || 0.5 * Distribution::UniformArea.sample(diameter, rng);
    // Two seeds: one at the centre and one tangent to it in a random direction, so every
    // later disk has a pair to sit against.
    let r0 = next_radius();
    let r1 = next_radius();
    let angle = 2.0 * std::f64::consts::PI * rng_angle;
    let x1 = (r0 + r1) * V2::new(angle.cos(), angle.sin());
    for (k, (x, r)) in [(V2::zeros(), r0), (x1, r1)].into_iter().enumerate() {
        pos.push(x);
        rad.push(r);
        grid.insert(k, x);
    }
    let mut front: Vec<usize> = vec![0, 1];
    let mut failures = 0;
    let mut since_prune = 0;
    while failures < MAX_FAILURES && !front.is_empty() {
        let r = next_radius();
        match best_site(&pos, &rad, &grid, &front, r, radius) {
            Some(x) => {
                let k = pos.len();
                pos.push(x);
                rad.push(r);
                grid.insert(k, x);
                front.push(k);
                failures = 0;
                since_prune += 1;
                if since_prune == 50 {
                    since_prune = 0;
                    front.retain(|&a| has_room(&pos, &rad, &grid, a, r_min, radius));
                }
            }
            None => failures += 1,
        }
    }
    (pos, rad)
}

/// The admissible site for a disk of radius `r` nearest the centre, over all pairs of a
/// front disk and a neighbour of it.
fn best_site(
    pos: &[V2],
    rad: &[f64],
    grid: &Grid,
    front: &[usize],
    r: f64,
    radius: f64,
) -> Option<V2> {
    let mut best: Option<(f64, V2)> = None;
    for &a in front {
        // a disk tangent to `a` lies at |x - x_a| = r_a + r; prune by that lower bound
        let lower = (pos[a].norm() - rad[a] - r).max(0.0);
        if best.is_some_and(|(d, _)| lower >= d) {
            continue;
        }
        grid.for_each_near(pos[a], |b| {
            if b == a {
                return;
            }
            for x in tangent_sites(pos[a], rad[a] + r, pos[b], rad[b] + r) {
                let d = x.norm();
                if best.is_some_and(|(bd, _)| d >= bd) || d > radius - r {
                    continue;
                }
                if grid.free(pos, rad, x, r) {
                    best = Some((d, x));
                }
            }
        });
    }
    best.map(|(_, x)| x)
}

/// Whether some disk of radius `r` still fits tangent to disk `a`.
fn has_room(pos: &[V2], rad: &[f64], grid: &Grid, a: usize, r: f64, radius: f64) -> bool {
    let mut room = false;
    grid.for_each_near(pos[a], |b| {
        if room || b == a {
            return;
        }
        for x in tangent_sites(pos[a], rad[a] + r, pos[b], rad[b] + r) {
            if x.norm() <= radius - r && grid.free(pos, rad, x, r) {
                room = true;
            }
        }
    });
    room
}

/// The (up to two) intersections of the circles |x - a| = ra and |x - b| = rb.
fn tangent_sites(a: V2, ra: f64, b: V2, rb: f64) -> impl Iterator<Item = V2> {
    let d = b - a;
    let l = d.norm();
    let ok = l > 0.0 && l <= ra + rb && l >= (ra - rb).abs();
    let (mid, off) = if ok {
        let along = (ra * ra - rb * rb + l * l) / (2.0 * l);
        let h = (ra * ra - along * along).max(0.0).sqrt();
        let u = d / l;
        (a + along * u, h * V2::new(-u.y, u.x))
    } else {
        (V2::zeros(), V2::zeros())
    };
    [mid + off, mid - off]
        .into_iter()
        .take(if ok { 2 } else { 0 })
}

/// A cell grid over the grain's circle for overlap tests while the grain grows (the
/// `geom::CellList` bins a fixed set of points; this one takes insertions).
struct Grid {
    origin: V2,
    cell: f64,
    n: usize,
    cells: Vec<Vec<u32>>,
}

impl Grid {
    fn new(radius: f64, cell: f64) -> Self {
        let n = (2.0 * radius / cell).ceil() as usize + 1;
        Grid {
            origin: V2::new(-radius, -radius),
            cell,
            n,
            cells: vec![Vec::new(); n * n],
        }
    }

    fn coords(&self, x: V2) -> (usize, usize) {
        let c = |v: f64| ((v / self.cell).floor().max(0.0) as usize).min(self.n - 1);
        (c(x.x - self.origin.x), c(x.y - self.origin.y))
    }

    fn insert(&mut self, k: usize, x: V2) {
        let (cx, cy) = self.coords(x);
        self.cells[cy * self.n + cx].push(k as u32);
    }

    /// Visits the disks in the 5x5 cells around `x` (reach: two cell sides, enough for the
    /// neighbours a tangent disk can touch since the cell side is d_max).
    fn for_each_near(&self, x: V2, mut f: impl FnMut(usize)) {
        let (cx, cy) = self.coords(x);
        for y in cy.saturating_sub(2)..=(cy + 2).min(self.n - 1) {
            for xx in cx.saturating_sub(2)..=(cx + 2).min(self.n - 1) {
                for &k in &self.cells[y * self.n + xx] {
                    f(k as usize);
                }
            }
        }
    }

    /// No placed disk overlaps a disk of radius `r` at `x` (a relative tolerance lets
    /// tangent neighbours through).
    fn free(&self, pos: &[V2], rad: &[f64], x: V2, r: f64) -> bool {
        let mut free = true;
        self.for_each_near(x, |k| {
            if free && (pos[k] - x).norm() < (rad[k] + r) * (1.0 - 1e-9) {
                free = false;
            }
        });
        free
    }
}
