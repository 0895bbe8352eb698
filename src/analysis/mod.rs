//! Post-processing (METHODS.md §5): the cases' time series as Polars frames, the paper's
//! measures and fits on them, figures (plotters) and the report. Pure functions of the
//! compact stages' states; `stages::analyse` is the glue that reads and writes.

pub mod figures;
pub mod fits;
pub mod measures;
pub mod plots;
pub mod reference;
pub mod report;
pub mod series;
pub mod summary;
