//! VTK frames of disk sets (rigid disks, BPM particles) for ParaView and pyvista.

use crate::cd::Bodies;
use crate::io::vtk::{Data, Frame, Series, write_vtu};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The frames written so far in one stage folder (kept in snapshots, so a resumed stage
/// continues the same `series.pvd`).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct FrameLog {
    pub entries: Vec<(f64, String)>,
}

impl FrameLog {
    /// Writes `frame_NNNNNN.vtu` with `grain_id`, `radius`, `velocity`, `omega` and
    /// rewrites `series.pvd`.
    pub fn write_disks(&mut self, dir: &Path, time: f64, b: &Bodies) -> std::io::Result<()> {
        let points: Vec<[f64; 2]> = b.pos.iter().map(|p| [p.x, p.y]).collect();
        let vel: Vec<[f64; 2]> = b.vel.iter().map(|v| [v.x, v.y]).collect();
        let grain: Vec<i32> = b.group.iter().map(|&g| g as i32).collect();
        let frame = Frame::new(&points)
            .with("grain_id", Data::Int(&grain))
            .with("radius", Data::Scalar(&b.radius))
            .with("velocity", Data::Vector(&vel))
            .with("omega", Data::Scalar(&b.omega));
        let file = format!("frame_{:06}.vtu", self.entries.len());
        write_vtu(&dir.join(&file), &frame)?;
        self.entries.push((time, file));
        self.write_pvd(&dir.join("series.pvd"))
    }

    /// Writes the collection of every frame logged so far.
    pub fn write_pvd(&self, path: &Path) -> std::io::Result<()> {
        let mut series = Series::new();
        for (t, f) in &self.entries {
            series.push(*t, f);
        }
        series.write_pvd(path)
    }
}
