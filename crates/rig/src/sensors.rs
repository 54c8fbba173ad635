//! Synthetic measurements from a simulated trace: what a data logger on the
//! real rig would record.
//!
//! For each channel c (head pressure, rod pressure, position, and
//! optionally the two temperatures and the velocity) and sample i:
//!
//! ```text
//!   y_c,i = Q_c( o_c + (1 + g_c) · s_c(t_i) + σ_c ε_c,i )
//! ```
//!
//! * s_c(t_i): the simulated signal at the true sampling instant t_i;
//! * o_c ~ N(0, σ_o,c²): a constant offset, drawn once per experiment;
//! * g_c ~ N(0, σ_g,c²): a constant gain error, drawn once per experiment
//!   (applied to the absolute value, e.g. to absolute pressure);
//! * ε_c,i ~ N(0, 1): white noise;
//! * Q_c: quantisation to a multiple of the channel's quantum (none if 0).
//!
//! Timing: nominal sampling every Δ from t_start, each instant displaced by
//! Gaussian jitter (σ_j, clipped to ±0.4Δ so the order is kept); each sample
//! is dropped with probability p_drop; the logger's time stamps are
//! t_i + skew (a constant offset between the logger clock and the command
//! at t = 0).
//!
//! Random numbers: xoshiro256** (Blackman & Vigna, "Scrambled linear
//! pseudorandom number generators", ACM TOMS 47 (2021)) seeded through
//! SplitMix64, Gaussians by the Box–Muller transform. Everything is a
//! deterministic function of the seed; the timing and the sensor errors use
//! separate streams, so changing e.g. the noise level does not move the
//! sampling instants.
//!
//! The CSV has the header `t,head.p,rod.p,piston.x` (+ `head.T,rod.T`,
//! `piston.v` when enabled), SI units: s, Pa absolute, m, K, m/s — the
//! signal names of `models/meter_out.json`, so pneumo's reader needs no
//! column mapping.

use std::io::Write;

use crate::error::RigError;
use crate::params::{Effects, ModelForm, Rig, RunSpec, Sampling};
use crate::sim::{simulate, Trace};

/// xoshiro256** seeded with SplitMix64.
#[derive(Debug, Clone)]
pub struct Rng {
    s: [u64; 4],
    spare: Option<f64>,
}

fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Rng {
    /// A generator for `seed` (any value, including 0).
    pub fn new(seed: u64) -> Self {
        let mut sm = seed;
        let s = [splitmix64(&mut sm), splitmix64(&mut sm), splitmix64(&mut sm), splitmix64(&mut sm)];
        Rng { s, spare: None }
    }

    /// An independent stream derived from `seed` and a stream number.
    pub fn stream(seed: u64, stream: u64) -> Self {
        let mut sm = seed ^ stream.wrapping_mul(0xD605_BBB5_8C8A_BBB5);
        Rng::new(splitmix64(&mut sm))
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let result = self.s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = self.s[1] << 17;
        self.s[2] ^= self.s[0];
        self.s[3] ^= self.s[1];
        self.s[1] ^= self.s[2];
        self.s[0] ^= self.s[3];
        self.s[2] ^= t;
        self.s[3] = self.s[3].rotate_left(45);
        result
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard normal (Box–Muller; the second value is kept for the next call).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        // u1 in (0, 1] so the logarithm is finite
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let a = 2.0 * std::f64::consts::PI * u2;
        self.spare = Some(r * a.sin());
        r * a.cos()
    }
}

/// Error model of one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Channel {
    /// White noise standard deviation [channel unit].
    pub noise: f64,
    /// Standard deviation of the constant offset drawn per experiment.
    pub offset_sd: f64,
    /// Standard deviation of the relative gain error drawn per experiment.
    pub gain_sd: f64,
    /// Quantisation step (0: none).
    pub quantum: f64,
}

impl Channel {
    fn validate(&self, name: &str) -> Result<(), RigError> {
        for (k, v) in [("noise", self.noise), ("offset_sd", self.offset_sd), ("gain_sd", self.gain_sd), ("quantum", self.quantum)] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(RigError::invalid(&format!("sensors.{name}.{k}"), v, "must be non-negative and finite"));
            }
        }
        Ok(())
    }
}

/// The logger and its sensors.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorSpec {
    /// Both pressure channels [Pa]. Default: noise 5 mbar, offset 10 mbar.
    pub pressure: Channel,
    /// Position [m]. Default: noise 20 µm, quantum 10 µm.
    pub position: Channel,
    /// Temperatures [K]. Default: noise 0.2 K, offset 0.3 K.
    pub temperature: Channel,
    /// Velocity [m/s]. Default: noise 1 mm/s.
    pub velocity: Channel,
    /// Nominal sampling interval Δ [s]. Default 1 ms (1 kHz).
    pub interval: f64,
    /// First nominal instant [s] (negative: the logger runs before the command).
    pub t_start: f64,
    /// Standard deviation of the sampling jitter [s]. Default 20 µs.
    pub jitter_sd: f64,
    /// Probability that a sample is lost. Default 0.
    pub dropout: f64,
    /// Logger clock minus simulation time [s]. Default 0.
    pub time_skew: f64,
    /// Write `head.T` and `rod.T`.
    pub temperatures: bool,
    /// Write `piston.v`.
    pub velocity_column: bool,
}

impl Default for SensorSpec {
    fn default() -> Self {
        SensorSpec {
            pressure: Channel { noise: 500.0, offset_sd: 1000.0, gain_sd: 0.0, quantum: 0.0 },
            position: Channel { noise: 20e-6, offset_sd: 0.0, gain_sd: 0.0, quantum: 10e-6 },
            temperature: Channel { noise: 0.2, offset_sd: 0.3, gain_sd: 0.0, quantum: 0.0 },
            velocity: Channel { noise: 1e-3, offset_sd: 0.0, gain_sd: 0.0, quantum: 0.0 },
            interval: 1e-3,
            t_start: 0.0,
            jitter_sd: 20e-6,
            dropout: 0.0,
            time_skew: 0.0,
            temperatures: false,
            velocity_column: false,
        }
    }
}

impl SensorSpec {
    /// An ideal logger: no noise, offsets, gain errors, quantisation, jitter.
    pub fn ideal() -> Self {
        let z = Channel { noise: 0.0, offset_sd: 0.0, gain_sd: 0.0, quantum: 0.0 };
        SensorSpec { pressure: z, position: z, temperature: z, velocity: z, jitter_sd: 0.0, ..SensorSpec::default() }
    }

    /// Checks the settings.
    pub fn validate(&self) -> Result<(), RigError> {
        self.pressure.validate("pressure")?;
        self.position.validate("position")?;
        self.temperature.validate("temperature")?;
        self.velocity.validate("velocity")?;
        if !(self.interval > 0.0 && self.interval.is_finite()) {
            return Err(RigError::invalid("sensors.interval", self.interval, "must be positive and finite"));
        }
        if !(self.jitter_sd >= 0.0 && self.jitter_sd.is_finite()) {
            return Err(RigError::invalid("sensors.jitter_sd", self.jitter_sd, "must be non-negative and finite"));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(RigError::invalid("sensors.dropout", self.dropout, "must lie in [0, 1)"));
        }
        if !self.time_skew.is_finite() || !self.t_start.is_finite() {
            return Err(RigError::invalid("sensors.time_skew", self.time_skew, "must be finite"));
        }
        Ok(())
    }
}

/// The per-experiment draws (offsets and gain errors), kept for reference.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Draws {
    /// Offsets of head p, rod p, x, head T, rod T, v.
    pub offset: [f64; 6],
    /// Gain errors, same order.
    pub gain: [f64; 6],
}

/// Logged data: logger time stamps and named columns (SI).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Measurements {
    /// Logger time stamps [s].
    pub t: Vec<f64>,
    /// (column name, values).
    pub columns: Vec<(String, Vec<f64>)>,
    /// The offsets and gains drawn for this experiment.
    pub draws: Draws,
}

const STREAM_CLOCK: u64 = 1;
const STREAM_SENSOR: u64 = 2;

/// True sampling instants (simulation time) up to `t_end`: nominal grid,
/// jitter and dropouts, drawn from the clock stream of `seed`.
pub fn sample_instants(spec: &SensorSpec, t_end: f64, seed: u64) -> Result<Vec<f64>, RigError> {
    spec.validate()?;
    let mut rng = Rng::stream(seed, STREAM_CLOCK);
    let mut out = Vec::new();
    let lim = 0.4 * spec.interval;
    let mut k = 0u64;
    loop {
        let nominal = spec.t_start + k as f64 * spec.interval;
        if nominal > t_end {
            break;
        }
        let jitter = if spec.jitter_sd > 0.0 { (spec.jitter_sd * rng.normal()).clamp(-lim, lim) } else { 0.0 };
        let keep = spec.dropout == 0.0 || rng.uniform() >= spec.dropout;
        let t = nominal + jitter;
        if keep && t <= t_end {
            out.push(t);
        }
        k += 1;
    }
    Ok(out)
}

fn quantise(v: f64, q: f64) -> f64 {
    if q > 0.0 {
        (v / q).round() * q
    } else {
        v
    }
}

/// Turns a trace into logged data: every trace sample becomes one logged
/// sample (so sample the simulation at [`sample_instants`] first, as
/// [`acquire`] does). Sensor errors come from the sensor stream of `seed`.
pub fn measure(trace: &Trace, spec: &SensorSpec, seed: u64) -> Result<Measurements, RigError> {
    spec.validate()?;
    let mut rng = Rng::stream(seed, STREAM_SENSOR);
    let chans = [spec.pressure, spec.pressure, spec.position, spec.temperature, spec.temperature, spec.velocity];
    let mut draws = Draws::default();
    for (i, c) in chans.iter().enumerate() {
        draws.offset[i] = c.offset_sd * rng.normal();
        draws.gain[i] = c.gain_sd * rng.normal();
    }
    let names = ["head.p", "rod.p", "piston.x", "head.T", "rod.T", "piston.v"];
    let signals: [&Vec<f64>; 6] = [&trace.p1, &trace.p2, &trace.x, &trace.temp1, &trace.temp2, &trace.v];
    let mut wanted = vec![0usize, 1, 2];
    if spec.temperatures {
        wanted.extend([3, 4]);
    }
    if spec.velocity_column {
        wanted.push(5);
    }
    let mut columns: Vec<(String, Vec<f64>)> = wanted.iter().map(|&i| (names[i].to_string(), Vec::with_capacity(trace.t.len()))).collect();
    for k in 0..trace.t.len() {
        for (col, &i) in columns.iter_mut().zip(&wanted) {
            let c = chans[i];
            let noise = if c.noise > 0.0 { c.noise * rng.normal() } else { 0.0 };
            let s = signals[i].get(k).copied().unwrap_or(f64::NAN);
            let v = draws.offset[i] + (1.0 + draws.gain[i]) * s + noise;
            col.1.push(quantise(v, c.quantum));
        }
    }
    let t = trace.t.iter().map(|t| t + spec.time_skew).collect();
    Ok(Measurements { t, columns, draws })
}

/// Simulates the rig at the logger's instants and measures the trace. The
/// run's own sampling is replaced by the logger's; its `t_end` bounds the
/// record (the run also ends after `run.cycles` cycles).
pub fn acquire(
    rig: &Rig,
    form: &ModelForm,
    effects: &Effects,
    run: &RunSpec,
    spec: &SensorSpec,
    seed: u64,
) -> Result<(Trace, Measurements), RigError> {
    let instants = sample_instants(spec, run.t_end, seed)?;
    let run = RunSpec { sampling: Sampling::At(instants), ..run.clone() };
    let trace = simulate(rig, form, effects, &run)?;
    let m = measure(&trace, spec, seed)?;
    Ok((trace, m))
}

/// Writes the measurements as CSV (header `t,head.p,rod.p,piston.x`…,
/// shortest round-trip decimal representation of every value).
pub fn write_csv<W: Write>(m: &Measurements, mut w: W) -> Result<(), RigError> {
    let io = |e: std::io::Error| RigError::Io(e.to_string());
    let mut header = String::from("t");
    for (name, _) in &m.columns {
        header.push(',');
        header.push_str(name);
    }
    writeln!(w, "{header}").map_err(io)?;
    let mut line = String::new();
    for k in 0..m.t.len() {
        line.clear();
        line.push_str(&format!("{}", m.t[k]));
        for (_, col) in &m.columns {
            line.push(',');
            line.push_str(&format!("{}", col[k]));
        }
        writeln!(w, "{line}").map_err(io)?;
    }
    w.flush().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xoshiro_reference_values() {
        // xoshiro256** from the state {1, 2, 3, 4}: the first outputs of
        // the reference implementation are 11520, 0, 1509978240, 1215971899390074240
        let mut r = Rng { s: [1, 2, 3, 4], spare: None };
        assert_eq!(r.next_u64(), 11520);
        assert_eq!(r.next_u64(), 0);
        assert_eq!(r.next_u64(), 1509978240);
        assert_eq!(r.next_u64(), 1215971899390074240);
    }

    #[test]
    fn splitmix_reference_value() {
        // SplitMix64 from state 0: first output 0xE220A8397B1DCDAF
        let mut s = 0u64;
        assert_eq!(splitmix64(&mut s), 0xE220_A839_7B1D_CDAF);
    }

    #[test]
    fn normal_moments() {
        let mut r = Rng::new(42);
        let n = 200_000;
        let (mut s1, mut s2, mut s4) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let z = r.normal();
            s1 += z;
            s2 += z * z;
            s4 += z * z * z * z;
        }
        let (m, v, k) = (s1 / n as f64, s2 / n as f64, s4 / n as f64);
        assert!(m.abs() < 0.01, "{m}");
        assert!((v - 1.0).abs() < 0.01, "{v}");
        assert!((k - 3.0).abs() < 0.05, "{k}");
    }

    #[test]
    fn instants_are_sorted_and_jittered_within_bounds() {
        let spec = SensorSpec { jitter_sd: 1e-3, dropout: 0.1, ..SensorSpec::default() };
        let t = sample_instants(&spec, 1.0, 7).unwrap();
        assert!(t.windows(2).all(|w| w[1] > w[0]));
        assert!(t.len() > 850 && t.len() < 950, "{}", t.len());
        let again = sample_instants(&spec, 1.0, 7).unwrap();
        assert_eq!(t, again);
    }

    #[test]
    fn quantisation() {
        assert!((quantise(0.123_456, 1e-3) - 0.123).abs() < 1e-15);
        assert!((quantise(-2.6e-5, 1e-5) + 3e-5).abs() < 1e-18);
        assert_eq!(quantise(7.0, 0.0), 7.0);
    }
}
