"""Linear models about an operating point: :meth:`pneumo.Model.linearize`
returns a :class:`Linearization` (issue 25, docs/linearize.md)."""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import _pneumo

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["Linearization", "operating_point_text"]


def operating_point_text(at: Any) -> str:
    """The operating point as ``pneumo linearize --at`` takes it: ``"rest"``,
    ``"t=1.2 s"``, a number of seconds (``1.2``), or a trim
    (``"piston.x=200 mm; F=0 N"``)."""
    if isinstance(at, bool):
        raise TypeError(f"at must be 'rest', a time such as 't=1.2 s', or a number of seconds, got {at!r}")
    if isinstance(at, (int, float)):
        if not math.isfinite(at) or at <= 0:
            raise ValueError(f"at = {at!r} s: the time must be a finite number > 0 s (for the state before anything moves, use at='rest')")
        return f"t={float(at)!r} s"
    if isinstance(at, str):
        return at
    raise TypeError(f"at must be 'rest', a time such as 't=1.2 s', or a number of seconds, got {type(at).__name__}")


def _matrix(rows: List[List[float]], n_rows: int, n_cols: int) -> np.ndarray:
    a = np.array(rows, dtype=float)
    return a.reshape(n_rows, n_cols)


class Linearization:
    """The linear model ẋ = A x + B u, y = C x + D u of a circuit about an
    operating point, in SI, as deviations from it (x − x₀, u − u₀, y − y₀).

    ``A``, ``B``, ``C``, ``D`` are numpy arrays; ``states``, ``inputs`` and
    ``outputs`` name their rows and columns (``units`` gives each name's SI
    unit). ``eigenvalues``, ``natural_frequencies`` [rad/s] and
    ``damping_ratios`` describe the modes; :meth:`to_control` gives a
    ``control.StateSpace`` (python-control), :meth:`bode` Bode data.
    """

    def __init__(self, raw: "_pneumo.RawLinearization") -> None:
        self._raw = raw
        j = json.loads(raw.json())
        self._json = j
        self.states: List[str] = [s["name"] for s in j["states"]]
        self.inputs: List[str] = [s["name"] for s in j["inputs"]]
        self.outputs: List[str] = [s["name"] for s in j["outputs"]]
        self.units: Dict[str, str] = {}
        for group in ("states", "inputs", "outputs"):
            for s in j[group]:
                self.units.setdefault(s["name"], s["unit"])
        n, m, p = len(self.states), len(self.inputs), len(self.outputs)
        self.A = _matrix(j["A"], n, n)
        self.B = _matrix(j["B"], n, m)
        self.C = _matrix(j["C"], p, n)
        self.D = _matrix(j["D"], p, m)
        op = j["operating_point"]
        self.t: float = float(op["t"])
        #: x₀, u₀, y₀: the operating point (SI), and ẋ₀ (zero at an equilibrium).
        self.x0 = np.array(op["x0"], dtype=float)
        self.u0 = np.array(op["u0"], dtype=float)
        self.y0 = np.array(op["y0"], dtype=float)
        self.dx0 = np.array(op["dx0"], dtype=float)
        #: "rest", "time" or "trim".
        self.kind: str = op["kind"]
        #: How the derivatives were taken ("exact chain rule (block partials, ...)", "central differences").
        self.method: str = j["method"]
        #: ``{node id: the mode its linear model belongs to}`` (sliding, stuck, on an end stop).
        self.mechanics: Dict[str, str] = {n["id"]: n["mode"] for n in j["mechanics"]}
        #: ``{(output, input): pair}``: each output/input pair's transfer
        #: function G(s) = k Π(s − z)/Π(s − p) of its minimal realisation, as
        #: ``pneumo linearize`` prints it (see :meth:`pair`).
        self._pairs: Dict[Tuple[str, str], Dict[str, Any]] = {
            (pr["output"], pr["input"]): {
                "order": int(pr["order"]),
                "poles": np.array([complex(z["re"], z["im"]) for z in pr["poles"]], dtype=complex),
                "zeros": np.array([complex(z["re"], z["im"]) for z in pr["zeros"]], dtype=complex),
                "gain": float(pr["gain"]),
                "dc_gain": None if pr.get("dc_gain") is None else float(pr["dc_gain"]),
            }
            for pr in j.get("pairs", [])
        }
        #: ``{state: why it is not a state of the linear model}``.
        self.left_out: Dict[str, str] = {s["state"]: s["why"] for s in j["left_out"]}
        # one entry per eigenvalue: a complex pair's mode gives λ and its conjugate
        lams, omegas, zetas = [], [], []
        for md in j["modes"]:
            lam = complex(md["re"], md["im"])
            zeta = np.nan if md["damping"] is None else md["damping"]
            for value in (lam, lam.conjugate()) if md["pair"] else (lam,):
                lams.append(value)
                omegas.append(md["natural_frequency_rad_s"])
                zetas.append(zeta)
        #: Eigenvalues of A [1/s], both members of each complex pair.
        self.eigenvalues = np.array(lams, dtype=complex)
        #: |λ| of each eigenvalue [rad/s].
        self.natural_frequencies = np.array(omegas, dtype=float)
        #: −Re λ / |λ| of each eigenvalue (NaN for λ = 0).
        self.damping_ratios = np.array(zetas, dtype=float)

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Natural frequencies in Hz (ω_n / 2π)."""
        return self.natural_frequencies / (2 * math.pi)

    def modes(self) -> "pd.DataFrame":
        """The modes as a DataFrame: eigenvalue, natural frequency [rad/s]
        and [Hz], damping ratio, one row per eigenvalue."""
        import pandas as pd

        return pd.DataFrame(
            {
                "eigenvalue": self.eigenvalues,
                "natural_frequency [rad/s]": self.natural_frequencies,
                "frequency [Hz]": self.frequencies_hz,
                "damping [1]": self.damping_ratios,
            }
        )

    def pair(self, output: str, input: str) -> Dict[str, Any]:
        """The transfer function from ``input`` to ``output``, G(s) = k
        Π(s − z)/Π(s − p) of the pair's minimal realisation (the modes the
        pair cannot excite or see removed): ``{"order", "poles", "zeros"
        (complex numpy arrays [1/s]), "gain" (k), "dc_gain" (G(0), None with
        a pole at 0)}``, in SI."""
        try:
            return self._pairs[(output, input)]
        except KeyError:
            raise KeyError(f"no pair {output!r}/{input!r}: outputs {self.outputs}, inputs {self.inputs}") from None

    def frequency_response(self, f_hz: Sequence[float]) -> np.ndarray:
        """H(j 2π f) = C (j 2π f I − A)⁻¹ B + D at the frequencies ``f_hz``
        [Hz], computed by pneumo: a complex array indexed [output, input,
        frequency] (python-control's order)."""
        f = [float(x) for x in np.atleast_1d(np.asarray(f_hz, dtype=float))]
        re, im = self._raw.frequency_response(f)
        p, m = len(self.outputs), len(self.inputs)
        h = np.array(re, dtype=float).reshape(len(f), p, m) + 1j * np.array(im, dtype=float).reshape(len(f), p, m)
        return np.moveaxis(h, 0, -1)

    def bode(self, f_hz: Optional[Sequence[float]] = None) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(f [Hz], magnitude [dB], phase [deg])``, the last two indexed
        [output, input, frequency], the phase unwrapped along frequency.
        Without ``f_hz``, the frequencies of ``pneumo linearize``'s bode.csv."""
        f = np.asarray(self._raw.bode_frequencies() if f_hz is None else f_hz, dtype=float)
        h = self.frequency_response(f)
        mag = 20 * np.log10(np.abs(h))
        phase = np.degrees(np.unwrap(np.angle(h), axis=-1))
        return f, mag, phase

    def bode_csv(self) -> str:
        """The text of ``pneumo linearize --out``'s bode.csv."""
        return self._raw.bode_csv()

    def to_control(self) -> Any:
        """The model as a ``control.StateSpace`` with named states, inputs and
        outputs (python-control: ``pip install control``)."""
        try:
            import control
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("Linearization.to_control needs python-control: pip install control") from e
        return control.ss(self.A, self.B, self.C, self.D, states=list(self.states), inputs=list(self.inputs), outputs=list(self.outputs))

    def __str__(self) -> str:
        return self._raw.text()

    def __repr__(self) -> str:
        return (
            f"<pneumo.Linearization at t = {self.t:g} s ({self.kind}): {len(self.states)} states, "
            f"{len(self.inputs)} inputs, {len(self.outputs)} outputs>"
        )
