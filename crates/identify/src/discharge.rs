//! Discharge-test identification (being written).
