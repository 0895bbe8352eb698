//! How a BPM packing's Φ depends on the grain-area convention (issue #6; the paper's warning
//! that above Φ ≈ 0.98 Φ "is defined up to the porosity along all grain-grain interfaces").
//!
//! `cargo run --release --example phi_conventions -- <compact case folder> [min strain]`,
//! e.g. `-- runs/paper-coarse/compact/bpm-mu0 0.3`. Reads the folder's `timeseries.csv` and
//! its `frame_*.vtu` (one per row), and recomputes each frame's grain areas by morphological
//! closing with the structuring radius s = r_min, r_max (the convention Φ is reported in) and
//! 2 r_max, and as the particles' own area (no pores at all). The box area L h0 e^-ε is
//! calibrated on the first frame (the reported Φ0 and its r_max areas), so at later strains
//! the r_max column checks the reported Φ independently. Prints CSV; nothing is written.

use softgrain::bpm::measure::closed_area;
use softgrain::geom::V2;
use std::path::Path;
use vtkio::Vtk;
use vtkio::model::{Attribute, IOBuffer, UnstructuredGridPiece};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = Path::new(
        args.get(1)
            .expect("usage: phi_conventions <case folder> [min strain]"),
    );
    let min_strain: f64 = args.get(2).map_or(0.0, |s| s.parse().expect("min strain"));
    let csv = std::fs::read_to_string(dir.join("timeseries.csv")).expect("timeseries.csv");
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).expect(name);
    let (strain_col, phi_col) = (col("strain"), col("phi"));
    let rows: Vec<(f64, f64)> = lines
        .map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect();
            (v[strain_col], v[phi_col])
        })
        .collect();
    // L h0, from the first frame in the reported convention
    let first = read_grains(&dir.join("frame_000000.vtu"));
    let box0 = total_area(&first, max_radius(&first)) / rows[0].1;
    println!("strain,phi_reported,phi_closed_rmax,phi_closed_rmin,phi_closed_2rmax,phi_particles");
    for (k, &(strain, phi)) in rows.iter().enumerate() {
        if strain < min_strain {
            continue;
        }
        let frame = dir.join(format!("frame_{k:06}.vtu"));
        if !frame.exists() {
            continue;
        }
        let grains = read_grains(&frame);
        let (r_min, r_max) = (min_radius(&grains), max_radius(&grains));
        let total = |s: f64| total_area(&grains, s);
        let box_area = box0 * (-strain).exp();
        let particles: f64 = grains
            .iter()
            .flat_map(|g| &g.1)
            .map(|r| std::f64::consts::PI * r * r)
            .sum();
        println!(
            "{strain:.4},{phi:.4},{:.4},{:.4},{:.4},{:.4}",
            total(r_max) / box_area,
            total(r_min) / box_area,
            total(2.0 * r_max) / box_area,
            particles / box_area
        );
    }
}

/// The grains' total area closed with radius `s`, on the pipeline's raster (pixel r_min / 2).
fn total_area(grains: &[(Vec<V2>, Vec<f64>)], s: f64) -> f64 {
    let pixel = 0.5 * min_radius(grains);
    grains
        .iter()
        .map(|(pos, rad)| closed_area(pos, rad, s, pixel))
        .sum()
}

fn min_radius(grains: &[(Vec<V2>, Vec<f64>)]) -> f64 {
    grains
        .iter()
        .flat_map(|g| &g.1)
        .cloned()
        .fold(f64::INFINITY, f64::min)
}

fn max_radius(grains: &[(Vec<V2>, Vec<f64>)]) -> f64 {
    grains
        .iter()
        .flat_map(|g| &g.1)
        .cloned()
        .fold(0.0, f64::max)
}

/// Each grain's particle centres and radii, from a frame's `grain_id` and `radius`.
fn read_grains(path: &Path) -> Vec<(Vec<V2>, Vec<f64>)> {
    let vtk = Vtk::import(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let piece = UnstructuredGridPiece::try_from(vtk.data).expect("one UnstructuredGrid piece");
    let xyz: Vec<f64> = piece.points.cast_into().expect("points");
    let (mut ids, mut radius) = (Vec::new(), Vec::new());
    for a in &piece.data.point {
        if let Attribute::DataArray(d) = a {
            match (d.name.as_str(), &d.data) {
                ("grain_id", IOBuffer::I32(v)) => ids = v.clone(),
                ("radius", IOBuffer::F64(v)) => radius = v.clone(),
                _ => {}
            }
        }
    }
    let n = ids.iter().cloned().max().map_or(0, |m| m as usize + 1);
    let mut grains = vec![(Vec::new(), Vec::new()); n];
    for (i, &g) in ids.iter().enumerate() {
        grains[g as usize]
            .0
            .push(V2::new(xyz[3 * i], xyz[3 * i + 1]));
        grains[g as usize].1.push(radius[i]);
    }
    grains
}
