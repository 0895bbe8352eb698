//! VTK frame series of a stage folder, for ParaView and pyvista.

use crate::cd::{Bodies, InteractionLaw, Partner, Scene};
use crate::io::vtk::{Data, Frame, Lines, Series, write_vtu};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One series of frames in a stage folder, `<prefix>_NNNNNN.vtu` listed in `<pvd>`. It is
/// kept in snapshots, so a resumed stage continues the same series.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameLog {
    prefix: String,
    pvd: String,
    series: Series,
}

impl FrameLog {
    pub fn new(prefix: &str, pvd: &str) -> Self {
        FrameLog {
            prefix: prefix.into(),
            pvd: pvd.into(),
            series: Series::new(),
        }
    }

    /// The particles or points of a stage: `frame_NNNNNN.vtu` in `series.pvd`.
    pub fn particles() -> Self {
        FrameLog::new("frame", "series.pvd")
    }

    /// Writes the next frame at `time` and rewrites the collection file.
    pub fn write(&mut self, dir: &Path, time: f64, frame: &Frame) -> std::io::Result<()> {
        let file = format!("{}_{:06}.vtu", self.prefix, self.series.entries().len());
        write_vtu(&dir.join(&file), frame)?;
        self.series.push(time, &file);
        self.series.write_pvd(&dir.join(&self.pvd))
    }

    /// A frame of disks with `grain_id`, `radius`, `velocity` and `omega`.
    pub fn write_disks(&mut self, dir: &Path, time: f64, b: &Bodies) -> std::io::Result<()> {
        let points: Vec<[f64; 2]> = b.pos.iter().map(|p| [p.x, p.y]).collect();
        let vel: Vec<[f64; 2]> = b.vel.iter().map(|v| [v.x, v.y]).collect();
        let grain: Vec<i32> = b.group.iter().map(|&g| g as i32).collect();
        let frame = Frame::new(&points)
            .with("grain_id", Data::Int(&grain))
            .with("radius", Data::Scalar(&b.radius))
            .with("velocity", Data::Vector(&vel))
            .with("omega", Data::Scalar(&b.omega));
        self.write(dir, time, &frame)
    }

    /// Paper Figs. 5c and 8g: a line per repulsive disk-disk contact of the last step, cell
    /// data `normal_force` (N/m, the step's impulse over h).
    pub fn write_network<L: InteractionLaw>(
        &mut self,
        dir: &Path,
        scene: &Scene<L>,
    ) -> std::io::Result<()> {
        let b = &scene.bodies;
        let h = scene.params.dt;
        let points: Vec<[f64; 2]> = b.pos.iter().map(|p| [p.x, p.y]).collect();
        let mut pairs = Vec::new();
        let mut force = Vec::new();
        for c in &scene.contacts {
            if let Partner::Body(j) = c.j
                && c.p_n > 0.0
            {
                pairs.push([c.i, j]);
                force.push(c.p_n / h);
            }
        }
        let grain: Vec<i32> = b.group.iter().map(|&g| g as i32).collect();
        let frame = Frame::new(&points)
            .with("grain_id", Data::Int(&grain))
            .with("radius", Data::Scalar(&b.radius))
            .with_lines(Lines {
                pairs: &pairs,
                cell_data: vec![("normal_force", Data::Scalar(&force))],
            });
        self.write(dir, scene.time, &frame)
    }
}
