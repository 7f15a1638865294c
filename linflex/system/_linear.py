"""Linear time-invariant system types: first-order ``LinearSystem`` and ``SecondOrderSystem``.

Both are frozen, hold read-only float64 arrays and carry signal names. :func:`as_linear_system`
is what every linflex function that takes a linear system calls on its argument; the conversions
from python-control, scipy.signal and tuples are in ``_foreign.py``.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse
from numpy.typing import ArrayLike, NDArray

from ._errors import ModelError, ShapeError
from ._foreign import _CONTROL_DOT, from_control, from_scipy, from_tuple, sampling_period, to_control_name
from ._signals import real_array, real_matrix, real_vector, signal_index, signal_names

__all__ = ["DENSE_STATES_MAX", "LinearSystem", "SecondOrderSystem", "as_linear_system"]

#: The largest sparse ``A`` that :attr:`LinearSystem.A` forms densely (8 * n^2 bytes: 0.8 GB at
#: 10000 states) for the functions that need the dense matrix.
DENSE_STATES_MAX = 10000


def _sparse_matrix(A):
    """A real, square, finite ``scipy.sparse`` ``A`` as a float64 CSR copy (explicit zeros
    dropped, indices sorted)."""
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ShapeError(f"A must be a square matrix, got a sparse matrix of shape {A.shape}")
    if np.iscomplexobj(A.data) and np.any(np.imag(A.data) != 0):
        raise ShapeError("A must be a real matrix, got complex values; linflex's systems are real")
    out = scipy.sparse.csr_matrix(A, dtype=np.float64, copy=True)
    out.eliminate_zeros()
    out.sort_indices()
    if not np.all(np.isfinite(out.data)):
        k = int(np.flatnonzero(~np.isfinite(out.data))[0])
        row = int(np.searchsorted(out.indptr, k, side="right") - 1)
        raise ShapeError(f"A[{row}, {int(out.indices[k])}] is not finite ({out.data[k]})")
    return out


@dataclass(frozen=True, init=False, eq=False)
class LinearSystem:
    """A state-space system: continuous ``x' = A x + B u`` or discrete ``x[k+1] = A x[k] + B u[k]``, ``y = C x + D u``.

    Parameters
    ----------
    A, B, C, D : array_like
        System matrices of shapes ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``. ``C`` and
        ``D`` may be omitted: ``C`` then defaults to no outputs (``p = 0``) and ``D`` to zeros.
        Units are those of the signals: ``A`` in 1/s for states in their own units. ``A`` may
        be a ``scipy.sparse`` matrix or array: the system keeps it (:attr:`A_sparse`), and the
        frequency response, Nyquist and margins (their sensitivity peaks included) evaluate
        ``G(s)`` from it at O(nnz) per point (:mod:`linflex.frequency`), ``hinf_norm`` bounds a
        block-diagonal (modal) one block by block, and balanced truncation takes low-rank
        gramian factors of it; functions that need the dense matrix
        form it on first use of :attr:`A`, up to ``DENSE_STATES_MAX`` states.
    states, inputs, outputs : sequence of str, optional
        Unique, non-empty names; defaults ``x0.., u0.., y0..``.
    dt : float, optional
        Sampling period [s] of a discrete-time system; None (or 0, python-control's word for
        continuous time) for a continuous-time system.
    input_delay, output_delay : float or array_like, optional
        Pure time delays [s] on each input (shape ``(m,)``) and each output (shape ``(p,)``); a
        scalar applies to every channel. The transfer matrix is then
        ``diag(exp(-s output_delay)) (C (sI - A)^-1 B + D) diag(exp(-s input_delay))`` (with
        ``s = ln(z) / dt`` in discrete time, where each delay must be a whole number of periods).
        The frequency-domain functions use the delays exactly; state-space algorithms that need
        rational systems take :func:`linflex.pade` of them first.

    Notes
    -----
    The arrays are copied and made read-only (a sparse ``A`` is copied to CSR); variants come
    from :meth:`with_`. Functions that
    do not handle discrete time or delays refuse such systems with a :class:`ModelError` (see
    :func:`as_linear_system`), never treating them as continuous or undelayed.

    Examples
    --------
    >>> sys = LinearSystem([[0, 1], [-4, -0.4]], [[0], [1]], [[1, 0]], states=["q", "v"])
    >>> sys.shape
    (1, 1)

    The same plant sampled at 10 Hz, with a 20 ms computational delay on its input:

    >>> LinearSystem([[1.0]], [[0.1]], [[1.0]], dt=0.1, input_delay=0.2).dt
    0.1
    """

    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    dt: float | None
    input_delay: NDArray[np.float64]
    output_delay: NDArray[np.float64]

    def __init__(
        self,
        A: ArrayLike,
        B: ArrayLike,
        C: ArrayLike | None = None,
        D: ArrayLike | None = None,
        *,
        states=None,
        inputs=None,
        outputs=None,
        dt: float | None = None,
        input_delay: ArrayLike | None = None,
        output_delay: ArrayLike | None = None,
    ) -> None:
        # B, C and D have few columns or rows: a sparse one is taken dense
        B, C, D = (x.toarray() if scipy.sparse.issparse(x) else x for x in (B, C, D))
        if scipy.sparse.issparse(A):
            sparse_A = _sparse_matrix(A)
            A_, n = None, sparse_A.shape[0]
        else:
            sparse_A = None
            A_ = real_array(A, "A", "matrix")
            n = A_.shape[0] if A_.ndim == 2 else (0 if A_.size == 0 else 1)
            A_ = real_matrix(A_.reshape(n, n) if A_.size == n * n else A_, "A", (n, n))
        # An empty B or C given flat ([], as python-control takes ss([], [], [], D)) has no columns or
        # rows to count: without states, D's shape gives them.
        p_D, m_D = np.atleast_2d(D).shape if n == 0 and D is not None and np.ndim(D) <= 2 else (0, 0)
        B_ = real_matrix(np.zeros((n, m_D)) if np.size(B) == 0 and np.ndim(B) != 2 else B, "B", (n, None))
        m = B_.shape[1]
        if C is None:
            C_ = real_matrix(np.zeros((0, n)), "C", (0, n))
        else:
            C_ = real_matrix(np.zeros((p_D, n)) if np.size(C) == 0 and np.ndim(C) != 2 else C, "C", (None, n))
        p = C_.shape[0]
        D_ = real_matrix(np.zeros((p, m)) if D is None else D, "D", (p, m))
        object.__setattr__(self, "_A", A_)
        object.__setattr__(self, "_A_sparse", sparse_A)
        object.__setattr__(self, "_n", n)
        object.__setattr__(self, "B", B_)
        object.__setattr__(self, "C", C_)
        object.__setattr__(self, "D", D_)
        object.__setattr__(self, "states", signal_names(states, n, "x", "states"))
        object.__setattr__(self, "inputs", signal_names(inputs, m, "u", "inputs"))
        object.__setattr__(self, "outputs", signal_names(outputs, p, "y", "outputs"))
        dt_ = sampling_period(dt)
        object.__setattr__(self, "dt", dt_)
        object.__setattr__(self, "input_delay", _delays(input_delay, m, "input_delay", dt_))
        object.__setattr__(self, "output_delay", _delays(output_delay, p, "output_delay", dt_))

    @property
    def A(self) -> NDArray[np.float64]:
        """The state matrix [1/s], dense and read-only (formed on first use where the system
        was given a sparse ``A``).

        Raises
        ------
        ModelError
            Where ``A`` is sparse with more than ``DENSE_STATES_MAX`` states: the function that
            asked for it needs the dense matrix (the structure-aware ones use :attr:`A_sparse`).
        """
        if self._A is None:
            n = self._n
            if n > DENSE_STATES_MAX:
                raise ModelError(
                    f"this function needs the dense state matrix, and this system's A is sparse with {n} states "
                    f"(a dense copy would take {8 * n * n / 1e9:.1f} GB, above DENSE_STATES_MAX = {DENSE_STATES_MAX}); "
                    "frequency_response, nyquist_response, stability_margins and hinf_norm evaluate sparse systems "
                    "as they are")
            dense = self._A_sparse.toarray()
            dense.setflags(write=False)
            object.__setattr__(self, "_A", dense)
        return self._A

    @property
    def A_sparse(self):
        """The state matrix [1/s] as given when it was sparse (``scipy.sparse`` CSR, not to be
        modified), else None."""
        return self._A_sparse

    @property
    def is_sparse(self) -> bool:
        """Whether ``A`` was given (and is kept) as a sparse matrix."""
        return self._A_sparse is not None

    @property
    def is_discrete(self) -> bool:
        """Whether this is a discrete-time system (``dt`` is a sampling period [s])."""
        return self.dt is not None

    @property
    def has_delay(self) -> bool:
        """Whether any input or output carries a pure time delay."""
        return bool(self.input_delay.any() or self.output_delay.any())

    @property
    def n_states(self) -> int:
        """Number of states ``n``."""
        return self._n

    @property
    def n_inputs(self) -> int:
        """Number of inputs ``m``."""
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        """Number of outputs ``p``."""
        return self.C.shape[0]

    @property
    def shape(self) -> tuple[int, int]:
        """``(n_outputs, n_inputs)``, as python-control reports it."""
        return (self.n_outputs, self.n_inputs)

    def with_(self, **changes: Any) -> LinearSystem:
        """A copy with some of ``A, B, C, D, states, inputs, outputs`` replaced.

        Parameters
        ----------
        **changes
            New values by field name, as the constructor takes them (matrices in the units of
            the signals, names as sequences of str).

        Returns
        -------
        LinearSystem
            The modified copy (validated like a new system).

        Raises
        ------
        ModelError
            For a name that is not a field.
        """
        fields = {"A": self._A_sparse if self.is_sparse else self.A,
                  **{f.name: getattr(self, f.name) for f in dataclasses.fields(self)}}
        unknown = set(changes) - set(fields)
        if unknown:
            raise ModelError(f"with_: unknown fields {sorted(unknown)}; known: {sorted(fields)}")
        fields.update(changes)
        return LinearSystem(**fields)

    def subsystem(self, inputs=None, outputs=None) -> LinearSystem:
        """The channels from the named (or indexed) ``inputs`` to ``outputs``; None keeps all.

        Parameters
        ----------
        inputs, outputs : str, int or sequence of them, optional
            Names or indices of the channels to keep, in the order given; None keeps all.

        Returns
        -------
        LinearSystem
            The same states and ``A``, with the selected columns of ``B``, ``D`` and rows of
            ``C``, ``D`` (units unchanged).
        """
        ii = range(self.n_inputs) if inputs is None else [signal_index(self.inputs, k, "inputs") for k in _as_list(inputs)]
        oo = range(self.n_outputs) if outputs is None else [signal_index(self.outputs, k, "outputs") for k in _as_list(outputs)]
        ii, oo = list(ii), list(oo)
        return LinearSystem(
            self._A_sparse if self.is_sparse else self.A, self.B[:, ii], self.C[oo, :], self.D[np.ix_(oo, ii)],
            states=self.states, inputs=[self.inputs[i] for i in ii], outputs=[self.outputs[o] for o in oo],
            dt=self.dt, input_delay=self.input_delay[ii], output_delay=self.output_delay[oo],
        )

    def connected_part(self) -> LinearSystem:
        """The states that connect some input to some output through the sparsity of A, B, C.

        A state that no input reaches through the graph of ``(A, B)``, or that reaches no output
        through the graph of ``(A, C)``, is structurally uncontrollable or unobservable: it
        appears in no transfer function, exactly (no rank decision, no tolerance). Examples: a
        quaternion's scalar part linearized at the identity (nothing drives it), a reaction
        wheel's speed when no sensor sees it (it drives nothing). Such states still count as
        closed-loop poles, usually at 0, so loop analyses should drop them.

        Returns
        -------
        LinearSystem
            This system when every state is connected, else the connected states only.
        """
        coupled = (self.A != 0) & ~np.eye(self.n_states, dtype=bool)  # coupled[i, j]: x_j drives x_i'
        reached = _closure(self.B.any(axis=1), coupled)
        observed = _closure(self.C.any(axis=0), coupled.T)
        keep = np.flatnonzero(reached & observed)
        if keep.size == self.n_states:
            return self
        return LinearSystem(self.A[np.ix_(keep, keep)], self.B[keep], self.C[:, keep], self.D,
                            states=[self.states[i] for i in keep], inputs=self.inputs, outputs=self.outputs,
                            dt=self.dt, input_delay=self.input_delay, output_delay=self.output_delay)

    def to_control(self):
        """This system as a ``control.StateSpace`` with the same signal names.

        python-control 0.10 refuses ``"."`` in input and output names (it reserves the dot for
        ``system.signal`` references in ``interconnect``), while compiled scenes name signals
        ``"motor_x.command"`` or ``"gyro.x"``. Every ``"."`` of an input or output name is
        therefore written as ``"$"`` (a character python-control's own signal patterns accept,
        ``[\\w$]``), and :meth:`from_control` writes each ``"$"`` back as ``"."``, so the round trip
        is exact. State names keep their dots (python-control accepts them there).

        Returns
        -------
        control.StateSpace
            Same matrices (same units), same sampling period ``dt`` [s] (python-control's 0 for
            continuous time), same state names and the input and output names with ``"."``
            written as ``"$"``.

        Raises
        ------
        ModelError
            If the system has delays (python-control's ``StateSpace`` holds none: convert
            ``linflex.pade(sys, order)`` instead), if an input or output name already holds a
            ``"$"`` (the mapping would not be reversible), or for one output and no inputs where the installed python-control
            reads a ``D`` of shape ``(1, 0)`` as ``(0, 0)`` and cannot hold that system (0.10.2
            does: python-control issue #1176).

        Examples
        --------
        >>> sys = LinearSystem([[-1.0]], [[1.0]], [[1.0]], inputs=["motor.command"], outputs=["gyro.x"])
        >>> sys.to_control().input_labels, sys.to_control().output_labels
        (['motor$command'], ['gyro$x'])
        >>> LinearSystem.from_control(sys.to_control()).inputs
        ('motor.command',)
        """
        import control

        if self.has_delay:
            raise ModelError(
                "to_control: python-control's StateSpace holds no time delays; convert "
                "linflex.pade(sys, order) (a rational approximation with its error reported) instead"
            )
        for what in ("inputs", "outputs"):
            for i, label in enumerate(getattr(self, what)):
                if _CONTROL_DOT in label:
                    raise ModelError(
                        f"to_control: {what}[{i}] = {label!r} holds {_CONTROL_DOT!r}, which to_control reserves "
                        f"for '.' (python-control refuses '.' in signal names); rename the signal"
                    )
        try:
            return control.StateSpace(
                self.A, self.B, self.C, self.D,
                states=list(self.states), inputs=[to_control_name(n) for n in self.inputs],
                outputs=[to_control_name(n) for n in self.outputs], dt=0 if self.dt is None else self.dt,
            )
        except ValueError as err:  # control.ControlDimension is a ValueError
            if self.D.shape != (1, 0):
                raise
            # python-control 0.10.2 reads a D of shape (1, 0) as (0, 0) and then refuses its own
            # shapes (python-control issue #1176, fixed by pull request #1221 after 0.10.2).
            raise ModelError(
                f"to_control: this python-control ({control.__version__}) cannot hold a system with one "
                f"output and no inputs (its StateSpace reads D of shape (1, 0) as (0, 0), python-control "
                f"issue #1176); add an input or an output first"
            ) from err

    @classmethod
    def from_control(cls, sys) -> LinearSystem:
        """Build from a ``control.StateSpace`` or ``TransferFunction``, continuous or discrete.

        Parameters
        ----------
        sys : control.StateSpace or control.TransferFunction
            The system, with its sampling period ``dt`` [s] (0 for continuous time); a transfer
            function is realized in controllable canonical form when it has one input and one
            output (exact in its coefficients, with or without slycot), else by ``control.ss``,
            checked against the polynomials at frequencies about its poles and zeros (an
            ``AccuracyWarning`` names the largest difference where it exceeds 1e-10). Each ``"$"`` in an input or output name becomes ``"."`` (the inverse of
            :meth:`to_control`).

        Returns
        -------
        LinearSystem
            Same matrices (in the units of the signals) and signal labels.

        Raises
        ------
        ModelError
            For a discrete-time system of unspecified sampling period (``dt=True``) or an object
            python-control cannot convert.
        """
        args, kwargs = from_control(sys, "sys")
        return cls(*args, **kwargs)

    def _display_fields(self):
        fields = [("n_states", self.n_states), ("inputs", self.inputs), ("outputs", self.outputs)]
        if self.dt is not None:
            fields.append(("dt", self.dt))
        if self.input_delay.any():
            fields.append(("input_delay", tuple(self.input_delay.tolist())))
        if self.output_delay.any():
            fields.append(("output_delay", tuple(self.output_delay.tolist())))
        return fields

    def __repr__(self) -> str:
        from ._display import short_repr

        return short_repr("LinearSystem", self._display_fields())

    def _repr_html_(self) -> str:
        from ._display import html_summary

        return html_summary(f"LinearSystem ({self.n_states} states, {self.n_inputs} inputs, {self.n_outputs} outputs)",
                            [*self._display_fields(), ("states", self.states)])


@dataclass(frozen=True, init=False, eq=False)
class SecondOrderSystem:
    """A second-order system ``M q'' + D q' + K q = B u``, ``y = Cq q + Cv q' + Du u``.

    Parameters
    ----------
    M, D, K : array_like
        Mass, damping (including gyroscopic terms) and stiffness matrices, ``(n, n)``, in the
        generalized units of the dofs: [kg], [N s/m], [N/m] for a displacement [m];
        [kg m^2], [N m s/rad], [N m/rad] for a rotation [rad]. ``M`` must be invertible.
    B : array_like
        Input matrix ``(n, m)``: generalized force ([N] or [N m]) per unit of each input.
    Cq, Cv, Du : array_like, optional
        Output maps on displacements ``(p, n)``, velocities ``(p, n)`` and inputs ``(p, m)``
        [output units per dof, dof rate or input unit]; omitted ones are zero (with ``p = 0``
        when all are omitted).
    dofs, inputs, outputs : sequence of str, optional
        Names of the degrees of freedom, inputs and outputs.

    Examples
    --------
    A 2 kg mass on an 8 N/m spring with 0.4 N s/m damping (2 rad/s, damping ratio 0.05):

    >>> import numpy as np
    >>> from linflex import SecondOrderSystem
    >>> sys = SecondOrderSystem([[2.0]], [[0.4]], [[8.0]], [[1.0]], Cq=[[1.0]], dofs=["q"])
    >>> sys.to_state_space().states
    ('q', 'q_dot')
    >>> np.abs(np.linalg.eigvals(sys.to_state_space().A)).round(6).tolist()   # [rad/s]
    [2.0, 2.0]
    """

    M: NDArray[np.float64]
    D: NDArray[np.float64]
    K: NDArray[np.float64]
    B: NDArray[np.float64]
    Cq: NDArray[np.float64]
    Cv: NDArray[np.float64]
    Du: NDArray[np.float64]
    dofs: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    _cache: dict = field(repr=False, compare=False)

    def __init__(self, M, D, K, B, Cq=None, Cv=None, Du=None, *, dofs=None, inputs=None, outputs=None) -> None:
        M_ = real_matrix(M, "M", (None, None))
        n = M_.shape[0]
        M_ = real_matrix(M_, "M", (n, n))
        D_ = real_matrix(D, "D", (n, n))
        K_ = real_matrix(K, "K", (n, n))
        B_ = real_matrix(B, "B", (n, None))
        m = B_.shape[1]
        given = [c for c in (Cq, Cv) if c is not None]
        # p from the first output map given; a 0-d or 1-d one counts as one row (real_matrix then
        # checks its shape and names it)
        first = given[0] if given else Du
        p = 0 if first is None else (np.shape(first)[0] if np.ndim(first) == 2 else 1)
        Cq_ = real_matrix(np.zeros((p, n)) if Cq is None else Cq, "Cq", (p, n))
        Cv_ = real_matrix(np.zeros((p, n)) if Cv is None else Cv, "Cv", (p, n))
        Du_ = real_matrix(np.zeros((p, m)) if Du is None else Du, "Du", (p, m))
        for name, value in zip(("M", "D", "K", "B", "Cq", "Cv", "Du"), (M_, D_, K_, B_, Cq_, Cv_, Du_)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "dofs", signal_names(dofs, n, "q", "dofs"))
        object.__setattr__(self, "inputs", signal_names(inputs, m, "u", "inputs"))
        object.__setattr__(self, "outputs", signal_names(outputs, p, "y", "outputs"))
        object.__setattr__(self, "_cache", {})

    @property
    def n_dofs(self) -> int:
        """Number of degrees of freedom ``n``."""
        return self.M.shape[0]

    @property
    def n_states(self) -> int:
        """Number of states of the first-order form, ``2 n``."""
        return 2 * self.n_dofs

    @property
    def n_inputs(self) -> int:
        """Number of inputs ``m``."""
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        """Number of outputs ``p``."""
        return self.Cq.shape[0]

    @property
    def shape(self) -> tuple[int, int]:
        """``(n_outputs, n_inputs)``, as python-control reports it."""
        return (self.n_outputs, self.n_inputs)

    def to_state_space(self) -> LinearSystem:
        """The first-order form with state ``x = [q; q']`` (names ``dof`` and ``dof_dot``).

        ::

            A = [    0         I    ]   B = [   0    ]   C = [Cq  Cv]   D = Du
                [ -M^-1 K  -M^-1 D  ]       [ M^-1 B ]

        Returns
        -------
        LinearSystem
            ``2 n`` states: the dofs in their units ([m] or [rad]) then their rates ([m/s] or
            [rad/s]); cached, so repeated calls return the same object.

        Raises
        ------
        ModelError
            If ``M`` is singular.
        """
        if "ss" not in self._cache:
            n = self.n_dofs
            try:
                with warnings.catch_warnings():
                    # A singular M is reported below as a ModelError, not as scipy's warning.
                    warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
                    lu = scipy.linalg.lu_factor(self.M, check_finite=False)
            except (ValueError, np.linalg.LinAlgError) as err:
                raise ModelError(f"M cannot be factored: {err}") from err
            if n and np.min(np.abs(np.diag(lu[0]))) <= np.finfo(float).eps * n * max(np.max(np.abs(self.M)), 1e-300):
                raise ModelError("M is singular: the second-order system has no first-order form")
            MinvKDB = scipy.linalg.lu_solve(lu, np.hstack([self.K, self.D, self.B]), check_finite=False)
            A = np.block([[np.zeros((n, n)), np.eye(n)], [-MinvKDB[:, :n], -MinvKDB[:, n:2 * n]]])
            B = np.vstack([np.zeros((n, self.n_inputs)), MinvKDB[:, 2 * n:]])
            self._cache["ss"] = LinearSystem(
                A, B, np.hstack([self.Cq, self.Cv]), self.Du,
                states=list(self.dofs) + [f"{d}_dot" for d in self.dofs],
                inputs=self.inputs, outputs=self.outputs,
            )
        return self._cache["ss"]

    def to_control(self):
        """The first-order form as a ``control.StateSpace``.

        Returns
        -------
        control.StateSpace
            :meth:`to_state_space` converted by :meth:`LinearSystem.to_control`.
        """
        return self.to_state_space().to_control()

    @classmethod
    def from_control(cls, sys) -> LinearSystem:
        """python-control systems are first-order: this returns a :class:`LinearSystem`.

        Parameters
        ----------
        sys : control.StateSpace or control.TransferFunction
            A continuous- or discrete-time system.

        Returns
        -------
        LinearSystem
            As :meth:`LinearSystem.from_control`.
        """
        return LinearSystem.from_control(sys)

    def __repr__(self) -> str:
        from ._display import short_repr

        return short_repr("SecondOrderSystem", [("n_dofs", self.n_dofs), ("inputs", self.inputs),
                                                ("outputs", self.outputs)])

    def _repr_html_(self) -> str:
        from ._display import html_summary

        return html_summary(f"SecondOrderSystem ({self.n_dofs} degrees of freedom)",
                            [("n_dofs", self.n_dofs), ("inputs", self.inputs), ("outputs", self.outputs),
                             ("dofs", self.dofs)])


def as_linear_system(sys, name: str = "sys", *, discrete: bool = False, delay: bool = False) -> LinearSystem:
    """Accept any linear system linflex, python-control or scipy can describe.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem, control.StateSpace, control.TransferFunction, \
scipy.signal.lti, scipy.signal.dlti or tuple
        The system: a linflex system; a python-control ``StateSpace`` or ``TransferFunction``
        (input and output names as in :meth:`LinearSystem.from_control`); a scipy.signal
        ``StateSpace``, ``TransferFunction`` or ``ZerosPolesGain`` (continuous or discrete); a
        tuple ``(A, B, C, D)`` of matrices or ``(A, B, C, D, dt)`` with a sampling period [s]; or
        a tuple ``(num, den)`` or ``(num, den, dt)`` of polynomial coefficients in descending
        powers of ``s`` (or ``z``), proper: ``len(num) <= len(den)``. Units are those of the
        signals. A one-input one-output transfer function is realized in controllable canonical
        form, exact in its coefficients (``scipy.signal.tf2ss``: for ``(num, den)``, scipy's
        ``lti.to_ss`` and python-control's ``TransferFunction``, whose ``control.ss`` would take
        SLICOT's TD04AD when slycot is installed and perturb multiple poles by ``eps^(1/k)``);
        a MIMO python-control ``TransferFunction`` by ``control.ss``, checked against its
        polynomials (an ``AccuracyWarning`` where they differ by more than 1e-10).
    name : str, optional
        The argument's name, for error messages.
    discrete : bool, optional
        Whether the caller handles discrete-time systems; if not, one is refused.
    delay : bool, optional
        Whether the caller handles input and output delays; if not, a delayed system is refused.

    Returns
    -------
    LinearSystem
        ``sys`` itself when it is one, else its first-order state-space form.

    Raises
    ------
    ModelError
        If ``sys`` is none of these, is an improper transfer function, or is discrete-time or
        delayed where the caller does not handle it; the message names the argument ``name``.
    ShapeError
        For tuple entries of inconsistent shapes or non-finite values.

    Examples
    --------
    A mass of 1 kg on a 4 N/m spring with 0.4 N s/m damping, in first-order form:

    >>> from linflex import SecondOrderSystem, as_linear_system
    >>> sys = as_linear_system(SecondOrderSystem([[1.0]], [[0.4]], [[4.0]], [[1.0]], Cq=[[1.0]]))
    >>> sys.A.tolist(), sys.states
    ([[0.0, 1.0], [-4.0, -0.4]], ('q0', 'q0_dot'))

    The first-order lag ``1 / (s + 2)`` as ``(num, den)``:

    >>> as_linear_system(([1.0], [1.0, 2.0])).A.tolist()
    [[-2.0]]
    """
    if isinstance(sys, LinearSystem):
        result = sys
    elif isinstance(sys, SecondOrderSystem):
        result = sys.to_state_space()
    elif isinstance(sys, tuple):
        args, kwargs = from_tuple(sys, name)
        result = LinearSystem(*args, **kwargs)
    else:
        module = type(sys).__module__ or ""
        if module == "control" or module.startswith("control."):
            args, kwargs = from_control(sys, name)
        elif module.startswith("scipy.signal"):
            args, kwargs = from_scipy(sys, name)
        else:
            raise ModelError(
                f"{name} must be a LinearSystem, SecondOrderSystem, control.StateSpace or TransferFunction, "
                f"scipy.signal.lti or dlti, (A, B, C, D[, dt]) or (num, den[, dt]) tuple; got {type(sys).__name__}"
            )
        result = LinearSystem(*args, **kwargs)
    if result.is_discrete and not discrete:
        raise ModelError(
            f"{name}: this function takes continuous-time systems only, got a discrete-time one (dt = {result.dt} s)"
        )
    if result.has_delay and not delay:
        raise ModelError(
            f"{name}: this function takes systems without time delays; convert linflex.pade({name}, order) "
            f"(a rational approximation with its error reported) first"
        )
    return result


def _delays(values, n: int, name: str, dt: float | None) -> NDArray[np.float64]:
    """Per-channel delays [s]: a scalar broadcast to ``n`` channels; non-negative, finite, whole periods if sampled."""
    if values is None:
        arr = np.zeros(n)
    else:
        arr = real_array(values, name, "vector")
        if arr.ndim == 0:
            arr = np.full(n, float(arr))
        arr = real_vector(arr, name, n).copy()
    if np.any(arr < 0):
        i = int(np.flatnonzero(arr < 0)[0])
        raise ModelError(f"{name}[{i}] = {arr[i]} s: a delay cannot be negative")
    if dt is not None and arr.any():
        periods = arr / dt
        off = np.abs(periods - np.round(periods)) > 1e-9 * np.maximum(1.0, periods)
        if off.any():
            i = int(np.flatnonzero(off)[0])
            raise ModelError(
                f"{name}[{i}] = {arr[i]} s is not a whole number of sampling periods (dt = {dt} s); a fractional "
                f"delay of a sampled system is a state-space effect: discretize the continuous system with the delay"
            )
        arr = np.round(periods) * dt
    arr.setflags(write=False)
    return arr


def _closure(start: NDArray[np.bool_], edges: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """States reachable from ``start`` along ``edges[i, j]`` (from j to i), breadth first."""
    marked = start.copy()
    frontier = marked.copy()
    while frontier.any():
        frontier = edges[:, frontier].any(axis=1) & ~marked
        marked |= frontier
    return marked


def _as_list(keys) -> list:
    # one key, or a sequence of keys (a float is one key, which signal_index then refuses by name)
    return [keys] if isinstance(keys, (str, int, np.integer)) or not np.iterable(keys) else list(keys)
