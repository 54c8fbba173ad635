"""Parameter sensitivities from Python: ``simulate(sensitivities=[...])``
and ``Result.sensitivity(signal, param)``, checked against a central
difference of two whole runs on the meter-out circuit (through its
stick–slip transitions, end stops and valve switching)."""

from __future__ import annotations

import numpy as np
import pytest

import pneumo


def test_sensitivity_to_friction_matches_a_difference_of_two_runs(meter_out):
    # a run with sensitivities integrates with ROS34PW2 (docs/performance.md);
    # the runs differenced here do too, at tight tolerance
    tight = {"simulation.rtol": 1e-9, "simulation.atol": 1e-9, "simulation.sample_interval": "5 ms", "simulation.method": "ros34pw2"}
    m = pneumo.load(meter_out).with_params(**tight)
    r = m.simulate(cycles=1, sensitivities=["friction.k0"])
    s = r.sensitivity("piston.x", "friction.k0")  # m per N
    assert s.shape == r.t.shape and s.dtype == np.float64
    k0, h = 10.0, 1e-3 * 10.0
    plus = m.with_params(**{"friction.k0": k0 + h}).simulate(cycles=1)
    minus = m.with_params(**{"friction.k0": k0 - h}).simulate(cycles=1)
    # compare on the sample grid, away from events (a finite change of k0
    # moves them past a sample, and event rows are at different times)
    events = np.array([t for t, _ in r.events])
    grid = 5e-3

    def on_grid(res):
        keep = np.abs(res.t / grid - np.round(res.t / grid)) < 1e-6
        return dict(zip(np.round(res.t[keep] / grid).astype(int), res["piston.x"][keep]))

    xp, xm = on_grid(plus), on_grid(minus)
    diffs = []
    for i, t in enumerate(r.t):
        k = int(round(t / grid))
        if abs(t - k * grid) > 1e-9 or np.min(np.abs(events - t)) <= 5e-3 or k not in xp or k not in xm:
            continue
        diffs.append(abs((xp[k] - xm[k]) / (2 * h) - s[i]))
    scale = np.nanmax(np.abs(s))
    assert scale > 1e-5, "more friction slows the piston: x must depend on k0"
    assert len(diffs) > 50 and max(diffs) < 1e-2 * scale, (max(diffs), scale, len(diffs))
    # the run itself is the run without sensitivities
    np.testing.assert_array_equal(r["piston.x"], m.simulate(cycles=1)["piston.x"])


def test_unknown_names_are_clear_errors(meter_out):
    m = pneumo.load(meter_out)
    r = m.simulate(t_end=0.05, sensitivities=["flow_control.C"])
    assert np.isfinite(r.sensitivity("rod.p", "flow_control.C")).all()
    with pytest.raises(KeyError, match="no sensitivities to 'friction.k0'"):
        r.sensitivity("piston.x", "friction.k0")
    with pytest.raises(KeyError, match="unknown signal"):
        r.sensitivity("nothing.x", "flow_control.C")
    with pytest.raises(ValueError, match="sensitivity to friction.kk"):
        m.simulate(t_end=0.05, sensitivities=["friction.kk"])
    with pytest.raises(TypeError):
        m.simulate(t_end=0.05, sensitivities="friction.k0")
