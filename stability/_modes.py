"""Modal table of a linear system: eigenvalues, frequencies, damping and participating states."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import ModelError, as_linear_system, pade
from linflex.frequency._spectrum import AXIS_FLOOR_FACTOR, AXIS_RTOL, EPS, classify, rigid_mask

__all__ = ["Mode", "ModeTable", "modes"]


@dataclass(frozen=True)
class Mode:
    """One row of a :class:`ModeTable`: a real eigenvalue or a complex-conjugate pair.

    Attributes
    ----------
    eigenvalue : complex
        The eigenvalue [1/s]; of a pair, the member with positive imaginary part. Of a
        discrete system, the equivalent continuous eigenvalue ``s = ln(z) / dt`` [1/s]
        (``-inf`` for ``z = 0``).
    natural_frequency : float
        ``|lambda|`` [rad/s].
    frequency_hz : float
        ``|lambda| / (2 pi)`` [Hz].
    damped_frequency : float
        ``|Im lambda|`` [rad/s].
    damping_ratio : float
        ``-Re(lambda) / |lambda|`` [-] (negative when unstable); ``nan`` for a
        rigid-body eigenvalue, whose damping is not defined.
    time_constant : float
        ``-1 / Re(lambda)`` [s]: decay time of the envelope; negative for a growing mode (its
        e-folding time), ``inf`` when ``Re(lambda) == 0`` or for a rigid-body eigenvalue.
    kind : str
        ``"rigid-body"`` (a zero eigenvalue, see :func:`modes`), ``"oscillatory"`` (a complex
        pair) or ``"real"``.
    unstable : bool
        True if the eigenvalue is neither rigid-body nor on the imaginary axis by the spectrum
        policy (``frequency/_spectrum.py``: ``Re(lambda) > max(100 eps scale, 1e-12 |lambda|)``)
        and lies in the open right half-plane; of a discrete system, if ``|z| > 1`` beyond rounding
        (see :func:`modes`).
    participation : tuple of (str, float)
        The states that take part most, by normalized eigenvector magnitude [-]
        (``|v_i| / max |v|``, so the largest is 1), largest first, those above the table's
        ``participation_threshold``.
    z : complex or None
        Of a discrete system, the eigenvalue of ``A`` itself, ``z = exp(s dt)`` [-]; None for
        a continuous system.
    """

    eigenvalue: complex
    natural_frequency: float
    frequency_hz: float
    damped_frequency: float
    damping_ratio: float
    time_constant: float
    kind: str
    unstable: bool
    participation: tuple[tuple[str, float], ...]
    z: complex | None = None


@dataclass(frozen=True, eq=False)
class ModeTable:
    """Result of :func:`modes`: one :class:`Mode` per real eigenvalue or conjugate pair.

    Rows are sorted with rigid-body eigenvalues first, then by natural frequency. Rigid-body
    eigenvalues are listed one by one (a double integrator gives two rows), because the split of
    a Jordan block at the origin into a tiny real pair or a tiny complex pair is rounding noise.

    Attributes
    ----------
    modes : tuple of Mode
        The rows.
    states : tuple of str
        State names of the system.
    eigenvectors : ndarray, shape (n_states, n_modes), complex
        Right eigenvector of each row, scaled to unit 2-norm (read-only).
    rigid_radius : float
        Largest ``|lambda|`` [1/s] labelled rigid-body (the user's ``rigid_tol`` when given).
    participation_threshold : float
        Normalized magnitude [-] above which a state is listed as participating.
    n_rigid : int
        Number of rigid-body eigenvalues (each counted once, not per pair).
    method : str
        ``"scipy.linalg.eig (LAPACK geev)"``.
    seconds : float
        Wall time of the computation [s].
    dt : float or None
        Sampling period [s] of a discrete system, None for a continuous one.
    """

    modes: tuple[Mode, ...]
    states: tuple[str, ...]
    eigenvectors: NDArray[np.complex128]
    rigid_radius: float
    participation_threshold: float
    n_rigid: int
    method: str
    seconds: float
    dt: float | None = None

    def __len__(self) -> int:
        return len(self.modes)

    def __iter__(self):
        return iter(self.modes)

    def __getitem__(self, index: int) -> Mode:
        return self.modes[index]

    @property
    def eigenvalues(self) -> NDArray[np.complex128]:
        """Eigenvalue of each row [1/s] (one per pair)."""
        return np.array([m.eigenvalue for m in self.modes], dtype=complex)

    @property
    def z_eigenvalues(self) -> NDArray[np.complex128]:
        """Of a discrete system, the eigenvalue ``z`` [-] of ``A`` of each row (one per pair).

        Raises
        ------
        ModelError
            For a continuous system, which has none.
        """
        if self.dt is None:
            raise ModelError("z_eigenvalues: the system is continuous; its eigenvalues are ModeTable.eigenvalues")
        return np.array([m.z for m in self.modes], dtype=complex)

    @property
    def natural_frequencies(self) -> NDArray[np.float64]:
        """Natural frequency of each row [rad/s]."""
        return np.array([m.natural_frequency for m in self.modes])

    @property
    def damping_ratios(self) -> NDArray[np.float64]:
        """Damping ratio of each row [-] (``nan`` for rigid-body rows)."""
        return np.array([m.damping_ratio for m in self.modes])

    def _rows(self, max_states: int) -> list[list[str]]:
        rows = []
        for i, m in enumerate(self.modes):
            lam = m.eigenvalue
            eig = f"{lam.real:.4g}" + (f" ± {abs(lam.imag):.4g}j" if m.kind == "oscillatory" else "")
            part = ", ".join(f"{name} {mag:.2f}" for name, mag in m.participation[:max_states])
            rows.append([
                str(i),
                eig,
                f"{m.natural_frequency:.5g}",
                f"{m.frequency_hz:.5g}",
                "-" if np.isnan(m.damping_ratio) else f"{m.damping_ratio:.4g}",
                "inf" if np.isinf(m.time_constant) else f"{m.time_constant:.4g}",
                m.kind + (" (unstable)" if m.unstable else ""),
                part,
            ])
        return rows

    _HEADER = ("#", "eigenvalue [1/s]", "wn [rad/s]", "f [Hz]", "zeta", "tau [s]", "kind", "participating states")

    def to_markdown(self, *, max_states: int = 3) -> str:
        """The table as GitHub-flavoured markdown, with at most ``max_states`` states per row.

        Parameters
        ----------
        max_states : int, optional
            Participating states listed per mode.

        Returns
        -------
        str
            One row per mode; columns eigenvalue [1/s], natural frequency [rad/s] and [Hz],
            damping ratio [-], time constant [s], kind and participating states.

        Raises
        ------
        ModelError
            If ``max_states`` is not a non-negative integer.
        """
        if isinstance(max_states, (bool, np.bool_)) or not isinstance(max_states, (int, np.integer)) or max_states < 0:
            # a negative count would slice from the end: -1 listed all states but the last
            raise ModelError(f"max_states must be a non-negative integer, got {max_states!r}")
        lines = ["| " + " | ".join(self._HEADER) + " |", "|" + "---|" * len(self._HEADER)]
        lines += ["| " + " | ".join(r) + " |" for r in self._rows(max_states)]
        return "\n".join(lines)

    def _display_fields(self):
        oscillatory = [m for m in self.modes if m.kind == "oscillatory"]
        return [("n_modes", len(self.modes)), ("n_rigid", self.n_rigid), ("oscillatory", len(oscillatory)),
                ("unstable", sum(m.unstable for m in self.modes)),
                ("lowest_oscillatory [rad/s]", min((m.natural_frequency for m in oscillatory), default=None)),
                ("least_damping_ratio", min((m.damping_ratio for m in oscillatory), default=None)),
                ("n_states", len(self.states)), ("seconds", self.seconds)]

    def __repr__(self) -> str:
        from linflex.system import short_repr

        return short_repr("ModeTable", self._display_fields())

    def _repr_html_(self) -> str:
        from linflex.system import html_summary

        return html_summary(f"ModeTable ({len(self.modes)} modes)", self._display_fields(), self._HEADER,
                            self._rows(3), max_rows=20, note="str() or to_markdown() gives every row.")

    def __str__(self) -> str:
        rows = [list(self._HEADER)] + self._rows(3)
        widths = [max(len(r[j]) for r in rows) for j in range(len(self._HEADER))]
        out = [f"{len(self.modes)} modes ({self.n_rigid} rigid-body eigenvalues, |lambda| <= {self.rigid_radius:.3g} 1/s)"
               + ("" if self.dt is None else f"; sampled at dt = {self.dt:g} s, eigenvalues s = ln(z) / dt")]
        for k, r in enumerate(rows):
            out.append("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
            if k == 0:
                out.append("  ".join("-" * w for w in widths))
        return "\n".join(out)


def modes(sys, *, rigid_tol: float | None = None, participation_threshold: float = 0.1) -> ModeTable:
    """Modal table of a linear system: frequency, damping, time constant and participating states.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        The system, continuous or discrete (``dt``); only ``A`` and the state names are used
        (a discrete system's whole-period delays first become their exact shift-register
        states; a continuous system with delays is refused).
    rigid_tol : float, optional
        Absolute tolerance [1/s]: eigenvalues with ``|lambda| <= rigid_tol`` are rigid-body
        eigenvalues. By default the rigid group is found without a fixed tolerance: the smallest
        eigenvalues (up to ``1e-3 * ||balanced A||_1``) whose sum vanishes to rounding, which is
        how a Jordan block at the origin (double or triple integrator) appears in floating point
        while a genuine slow pole does not.
    participation_threshold : float, optional
        States whose normalized eigenvector magnitude [-] is at least this value (0 to 1) are listed
        as participating. Default 0.1.

    Returns
    -------
    ModeTable
        Rows for real eigenvalues and conjugate pairs (each pair once), rigid-body first, then
        sorted by natural frequency.

    Raises
    ------
    ModelError
        If ``sys`` is not a linear system, is continuous with time delays, or
        ``participation_threshold`` is not in [0, 1].

    Notes
    -----
    Eigenvalues come from LAPACK ``geev`` (which balances ``A``). For an eigenvalue
    ``lambda = sigma + j omega_d``: ``omega_n = |lambda|``, ``zeta = -sigma / omega_n``,
    ``tau = -1 / sigma``, as in the resonance table of the reference notes
    (linear-analysis-discos.md, section 2). Participation is the magnitude of the right
    eigenvector normalized to a largest entry of 1; it depends on the units of the states.

    **Discrete systems.** Each eigenvalue ``z`` of ``A`` (kept as :attr:`Mode.z`) is mapped to
    ``s = ln(z) / dt`` (principal logarithm, ``|Im s| <= pi / dt``) and the row's frequency,
    damping and time constant are those of ``s``, so a continuous system discretized with a
    zero-order hold (``z = exp(s dt)``) keeps its table, up to the Nyquist frequency ``pi / dt``
    above which frequencies alias. ``z = 1`` is the origin (rigid-body eigenvalues: the rule
    above applied to ``A - I``; with ``rigid_tol``, ``|ln z| / dt <= rigid_tol``). Unstable
    means outside the unit circle beyond rounding: ``|z| - 1 > max(100 eps scale, 1e-12)``
    with the scale of the spectrum policy, so a pole on the circle within rounding is not
    unstable. A real negative ``z`` is a real eigenvalue alternating at the Nyquist frequency
    (``Im s = pi / dt``). Pure delay states (whole-period delays, a hold's memory) give ``z = 0``
    (within rounding: the rule above applied to ``A`` itself, since a chain of ``k`` delays is
    a Jordan block at 0): they are listed last as ``"real"`` with ``s = -inf``, natural
    frequency ``inf``, damping 1 and time constant 0 [s] (gone after ``k`` samples).

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> table = modes(LinearSystem([[0, 1], [-4, -0.4]], [[0], [1]]))
    >>> round(table[0].natural_frequency, 6), round(table[0].damping_ratio, 6)
    (2.0, 0.1)

    The same system held and sampled at 10 Hz keeps its frequency and damping:

    >>> from linflex import discretize
    >>> sampled = modes(discretize(LinearSystem([[0, 1], [-4, -0.4]], [[0], [1]]), 0.1, "zoh"))
    >>> round(sampled[0].natural_frequency, 6), round(sampled[0].damping_ratio, 6), abs(sampled[0].z) < 1
    (2.0, 0.1, True)
    """
    sys = as_linear_system(sys, "sys", discrete=True, delay=True)
    if sys.has_delay:
        if not sys.is_discrete:
            as_linear_system(sys, "sys")  # the refusal of a continuous delay, with its advice
        sys = pade(sys, 1).sys  # whole periods: exact shift registers
    try:
        threshold = float(participation_threshold)
    except (TypeError, ValueError) as err:
        raise ModelError(f"participation_threshold must be a number in [0, 1], got {participation_threshold!r}") from err
    if not 0.0 <= threshold <= 1.0:
        raise ModelError(f"participation_threshold must be in [0, 1], got {participation_threshold!r}")
    t0 = time.perf_counter()
    A = np.asarray(sys.A)
    n = A.shape[0]
    if n == 0:
        w, V = np.zeros(0, complex), np.zeros((0, 0), complex)
    else:
        w, V = scipy.linalg.eig(A, check_finite=False)
    dt = sys.dt
    if dt is None:
        spec = classify(A, rigid_tol, poles=w, B=sys.B, C=sys.C)
        rigid, radius, rhp = spec.rigid, spec.rigid_radius, spec.rhp
        lams, dead = w, np.zeros(w.shape, dtype=bool)
    else:
        rigid, radius, rhp, lams, dead = _discrete_spectrum(sys, w, rigid_tol)
    # LAPACK geev returns conjugate pairs exactly conjugate and adjacent (positive imaginary part
    # first), so keeping Im >= 0 lists every pair once; rigid-body eigenvalues are kept one by one.
    keep = rigid | dead | (w.imag >= 0)
    idx = np.flatnonzero(keep)
    order = sorted(idx, key=lambda i: (not rigid[i], bool(dead[i]), abs(lams[i]), -lams[i].real))
    rows = []
    vecs = []
    for i in order:
        lam = complex(lams[i])
        v = V[:, i] / max(np.linalg.norm(V[:, i]), np.finfo(float).tiny)
        mag = np.abs(v)
        mag = mag / mag.max() if mag.max() > 0 else mag
        top = np.argsort(-mag, kind="stable")
        part = tuple((sys.states[j], float(mag[j])) for j in top if mag[j] >= threshold and mag[j] > 0)
        wn = abs(lam)
        if rigid[i]:
            kind, zeta, tau = "rigid-body", float("nan"), float("inf")
        elif dead[i]:
            kind, zeta, tau = "real", 1.0, 0.0
        else:
            kind = "oscillatory" if w[i].imag > 0 else "real"
            zeta = -lam.real / wn + 0.0  # + 0.0 turns -0.0 into 0.0
            tau = float("inf") if lam.real == 0 else -1.0 / lam.real
        rows.append(Mode(
            eigenvalue=lam,
            natural_frequency=wn,
            frequency_hz=wn / (2 * np.pi),
            damped_frequency=abs(lam.imag),
            damping_ratio=zeta,
            time_constant=tau,
            kind=kind,
            unstable=bool(rhp[i]),
            participation=part,
            z=None if dt is None else complex(w[i]),
        ))
        vecs.append(v)
    vectors = np.array(vecs, dtype=complex).T.reshape(n, len(vecs))
    vectors.setflags(write=False)
    return ModeTable(
        modes=tuple(rows),
        states=sys.states,
        eigenvectors=vectors,
        rigid_radius=radius,
        participation_threshold=threshold,
        n_rigid=int(np.count_nonzero(rigid)),
        method="scipy.linalg.eig (LAPACK geev)",
        seconds=time.perf_counter() - t0,
        dt=dt,
    )


def _discrete_spectrum(sys, z: NDArray[np.complex128], rigid_tol: float | None):
    """Rigid (``z = 1``), unstable (outside the unit circle beyond rounding), equivalent ``s``
    [1/s] and dead-beat (``z = 0``) eigenvalues of a discrete system (see :func:`modes`)."""
    A, dt = np.asarray(sys.A, dtype=float), float(sys.dt)
    n = A.shape[0]
    with np.errstate(divide="ignore"):
        s = np.log(np.abs(z)) / dt + 1j * (np.angle(z) / dt)  # principal ln(z) / dt; -inf at z = 0
    if rigid_tol is None:
        rigid, radius = rigid_mask(z - 1.0, A - np.eye(n), None)
        radius = radius / dt  # |z - 1| = |s| dt to first order
    else:
        rigid, radius = rigid_mask(s, A, rigid_tol)
    dead = rigid_mask(z, A, None)[0] & ~rigid
    s = np.where(dead, complex(-np.inf, 0.0), s)
    spec = classify(A, None, poles=z, B=sys.B, C=sys.C)
    tol = max(AXIS_FLOOR_FACTOR * EPS * spec.scale, AXIS_RTOL)
    unstable = ~rigid & (np.abs(z) - 1.0 > tol)
    return rigid, radius, unstable, s, dead
