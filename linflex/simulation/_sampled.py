"""Sampled-data simulation: the plant integrated between sample instants, sampled controllers at them.

A compiled scene whose ``control`` effect has sampled controllers lists them in
``model.compiled.sampled_controllers`` (each with a discrete chain ``system``, a ``reference``,
``sample_time``, ``delay``, output stages ``limited(command, previous)``, ``noise`` and ``seed``;
see :class:`linflex.effects._controllers.SampledController`). Their actuators' commands are inputs
of the model. :func:`sampled_run` integrates the model from event to event:

- at each sample instant ``t_k = t0 + k T`` of a controller: the model's outputs at ``(x(t_k),
  u(t_k), t_k)`` give the measurements (plus seeded noise), the discrete chain steps once
  (``u_k = C xc + D d``, ``xc = A xc + B d``) and the output stages give the command;
- the command takes effect at ``t_k + delay`` and is held (zero-order hold) until the next one;
- between events the integrator runs with piecewise-constant inputs (the user's inputs, held as
  :func:`simulate` holds them, plus the held commands), restarted at every event.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["sampled_run"]


def _snap(times: np.ndarray, onto: np.ndarray, tol: float) -> np.ndarray:
    """Each of ``times`` replaced by the nearest of ``onto`` when within ``tol`` (round-off of ``k T``)."""
    if onto.size == 0 or times.size == 0:
        return times
    k = np.clip(np.searchsorted(onto, times), 1, onto.size - 1) if onto.size > 1 else np.zeros(times.size, int)
    best = np.where(np.abs(onto[k - 1] - times) < np.abs(onto[k] - times), k - 1, k) if onto.size > 1 else k
    return np.where(np.abs(onto[best] - times) <= tol, onto[best], times)


def _output_function(model) -> Callable[[np.ndarray, np.ndarray, float], np.ndarray]:
    if model.is_casadi:
        pargs = (np.asarray(model.param_values),) if model.params else ()
        return lambda x, u, t: np.asarray(model.h(x, u, *pargs, t), float).reshape(-1)
    return lambda x, u, t: np.asarray(model.evaluate_raw(x, u, t)[1], float).reshape(-1)


def sampled_run(model, controllers: tuple, timepts: np.ndarray, x: np.ndarray, user: Callable[[float], np.ndarray],
                stepper, quats: tuple[int, ...], bar) -> tuple[np.ndarray, np.ndarray, float]:
    """Integrate ``model`` over ``timepts`` with its sampled ``controllers`` in the loop.

    Parameters
    ----------
    model : NonlinearModel
        The compiled scene.
    controllers : tuple of SampledController
        Its sampled controllers.
    timepts : ndarray
        The output times [s].
    x : ndarray
        Initial state [state units].
    user : callable
        The user's inputs as held at time ``t`` [input units].
    stepper : callable
        ``stepper(times, x0, U) -> X[1:]`` with ``U`` held over each interval.
    quats : tuple of int
        Indices of quaternion scalar parts (renormalized at every event).
    bar : Progress
        Progress over ``timepts``.

    Returns
    -------
    X, U : ndarray
        States and inputs (the user's plus the held commands) at ``timepts``.
    drift : float
        Largest quaternion norm error before renormalization [-].
    """
    t0, t_end = float(timepts[0]), float(timepts[-1])
    tol = 1e-9 * min(c.sample_time for c in controllers)
    # Events: (time, kind, controller); kind 0 = sample, 1 = a command takes effect. Effects
    # after the end do not matter.
    samples = [t0 + c.sample_time * np.arange(int(np.floor((t_end - t0) / c.sample_time + 1e-9)) + 1)
               for c in controllers]
    effects = [s + c.delay for s, c in zip(samples, controllers)]
    snapped_s = [_snap(s, timepts, tol) for s in samples]
    snapped_e = [_snap(e[e <= t_end + tol], timepts, tol) for e in effects]
    pool = np.sort(np.concatenate(snapped_s + snapped_e))
    merged: list[float] = []
    for t in pool:
        if not merged or t - merged[-1] > tol:
            merged.append(float(t))
    events = _snap(np.array(merged), timepts, tol)
    grid = np.union1d(timepts, events)
    grid = grid[grid <= t_end]
    n_g = grid.size

    def index(times: np.ndarray) -> np.ndarray:
        return np.searchsorted(grid, _snap(times, grid, tol))

    sample_at = [index(s) for s in snapped_s]
    effect_at = [index(e) for e in snapped_e]
    out_of = _output_function(model)
    sensors = [np.array([model.output_index(n) for n in c.system.inputs]) for c in controllers]
    actuators = [np.array([model.input_index(n) for n in c.system.outputs]) for c in controllers]
    rngs = [np.random.default_rng(c.seed) for c in controllers]
    xc = [np.zeros(c.system.n_states) for c in controllers]
    last = [np.zeros(c.system.n_outputs) for c in controllers]  # the last command computed
    held = [np.zeros(c.system.n_outputs) for c in controllers]  # the command in effect
    pending: list[dict[int, np.ndarray]] = [{} for _ in controllers]  # effect grid index -> command
    next_sample = [0] * len(controllers)
    is_event = np.zeros(n_g, bool)
    for idx in sample_at + effect_at:
        is_event[idx] = True
    is_event[-1] = True

    X = np.zeros((n_g, x.size))
    U = np.zeros((n_g, model.n_inputs))
    X[0] = x
    drift = 0.0

    def total_input(i: int) -> np.ndarray:
        u = np.array(user(grid[i]), dtype=float)
        for c_held, acts in zip(held, actuators):
            np.add.at(u, acts, c_held)
        return u

    def process(i: int) -> None:
        for j, c in enumerate(controllers):
            if next_sample[j] < sample_at[j].size and sample_at[j][next_sample[j]] == i:
                next_sample[j] += 1
                y = out_of(X[i], total_input(i), grid[i])[sensors[j]] - c.reference
                if c.noise is not None:
                    y = y + rngs[j].standard_normal(y.size) * c.noise
                K = c.system
                command = K.C @ xc[j] + K.D @ y
                xc[j] = K.A @ xc[j] + K.B @ y
                last[j] = c.limited(command, last[j])
                k = int(effect_at[j][next_sample[j] - 1]) if next_sample[j] - 1 < effect_at[j].size else -1
                if k >= 0:
                    pending[j][k] = last[j]
            if i in pending[j]:
                held[j] = pending[j].pop(i)

    a = 0
    process(0)
    U[0] = total_input(0)
    done = 0
    while a < n_g - 1:
        b = a + 1
        while not is_event[b]:
            b += 1
        seg = np.array([total_input(i) for i in range(a, b + 1)])
        # the commands are constant over the segment; the user's inputs keep their own holds
        X[a + 1:b + 1] = stepper(grid[a:b + 1], X[a], seg)
        U[a + 1:b] = seg[1:-1]
        for k in quats:
            norm = float(np.linalg.norm(X[b, k:k + 4]))
            drift = max(drift, abs(norm - 1.0))
            X[b, k:k + 4] /= norm
        process(b)
        U[b] = total_input(b)
        a = b
        reached = int(np.searchsorted(timepts, grid[b], side="right")) - 1
        if reached > done:
            bar.update(reached)
            done = reached
    keep = np.searchsorted(grid, timepts)
    return X[keep], U[keep], drift


def user_inputs(timepts: np.ndarray, samples: np.ndarray, cont: Any) -> Callable[[float], np.ndarray]:
    """The user's inputs at ``t``: a continuous function's value, else the sample held at ``t``."""
    if cont is not None:
        return lambda t: np.asarray(cont(t), float)

    def held(t: float) -> np.ndarray:
        k = int(np.clip(np.searchsorted(timepts, t, side="right") - 1, 0, timepts.size - 1))
        return samples[k]
    return held
