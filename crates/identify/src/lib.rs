//! Calibration and discrepancy analysis (placeholder, being written).

pub mod discharge;
pub mod lsq;
