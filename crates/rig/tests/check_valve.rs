//! An exact check valve with a cracking pressure in the speed-control
//! valve (issue 23).
//!
//! The truth generator of the discrepancy matrix (`crates/identify/tests/
//! truth`, varied form, nothing hidden, seed 3) draws such a valve —
//! cracking at 133.8 mbar, exact opening, subsonic index 0.520, laminar end
//! region 2.26·10⁻³, limit switches 7 µm early with 0.146 ms latency. Before
//! the junction let the valve float at its cracking pressure
//! (`model::Plant::fill_junction`), its right-hand side chattered by the
//! check valve's whole flow while the rod chamber filled, the step size
//! collapsed and the run had not finished after 16 minutes. Here the same
//! draw runs its cycles at every operating point of the matrix within the
//! default step budget, and a run whose budget is too small ends with an
//! error naming the time and the state instead of crawling on.

use rig::{simulate, CheckLaw, Effects, ModelForm, Rig, RigError, RunSpec, SubsonicLaw, Switches};

/// The form drawn for the varied null case, seed 3 (values as drawn).
fn seed3() -> (ModelForm, f64) {
    let form = ModelForm {
        subsonic: SubsonicLaw { index: 0.5196591183969305, laminar_width: Some(0.00225853526831238) },
        check: CheckLaw::Exact,
        switches: Switches { tolerance: 7.126934347142999e-06, latency: 0.00014606991734401927, ..Switches::default() },
        ..ModelForm::default()
    };
    (form, 13376.665552485387)
}

/// The truth matrix's run: three cycles sampled at 1 kHz, rtol 10⁻⁷.
fn matrix_run() -> RunSpec {
    RunSpec { t_end: 60.0, rtol: 1e-7, ..RunSpec::cycles(3, 1e-3) }
}

#[test]
fn the_stalling_draw_runs_its_cycles_within_the_step_budget() {
    let (form, cracking) = seed3();
    let effects = Effects { tau_thermal: Some(5.0), ..Effects::default() };
    for (p, c) in [(4.0, 26.0), (4.0, 52.0), (7.0, 26.0), (7.0, 52.0)] {
        let rig = Rig { check_cracking: cracking, ..Rig::paper_bar_lpm(p, c) };
        let run = matrix_run();
        let tr = simulate(&rig, &form, &effects, &run).unwrap_or_else(|e| panic!("{p} bar, {c} L/min/bar: {e}"));
        assert_eq!(tr.cycles.len(), 3, "{p} bar, {c} L/min/bar");
        let s = tr.stats;
        eprintln!("{p} bar {c} L/min/bar: {s:?}");
        // mass is conserved through the floating valve as everywhere else
        assert!(tr.balance.mass_residual.abs() < 1e-9 * tr.balance.mass_in.abs().max(1e-6), "{:?}", tr.balance);
    }
}

#[test]
fn a_collapsing_step_size_ends_in_an_error_naming_time_and_state() {
    let (form, cracking) = seed3();
    let rig = Rig { check_cracking: cracking, ..Rig::paper_bar_lpm(4.0, 26.0) };
    let run = RunSpec { max_steps: 50, ..matrix_run() };
    match simulate(&rig, &form, &Effects::default(), &run) {
        Err(e @ RigError::StepLimit { .. }) => {
            let text = e.to_string();
            assert!(text.contains("50 step attempts") && text.contains("run.max_steps"), "{text}");
            assert!(text.contains("p_head") && text.contains("bar") && text.contains("x "), "{text}");
        }
        other => panic!("expected the step limit, got {other:?}"),
    }
}
