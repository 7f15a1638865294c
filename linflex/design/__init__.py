"""linflex.design: control design on a linearized plant, checked the way the report checks it.

- :func:`rigid_inertia` and :func:`pid_from_bandwidth`: PD/PID gains from a bandwidth and a
  damping on the vehicle's rigid-body inertia, read exactly from the plant;
- :func:`notch_at` (a notch on a mode chosen by state name or frequency), :func:`roll_off` (a
  low-pass for an attenuation above a frequency), chained by :func:`linflex.series`;
- :func:`lqr`, :func:`lqg` through python-control with the signal names kept;
- :func:`tune`: the largest bandwidth (or best objective) that meets gain, phase, delay and disk
  margin requirements, naming the active one.

The filters are those of :mod:`linflex.system` (``notch``, ``low_pass``, ``lead_lag``). This
room stands above the three layers (it uses ``linflex.stability``'s margins and the report's
requirement checks); only ``linflex.cli`` stands above it.
"""

from ._optimal import LQGDesign, LQRDesign, lqg, lqr
from ._rigid import PIDGains, RigidInertia, pid_from_bandwidth, rigid_inertia
from ._shaping import NotchDesign, notch_at, roll_off
from ._tune import TuneResult, tune

__all__ = ["LQGDesign", "LQRDesign", "NotchDesign", "PIDGains", "RigidInertia", "TuneResult", "lqg", "lqr",
           "notch_at", "pid_from_bandwidth", "rigid_inertia", "roll_off", "tune"]
