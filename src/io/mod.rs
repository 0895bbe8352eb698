//! Output of simulation state for visualisation and post-processing.
//!
//! See [`vtk`] for VTK XML UnstructuredGrid (`.vtu`) frames and ParaView
//! `.pvd` time series.

pub mod vtk;
