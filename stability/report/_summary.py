"""The report's summary text: verdict, limiting items, plant and controller, flexible modes, mode rows.

Plain functions of the analysis and the verdicts, shared by the Markdown, HTML and PDF renderings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linflex.scene import REQUIREMENTS

from ._analysis import SceneAnalysis
from ._table import Table
from ._table import fmt as _fmt
from ._verdicts import LABELS, Check, Verdicts

PM_CONVENTION = (
    "Phase margin PM = 180 deg + arg L(j wc), wrapped to (-180, 180] deg, at each gain crossover |L(j wc)| = 1 "
    "of the loop-at-a-time return ratio L (negative feedback, loop broken at the actuator). A negative PM at a "
    "crossover of a stable closed loop is normal for a phase-stabilized flexible mode: its distance to -180 deg "
    "is |PM|, which is what a phase-margin requirement bounds. Closed-loop stability is decided by the Nyquist "
    "count Z = N + P (N clockwise encirclements of -1, P open-loop unstable poles), not by the sign of a margin. "
    "Gain margins are |20 log10 GM| at each phase crossover (arg L = -180 deg), an increase (GM > 1) or a "
    "reduction (GM < 1); the delay margin at a crossover is the added delay that turns its phase to -180 deg.")

#: Units of sensor signals and actuator commands by type.
SENSOR_UNITS = {"attitude": "rad", "rate": "rad/s", "position": "m", "velocity": "m/s", "acceleration": "m/s^2",
                "wheel_speed": "rad/s"}
ACTUATOR_UNITS = {"torque": "N m", "wheel_torque": "N m", "force": "N", "thruster": "N"}


def verdict_text(v: Verdicts) -> str:
    required = [c for c in v.checks if c.required is not None]
    names = sorted({LABELS[c.quantity] for c in required}, key=list(LABELS.values()).index)
    if not v.closed_loop_stable:
        return ("FAIL: the closed loop is UNSTABLE, so no margin holds"
                + (f" ({len(required)} required checks fail)." if required else "."))
    if not required:
        return "No requirements given (add a [requirements] table or --require): the closed loop is stable."
    if v.passed:
        return (f"PASS: all {len(required)} checks of {len(names)} requirement{'s' if len(names) > 1 else ''} "
                f"({', '.join(names)}) hold on every "
                "loop and crossing; the closed loop is stable.")
    failed = v.failed
    worst = [v.limiting(q) for q in REQUIREMENTS if any(c.quantity == q for c in failed)]  # one per quantity
    return (f"FAIL: {len(failed)} of {len(required)} checks fail. Worst of each: "
            + "; ".join(f"{LABELS[c.quantity]} {value_text(c)}{'' if c.unit == '-' else ' ' + c.unit} "
                        f"({bound_text(c)}) in {c.channel}, {where(c)}" for c in worst) + ".")


def unstable_poles(margins) -> int:
    """Open-loop poles in the open right half-plane of a margins result (``open_loop_unstable_poles``)."""
    return int(margins.open_loop_unstable_poles)


def stability_text(a: SceneAnalysis) -> str:
    """Whether the closed loop is stable, its Nyquist count, and the eigenvalues [1/s] of its unstable modes."""
    m = a.margins
    count = (f" (Nyquist: Z = N + P = {m.nyquist_encirclements} + {unstable_poles(m)})"
             if m.nyquist_encirclements is not None else "")
    growing = [md for md in a.closed_loop_modes if md.unstable]
    untouched = hidden_modes_text(a)
    return ("stable" if a.closed_loop_stable else
            f"UNSTABLE, {len(growing)} unstable mode(s)") + count + (
        f"; unstable eigenvalues {', '.join(_complex(md.eigenvalue) for md in growing)} [1/s]" if growing else "") + (
        f"; {untouched}" if untouched else "")


def hidden_modes_text(a: SceneAnalysis) -> str:
    """The undamped modes the loops neither drive nor see (``StabilityMargins.hidden_poles``), in
    words; empty where there are none."""
    m = a.margins
    if not m.hidden_poles.size:
        return ""
    shown = sorted({_fmt(w) for w in np.abs(m.hidden_poles.imag)}, key=float)   # as printed: repeats once
    return (f"{m.hidden_poles.size // 2} undamped mode(s) the loops neither drive nor see stay undamped, at "
            + ", ".join(shown) + " rad/s")


def where(c: Check) -> str:
    if np.isnan(c.frequency):
        return c.where
    return f"{c.where} at {_fmt(c.frequency)} rad/s"


def _digits(c: Check) -> int:
    """Significant digits that tell a value from its bound: 4, more where both would print alike
    (65.1564 against 65.16 fails, and must not read "65.16 (>= 65.16): FAIL")."""
    if c.required is None or not np.isfinite(c.value) or c.value == c.required:
        return 4
    return next((d for d in range(4, 17) if _fmt(c.value, d) != _fmt(c.required, d)), 4)


def value_text(c: Check) -> str:
    return "none (unstable)" if np.isnan(c.value) else _fmt(c.value, _digits(c))


def bound_text(c: Check) -> str:
    """The requirement at a check, as ``">= 30"`` (digits as :func:`value_text`); ``""`` when none."""
    if c.required is None:
        return ""
    return f"{'>=' if REQUIREMENTS[c.quantity][1] == '>=' else '<='} {_fmt(c.required, _digits(c))}"


def check_text(c: Check) -> str:
    bound = "" if c.required is None else f" (required {bound_text(c)}: {'pass' if c.passed else 'FAIL'})"
    return f"{value_text(c)}, {c.channel}, {where(c)}{bound}"


def _gains(value) -> str:
    values = np.atleast_1d(np.asarray(value, dtype=float))
    return _fmt(values[0]) if values.size == 1 else "[" + ", ".join(_fmt(x) for x in values) + "]"


def description(a: SceneAnalysis) -> str:
    """The plant and the controller in one paragraph, with units."""
    scene = a.scene
    bodies = []
    for b in scene.bodies:
        if b.type == "flexible":
            beam = getattr(b, "beam", None)
            length = f"{_fmt(beam['length'])} m beam, " if isinstance(beam, dict) and "length" in beam else ""
            bodies.append(f"{b.name} (flexible, {length}{b.modes if b.modes is not None else 'all'} modes)")
        else:
            inertia = np.asarray(b.inertia, dtype=float)
            diag = np.diag(inertia) if inertia.ndim == 2 else inertia
            bodies.append(f"{b.name} (rigid, {_fmt(b.mass)} kg, inertia {_gains(diag)} kg m^2)")
    text = [f"Plant: {len(scene.bodies)} {'body' if len(scene.bodies) == 1 else 'bodies'}: " + "; ".join(bodies) + "."]
    if scene.wheels:
        text.append(f"{len(scene.wheels)} momentum wheels ({', '.join(w.name for w in scene.wheels)}).")
    plant_effects = [e for e in scene.effects if e != "control"]
    text.append("Effects in the plant (compiled and linearized): " + (", ".join(plant_effects) or "none")
                + "; the controllers are closed as linear systems, not linearized.")
    flexible = [m for m in a.plant_modes if m.kind == "oscillatory"]
    if flexible:
        text.append(f"{len(flexible)} lightly damped plant modes from {_fmt(flexible[0].natural_frequency)} to "
                    f"{_fmt(flexible[-1].natural_frequency)} rad/s: "
                    + ", ".join(f"{_fmt(m.natural_frequency)} rad/s (zeta {_fmt(m.damping_ratio, 2)})"
                                for m in flexible) + ".")
    text.append(f"{a.loop.plant.n_states} plant states in the loop.")
    sensors = {s.name: s for s in scene.sensors}
    actuators = {x.name: x for x in scene.actuators}

    def signals(names, table, units):
        return ", ".join(f"{n} ({table[n].type}, {units.get(table[n].type, '?')})" if n in table else n for n in names)

    text.append("Sensors: " + signals(a.loop.sensors, sensors, SENSOR_UNITS) + ". Actuators: "
                + signals(a.loop.actuators, actuators, ACTUATOR_UNITS) + ".")
    for c in scene.controllers:
        inputs = list(np.atleast_1d(c.inputs))
        outputs = list(np.atleast_1d(c.outputs))
        out_unit = ACTUATOR_UNITS.get(actuators[outputs[0]].type, "?") if outputs[0] in actuators else "?"
        in_unit = SENSOR_UNITS.get(sensors[inputs[0]].type, "?") if inputs[0] in sensors else "?"
        if c.type == "pid":
            terms = [f"kp = {_gains(c.kp)} {out_unit}/{in_unit}"]
            if np.any(np.asarray(c.ki, dtype=float)):
                terms.append(f"ki = {_gains(c.ki)} {out_unit}/({in_unit} s)")
            if np.any(np.asarray(c.kd, dtype=float)):
                rate = f" on {', '.join(np.atleast_1d(c.rate_inputs))}" if c.rate_inputs is not None else ""
                terms.append(f"kd = {_gains(c.kd)} {out_unit} s/{in_unit}{rate}")
            law = "PID, " + ", ".join(terms)
        else:
            law = c.type.replace("_", "-")
        text.append(f"Controller {c.name}: {law}; from {', '.join(inputs)} to {', '.join(outputs)}; "
                    + sampling_text(c, out_unit))
    if a.loop.dt is not None:
        T = a.loop.dt
        text.append(f"The loop is analysed as the linear sampled-data loop at T = {_fmt(T)} s: the plant discretized "
                    "with the zero-order hold, each computational delay exact on its actuators' inputs, the chains "
                    "in z; every result holds at the sample instants, frequencies up to the Nyquist frequency "
                    f"pi/T = {_fmt(np.pi / T)} rad/s, eigenvalues z shown as s = ln(z)/T, delay margins in seconds "
                    "(the phase exp(-j w tau) of an added delay at the crossover: exact for whole periods, "
                    "otherwise without the aliasing of the held command).")
    first = [f"{lm.channel} {_fmt(lm.gain_crossovers[0])}" for lm in a.margins.loops if lm.gain_crossovers.size]
    if first:
        text.append("Loop bandwidth (first gain crossover) [rad/s]: " + ", ".join(first) + ".")
    return " ".join(text)


FILTER_UNITS = {"frequency": "rad/s", "width": "rad/s", "depth": "dB", "zero": "rad/s", "pole": "rad/s",
                "damping": "-", "gain": "-"}


def _filter_text(spec, sampled: bool) -> str:
    spec = dict(spec)
    kind = spec.pop("kind", "?")
    domain = spec.pop("domain", "s")
    if kind in ("transfer_function", "state_space"):
        detail = f"given in {domain}" + ("" if domain == "z" or not sampled else ", by Tustin's method")
        return f"{kind.replace('_', '-')} filter ({detail})"
    params = ", ".join(f"{k} {_gains(v)} {FILTER_UNITS.get(k, '')}".rstrip() for k, v in spec.items())
    how = "" if not sampled else (", by Tustin's method prewarped at its frequency" if kind == "notch"
                                  else ", by Tustin's method")
    return f"{kind.replace('_', '-')} ({params}{how})"


def sampling_text(c, out_unit: str = "?") -> str:
    """A controller's timing in words: continuous, or sampled (period, rate, delay, hold, filters, limits)."""
    filters = [_filter_text(f, c.sample_time is not None) for f in (c.filters or ())]
    chain = ("; filters on every command: " + "; ".join(filters)) if filters else ""
    if c.sample_time is None:
        return "continuous time (no sampling)" + chain + "."
    T, tau = float(c.sample_time), float(c.delay or 0.0)
    text = (f"sampled every {_fmt(T)} s ({_fmt(1.0 / T)} Hz) with a {c.hold or 'zoh'} hold, the law by Tustin's "
            f"method; computational delay {_fmt(tau)} s ({_fmt(tau / T, 3)} periods)" + chain + ".")
    limits = [f"{name.replace('_', ' ')} {_gains(value)} {unit}" for name, value, unit in
              (("saturation", c.saturation, out_unit), ("rate_limit", c.rate_limit, f"{out_unit}/s"),
               ("quantization", c.quantization, out_unit)) if value is not None]
    if limits:
        text += (" Output stages (" + ", ".join(limits) + ") are nonlinear and not part of the linear loop "
                 "analysed here (the simulator applies them).")
    return text


@dataclass(frozen=True)
class Resonance:
    """A resonance peak of a loop-at-a-time return ratio, classified.

    Attributes
    ----------
    channel : str
    frequency : float
        Of the peak [rad/s].
    peak_db : float
        ``20 log10 |L(j omega)|`` at the peak [dB].
    kind : str
        ``"gain-stabilized"`` (peak below 0 dB) or ``"phase-stabilized"`` (above: it crosses 0 dB).
    clearance : float
        Gain-stabilized: dB below 0 dB; phase-stabilized: the least |PM| [deg] of the gain
        crossovers around the peak.
    mode_frequency, mode_damping : float
        The nearest lightly damped plant mode [rad/s] and its damping ratio [-].
    """

    channel: str
    frequency: float
    peak_db: float
    kind: str
    clearance: float
    mode_frequency: float
    mode_damping: float


def _prominent_peaks(values: np.ndarray, prominence: float) -> list[int]:
    """Indices of the local maxima that rise at least ``prominence`` above the higher of the lowest
    points between them and the nearest higher sample on either side (``scipy.signal.find_peaks``'
    prominence, without importing scipy.signal: its import costs more than drawing a figure)."""
    inner = np.flatnonzero((values[1:-1] > values[:-2]) & (values[1:-1] >= values[2:])) + 1
    out = []
    for k in inner:
        higher = np.flatnonzero(values > values[k])
        left = higher[higher < k]
        right = higher[higher > k]
        left_base = values[(left[-1] if left.size else 0):k + 1].min()
        right_base = values[k:(right[0] + 1 if right.size else values.size)].min()
        if values[k] - max(left_base, right_base) >= prominence:
            out.append(int(k))
    return out


def flexible_resonances(a: SceneAnalysis, prominence_db: float = 3.0) -> list[Resonance]:
    """The resonance peaks of every loop-at-a-time return ratio, gain- or phase-stabilized.

    Parameters
    ----------
    a : SceneAnalysis
        With ``channels`` (``analyse_scene(..., figures=True)``).
    prominence_db : float
        Least prominence of a peak of ``|L|`` [dB] on the adaptive grid.

    Returns
    -------
    list of Resonance
    """
    flexible = [m for m in a.plant_modes if m.kind == "oscillatory"]
    if not flexible:
        return []
    wn = np.array([m.natural_frequency for m in flexible])
    margins = {lm.channel: lm for lm in a.margins.loops}
    out = []
    for c in a.channels:
        mag_db = 20 * np.log10(np.abs(c.response.response[:, 0, 0]))
        peaks = _prominent_peaks(mag_db, prominence_db)
        lm = margins[c.channel]
        for k in peaks:
            w, peak = float(c.response.omega[k]), float(mag_db[k])
            near = int(np.argmin(np.abs(np.log(wn / w))))
            if peak < 0:
                kind, clearance = "gain-stabilized", -peak
            else:
                below = lm.gain_crossovers[lm.gain_crossovers <= w]
                above = lm.gain_crossovers[lm.gain_crossovers >= w]
                around = [i for i, x in enumerate(lm.gain_crossovers)
                          if (below.size and x == below[-1]) or (above.size and x == above[0])]
                kind = "phase-stabilized"
                clearance = float(min((abs(lm.phase_margins[i]) for i in around), default=np.nan))
            out.append(Resonance(c.channel, w, peak, kind, clearance, float(wn[near]),
                                 float(flexible[near].damping_ratio)))
    return out


def flexible_table(resonances: list[Resonance]) -> Table:
    rows = tuple((r.channel, _fmt(r.frequency), f"{_fmt(r.mode_frequency)} / {_fmt(r.mode_damping, 2)}",
                  f"{r.peak_db:+.1f}", r.kind.upper() if r.kind == "phase-stabilized" else r.kind,
                  (f"{r.clearance:.1f} dB below 0 dB" if r.kind == "gain-stabilized"
                   else f"|PM| {_fmt(r.clearance)} deg at its crossings"))
                 for r in resonances)
    n_phase = sum(r.kind == "phase-stabilized" for r in resonances)
    note = ("Resonance peaks of each loop's return ratio |L|. A gain-stabilized mode stays below 0 dB whatever its "
            "phase; a phase-stabilized one rises above 0 dB and is stable only through its phase (its clearance "
            "is the phase distance to -180 deg at its crossings), so an error in its frequency or in the loop's "
            "phase can destabilize it.")
    if n_phase:
        note = (f"WARNING: {n_phase} resonance(s) are phase-stabilized (peak above 0 dB). " + note)
    return Table("Flexible modes: gain- or phase-stabilized",
                 ("loop", "peak at [rad/s]", "plant mode [rad/s] / damping", "peak [dB]", "stabilized by",
                  "clearance"), rows, note=note)


def _rigid_labels(table, plant) -> dict[int, str]:
    """Labels of rigid-body rows by their Jordan chains: positions, then the rates that drive them.

    A double integrator has one eigenvector (the position) for two eigenvalues at 0; the eigen
    solver returns it twice. The rate of a chain is the least-squares ``w`` of ``A w = v``.
    """
    rows = [i for i, m in enumerate(table) if m.kind == "rigid-body"]
    if plant is None or not rows:
        return {}
    V = np.asarray(table.eigenvectors)[:, rows]
    positions, duplicates = [], []  # eigenvectors in row order; rows that repeat an earlier one
    for k in range(len(rows)):
        v = V[:, k] / np.linalg.norm(V[:, k])
        if positions:
            P = np.column_stack(positions)
            if np.linalg.norm(v - P @ np.linalg.lstsq(P, v, rcond=None)[0]) < 1e-3:
                duplicates.append(k)
                continue
        positions.append(v)
    if not duplicates:
        return {}
    P = np.column_stack(positions).real
    rates = np.linalg.lstsq(np.asarray(plant.A, dtype=float), P, rcond=None)[0]
    rates -= P @ np.linalg.lstsq(P, rates, rcond=None)[0]  # the part along the positions is not the rate
    names = plant.states

    def label(vector):
        weight = np.abs(vector) / np.max(np.abs(vector))
        order = np.argsort(-weight)[:3]
        return ", ".join(f"{names[j]} {weight[j]:.2f}" for j in order if weight[j] > 0.05)

    out = {}
    for j, k in enumerate(duplicates):
        if j < rates.shape[1] and np.max(np.abs(rates[:, j])) > 0:
            out[rows[k]] = label(rates[:, j]) + " (rate)"
    return out


def _complex(value: complex) -> str:
    return _fmt(value.real) + (f" ± {_fmt(abs(value.imag))}j" if value.imag else "")


def modes_table(title: str, table, states, plant) -> Table:
    """A mode table; a sampled one (``table.dt``) shows each ``z`` and its ``s = ln(z) / dt``."""
    rigid = _rigid_labels(table, plant)
    sampled = getattr(table, "dt", None) is not None
    rows = tuple((str(i), *((_complex(m.z),) if sampled else ()), _complex(m.eigenvalue),
                  _fmt(m.natural_frequency), _fmt(m.frequency_hz), _fmt(m.damping_ratio),
                  m.kind + (" (unstable)" if m.unstable else ""),
                  rigid.get(i) or ", ".join(f"{name} {weight:.2f}" for name, weight in m.participation[:3]))
                 for i, m in enumerate(table))
    header = ("#", *(("z [-]", "s = ln(z)/dt [1/s]") if sampled else ("eigenvalue [1/s]",)), "wn [rad/s]", "f [Hz]",
              "damping", "kind", "participating states")
    note = (f"Sampled loop (dt = {table.dt:g} s): eigenvalues z of the discrete closed loop, unstable outside the unit "
            "circle; frequency and damping from s = ln(z)/dt (aliased above the Nyquist frequency pi/dt); z = 0 "
            "rows are dead-beat states (the hold's memory of a delayed command), time constant 0."
            if sampled else "")
    return Table(title, header, rows, note=note)


