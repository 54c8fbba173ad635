//! Step sequencer: a GRAFCET-like sequential controller written in the
//! netlist — steps, transitions with conditions on on/off inputs and step
//! times, and actions that set its outputs.
//!
//! ```json
//! { "id": "seq", "type": "sequencer", "params": {
//!     "inputs":  "start, a0, a1, b0, b1",
//!     "outputs": "A, B",
//!     "transitions": ["0 -> 1 : start & a0 & b0", "1 -> 2 : a1", "2 -> 3 : b1",
//!                     "3 -> 4 : a0", "4 -> 1 : b0 & after 0.2 s"],
//!     "actions": ["A : 1, 2", "B : 2, 3"],
//!     "cycle_step": "1", "cycles": 3 } }
//! ```
//!
//! # Ports
//! - one signal input [1] per name in `inputs` (on above 0.5);
//! - one signal output [1] per name in `outputs`.
//!
//! # Parameters (defaults in brackets)
//! - `inputs`, `outputs` [text, required]: port names (letters, digits, `_`),
//!   comma-separated or as a list.
//! - `steps` [text, from the transitions]: step names in order; by default
//!   the steps named by `initial` and the transitions, in order of appearance.
//! - `initial` [text, the first step]: the initially active step(s).
//! - `transitions` [text list, required]: `"S -> T : condition"`; several
//!   sources (`"3, 7 -> 4"`, a synchronisation) or targets (`"1 -> 2, 5"`,
//!   parallel branches) separated by commas. A condition combines input
//!   names, `true`, `after <duration>` (the source step has been active that
//!   long, e.g. `after 0.5 s`), `!`/`not`, `&`/`and`, `|`/`or` and parentheses.
//! - `actions` [text list]: `"OUT : S1, S2"` — OUT is 1 while one of the
//!   steps is active (a continuous action), `"OUT = 0.7 : S3"` with another
//!   value; `"set OUT : S1"` and `"reset OUT : S4"` — stored actions, OUT
//!   keeps its value between the activation of S1 and of S4 (for
//!   single-solenoid valves that must stay actuated). An output takes either
//!   kind of action, not both; without an active action it is 0.
//! - `cycle_step` [text, the first initial step]: each re-activation of this
//!   step completes a cycle (recorded, and counted by the run's `cycles`).
//! - `cycles` [count, 0]: stop after this many cycles (0 = until the run ends).
//!
//! # Behaviour (IEC 60848 GRAFCET evolution rules)
//! A transition is enabled when all its source steps are active and fires
//! when its condition is true; all transitions firable at one instant fire
//! together (sources deactivated, targets activated), and firing repeats
//! until no transition can fire (a stable situation). Input conditions are
//! watched by one root function, the largest "truth margin" of the enabled
//! transitions (input − 0.5, negated by `not`, min over `and`, max over
//! `or`), so a transition fires exactly when its condition becomes true;
//! step times are time events. At rest (before t = 0) the outputs are those
//! of the initial situation.
//!
//! # Checked when the netlist is built
//! Every step named is declared; every input named by a condition is an
//! input; every output named by an action is an output; every step can be
//! reached from the initial situation; the transitions are well formed.

use crate::block::*;
use crate::params::{ParamSpec, Params};
use crate::support::intern;
use crate::BlockError;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::words("inputs", true, "names of the on/off input ports"),
    ParamSpec::words("outputs", true, "names of the output ports"),
    ParamSpec::words("steps", false, "step names, in order (default: from the transitions)"),
    ParamSpec::words("initial", false, "initially active step(s) (default: the first step)"),
    ParamSpec::words("transitions", true, "\"S -> T : condition\" each"),
    ParamSpec::words("actions", false, "\"OUT : S1, S2\", \"OUT = v : S\", \"set OUT : S\", \"reset OUT : S\""),
    ParamSpec::words("cycle_step", false, "a cycle completes when this step is activated again (default: initial)"),
    ParamSpec::count("cycles", Some(0.0), "cycles after which the sequencer stops (0 = until the run ends)"),
];
/// Ports shown in listings: the real ones are named by `inputs` and `outputs`.
pub const PORTS: &[PortSpec] = &[
    PortSpec::signal("<input>", PortKind::SignalIn, "1", "one per name in `inputs`"),
    PortSpec::signal("<output>", PortKind::SignalOut, "1", "one per name in `outputs`"),
];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "step", unit: "1" }];

/// A transition condition.
#[derive(Debug, Clone, PartialEq)]
pub enum Cond {
    True,
    Input(usize),
    After(f64),
    Not(Box<Cond>),
    And(Box<Cond>, Box<Cond>),
    Or(Box<Cond>, Box<Cond>),
}

impl Cond {
    /// Truth margin: > 0 when true. Inputs: u − 0.5; `after d`: ±1.
    fn margin(&self, u: &[f64], elapsed: f64) -> f64 {
        match self {
            Cond::True => 1.0,
            Cond::Input(i) => u[*i] - 0.5,
            Cond::After(d) => {
                if elapsed >= d - 1e-9 * d.max(1.0) {
                    1.0
                } else {
                    -1.0
                }
            }
            Cond::Not(c) => -c.margin(u, elapsed),
            Cond::And(a, b) => a.margin(u, elapsed).min(b.margin(u, elapsed)),
            Cond::Or(a, b) => a.margin(u, elapsed).max(b.margin(u, elapsed)),
        }
    }
    fn delays(&self, out: &mut Vec<f64>) {
        match self {
            Cond::After(d) => out.push(*d),
            Cond::Not(c) => c.delays(out),
            Cond::And(a, b) | Cond::Or(a, b) => {
                a.delays(out);
                b.delays(out);
            }
            Cond::True | Cond::Input(_) => {}
        }
    }
}

/// One transition.
#[derive(Debug, Clone, PartialEq)]
pub struct Transition {
    pub sources: Vec<usize>,
    pub targets: Vec<usize>,
    pub condition: Cond,
    pub text: String,
}

/// What an action does to its output.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// The output has this value while one of the steps is active.
    Continuous { output: usize, value: f64, steps: Vec<usize> },
    /// The output is set to 1 (`true`) or reset to 0 when one of the steps is activated.
    Stored { output: usize, set: bool, steps: Vec<usize> },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Sequencer {
    pub steps: Vec<String>,
    pub transitions: Vec<Transition>,
    pub actions: Vec<Action>,
    initial: Vec<usize>,
    cycle_step: usize,
    cycles: u64,
    ports: Vec<PortSpec>,
    n_inputs: usize,
    n_outputs: usize,
    /// Activation time of each step, `None` while inactive.
    active: Vec<Option<f64>>,
    /// Values of stored outputs.
    stored: Vec<f64>,
    last_cycle_start: Option<f64>,
    done: u64,
}

/// Names in a text parameter: each entry split at commas (and at ';').
fn names(lines: &[String]) -> Vec<String> {
    lines.iter().flat_map(|l| l.split([',', ';'])).map(|s| s.trim().to_string()).filter(|s| !s.is_empty()).collect()
}

fn entries(lines: &[String]) -> Vec<String> {
    lines.iter().flat_map(|l| l.split(';')).map(|s| s.trim().to_string()).filter(|s| !s.is_empty()).collect()
}

fn valid_name(s: &str) -> bool {
    !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Tokens of a condition.
#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Word(String),
    Number(String),
    And,
    Or,
    Not,
    Open,
    Close,
}

fn tokens(text: &str) -> Result<Vec<Tok>, String> {
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    while let Some(&c) = chars.peek() {
        match c {
            ' ' | '\t' => {
                chars.next();
            }
            '&' => {
                chars.next();
                out.push(Tok::And);
            }
            '|' => {
                chars.next();
                out.push(Tok::Or);
            }
            '!' => {
                chars.next();
                out.push(Tok::Not);
            }
            '(' => {
                chars.next();
                out.push(Tok::Open);
            }
            ')' => {
                chars.next();
                out.push(Tok::Close);
            }
            c if c.is_ascii_digit() || c == '.' => {
                let mut s = String::new();
                while let Some(&d) = chars.peek() {
                    let exponent_sign = (d == '-' || d == '+') && s.ends_with(['e', 'E']);
                    if d.is_ascii_digit() || d == '.' || d == 'e' || d == 'E' || exponent_sign {
                        s.push(d);
                        chars.next();
                    } else {
                        break;
                    }
                }
                out.push(Tok::Number(s));
            }
            c if c.is_alphanumeric() || c == '_' || c == 'µ' => {
                let mut s = String::new();
                while let Some(&d) = chars.peek() {
                    if d.is_alphanumeric() || d == '_' || d == 'µ' {
                        s.push(d);
                        chars.next();
                    } else {
                        break;
                    }
                }
                out.push(match s.as_str() {
                    "and" => Tok::And,
                    "or" => Tok::Or,
                    "not" => Tok::Not,
                    _ => Tok::Word(s),
                });
            }
            other => return Err(format!("unexpected character '{other}'")),
        }
    }
    Ok(out)
}

struct CondParser<'a> {
    toks: Vec<Tok>,
    pos: usize,
    inputs: &'a [String],
    depth: usize,
}

impl CondParser<'_> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.pos)
    }
    fn expr(&mut self) -> Result<Cond, String> {
        let mut c = self.term()?;
        while self.peek() == Some(&Tok::Or) {
            self.pos += 1;
            c = Cond::Or(Box::new(c), Box::new(self.term()?));
        }
        Ok(c)
    }
    fn term(&mut self) -> Result<Cond, String> {
        let mut c = self.factor()?;
        while self.peek() == Some(&Tok::And) {
            self.pos += 1;
            c = Cond::And(Box::new(c), Box::new(self.factor()?));
        }
        Ok(c)
    }
    fn factor(&mut self) -> Result<Cond, String> {
        self.depth += 1;
        if self.depth > 64 {
            return Err("condition nested too deeply".into());
        }
        let tok = self.peek().cloned();
        self.pos += 1;
        let c = match tok {
            Some(Tok::Not) => Cond::Not(Box::new(self.factor()?)),
            Some(Tok::Open) => {
                let c = self.expr()?;
                if self.peek() != Some(&Tok::Close) {
                    return Err("missing ')'".into());
                }
                self.pos += 1;
                c
            }
            Some(Tok::Word(w)) if w == "true" => Cond::True,
            Some(Tok::Word(w)) if w == "after" => {
                let number = match self.peek() {
                    Some(Tok::Number(n)) => n.clone(),
                    _ => return Err("\"after\" needs a duration, e.g. \"after 0.5 s\"".into()),
                };
                self.pos += 1;
                let unit = match self.peek() {
                    Some(Tok::Word(u)) => u.clone(),
                    _ => return Err(format!("\"after {number}\" needs a unit, e.g. \"after {number} s\"")),
                };
                self.pos += 1;
                let d = units::parse_quantity(&format!("{number} {unit}"), units::dim::TIME).map_err(|e| e.to_string())?;
                if !(d >= 0.0 && d.is_finite()) {
                    return Err(format!("\"after {number} {unit}\" must be a duration >= 0"));
                }
                Cond::After(d)
            }
            Some(Tok::Word(w)) => match self.inputs.iter().position(|i| *i == w) {
                Some(i) => Cond::Input(i),
                None => return Err(format!("\"{w}\" is not an input (inputs: {})", self.inputs.join(", "))),
            },
            Some(Tok::Number(n)) => return Err(format!("unexpected number {n} (a condition names inputs)")),
            Some(t) => return Err(format!("unexpected {t:?}")),
            None => return Err("the condition ends too early".into()),
        };
        self.depth -= 1;
        Ok(c)
    }
}

fn parse_condition(text: &str, inputs: &[String]) -> Result<Cond, String> {
    let toks = tokens(text)?;
    if toks.is_empty() {
        return Err("empty condition (write \"true\" for an unconditional transition)".into());
    }
    let mut p = CondParser { toks, pos: 0, inputs, depth: 0 };
    let c = p.expr()?;
    if p.pos < p.toks.len() {
        return Err(format!("unexpected {:?} after the condition", p.toks[p.pos]));
    }
    Ok(c)
}

impl Sequencer {
    pub fn from_params(p: &Params) -> Result<Self, BlockError> {
        let inputs = names(p.words("inputs"));
        let outputs = names(p.words("outputs"));
        for (what, list) in [("inputs", &inputs), ("outputs", &outputs)] {
            if list.is_empty() && what == "outputs" {
                return Err(BlockError::invalid(what, "needs at least one name"));
            }
            if let Some(bad) = list.iter().find(|n| !valid_name(n)) {
                return Err(BlockError::invalid(what, &format!("\"{bad}\" is not a port name (letters, digits, '_')")));
            }
            let mut sorted = list.clone();
            sorted.sort();
            if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
                return Err(BlockError::invalid(what, &format!("\"{}\" is named twice", w[0])));
            }
        }
        if let Some(both) = inputs.iter().find(|i| outputs.contains(i)) {
            return Err(BlockError::invalid("outputs", &format!("\"{both}\" is both an input and an output")));
        }
        // steps: declared, or collected from `initial` and the transitions
        let declared = names(p.words("steps"));
        let mut steps: Vec<String> = declared.clone();
        let step_lists: Vec<(String, String, String)> = entries(p.words("transitions"))
            .iter()
            .map(|t| {
                let (arrow, cond) = t.split_once(':').ok_or_else(|| {
                    BlockError::invalid("transitions", &format!("\"{t}\" needs the form \"S -> T : condition\""))
                })?;
                let (src, dst) = arrow
                    .split_once("->")
                    .ok_or_else(|| BlockError::invalid("transitions", &format!("\"{t}\" needs an arrow \"->\" between steps")))?;
                Ok((src.trim().to_string(), dst.trim().to_string(), cond.trim().to_string()))
            })
            .collect::<Result<_, BlockError>>()?;
        if step_lists.is_empty() {
            return Err(BlockError::invalid("transitions", "needs at least one transition"));
        }
        let initial_names = names(p.words("initial"));
        if declared.is_empty() {
            for n in initial_names.iter().cloned().chain(step_lists.iter().flat_map(|(s, d, _)| names(&[s.clone(), d.clone()]))) {
                if !steps.contains(&n) {
                    steps.push(n);
                }
            }
        }
        if let Some(bad) = steps.iter().find(|s| !valid_name(s)) {
            return Err(BlockError::invalid("steps", &format!("\"{bad}\" is not a step name (letters, digits, '_')")));
        }
        let step_index = |name: &str, param: &str| -> Result<usize, BlockError> {
            steps.iter().position(|s| s == name).ok_or_else(|| {
                BlockError::invalid(param, &format!("\"{name}\" is not a step (steps: {})", steps.join(", ")))
            })
        };
        let mut transitions = Vec::new();
        for (src, dst, cond) in &step_lists {
            let sources = names(std::slice::from_ref(src)).iter().map(|s| step_index(s, "transitions")).collect::<Result<Vec<_>, _>>()?;
            let targets = names(std::slice::from_ref(dst)).iter().map(|s| step_index(s, "transitions")).collect::<Result<Vec<_>, _>>()?;
            if sources.is_empty() || targets.is_empty() {
                return Err(BlockError::invalid("transitions", &format!("\"{src} -> {dst}\" needs steps on both sides")));
            }
            let condition = parse_condition(cond, &inputs)
                .map_err(|e| BlockError::invalid("transitions", &format!("\"{src} -> {dst} : {cond}\": {e}")))?;
            transitions.push(Transition { sources, targets, condition, text: format!("{src} -> {dst}") });
        }
        let initial = if initial_names.is_empty() {
            vec![0]
        } else {
            initial_names.iter().map(|s| step_index(s, "initial")).collect::<Result<Vec<_>, _>>()?
        };
        // every step reachable from the initial situation (a synchronisation needs all its sources)
        let mut reach = vec![false; steps.len()];
        for &i in &initial {
            reach[i] = true;
        }
        loop {
            let mut changed = false;
            for t in &transitions {
                if t.sources.iter().all(|&s| reach[s]) {
                    for &d in &t.targets {
                        changed |= !reach[d];
                        reach[d] = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let unreachable: Vec<&str> = steps.iter().zip(&reach).filter(|(_, r)| !**r).map(|(s, _)| s.as_str()).collect();
        if !unreachable.is_empty() {
            return Err(BlockError::invalid(
                "transitions",
                &format!("step(s) {} cannot be reached from the initial step(s)", unreachable.join(", ")),
            ));
        }
        // actions
        let mut actions = Vec::new();
        for a in entries(p.words("actions")) {
            let (head, list) =
                a.split_once(':').ok_or_else(|| BlockError::invalid("actions", &format!("\"{a}\" needs the form \"OUT : S1, S2\"")))?;
            let step_ids = names(&[list.to_string()]).iter().map(|s| step_index(s, "actions")).collect::<Result<Vec<_>, _>>()?;
            let head = head.trim();
            let (kind, rest) = match head.split_once(char::is_whitespace) {
                Some((w, rest)) if w == "set" || w == "reset" => (Some(w == "set"), rest.trim()),
                _ => (None, head),
            };
            let (name, value) = match rest.split_once('=') {
                Some((n, v)) => {
                    let v = v.trim().parse::<f64>().map_err(|_| BlockError::invalid("actions", &format!("\"{a}\": \"{}\" is not a number", v.trim())))?;
                    (n.trim(), v)
                }
                None => (rest, 1.0),
            };
            let output = outputs.iter().position(|o| o == name).ok_or_else(|| {
                BlockError::invalid("actions", &format!("\"{name}\" is not an output (outputs: {})", outputs.join(", ")))
            })?;
            actions.push(match kind {
                Some(set) => Action::Stored { output, set, steps: step_ids },
                None => Action::Continuous { output, value, steps: step_ids },
            });
        }
        for (o, name) in outputs.iter().enumerate() {
            let continuous = actions.iter().any(|a| matches!(a, Action::Continuous { output, .. } if *output == o));
            let stored = actions.iter().any(|a| matches!(a, Action::Stored { output, .. } if *output == o));
            if continuous && stored {
                return Err(BlockError::invalid("actions", &format!("output \"{name}\" has both continuous and set/reset actions")));
            }
        }
        let cycle_names = names(p.words("cycle_step"));
        let cycle_step = match cycle_names.as_slice() {
            [] => initial[0],
            [one] => step_index(one, "cycle_step")?,
            _ => return Err(BlockError::invalid("cycle_step", "names one step")),
        };
        let mut ports: Vec<PortSpec> =
            inputs.iter().map(|n| PortSpec::signal(intern(n), PortKind::SignalIn, "1", "sequencer input (on above 0.5)")).collect();
        ports.extend(outputs.iter().map(|n| PortSpec::signal(intern(n), PortKind::SignalOut, "1", "sequencer output")));
        let mut s = Sequencer {
            steps,
            transitions,
            actions,
            initial,
            cycle_step,
            cycles: p.get("cycles") as u64,
            ports,
            n_inputs: inputs.len(),
            n_outputs: outputs.len(),
            active: Vec::new(),
            stored: vec![0.0; outputs.len()],
            last_cycle_start: None,
            done: 0,
        };
        s.reset();
        Ok(s)
    }

    /// Back to the initial situation at t = 0.
    fn reset(&mut self) {
        self.active = vec![None; self.steps.len()];
        for &i in &self.initial {
            self.active[i] = Some(0.0);
        }
        self.stored.fill(0.0);
        self.apply_stored(&self.initial.clone());
        self.last_cycle_start = self.initial.contains(&self.cycle_step).then_some(0.0);
    }

    fn apply_stored(&mut self, activated: &[usize]) {
        for a in &self.actions {
            if let Action::Stored { output, set, steps } = a {
                if steps.iter().any(|s| activated.contains(s)) {
                    self.stored[*output] = if *set { 1.0 } else { 0.0 };
                }
            }
        }
    }

    fn enabled(&self, t: &Transition) -> bool {
        t.sources.iter().all(|&s| self.active[s].is_some())
    }

    /// Time the sources of an enabled transition have all been active.
    fn elapsed(&self, t: &Transition, now: f64) -> f64 {
        let since = t.sources.iter().filter_map(|&s| self.active[s]).fold(f64::NEG_INFINITY, f64::max);
        now - since
    }

    /// Values of the outputs in the current situation.
    fn output_values(&self, out: &mut [f64]) {
        out.copy_from_slice(&self.stored);
        for (o, value) in out.iter_mut().enumerate() {
            let continuous = self.actions.iter().find_map(|a| match a {
                Action::Continuous { output, value, steps } if *output == o && steps.iter().any(|&s| self.active[s].is_some()) => Some(*value),
                _ => None,
            });
            let has_continuous = self.actions.iter().any(|a| matches!(a, Action::Continuous { output, .. } if *output == o));
            if has_continuous {
                *value = continuous.unwrap_or(0.0);
            }
        }
    }

    /// Fire transitions until the situation is stable; returns a note and a completed cycle.
    fn evolve(&mut self, now: f64, u: &[f64]) -> EventOutcome {
        let mut fired_names = Vec::new();
        let mut cycle = None;
        for _ in 0..=4 * self.transitions.len() {
            let firing: Vec<usize> = (0..self.transitions.len())
                .filter(|&k| {
                    let t = &self.transitions[k];
                    self.enabled(t) && t.condition.margin(u, self.elapsed(t, now)) > 0.0
                })
                .collect();
            if firing.is_empty() {
                break;
            }
            let mut activated = Vec::new();
            for &k in &firing {
                for &s in &self.transitions[k].sources {
                    self.active[s] = None;
                }
            }
            for &k in &firing {
                for &s in &self.transitions[k].targets {
                    self.active[s] = Some(now);
                    activated.push(s);
                }
                fired_names.push(self.transitions[k].text.clone());
            }
            self.apply_stored(&activated);
            if activated.contains(&self.cycle_step) {
                if let Some(start) = self.last_cycle_start {
                    self.done += 1;
                    cycle = Some(CycleRecord {
                        controller: String::new(),
                        start,
                        extend: f64::NAN,
                        retract: f64::NAN,
                        retract_start: f64::NAN,
                        total: now - start,
                    });
                }
                self.last_cycle_start = Some(now);
            }
        }
        let note = (!fired_names.is_empty()).then(|| format!("{}; active: {}", fired_names.join(", "), self.active_names()));
        EventOutcome { cycle, note }
    }

    fn active_names(&self) -> String {
        self.steps.iter().zip(&self.active).filter(|(_, a)| a.is_some()).map(|(s, _)| s.as_str()).collect::<Vec<_>>().join(", ")
    }

    /// Cycles completed so far.
    pub fn completed(&self) -> u64 {
        self.done
    }
}

impl Block for Sequencer {
    fn type_name(&self) -> &'static str {
        "sequencer"
    }
    fn ports(&self) -> &[PortSpec] {
        &self.ports
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    /// Every output is piecewise constant in the continuous states (it
    /// changes only at events): all partials are zero.
    fn partials(&self, _phase: Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        true
    }
    fn signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        self.output_values(out);
    }
    /// At rest: the outputs of the initial situation.
    fn rest_signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        let mut fresh = self.clone();
        fresh.reset();
        fresh.output_values(out);
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        let mut levels = vec![0.0, 1.0];
        for a in &self.actions {
            if let Action::Continuous { value, .. } = a {
                levels.push(*value);
            }
        }
        (0..self.n_outputs).map(|k| (self.n_inputs + k, Fact::CommandLevels(levels.clone()))).collect()
    }
    fn n_event_functions(&self) -> usize {
        1
    }
    fn event_functions(&self, ctx: &Ctx, out: &mut [f64]) {
        let g = self
            .transitions
            .iter()
            .filter(|t| self.enabled(t))
            .map(|t| t.condition.margin(ctx.signals, self.elapsed(t, ctx.t)))
            .fold(-1.0, f64::max);
        out[0] = if self.finished() { -1.0 } else { g };
    }
    fn next_time_event(&self, t: f64) -> Option<f64> {
        if self.finished() {
            return None;
        }
        let mut best: Option<f64> = None;
        for tr in self.transitions.iter().filter(|tr| self.enabled(tr)) {
            let since = tr.sources.iter().filter_map(|&s| self.active[s]).fold(f64::NEG_INFINITY, f64::max);
            let mut delays = Vec::new();
            tr.condition.delays(&mut delays);
            for d in delays {
                let due = since + d;
                if due > t && best.is_none_or(|b| due < b) {
                    best = Some(due);
                }
            }
        }
        best
    }
    fn on_event(&mut self, _event: EventKind, ctx: &Ctx) -> EventOutcome {
        if self.finished() {
            return EventOutcome::default();
        }
        self.evolve(ctx.t, ctx.signals)
    }
    fn finished(&self) -> bool {
        self.cycles > 0 && self.done >= self.cycles
    }
    fn counts_cycles(&self) -> bool {
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    /// The first active step's position in `steps` (0-based).
    fn record(&self, _ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = self.active.iter().position(|a| a.is_some()).map(|i| i as f64);
    }
}

/// Registry entry of `sequencer`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "sequencer",
    family: crate::registry::Family::Control,
    doc: "GRAFCET-like step sequencer: steps, transitions, actions",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Sequencer::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;

    fn build(raw: &[(&str, RawValue)]) -> Result<Sequencer, BlockError> {
        Sequencer::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v)))?)
    }

    fn list(items: &[&str]) -> RawValue {
        RawValue::List(items.iter().map(|s| RawValue::Text(s.to_string())).collect())
    }

    fn ab() -> Sequencer {
        build(&[
            ("inputs", RawValue::Text("start, a0, a1, b0, b1".into())),
            ("outputs", RawValue::Text("A, B".into())),
            ("transitions", list(&["0 -> 1 : start & a0 & b0", "1 -> 2 : a1", "2 -> 3 : b1", "3 -> 4 : a0", "4 -> 1 : b0"])),
            ("actions", list(&["A : 1, 2", "B : 2, 3"])),
            ("cycle_step", RawValue::Text("1".into())),
        ])
        .unwrap()
    }

    /// Handle events as the solver does: fire while the root is positive.
    fn settle(s: &mut Sequencer, t: f64, u: &[f64]) -> Vec<EventOutcome> {
        let gas = gas::IdealGas::air();
        let ctx = Ctx { t, gas: &gas, states: &[], pneumatic: &[], mechanical: &[], signals: u };
        let mut outcomes = Vec::new();
        for _ in 0..8 {
            let mut g = [0.0];
            s.event_functions(&ctx, &mut g);
            if g[0] <= 0.0 {
                break;
            }
            outcomes.push(s.on_event(EventKind::Crossing(0), &ctx));
        }
        outcomes
    }

    fn outputs(s: &Sequencer) -> [f64; 2] {
        let mut o = [0.0; 2];
        s.output_values(&mut o);
        o
    }

    #[test]
    fn runs_a_plus_b_plus_a_minus_b_minus_in_order() {
        let mut s = ab();
        assert_eq!(s.ports().len(), 7);
        assert_eq!(outputs(&s), [0.0, 0.0]);
        // inputs: start, a0, a1, b0, b1
        settle(&mut s, 0.0, &[1.0, 1.0, 0.0, 1.0, 0.0]);
        assert_eq!(outputs(&s), [1.0, 0.0], "A+");
        settle(&mut s, 1.0, &[1.0, 0.0, 1.0, 1.0, 0.0]);
        assert_eq!(outputs(&s), [1.0, 1.0], "B+");
        settle(&mut s, 2.0, &[1.0, 0.0, 1.0, 0.0, 1.0]);
        assert_eq!(outputs(&s), [0.0, 1.0], "A-");
        settle(&mut s, 3.0, &[1.0, 1.0, 0.0, 0.0, 1.0]);
        assert_eq!(outputs(&s), [0.0, 0.0], "B-");
        let o = settle(&mut s, 4.0, &[1.0, 1.0, 0.0, 1.0, 0.0]);
        assert_eq!(outputs(&s), [1.0, 0.0], "A+ again");
        let c = o.iter().find_map(|e| e.cycle.clone()).expect("a cycle completed");
        assert_eq!((c.start, c.total), (0.0, 4.0));
        assert!(c.extend.is_nan());
        // an input that is not the awaited one does nothing
        let before = s.active.clone();
        settle(&mut s, 4.5, &[0.0, 1.0, 0.0, 1.0, 1.0]);
        assert_eq!(s.active, before);
    }

    #[test]
    fn step_times_are_time_events_and_stored_actions_hold() {
        let mut s = build(&[
            ("inputs", RawValue::Text("go".into())),
            ("outputs", RawValue::Text("V".into())),
            ("transitions", list(&["idle -> on : go", "on -> off : after 500 ms", "off -> idle : !go"])),
            ("actions", list(&["set V : on", "reset V : idle"])),
        ])
        .unwrap();
        settle(&mut s, 0.1, &[1.0]);
        assert_eq!(s.next_time_event(0.1), Some(0.6));
        settle(&mut s, 0.6, &[1.0]);
        let gas = gas::IdealGas::air();
        s.on_event(EventKind::Time, &Ctx { t: 0.6, gas: &gas, states: &[], pneumatic: &[], mechanical: &[], signals: &[1.0] });
        assert_eq!(s.active_names(), "off");
        let mut o = [0.0];
        s.output_values(&mut o);
        assert_eq!(o[0], 1.0, "V stays set in step off");
        settle(&mut s, 0.7, &[0.0]);
        s.output_values(&mut o);
        assert_eq!(o[0], 0.0, "reset on re-entering idle");
    }

    #[test]
    fn parallel_branches_and_synchronisation() {
        let mut s = build(&[
            ("inputs", RawValue::Text("x, y".into())),
            ("outputs", RawValue::Text("P, Q".into())),
            ("transitions", list(&["0 -> 1, 2 : true", "1 -> 3 : x", "2 -> 4 : y", "3, 4 -> 0 : true"])),
            ("actions", list(&["P : 1", "Q : 2"])),
            ("initial", RawValue::Text("0".into())),
        ])
        .unwrap();
        settle(&mut s, 0.0, &[0.0, 0.0]);
        assert_eq!(s.active_names(), "1, 2");
        settle(&mut s, 1.0, &[1.0, 0.0]);
        assert_eq!(s.active_names(), "2, 3");
        // the synchronisation waits for both branches; then the loop passes 0 and re-enters 1 and 2,
        // where 2 moves on at once (y holds) and 1 waits for x
        settle(&mut s, 2.0, &[0.0, 1.0]);
        assert_eq!(s.active_names(), "1, 4");
    }

    #[test]
    fn bad_sequences_are_refused_naming_the_parameter() {
        let base = |transitions: &[&str], actions: &[&str]| {
            build(&[
                ("inputs", RawValue::Text("a0, a1".into())),
                ("outputs", RawValue::Text("A".into())),
                ("transitions", list(transitions)),
                ("actions", list(actions)),
            ])
        };
        let e = base(&["0 -> 1 : a1", "2 -> 0 : a0"], &[]).unwrap_err().to_string();
        assert!(e.contains("transitions") && e.contains("cannot be reached") && e.contains('2'), "{e}");
        let e = base(&["0 -> 1 : a2"], &[]).unwrap_err().to_string();
        assert!(e.contains("transitions") && e.contains("\"a2\" is not an input"), "{e}");
        let e = base(&["0 -> 1 :"], &[]).unwrap_err().to_string();
        assert!(e.contains("empty condition"), "{e}");
        let e = base(&["0 -> 1 : a0 &"], &[]).unwrap_err().to_string();
        assert!(e.contains("ends too early"), "{e}");
        let e = base(&["0 -> 1 : a0"], &["B : 1"]).unwrap_err().to_string();
        assert!(e.contains("actions") && e.contains("\"B\" is not an output"), "{e}");
        let e = base(&["0 -> 1 : a0"], &["A : 7"]).unwrap_err().to_string();
        assert!(e.contains("actions") && e.contains("\"7\" is not a step"), "{e}");
        let e = base(&["0 - 1 : a0"], &[]).unwrap_err().to_string();
        assert!(e.contains("->"), "{e}");
        let e = base(&["0 -> 1 : after 2"], &[]).unwrap_err().to_string();
        assert!(e.contains("unit"), "{e}");
        let e = base(&["0 -> 1 : a0"], &["A : 1", "set A : 0"]).unwrap_err().to_string();
        assert!(e.contains("both"), "{e}");
        assert!(base(&["0 -> 1 : (a0 | a1) & !a1", "1 -> 0 : after 1.5 s"], &["A = 0.5 : 1"]).is_ok());
    }
}
