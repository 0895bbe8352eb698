//! Plane geometry shared by the engines: 2-vectors, wall segments and the cell list.

mod cells;
mod wall;

pub use cells::CellList;
pub use wall::Wall;

/// A 2-vector in metres (positions), m/s (velocities) or N/m (forces per unit thickness).
pub type V2 = nalgebra::Vector2<f64>;

/// Unit tangent of a contact frame: the normal turned by +90 degrees, t = (-n_y, n_x).
#[inline]
pub fn perp(n: V2) -> V2 {
    V2::new(-n.y, n.x)
}
