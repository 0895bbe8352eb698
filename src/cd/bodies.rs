use crate::geom::V2;
use serde::{Deserialize, Serialize};

/// Rigid disks as structure-of-arrays. Masses are per unit thickness (kg/m), inertia
/// I = m r²/2 (kg m²/m). `group` is the grain a disk belongs to: disks of one group
/// interact through the table's same-group law (the BPM cohesion), others through the
/// other-group law. A body with 1/m = 0 (and 1/I = 0) is fixed: contacts cannot move it, and
/// it carries no mass or kinetic energy in the sums below.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Bodies {
    pub pos: Vec<V2>,
    pub angle: Vec<f64>,
    pub vel: Vec<V2>,
    pub omega: Vec<f64>,
    pub radius: Vec<f64>,
    pub inv_mass: Vec<f64>,
    pub inv_inertia: Vec<f64>,
    pub group: Vec<u32>,
    /// Constant external force on each disk (N/m), besides gravity.
    pub force: Vec<V2>,
}

impl Bodies {
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Adds a disk of areal density `density` (kg/m³ times unit thickness) at rest.
    pub fn push(&mut self, pos: V2, radius: f64, density: f64, group: u32) {
        let mass = density * std::f64::consts::PI * radius * radius;
        self.pos.push(pos);
        self.angle.push(0.0);
        self.vel.push(V2::zeros());
        self.omega.push(0.0);
        self.radius.push(radius);
        self.inv_mass.push(1.0 / mass);
        self.inv_inertia.push(2.0 / (mass * radius * radius));
        self.group.push(group);
        self.force.push(V2::zeros());
    }

    pub fn mass(&self, i: usize) -> f64 {
        1.0 / self.inv_mass[i]
    }

    pub fn is_fixed(&self, i: usize) -> bool {
        self.inv_mass[i] == 0.0
    }

    /// The bodies that can move.
    pub fn movable(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.len()).filter(|&i| !self.is_fixed(i))
    }

    pub fn total_mass(&self) -> f64 {
        self.movable().map(|i| 1.0 / self.inv_mass[i]).sum()
    }

    pub fn kinetic_energy(&self) -> f64 {
        self.movable()
            .map(|i| {
                0.5 * (self.vel[i].norm_squared() / self.inv_mass[i]
                    + self.omega[i] * self.omega[i] / self.inv_inertia[i])
            })
            .sum()
    }

    /// Kinetic energy of the centres' motion only (J/m).
    pub fn translational_energy(&self) -> f64 {
        self.movable()
            .map(|i| 0.5 * self.vel[i].norm_squared() / self.inv_mass[i])
            .sum()
    }

    pub fn max_radius(&self) -> f64 {
        self.radius.iter().cloned().fold(0.0, f64::max)
    }

    pub fn mean_radius(&self) -> f64 {
        self.radius.iter().sum::<f64>() / self.len().max(1) as f64
    }
}
