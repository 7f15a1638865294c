"""From a scene to the numbers of a stability-margin report.

This is one of the two places allowed to join every layer (ARCHITECTURE.md): it compiles the
scene's plant (every effect but ``control``), finds its operating point, linearizes it, closes
the loop with the scene's controllers as a :class:`linflex.frequency.Loop`, and computes modes
and margins, recording what each step cost.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np
import scipy.linalg

import linflex
from linflex import LinearSystem, ModelError, OperatingPoint
from linflex.frequency import (
    FrequencyResponse,
    Loop,
    NyquistResponse,
    RootLocus,
    frequency_response,
    hinf_norm,
    nyquist_response,
    root_locus,
    transfer_function,
)
from linflex.linearize import (
    Linearization,
    StiffnessShares,
    find_operating_point,
    linearize,
    scaled_residual,
    stiffness_shares,
)
from linflex.stability import ModeTable, StabilityMargins, modes, stability_margins

__all__ = ["ChannelAnalysis", "SceneAnalysis", "analyse_scene", "margin_summary"]

#: Poles of a return ratio damped below this ratio get extra response points across their band,
#: at these offsets in units of ``zeta omega_n`` (the half-power half-width) around ``omega_n``.
RESONANCE_DAMPING = 0.2
RESONANCE_SPREAD = np.concatenate([-np.geomspace(12.0, 0.05, 24), [0.0], np.geomspace(0.05, 12.0, 24)])
#: The damping ratio [-] below which a mode counts as undamped for those points: they are spread
#: over this fraction of its frequency instead, off the pole itself.
UNDAMPED_SPREAD = 1e-4

#: Root-locus gains as multiples of the nominal loop gain: the design's neighbourhood.
ROOT_LOCUS_GAINS = np.concatenate([[0.0], np.geomspace(0.01, 20.0, 80)])


@dataclass(frozen=True)
class ChannelAnalysis:
    """One loop broken at one actuator (the other loops closed): the data its figures draw.

    Attributes
    ----------
    channel : str
        The actuator where the loop is broken.
    return_ratio : LinearSystem
        The loop-at-a-time return ratio ``L_k`` (negative feedback: closed loop ``1 + L_k``).
    response : FrequencyResponse
        ``L_k(j omega)`` on the engine's adaptive grid (peaks resolved) with
        ``RESONANCE_SPREAD`` points across the band of each lightly damped pole [rad/s].
    nyquist : NyquistResponse
        ``L_k`` along the Nyquist contour, with the encirclement count.
    locus : RootLocus
        Closed-loop eigenvalues [1/s] with this loop's gain scaled by ``ROOT_LOCUS_GAINS``
        (1 is the nominal design), the other loops nominal.
    sensitivity, complementary_sensitivity : FrequencyResponse
        ``S_k = 1 / (1 + L_k)`` and ``T_k = L_k / (1 + L_k)`` on their own adaptive grids (their
        peaks are at closed-loop resonances).
    sensitivity_peak, complementary_sensitivity_peak : (float, float)
        Peak magnitude [-] and its frequency [rad/s] of ``S_k`` and ``T_k``: their H-infinity
        norms (attained, by :func:`~linflex.frequency.hinf_norm`), the grid's largest value for
        an unstable closed loop.
    """

    channel: str
    return_ratio: LinearSystem
    response: FrequencyResponse
    nyquist: NyquistResponse
    locus: RootLocus
    sensitivity: FrequencyResponse
    complementary_sensitivity: FrequencyResponse
    sensitivity_peak: tuple[float, float]
    complementary_sensitivity_peak: tuple[float, float]


def phase_deg(values: np.ndarray) -> np.ndarray:
    """Unwrapped phase [deg] of complex values along a grid, shifted by whole turns so that it
    starts in (-360, 0] (how every figure and envelope of the report draws a phase)."""
    phase = np.degrees(np.unwrap(np.angle(values)))
    return phase - 360.0 * np.ceil(phase[0] / 360.0)


def _peak(system: LinearSystem, response: FrequencyResponse) -> tuple[float, float]:
    """Peak magnitude [-] of a closed-loop transfer function and its frequency [rad/s].

    Its H-infinity norm (:func:`~linflex.frequency.hinf_norm`: attained, and within 1e-6 of its
    upper bound where certified, so that a requirement is checked against the peak and not
    against a grid's sample of it), or the
    grid's largest singular value where that norm is above it or not finite (an unstable closed
    loop, whose peak the report states beside its instability). ``inf`` frequency: the peak is
    the high-frequency limit."""
    sigma = np.linalg.svd(response.response, compute_uv=False)[:, 0]
    k = int(np.argmax(sigma))
    grid = (float(sigma[k]), float(response.omega[k]))
    try:
        norm = hinf_norm(system)
    except ModelError:
        return grid
    return (norm.value, norm.omega) if np.isfinite(norm.value) and norm.value >= grid[0] else grid


def _channel(loop: Loop, channel: str) -> ChannelAnalysis:
    L = transfer_function(loop, "quasi_open_loop", opened=[channel])
    adaptive = frequency_response(L)
    # The adaptive grid resolves each peak's height; a lightly damped mode's loop in the Nyquist
    # and Nichols planes also needs points across its half-power band (phase turning by 180 deg).
    # (a sampled loop's eigenvalues z as s = ln(z) / dt, its grid below the Nyquist frequency pi / dt)
    lam = np.array([m.eigenvalue for m in modes(L) if m.kind == "oscillatory"], dtype=complex)
    resonant = lam[-lam.real < RESONANCE_DAMPING * np.abs(lam)]
    # an undamped mode's band has no width: its points at UNDAMPED_SPREAD of its frequency, not on it
    clusters = [abs(p) * (1 + p.real / abs(p) * RESONANCE_SPREAD) if -p.real > UNDAMPED_SPREAD * abs(p)
                else abs(p) * (1 + UNDAMPED_SPREAD * RESONANCE_SPREAD[RESONANCE_SPREAD != 0]) for p in resonant]
    omega = np.unique(np.concatenate([adaptive.omega, *clusters])) if clusters else adaptive.omega
    top = np.inf if L.dt is None else np.pi / L.dt
    omega = omega[(omega > 0) & np.isfinite(omega) & ((omega <= top) | np.isin(omega, adaptive.omega))]
    response = frequency_response(L, omega) if clusters else adaptive
    # S_k = 1 / (1 + L_k), T_k = L_k / (1 + L_k): L_k closed by a unit gain, by the engine's interconnection
    unit = Loop(L, LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[1.0]], dt=L.dt),
                sensors=L.outputs, actuators=L.inputs)
    S = transfer_function(unit, "sensitivity", at="input")
    T = transfer_function(unit, "complementary_sensitivity", at="input")
    s_response, t_response = frequency_response(S), frequency_response(T)
    return ChannelAnalysis(channel, L, response, nyquist_response(L), root_locus(L, ROOT_LOCUS_GAINS),
                           s_response, t_response, _peak(S, s_response), _peak(T, t_response))


@dataclass(frozen=True)
class SceneAnalysis:
    """Everything a stability-margin report says about one scene.

    Attributes
    ----------
    scene : Scene
        The scene analysed.
    plant : Linearization
        The plant (the scene without its controllers) linearized about ``plant.op``, with
        its error estimate and cost.
    trimmed : bool
        Whether the operating point had to be trimmed (the scene's initial state was not an
        equilibrium of the plant).
    loop : Loop
        Plant and controllers joined by named channels, negative feedback.
    open_loop : LinearSystem
        The loop broken at the plant inputs, ``L = K P``.
    margins : StabilityMargins
        Loop-at-a-time and multi-loop margins of ``open_loop``.
    plant_modes, closed_loop_modes : ModeTable
        Modal tables of the plant and of the closed loop.
    closed_loop_stable : bool
        Whether no closed-loop mode is unstable (structural zero eigenvalues, such as a
        quaternion's scalar part, are rigid-body modes, not instabilities).
    costs : Mapping[str, float]
        Wall time of each step [s].
    stiffness : StiffnessShares or None
        What makes each undamped plant mode stiff (structure, springs, centrifugal field,
        geometric stiffness, gravity gradient), from Kane's direct linearization
        (:func:`linflex.linearize.stiffness_shares`; the plant's own linearization when
        ``method="kane"``): each origin's share of each mode's squared frequency [rad^2/s^2],
        the frequencies [rad/s]; None when not asked for.
    controller : LinearSystem
        All controllers in one block-diagonal system (the loop's negative-feedback sign).
    channels : tuple of ChannelAnalysis
        Per actuator: the loop-at-a-time return ratio and its response, Nyquist contour, root
        locus, sensitivity and complementary sensitivity (empty when not asked for).
    sensitivity, complementary_sensitivity : FrequencyResponse or None
        ``S_i = (I + K P)^-1`` and ``T_i = I - S_i`` at the plant input (all loops broken there
        at once), on their adaptive grids.
    output_sensitivity : FrequencyResponse or None
        ``S_o = (I + P K)^-1`` at the sensors.
    peaks : ((float, float), (float, float)) or None
        Peak [-] and frequency [rad/s] of ``sigma_max(S_i)`` and ``sigma_max(T_i)``: their
        H-infinity norms (as each channel's ``sensitivity_peak``).
    """

    scene: object
    plant: Linearization
    trimmed: bool
    loop: Loop
    open_loop: LinearSystem
    margins: StabilityMargins
    plant_modes: ModeTable
    closed_loop_modes: ModeTable
    closed_loop_stable: bool
    costs: Mapping[str, float]
    stiffness: StiffnessShares | None
    controller: LinearSystem | None = None
    channels: tuple[ChannelAnalysis, ...] = ()
    sensitivity: FrequencyResponse | None = None
    complementary_sensitivity: FrequencyResponse | None = None
    output_sensitivity: FrequencyResponse | None = None
    peaks: tuple[tuple[float, float], tuple[float, float]] | None = None

    def _display_fields(self):
        m = self.margins
        return [("scene", getattr(self.scene, "name", str(self.scene))), ("closed_loop_stable", self.closed_loop_stable),
                ("loops", m.channels), ("min_phase_margin [deg]", m.min_phase_margin if m.loops else None),
                ("min_gain_margin [dB]", m.min_gain_margin_db if m.loops else None),
                ("delay_margin [s]", m.delay_margin if m.loops and self.closed_loop_stable else None),
                ("disk_margin [-]", m.disk_margin.alpha),
                ("plant", f"{self.plant.sys.n_states} states, {self.plant.method}, max relative error estimate "
                          f"{self.plant.max_relative_error_estimate:.1e}"),
                ("trimmed", self.trimmed), ("seconds", sum(self.costs.values()))] + (
                    [("sampled: dt [s]", self.loop.dt)] if self.loop.dt is not None else [])

    def __repr__(self) -> str:
        from linflex.system import short_repr

        return short_repr("SceneAnalysis", self._display_fields())

    def _repr_html_(self) -> str:
        from linflex.system import html_summary

        return html_summary(f"SceneAnalysis of {getattr(self.scene, 'name', self.scene)}", self._display_fields(),
                            self.margins._LOOP_HEADER, self.margins._loop_rows(),
                            note="Loop-at-a-time margins; stability_report(analysis) writes the full report.")


def _sample_time(scene) -> float | None:
    """The one sampling period [s] of the scene's controllers, None when all are continuous."""
    periods = {c.name: (None if c.sample_time is None else float(c.sample_time)) for c in scene.controllers}
    distinct = set(periods.values())
    if len(distinct) > 1:
        groups = "; ".join(f"{'continuous' if T is None else f'sample_time {T:g} s'}: "
                           f"{sorted(n for n, t in periods.items() if t == T)}"
                           for T in sorted(distinct, key=lambda t: -1.0 if t is None else t))
        raise ModelError(f"controllers: the report analyses one loop, continuous or sampled at one rate, but the "
                         f"controllers mix {groups}; give them one sample_time")
    return distinct.pop()


def _feedback_controller(scene) -> tuple[LinearSystem, dict[str, float]]:
    """All controllers in one block-diagonal system, in the Loop's negative-feedback sign, and
    the computational delay [s] of each actuator they drive.

    Sampled controllers (one common ``sample_time``) give their discrete chains without the
    delay (:func:`linflex.controller_chain` with ``delay=False``); the delay goes on the
    continuous plant's ``input_delay`` of the controller's actuators, where the loop's
    zero-order-hold discretization makes it exact (whole periods or not).
    """
    if not scene.controllers:
        raise ModelError(f"scene {scene.name!r} has no controllers: there is no loop to analyse")
    _sample_time(scene)
    parts = [linflex.controller_chain(c, delay=False) for c in scene.controllers]  # the law and its filters
    delays = {name: float(c.delay or 0.0) for c, K in zip(scene.controllers, parts) for name in K.outputs}
    inputs = [name for K in parts for name in K.inputs]
    outputs = [name for K in parts for name in K.outputs]
    for what, names in (("sensor", inputs), ("actuator", outputs)):
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ModelError(f"controllers: the {what}s {repeated} are used by more than one controller; "
                             "merge those controllers to analyse their loop")
    A = scipy.linalg.block_diag(*[K.A for K in parts]) if any(K.n_states for K in parts) else np.zeros((0, 0))
    B = scipy.linalg.block_diag(*[K.B for K in parts]).reshape(A.shape[0], len(inputs))
    C = scipy.linalg.block_diag(*[K.C for K in parts]).reshape(len(outputs), A.shape[0])
    D = scipy.linalg.block_diag(*[K.D for K in parts])
    # Loop convention: plant input = -beta, so beta = -u (see linflex.frequency.Loop).
    K = LinearSystem(A, B, -C, -D, states=[s for K in parts for s in K.states], inputs=inputs, outputs=outputs,
                     dt=parts[0].dt)
    return K, {name: tau for name, tau in delays.items() if tau}


def analyse_scene(scene, *, method: str = "kane", equilibrium_tol: float = 1e-8,
                  stiffness_by_origin: bool = True, figures: bool = True, disk_margins: str = "all") -> SceneAnalysis:
    """Compile, trim, linearize and close the loops of a scene; margins and modes.

    Parameters
    ----------
    scene : Scene or path
        A scene (or a TOML file) with at least one controller.
    method : str
        Linearization method (see :func:`linflex.linearize.linearize`); default ``"kane"``,
        exact, whose one linearization also gives the stiffness by origin.
    equilibrium_tol : float
        Largest scaled residual [1/s] accepted without trimming.
    stiffness_by_origin : bool
        Also split the plant's stiffness by origin (a second, Kane, linearization at the same
        point when ``method`` is not ``"kane"``; sweeps that only want margins leave it out).
    figures : bool
        Also compute the data the report draws: per loop the return ratio's response, Nyquist
        contour, root locus and sensitivities, and the multi-loop sensitivities.
    disk_margins : {"all", "multi-loop"}
        Which disk margins to search (:func:`linflex.stability.stability_margins`): a report
        checks them all (:func:`stability_report` refuses an analysis without them);
        :func:`margin_summary` reports the multi-loop one only.

    Returns
    -------
    SceneAnalysis

    Raises
    ------
    ModelError
        For a scene without controllers, with a sensor or actuator shared between
        controllers, or with controllers that do not share one sampling (some continuous and
        some sampled, or different ``sample_time``); trim failures raise
        :class:`linflex.ConvergenceError`.

    Notes
    -----
    **Sampled controllers.** The plant is compiled and linearized without ``control``, so a
    sampled controller is never part of the linearized model: ``linearize(compile_model(scene))``
    of a scene with ``control`` leaves sampled controllers out (their actuators stay inputs of
    the model; only continuous controllers enter its equations), and this function closes them as linear systems instead. When the controllers
    share one ``sample_time`` ``T``, the loop analysed is the linear sampled-data loop: each
    controller's chain :func:`linflex.controller_chain` (``delay=False``: law and filters in z),
    its computational ``delay`` added to the plant's ``input_delay`` on its actuators, and the
    plant discretized by :class:`linflex.frequency.Loop` with the zero-order hold at ``T`` (the
    fractional delay exact). Margins, Nyquist counts, sensitivities and modes are then those of
    the discrete loop, exact at the sample instants, frequencies up to ``pi / T`` [rad/s]; the
    closed-loop modes are eigenvalues ``z`` with ``s = ln(z) / T`` (:func:`linflex.stability.modes`),
    root loci are in the z plane, delay margins stay in seconds and the plant modes are the
    continuous plant's. Saturation, rate limits, quantization and noise are nonlinear or random
    and not analysed (the simulator applies them).

    Examples
    --------
    The rigid spacecraft of ``examples/attitude_control.toml`` under a PD on three axes:

    >>> from linflex.stability.report import analyse_scene
    >>> a = analyse_scene("examples/attitude_control.toml")
    >>> a.closed_loop_stable, a.trimmed, a.margins.channels, a.plant.method
    (True, False, ('tx', 'ty', 'tz'), 'kane')
    >>> [round(float(loop.min_phase_margin), 2) for loop in a.margins.loops]   # [deg]
    [65.16, 65.16, 65.16]
    """
    costs: dict[str, float] = {}
    start = time.perf_counter()
    if isinstance(scene, (str, Path)):
        scene = linflex.load_scene(scene)
    costs["load scene"] = time.perf_counter() - start
    controller, delays = _feedback_controller(scene)

    start = time.perf_counter()
    plant_scene = dataclasses.replace(scene, effects=tuple(e for e in scene.effects if e != "control"))
    model = linflex.compile_model(plant_scene)
    costs["compile plant"] = time.perf_counter() - start

    start = time.perf_counter()
    op = OperatingPoint(model.x0, np.zeros(model.n_inputs))
    residual = model.evaluate(op.x, op.u)[0]
    trimmed = bool(np.max(scaled_residual(residual, op.x), initial=0.0) > equilibrium_tol)
    if trimmed:
        op = find_operating_point(model, op.x, op.u, fix_inputs=()).op
    costs["operating point"] = time.perf_counter() - start

    plant = linearize(model, op, method=method, equilibrium_tol=equilibrium_tol)
    costs[f"linearize ({plant.method})"] = plant.seconds

    start = time.perf_counter()
    # Structurally disconnected states (a quaternion's scalar part, unmeasured wheel speeds)
    # are in no transfer function but would count as closed-loop poles at 0.
    connected = plant.sys.connected_part()
    plant_sys = connected  # the continuous plant (its modes), before the computational delay
    if delays:  # a sampled controller's computational delay, on its actuators (exact under the hold)
        tau = connected.input_delay.copy()
        for name, d in delays.items():
            tau[connected.inputs.index(name)] += d
        connected = connected.with_(input_delay=tau)
    loop = Loop(connected, controller, sensors=controller.inputs, actuators=controller.outputs)
    open_loop = loop.open_loop()
    closed = transfer_function(loop, "closed_loop")
    costs["loop assembly"] = time.perf_counter() - start

    start = time.perf_counter()
    margins = stability_margins(open_loop, disk_margins=disk_margins)
    costs["margins"] = time.perf_counter() - start

    start = time.perf_counter()
    plant_modes = modes(plant_sys)
    closed_modes = modes(closed)
    costs["modes"] = time.perf_counter() - start
    stable = not any(m.unstable for m in closed_modes)

    shares = None
    if stiffness_by_origin:
        start = time.perf_counter()
        direct = plant if plant.method == "kane" else linearize(model, op, method="kane", equilibrium_tol=equilibrium_tol)
        shares = stiffness_shares(direct)
        costs["stiffness by origin" + ("" if plant.method == "kane" else " (second linearization, kane)")] = \
            time.perf_counter() - start

    channels: tuple[ChannelAnalysis, ...] = ()
    sensitivities: list[FrequencyResponse | None] = [None, None, None]
    if figures:
        start = time.perf_counter()
        channels = tuple(_channel(loop, actuator) for actuator in loop.actuators)
        costs["loop-at-a-time responses, Nyquist, root loci"] = time.perf_counter() - start
        start = time.perf_counter()
        systems = [transfer_function(loop, kind, at=at) for kind, at in
                   (("sensitivity", "input"), ("complementary_sensitivity", "input"), ("sensitivity", "output"))]
        sensitivities = [frequency_response(system) for system in systems]
        peaks = (_peak(systems[0], sensitivities[0]), _peak(systems[1], sensitivities[1]))
        costs["sensitivities"] = time.perf_counter() - start
    return SceneAnalysis(scene, plant, trimmed, loop, open_loop, margins, plant_modes, closed_modes, stable,
                         MappingProxyType(costs), shares, controller, channels, *sensitivities,
                         peaks if figures else None)


def margin_summary(scene, *, method: str = "kane") -> dict[str, float]:
    """The headline numbers of :func:`analyse_scene`, as a flat mapping for sweeps.

    Parameters
    ----------
    scene : Scene or path
        A scene with at least one controller.
    method : str
        Linearization method (see :func:`analyse_scene`).

    Returns
    -------
    dict
        ``gain_margin_db``: the smallest ``|20 log10 GM|`` over the loops (loop-at-a-time) [dB],
        ``inf`` without phase crossovers; ``phase_margin_deg``: the smallest ``|PM|`` [deg];
        ``delay_margin_s``: the smallest delay margin [s] (``nan`` for an unstable closed loop,
        which has none); ``disk_margin``: the multi-loop
        balanced disk margin ``alpha``; ``closed_loop_stable``: 1 or 0;
        ``min_closed_loop_damping``: the smallest damping ratio of the closed-loop oscillatory
        modes; ``first_flexible_frequency``: the lowest oscillatory plant mode [rad/s] (``nan``
        without one).

    Examples
    --------
    >>> from linflex import load_scene
    >>> summary = margin_summary(load_scene("examples/attitude_control.toml"))  # doctest: +SKIP
    >>> sorted(summary)[:2]  # doctest: +SKIP
    ['closed_loop_stable', 'delay_margin_s']
    """
    return summary_metrics(analyse_scene(scene, method=method, stiffness_by_origin=False, figures=False,
                                         disk_margins="multi-loop"))


def summary_metrics(result: SceneAnalysis) -> dict[str, float]:
    """The headline numbers of an analysis, as :func:`margin_summary` returns them.

    Parameters
    ----------
    result : SceneAnalysis
        From :func:`analyse_scene`.

    Returns
    -------
    dict
        As :func:`margin_summary` (margins in dB, deg, s; frequencies in rad/s).
    """
    loops = result.margins.loops
    gain_db = [abs(20.0 * np.log10(lp.min_gain_margin)) if 0 < lp.min_gain_margin < np.inf else np.inf for lp in loops]
    oscillatory_cl = [m.damping_ratio for m in result.closed_loop_modes.modes if m.kind == "oscillatory"]
    flexible = [m.natural_frequency for m in result.plant_modes.modes if m.kind == "oscillatory"]
    return {
        "gain_margin_db": float(min(gain_db, default=np.inf)),
        "phase_margin_deg": float(min((abs(lp.min_phase_margin) for lp in loops), default=np.inf)),
        "delay_margin_s": float(min((lp.delay_margin for lp in loops), default=np.inf))
        if result.closed_loop_stable else float("nan"),
        "disk_margin": float(result.margins.disk_margin.alpha),
        "closed_loop_stable": float(result.closed_loop_stable),
        "min_closed_loop_damping": float(min(oscillatory_cl, default=np.nan)),
        "first_flexible_frequency": float(min(flexible, default=np.nan)),
    }
