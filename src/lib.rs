pub mod mpm;
