//! Dense output of one RODAS4 step (continuous extension of order 3).
//!
//! Formula (Hairer & Wanner, *Solving ODEs II*, §IV.7, dense output of RODAS;
//! coefficients in `rodas4.rs`), with `θ = (t − t0)/(t1 − t0)`:
//! `y(t) ≈ (1 − θ)·y0 + θ·[y1 + (1 − θ)·(q1 + θ·q2)]`.
//! It interpolates `y0` at `θ = 0` and `y1` at `θ = 1` exactly, so the piecewise
//! dense output is continuous across steps. Units: those of the states and of `t`.

use crate::Dense;

/// Borrowed view of the interpolation data of one accepted step.
pub(crate) struct StepDense<'a> {
    /// Step start.
    pub t0: f64,
    /// Natural step end (`t0 + h`).
    pub t1: f64,
    /// End of the valid interval reported to observers (≤ `t1` in the step direction).
    pub t_end: f64,
    pub y0: &'a [f64],
    pub y1: &'a [f64],
    pub q1: &'a [f64],
    pub q2: &'a [f64],
    /// Sensitivity columns of the step (empty without sensitivities).
    pub sens: &'a [SensColumn],
}

/// One forward sensitivity column over an accepted step: its value at the
/// step start and end and the coefficients of its dense output (the same
/// formula as the state's, from the column's own stage increments).
#[derive(Debug, Clone, Default)]
pub(crate) struct SensColumn {
    pub s0: Vec<f64>,
    pub s1: Vec<f64>,
    pub q1: Vec<f64>,
    pub q2: Vec<f64>,
}

impl StepDense<'_> {
    /// Interpolate at `t` (no range check).
    pub(crate) fn interpolate(&self, t: f64, out: &mut [f64]) {
        if t == self.t1 {
            // the step's own end, bit for bit (a caller may recognise the point)
            out[..self.y1.len()].copy_from_slice(self.y1);
            return;
        }
        let h = self.t1 - self.t0;
        let theta = if h != 0.0 { (t - self.t0) / h } else { 1.0 };
        let s1 = 1.0 - theta;
        for (i, o) in out.iter_mut().enumerate().take(self.y0.len()) {
            // written around y0 so that a state that does not change is returned bit-exactly
            *o = self.y0[i] + theta * ((self.y1[i] - self.y0[i]) + s1 * (self.q1[i] + theta * self.q2[i]));
        }
    }
}

impl Dense for StepDense<'_> {
    fn t_start(&self) -> f64 {
        self.t0
    }
    fn t_end(&self) -> f64 {
        self.t_end
    }
    fn eval(&self, t: f64, out: &mut [f64]) {
        self.interpolate(t, out);
    }
    fn eval_sensitivity(&self, k: usize, t: f64, out: &mut [f64]) -> bool {
        let Some(c) = self.sens.get(k) else { return false };
        let view = StepDense { t0: self.t0, t1: self.t1, t_end: self.t_end, y0: &c.s0, y1: &c.s1, q1: &c.q1, q2: &c.q2, sens: &[] };
        view.interpolate(t, out);
        true
    }
}
