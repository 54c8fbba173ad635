//! Calibration and discrepancy analysis (placeholder, being written).
