//! Grain-level measures of BPM aggregates (METHODS.md §2.4).

use super::BpmLaw;
use crate::cd::{Bodies, InteractionLaw, LawTable, Partner, Scene};
use crate::geom::{CellList, V2};
use nalgebra::Matrix2;

/// Area of a grain by morphological closing (the recommended convention of METHODS.md
/// §2.4): the union of its disks, dilated then eroded by `s` (the largest particle radius),
/// on a raster of pixel size `pixel`. Dilating a union of disks by s is the union of the
/// disks grown by s, so the dilation is exact; the erosion keeps the pixels whose s-disk
/// lies inside it. Intra-grain pores smaller than s are filled, the outer boundary kept.
pub fn closed_area(pos: &[V2], rad: &[f64], s: f64, pixel: f64) -> f64 {
    if pos.is_empty() {
        return 0.0;
    }
    let pad = s + 2.0 * pixel;
    let (mut lo, mut hi) = (pos[0], pos[0]);
    for (p, r) in pos.iter().zip(rad) {
        lo = lo.inf(&(p - V2::repeat(r + pad)));
        hi = hi.sup(&(p + V2::repeat(r + pad)));
    }
    let nx = ((hi.x - lo.x) / pixel).ceil() as usize + 1;
    let ny = ((hi.y - lo.y) / pixel).ceil() as usize + 1;
    let centre =
        |i: usize, j: usize| lo + V2::new((i as f64 + 0.5) * pixel, (j as f64 + 0.5) * pixel);
    // dilation: pixels within r + s of a centre, painted disk by disk
    let mut dilated = vec![false; nx * ny];
    for (p, r) in pos.iter().zip(rad) {
        let reach = r + s;
        let (i0, i1) = (
            ((p.x - reach - lo.x) / pixel).floor() as usize,
            ((p.x + reach - lo.x) / pixel).ceil() as usize,
        );
        let (j0, j1) = (
            ((p.y - reach - lo.y) / pixel).floor() as usize,
            ((p.y + reach - lo.y) / pixel).ceil() as usize,
        );
        for j in j0..=j1.min(ny - 1) {
            for i in i0..=i1.min(nx - 1) {
                if (centre(i, j) - p).norm_squared() <= reach * reach {
                    dilated[j * nx + i] = true;
                }
            }
        }
    }
    // erosion by a disk of radius s (in pixels)
    let k = (s / pixel).floor() as isize;
    let offsets: Vec<(isize, isize)> = (-k..=k)
        .flat_map(|dj| (-k..=k).map(move |di| (di, dj)))
        .filter(|(di, dj)| ((di * di + dj * dj) as f64).sqrt() * pixel <= s)
        .collect();
    let inside = |i: isize, j: isize| {
        i >= 0
            && j >= 0
            && (i as usize) < nx
            && (j as usize) < ny
            && dilated[j as usize * nx + i as usize]
    };
    let mut count = 0usize;
    for j in 0..ny as isize {
        for i in 0..nx as isize {
            if dilated[j as usize * nx + i as usize]
                && offsets.iter().all(|(di, dj)| inside(i + di, j + dj))
            {
                count += 1;
            }
        }
    }
    count as f64 * pixel * pixel
}

/// Largest horizontal extent of a set of disks: max(x + r) - min(x - r).
pub fn width(pos: &[V2], rad: &[f64]) -> f64 {
    let hi = pos
        .iter()
        .zip(rad)
        .map(|(p, r)| p.x + r)
        .fold(f64::NEG_INFINITY, f64::max);
    let lo = pos
        .iter()
        .zip(rad)
        .map(|(p, r)| p.x - r)
        .fold(f64::INFINITY, f64::min);
    hi - lo
}

/// Particles with no particle of their own grain within the cohesion range
/// (gap ≤ cutoff · a0): they have left their grain. Grains of one particle do not count.
pub fn escaped(b: &Bodies, cutoff: f64) -> usize {
    let reach = 2.0 * b.max_radius() * (1.0 + cutoff);
    let cells = CellList::build(&b.pos, reach);
    let mut size = std::collections::HashMap::new();
    for g in &b.group {
        *size.entry(*g).or_insert(0usize) += 1;
    }
    (0..b.len())
        .filter(|&i| {
            let mut held = false;
            cells.for_each_near(b.pos[i], |j| {
                let a0 = b.radius[i] + b.radius[j];
                held |= j != i
                    && b.group[j] == b.group[i]
                    && (b.pos[i] - b.pos[j]).norm() - a0 <= cutoff * a0;
            });
            !held && size[&b.group[i]] > 1
        })
        .count()
}

/// The internal stress of a scene's one grain, split by force type: `attraction` from Eq. (1) at
/// every pair within the cut-off, `contact` from the unilateral reactions. Love-Weber
/// averages σ = (1/A) Σ f ℓ⊗n over the grain's own pairs (ℓ = centre distance, n the
/// normal, compression positive), from the last step's impulses.
#[derive(Clone, Copy, Debug)]
pub struct GrainStress {
    pub attraction: Matrix2<f64>,
    pub contact: Matrix2<f64>,
}

impl GrainStress {
    pub fn of(scene: &Scene<BpmLaw>, area: f64) -> Self {
        let b = &scene.bodies;
        let h = scene.params.dt;
        let mut s = GrainStress {
            attraction: Matrix2::zeros(),
            contact: Matrix2::zeros(),
        };
        for c in &scene.contacts {
            let (Partner::Body(j), LawTable::<BpmLaw>::SAME_GROUP) = (c.j, c.law) else {
                continue;
            };
            let a0 = b.radius[c.i as usize] + b.radius[j as usize];
            let nn = (a0 + c.gap) * c.n * c.n.transpose() / area;
            s.attraction += scene.laws.get(c.law).smooth_force(c.gap, a0) * nn;
            s.contact += c.p_n / h * nn;
        }
        s
    }

    /// The isotropic tension the attraction holds the grain under, −tr(σ_att)/2 (Pa,
    /// positive): the cohesive prestress σ_c.
    pub fn prestress(&self) -> f64 {
        -0.5 * self.attraction.trace()
    }

    /// Mobilised friction of the contact network, (σ1 − σ2)/(σ1 + σ2) of its principal
    /// stresses: the sine of its friction angle. The contacts carry the load plus σ_c, so
    /// at yield this is the internal friction of frictionless disks, and an unconfined
    /// grain's plateau is 2 σ_c s/(1 − s) (README, "the plateau level").
    pub fn mobilised_friction(&self) -> f64 {
        let m = self.contact;
        let mean = 0.5 * m.trace();
        let radius = (0.25 * (m[(0, 0)] - m[(1, 1)]).powi(2) + m[(0, 1)] * m[(1, 0)]).sqrt();
        if mean > 0.0 { radius / mean } else { 0.0 }
    }
}

/// Area shared by two disks of radii `r1`, `r2` whose centres are `d` apart: two circular
/// segments cut by the common chord, at distances a1 = (d² + r1² - r2²)/(2d) and d - a1
/// from the centres. Zero when they do not overlap, the smaller disk when one holds the
/// other.
pub fn lens_area(r1: f64, r2: f64, d: f64) -> f64 {
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        return std::f64::consts::PI * r1.min(r2).powi(2);
    }
    // segment of a disk of radius r beyond a chord at distance a from its centre
    let segment = |r: f64, a: f64| {
        r * r * (a / r).clamp(-1.0, 1.0).acos() - a * (r * r - a * a).max(0.0).sqrt()
    };
    let a1 = (d * d + r1 * r1 - r2 * r2) / (2.0 * d);
    segment(r1, a1) + segment(r2, d - a1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closing_fills_the_pores_of_a_disk_packing_and_keeps_a_lone_disk() {
        // one disk: closing changes nothing but the raster error
        let a = closed_area(&[V2::zeros()], &[1.0], 0.3, 0.01);
        assert!((a / std::f64::consts::PI - 1.0).abs() < 0.01, "{a}");
        // a hexagonal patch of touching unit disks: the closed area is the patch's outline,
        // above the disks' own area (pores filled) and below their hull grown by r
        let mut pos = Vec::new();
        for j in -3i32..=3 {
            for i in -3i32..=3 {
                let x = V2::new(2.0 * i as f64 + j as f64, 3f64.sqrt() * j as f64);
                if x.norm() < 6.5 {
                    pos.push(x);
                }
            }
        }
        let rad = vec![1.0; pos.len()];
        let area = closed_area(&pos, &rad, 1.0, 0.02);
        let disks = pos.len() as f64 * std::f64::consts::PI;
        assert!(
            area > disks * 1.05 && area < disks / 0.9069 * 1.2,
            "{area} vs {disks}"
        );
    }

    #[test]
    fn lens_area_of_two_disks() {
        use std::f64::consts::PI;
        // equal disks at d = r: two segments of a chord at r/2, 2 (π/3 - √3/4) r²
        let expected = 2.0 * (PI / 3.0 - 3f64.sqrt() / 4.0);
        assert!((lens_area(1.0, 1.0, 1.0) - expected).abs() < 1e-14);
        assert_eq!(lens_area(1.0, 2.0, 3.0), 0.0);
        assert!((lens_area(1.0, 3.0, 1.5) - PI).abs() < 1e-14);
        // coincident equal disks: the whole disk
        assert!((lens_area(2.0, 2.0, 0.0) - 4.0 * PI).abs() < 1e-14);
        // a shallow overlap δ: about (4/3) √(2 r*) δ^(3/2), r* = r1 r2 / (r1 + r2) (with
        // relative error of order δ/r)
        let (r1, r2, delta): (f64, f64, f64) = (1.0, 0.5, 1e-6);
        let reduced = r1 * r2 / (r1 + r2);
        let shallow = 4.0 / 3.0 * (2.0 * reduced).sqrt() * delta.powf(1.5);
        let lens = lens_area(r1, r2, r1 + r2 - delta);
        assert!(
            (lens / shallow - 1.0).abs() < 1e-4,
            "{lens} against {shallow}"
        );
    }
}
