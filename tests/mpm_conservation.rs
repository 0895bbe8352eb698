//! Mass is exact and, without plates or gravity, a moving elastic grain conserves momentum.

use nalgebra::Vector2;
use softgrain::mpm::grid::Grid;
use softgrain::mpm::points::Points;
use softgrain::mpm::{Material, MaterialKind, ShapeKind, Solver, SolverParams};

fn grain(shape: ShapeKind, bbar: bool) {
    let r = 5e-3;
    let n = 12.0;
    let h = 2.0 * r / n;
    let grid = Grid {
        origin: Vector2::new(-12.0 * h, -12.0 * h),
        h,
        nx: 25,
        ny: 25,
    };
    let mat = Material {
        kind: MaterialKind::LinearElastic,
        young: 10e6,
        poisson: 0.45,
        density: 990.0,
    };
    let mut pts = Points::seed_disk(&grid, Vector2::zeros(), r, mat.density);
    let area: f64 = pts.vol0.iter().sum();
    assert!((area / (std::f64::consts::PI * r * r) - 1.0).abs() < 1e-14);
    let mass0 = pts.total_mass();
    // Translation plus a shear-like velocity field, so the grain deforms and rings.
    for (x, v) in pts.x.iter().zip(pts.v.iter_mut()) {
        *v = Vector2::new(0.5 + 20.0 * x.y, -0.3 + 10.0 * x.x * x.x / r);
    }
    let p0 = pts.momentum();
    let params = SolverParams {
        shape,
        bbar,
        ..SolverParams::default()
    };
    let mut solver = Solver::default();
    let dt = 0.1 * h / 0.5;
    for step in 0..10 {
        solver
            .step(&params, &grid, &mat, &mut pts, &mut [], dt, step)
            .unwrap();
    }
    assert_eq!(pts.total_mass(), mass0);
    let p1 = pts.momentum();
    let scale = mass0 * 1.0;
    assert!(
        (p1 - p0).norm() < 1e-9 * scale,
        "{shape:?} bbar {bbar}: {p0} -> {p1}"
    );
}

#[test]
fn momentum_is_conserved_in_free_flight() {
    for shape in [ShapeKind::Bilinear, ShapeKind::Gimp, ShapeKind::BSpline2] {
        for bbar in [false, true] {
            grain(shape, bbar);
        }
    }
}
