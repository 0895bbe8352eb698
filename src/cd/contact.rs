use crate::geom::V2;
use serde::{Deserialize, Serialize};

/// The antagonist of a contact: another disk or a wall.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Partner {
    Body(u32),
    Wall(u32),
}

/// One candidate contact, frozen for a step: disk `i` against `j`, normal `n` from `j` into
/// `i`, gap at the detection configuration, the diagonal Delassus terms, and its impulse
/// (p_n, p_t) over the step (N s/m), and the rolling impulse p_r: the moment impulse
/// ℓ p_r on `i` (−ℓ p_r on `j`), ℓ = r_i r_j/(r_i + r_j), or r_i on a wall (METHODS.md
/// §1.10). Mean contact force = impulse / h.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    pub i: u32,
    pub j: Partner,
    pub law: u16,
    pub n: V2,
    pub gap: f64,
    pub w_nn: f64,
    pub w_tt: f64,
    pub p_n: f64,
    pub p_t: f64,
    pub p_r: f64,
}

impl Contact {
    pub fn key(&self) -> (u32, Partner) {
        (self.i, self.j)
    }
}
