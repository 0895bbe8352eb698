//! How far MPM grains pass into each other (README, "Open problem: interpenetration"),
//! measured on the material points rather than at the contact nodes.
//!
//! * `shared_area`, the area under two grains: each material point is drawn as the square
//!   of its current area v_p (side √v_p centred on the point; the shear of F is ignored),
//!   on one raster for all grains with pixels of `1/PIXELS_PER_SIDE` of the smallest side.
//!   A pixel is covered by a square when its centre lies in it, so each edge is placed to
//!   half a pixel. The worst node gap, the other measure, is one node at one step; this one
//!   counts every overlap and moves smoothly. `bench/mpm_overlap_area.py` is the same
//!   measure, read from a frame. Its squares are axis-aligned, so two grains touching along
//!   a slanted face share the corners of their staircases: a floor that falls with the
//!   cell (README).
//! * `points_inside`, the points whose centre lies inside another grain: inside one of its
//!   points' domains, each the reference rectangle of the point's extents (clipped by the
//!   seeded circle) carried by its F. A point's centre lies a half-size (Δr/2 = h_g/4)
//!   inside its own grain's face, so grains that touch, or overlap by less than that,
//!   have none; every point counted marks an overlap deeper than a half-size. A point the
//!   circle clipped has its centre nearer its face (0.01-0.06 l_p from it on the points
//!   counted in the tests' 12 grains, session 34), so it is tested at the centre of the
//!   whole point with the same faces; tested at its own centre it counted overlaps of a
//!   few hundredths of a cell. No staircase: the domains carry the shear.
//! * `deepest_pair`, the deepest overlap of two points of different grains: their domain
//!   ellipses carried by F, along the line joining their centres.

use super::points::Points;
use nalgebra::Vector2;

/// Raster pixels along the smallest point's side.
pub const PIXELS_PER_SIDE: f64 = 8.0;

/// Share of the area covered by the grains' points that two or more grains cover.
pub fn shared_area(grains: &[Points]) -> f64 {
    let views: Vec<(&[Vector2<f64>], &[f64])> = grains
        .iter()
        .map(|g| (g.x.as_slice(), g.vol.as_slice()))
        .collect();
    shared_share(&views)
}

/// `shared_area` on each grain's point positions and areas.
fn shared_share(grains: &[(&[Vector2<f64>], &[f64])]) -> f64 {
    let (mut lo, mut hi) = (
        Vector2::repeat(f64::INFINITY),
        Vector2::repeat(f64::NEG_INFINITY),
    );
    let mut side_min = f64::INFINITY;
    for (x, vol) in grains {
        for (p, v) in x.iter().zip(*vol) {
            let half = Vector2::repeat(0.5 * v.sqrt());
            lo = lo.inf(&(p - half));
            hi = hi.sup(&(p + half));
            side_min = side_min.min(v.sqrt());
        }
    }
    if !(side_min > 0.0 && side_min.is_finite()) {
        return 0.0;
    }
    let px = side_min / PIXELS_PER_SIDE;
    let nx = ((hi.x - lo.x) / px).ceil() as usize + 1;
    let ny = ((hi.y - lo.y) / px).ceil() as usize + 1;
    // pixels [first, last) whose centres lie in [a, b), along one axis
    let span = |a: f64, b: f64, lo: f64, n: usize| {
        let first = ((a - lo) / px - 0.5).ceil().max(0.0) as usize;
        let last = (((b - lo) / px - 0.5).ceil().max(0.0) as usize).min(n);
        first..last
    };
    // owner of each pixel: NONE, a grain's index, or SHARED once a second grain paints it
    const NONE: u32 = u32::MAX;
    const SHARED: u32 = u32::MAX - 1;
    let mut owner = vec![NONE; nx * ny];
    for (g, (x, vol)) in grains.iter().enumerate() {
        let g = g as u32;
        for (p, v) in x.iter().zip(*vol) {
            let half = 0.5 * v.sqrt();
            let cols = span(p.x - half, p.x + half, lo.x, nx);
            for j in span(p.y - half, p.y + half, lo.y, ny) {
                for o in &mut owner[j * nx + cols.start..j * nx + cols.end] {
                    if *o == NONE {
                        *o = g;
                    } else if *o != g {
                        *o = SHARED;
                    }
                }
            }
        }
    }
    let (covered, shared) = owner.iter().fold((0usize, 0usize), |(c, s), &o| {
        (c + usize::from(o != NONE), s + usize::from(o == SHARED))
    });
    shared as f64 / covered.max(1) as f64
}

/// The points, over all grains, whose centre lies strictly inside a point domain of another
/// grain: the rectangle `[-e0, e1] × [-e2, e3]` of the point's initial extents
/// (`Points::extent`) mapped by its F about its centre. A point the seeded circle clipped
/// is tested at its `whole_point_centre`, so that every point counted has a face a
/// half-size or more inside the other grain. Each domain is binned by its bounding box on a
/// grid whose bin is the largest box side, so a centre meets a few domains per grain
/// nearby.
pub fn points_inside(grains: &[Points]) -> usize {
    // each domain's bounding box, from its four corners
    let boxes: Vec<Vec<(Vector2<f64>, Vector2<f64>)>> = grains
        .iter()
        .map(|g| (0..g.len()).map(|q| domain_box(g, q)).collect())
        .collect();
    let (mut lo, mut hi, mut bin) = (
        Vector2::repeat(f64::INFINITY),
        Vector2::repeat(f64::NEG_INFINITY),
        0.0f64,
    );
    for (a, b) in boxes.iter().flatten() {
        lo = lo.inf(a);
        hi = hi.sup(b);
        bin = bin.max((b - a).max());
    }
    if !(bin > 0.0 && bin.is_finite()) {
        return 0;
    }
    let nx = ((hi.x - lo.x) / bin) as usize + 1;
    let ny = ((hi.y - lo.y) / bin) as usize + 1;
    let cell = |x: Vector2<f64>| {
        let c = (x - lo) / bin;
        ((c.x as usize).min(nx - 1), (c.y as usize).min(ny - 1))
    };
    let mut bins: Vec<Vec<(u32, u32)>> = vec![Vec::new(); nx * ny];
    for (g, list) in boxes.iter().enumerate() {
        for (q, (a, b)) in list.iter().enumerate() {
            let ((i0, j0), (i1, j1)) = (cell(*a), cell(*b));
            for j in j0..=j1 {
                for i in i0..=i1 {
                    bins[j * nx + i].push((g as u32, q as u32));
                }
            }
        }
    }
    let mut count = 0;
    for (a, pts) in grains.iter().enumerate() {
        for p in 0..pts.len() {
            let x = &whole_point_centre(pts, p);
            if x.x < lo.x || x.y < lo.y || x.x > hi.x || x.y > hi.y {
                continue;
            }
            let (i, j) = cell(*x);
            let inside = bins[j * nx + i]
                .iter()
                .any(|&(g, q)| g as usize != a && in_domain(&grains[g as usize], q as usize, x));
            count += usize::from(inside);
        }
    }
    count
}

/// Two points of different grains and how deep they overlap (`deepest_pair`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointPair {
    /// Overlap depth (m), 0 when no two points overlap (then `at` and `grains` are unset).
    pub depth: f64,
    /// Midpoint of the two points' centres (m).
    pub at: Vector2<f64>,
    /// Their grains, the lower index first.
    pub grains: [usize; 2],
}

/// The deepest overlap of two points of different grains (m, 0 if none) and where it is:
/// their domains' ellipses (the shape the contact's gap uses) carried by F, projected on the
/// line joining their centres, `l_p + l_q - |x_p - x_q|` with `l` each one's
/// `Points::support` toward the other. A pair measure on the material, where the node gap
/// takes one grain's extreme face and the other's from different points. Its ceiling is two
/// points with one centre, about h_g/2 (times their stretch): deeper passing does not show
/// here but in `points_inside`. Points are binned by twice the largest
/// `Points::support_bound`, so a pair that overlaps lies in neighbouring bins.
pub fn deepest_pair(grains: &[Points]) -> PointPair {
    let (mut lo, mut bin) = (Vector2::repeat(f64::INFINITY), 0.0f64);
    for g in grains {
        for p in 0..g.len() {
            lo = lo.inf(&g.x[p]);
            bin = bin.max(2.0 * g.support_bound(p));
        }
    }
    if !(bin > 0.0 && bin.is_finite()) {
        return PointPair::default();
    }
    let key = |x: &Vector2<f64>| {
        let c = (x - lo) / bin;
        (c.x as i64, c.y as i64)
    };
    let mut bins: std::collections::HashMap<(i64, i64), Vec<(u32, u32)>> =
        std::collections::HashMap::new();
    for (g, pts) in grains.iter().enumerate() {
        for (p, x) in pts.x.iter().enumerate() {
            bins.entry(key(x)).or_default().push((g as u32, p as u32));
        }
    }
    let mut deepest = PointPair::default();
    for (a, pts) in grains.iter().enumerate() {
        for (p, x) in pts.x.iter().enumerate() {
            let (i, j) = key(x);
            for (di, dj) in (-1..=1).flat_map(|di| (-1..=1).map(move |dj| (di, dj))) {
                let Some(list) = bins.get(&(i + di, j + dj)) else {
                    continue;
                };
                // each pair once: the partner from a later grain
                for &(g, q) in list.iter().filter(|&&(g, _)| g as usize > a) {
                    let (b, q) = (&grains[g as usize], q as usize);
                    let d = x - b.x[q];
                    let dist = d.norm();
                    let n = if dist > 0.0 { d / dist } else { Vector2::x() };
                    let depth = pts.support(p, &-n) + b.support(q, &n) - dist;
                    if depth > deepest.depth {
                        deepest = PointPair {
                            depth,
                            at: 0.5 * (x + b.x[q]),
                            grains: [a, g as usize],
                        };
                    }
                }
            }
        }
    }
    deepest
}

/// Centre of the whole point (half-size `l_p` every way) that has point `p`'s faces where
/// the seeded circle clipped it: `x_p + F (e1 - e0, e3 - e2)`, `x_p` itself for a point the
/// circle does not clip. A clipped point's centre lies on or near its grain's face, so
/// testing it would count a point that barely touches another grain. (A point clipped on
/// both sides of an axis, where the circle's chord is shorter than Δr, is mirrored across
/// the grain's axis instead, staying in its row or column at the circle's edge: rare.)
fn whole_point_centre(g: &Points, p: usize) -> Vector2<f64> {
    let e = g.extent[p];
    g.x[p] + g.def_grad[p] * Vector2::new(e[1] - e[0], e[3] - e[2])
}

/// Corners of point `q`'s domain: its centre plus F times the reference rectangle's corners.
fn domain_corners(g: &Points, q: usize) -> [Vector2<f64>; 4] {
    let e = g.extent[q];
    [(-e[0], -e[2]), (e[1], -e[2]), (-e[0], e[3]), (e[1], e[3])]
        .map(|(u, v)| g.x[q] + g.def_grad[q] * Vector2::new(u, v))
}

fn domain_box(g: &Points, q: usize) -> (Vector2<f64>, Vector2<f64>) {
    let c = domain_corners(g, q);
    (
        c.iter().fold(c[0], |m, p| m.inf(p)),
        c.iter().fold(c[0], |m, p| m.sup(p)),
    )
}

/// Whether `x` lies strictly inside point `q`'s domain (pulled back through F).
fn in_domain(g: &Points, q: usize, x: &Vector2<f64>) -> bool {
    let Some(inv) = g.def_grad[q].try_inverse() else {
        return false;
    };
    let (r, e) = (inv * (x - g.x[q]), g.extent[q]);
    -e[0] < r.x && r.x < e[1] && -e[2] < r.y && r.y < e[3]
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix2;

    /// A grain of `n × n` points of side `s` filling the square of side `n s` at `corner`.
    fn block(corner: Vector2<f64>, n: usize, s: f64) -> (Vec<Vector2<f64>>, Vec<f64>) {
        let x = (0..n * n)
            .map(|k| corner + Vector2::new((k % n) as f64 + 0.5, (k / n) as f64 + 0.5) * s)
            .collect();
        (x, vec![s * s; n * n])
    }

    /// `block` as a grain of points with square domains (extents s/2) and the given F.
    fn grain(corner: Vector2<f64>, n: usize, s: f64, f: Matrix2<f64>) -> Points {
        let (x, vol) = block(corner, n, s);
        Points {
            def_grad: vec![f; x.len()],
            extent: vec![[0.5 * s; 4]; x.len()],
            vol,
            x,
            ..Points::default()
        }
    }

    #[test]
    fn grains_count_points_inside_only_past_a_half_size() {
        let (n, s, id) = (4, 0.25, Matrix2::identity());
        let a = grain(Vector2::zeros(), n, s, id);
        let at = |dx: f64| grain(Vector2::new(n as f64 * s - dx, 0.0), n, s, id);
        // touching, and overlapping by less than a point's half-size s/2: no centre inside
        assert_eq!(points_inside(&[a.clone(), at(0.0)]), 0);
        assert_eq!(points_inside(&[a.clone(), at(0.4 * s)]), 0);
        // overlapping by 0.6 s: each grain's outer column has its centres in the other's
        assert_eq!(points_inside(&[a.clone(), at(0.6 * s)]), 2 * n);
        // a point the circle clipped to 0.01 l toward the block (l = s/2, its centre on its
        // face): counted once its face is a half-size deep, as for a whole point, and then
        // the block's edge point lies inside it too
        let l = 0.5 * s;
        let clipped = |x: f64| Points {
            x: vec![Vector2::new(x, 0.45)],
            def_grad: vec![id],
            extent: vec![[l, 0.01 * l, l, l]],
            ..Points::default()
        };
        assert_eq!(points_inside(&[a.clone(), clipped(0.1 * l)]), 0);
        assert_eq!(points_inside(&[a.clone(), clipped(0.9 * l)]), 0);
        assert_eq!(points_inside(&[a.clone(), clipped(1.05 * l)]), 2);
        // the same from below, clipped toward +y
        let below = |y: f64| Points {
            x: vec![Vector2::new(0.45, y)],
            def_grad: vec![id],
            extent: vec![[l, l, l, 0.01 * l]],
            ..Points::default()
        };
        assert_eq!(points_inside(&[a.clone(), below(0.9 * l)]), 0);
        assert_eq!(points_inside(&[a.clone(), below(1.05 * l)]), 2);
        // one grain's own points never count, however they overlap
        assert_eq!(points_inside(std::slice::from_ref(&a)), 0);
        assert_eq!(points_inside(&[]), 0);
    }

    #[test]
    fn the_deepest_pair_is_the_overlap_of_the_facing_columns() {
        let (n, s, id) = (4, 0.25, Matrix2::identity());
        let a = grain(Vector2::zeros(), n, s, id);
        let at = |dx: f64| grain(Vector2::new(n as f64 * s - dx, 0.0), n, s, id);
        // facing points a distance s - δ apart with reaches s/2 each: δ; diagonal partners
        // lie farther than their reaches
        let depth = |b: Points| deepest_pair(&[a.clone(), b]).depth;
        assert!(depth(at(0.0)).abs() < 1e-12);
        assert!((depth(at(0.1 * s)) - 0.1 * s).abs() < 1e-12);
        assert!((depth(at(0.7 * s)) - 0.7 * s).abs() < 1e-12);
        // between a's outer column (x = 3.5 s) and the other's first (4.5 s - 0.1 s)
        let pair = deepest_pair(&[a.clone(), at(0.1 * s)]);
        assert_eq!(pair.grains, [0, 1]);
        assert!((pair.at.x - 3.95 * s).abs() < 1e-12, "{pair:?}");
        assert_eq!(depth(at(-0.5 * s)), 0.0);
        // a grain's own points overlap nothing
        assert_eq!(deepest_pair(std::slice::from_ref(&a)), PointPair::default());
    }

    #[test]
    fn the_deepest_pair_finds_what_trying_every_pair_finds() {
        // points scattered over three grains, each with uneven extents and a rotated,
        // stretched F, against every pair tried
        let mut rng = crate::rng::Rng::new(11);
        let mut u = |a: f64, b: f64| a + (b - a) * rng.uniform();
        let grains: Vec<Points> = (0..3)
            .map(|_| {
                let n = 40;
                let (x, def_grad, extent) = (0..n)
                    .map(|_| {
                        let th = u(0.0, std::f64::consts::TAU);
                        let (c, s) = (th.cos(), th.sin());
                        let f = Matrix2::new(c, -s, s, c)
                            * Matrix2::new(u(0.7, 1.3), u(-0.2, 0.2), 0.0, u(0.7, 1.3));
                        let e = [
                            u(0.002, 0.05),
                            u(0.002, 0.05),
                            u(0.002, 0.05),
                            u(0.002, 0.05),
                        ];
                        (Vector2::new(u(0.0, 1.0), u(0.0, 1.0)), f, e)
                    })
                    .fold(
                        (vec![], vec![], vec![]),
                        |(mut x, mut f, mut e), (xi, fi, ei)| {
                            x.push(xi);
                            f.push(fi);
                            e.push(ei);
                            (x, f, e)
                        },
                    );
                Points {
                    x,
                    def_grad,
                    extent,
                    ..Points::default()
                }
            })
            .collect();
        let mut brute = PointPair::default();
        for a in 0..3 {
            for b in a + 1..3 {
                for p in 0..grains[a].len() {
                    for q in 0..grains[b].len() {
                        let d = grains[a].x[p] - grains[b].x[q];
                        let n = d.normalize();
                        let depth = grains[a].support(p, &-n) + grains[b].support(q, &n) - d.norm();
                        if depth > brute.depth {
                            let at = 0.5 * (grains[a].x[p] + grains[b].x[q]);
                            brute = PointPair {
                                depth,
                                at,
                                grains: [a, b],
                            };
                        }
                    }
                }
            }
        }
        assert!(brute.depth > 0.0);
        assert_eq!(deepest_pair(&grains), brute);
    }

    #[test]
    fn a_sheared_domain_is_its_parallelogram_not_a_square() {
        // F a simple shear: the domain of half-size l is the parallelogram with corners
        // (±l ± l, ±l). (1.5 l, 0.9 l) pulls back to (0.6 l, 0.9 l): inside, though outside
        // the axis-aligned square of the same area; (-1.5 l, 0.9 l) to (-2.4 l, 0.9 l): out.
        let l = 0.1;
        let shear = Matrix2::new(1.0, 1.0, 0.0, 1.0);
        let q = grain(Vector2::repeat(-l), 1, 2.0 * l, shear);
        let probe = |x: f64, y: f64| Points {
            x: vec![Vector2::new(x, y)],
            def_grad: vec![Matrix2::identity()],
            extent: vec![[0.01; 4]],
            ..Points::default()
        };
        assert_eq!(q.x[0], Vector2::zeros());
        assert_eq!(points_inside(&[q.clone(), probe(1.5 * l, 0.9 * l)]), 1);
        assert_eq!(points_inside(&[q.clone(), probe(-1.5 * l, 0.9 * l)]), 0);
        assert_eq!(points_inside(&[q, probe(-1.5 * l, -0.9 * l)]), 1);
    }

    #[test]
    fn two_offset_blocks_share_a_quarter_of_their_union() {
        // Two 1 × 1 blocks offset by 0.5 along x (and 0.2 along y): the shared area is
        // 0.5 × 0.8 = 0.4, the union 2 - 0.4 = 1.6, the share 0.25.
        let a = block(Vector2::zeros(), 4, 0.25);
        let b = block(Vector2::new(0.5, 0.2), 4, 0.25);
        let share = shared_share(&[(&a.0, &a.1), (&b.0, &b.1)]);
        // The offset 0.2 is off the pixel grid (pixels of 1/32), so B's edges move by up to
        // half a pixel along y: the shared area by 0.5/64, the share by that times
        // 1/1.6 + 0.4/1.6² = 0.78, that is 0.0061.
        assert!((share - 0.25).abs() < 0.0061, "share {share}");
    }

    #[test]
    fn grains_apart_share_nothing_and_a_grain_inside_another_all_of_itself() {
        // Points of one grain overlap each other (side 0.3 on a 0.25 pitch) and the two
        // grains are 0.01 apart, less than a pixel: nothing is under two grains.
        let (x, _) = block(Vector2::zeros(), 4, 0.25);
        let a = (x.clone(), vec![0.09; 16]);
        let b: Vec<Vector2<f64>> = x.iter().map(|p| p + Vector2::new(1.06, 0.0)).collect();
        let share = shared_share(&[(&a.0, &a.1), (&b, &a.1)]);
        assert_eq!(share, 0.0);
        // one grain entirely inside another: the smaller one's whole area is shared
        let small = block(Vector2::new(0.25, 0.25), 2, 0.25);
        let big = block(Vector2::zeros(), 4, 0.25);
        let share = shared_share(&[(&big.0, &big.1), (&small.0, &small.1)]);
        assert!((share - 0.25).abs() < 1e-12, "share {share}");
        assert_eq!(shared_share(&[]), 0.0);
    }
}
