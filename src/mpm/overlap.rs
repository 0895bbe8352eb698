//! The area under two grains: how far MPM grains pass into each other, as a share of the
//! area they cover (README, "Open problem: interpenetration").
//!
//! Each material point is drawn as the square of its current area v_p (side √v_p centred
//! on the point; the shear of F is ignored), on one raster for all grains with pixels of
//! `1/PIXELS_PER_SIDE` of the smallest side. A pixel is covered by a square when its centre
//! lies in it, so each edge is placed to half a pixel. The worst node gap, the other
//! measure, is one node at one step; this one counts every overlap and moves smoothly.
//! `bench/mpm_overlap_area.py` is the same measure, read from a frame.

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

#[cfg(test)]
mod tests {
    use super::*;

    /// A grain of `n × n` points of side `s` filling the square of side `n s` at `corner`.
    fn block(corner: Vector2<f64>, n: usize, s: f64) -> (Vec<Vector2<f64>>, Vec<f64>) {
        let x = (0..n * n)
            .map(|k| corner + Vector2::new((k % n) as f64 + 0.5, (k / n) as f64 + 0.5) * s)
            .collect();
        (x, vec![s * s; n * n])
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
