"""imucal: knee hinge axis and ankle joint centre from inertial sensors on the leg.

Implements Seel, Schauer, Raisch (2012), "Joint axis and position estimation from
inertial measurement data by exploiting kinematic constraints", with many random
restarts run together and a consensus estimate.

Library use::

    import imucal
    rec = imucal.load_recording("recording.h5")
    thigh, shank = rec.sensor("thigh"), rec.sensor("shank")
    axis = imucal.estimate_axis(thigh.gyr, shank.gyr, rate=rec.rate, seed=1)
    axis.j1, axis.j2          # unit knee axis in the thigh / shank sensor frames

    cal = imucal.calibrate(rec, seed=1)          # every joint; cal.write("cal.json")
    angles = imucal.joint_angles(imucal.load_recording("walk.h5"), cal)
    angles.to_frame()         # time (s), knee_flexion_deg, knee_flexion_sigma_deg

Units: rad/s, m/s^2, Hz, s, m in and out; uncertainties and angles also in mm and deg,
as each field's name says.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from .errors import ImucalError, InputError, NotIdentifiableError

__version__ = "0.1.0"

# The public names below load their modules on first use (PEP 562): the command line
# imports this package for ``__version__`` alone, and eager imports here would make
# every command pay for scipy.ndimage, h5py and the estimators before it parses its
# arguments (docs/performance.md).
_LAZY = {
    "AxisResult": ".axis",
    "Calibration": ".calibration",
    "calibrate": ".calibration",
    "load_calibration": ".calibration",
    "JointAngles": ".angles",
    "joint_angles": ".angles",
    "estimate_axis": ".axis",
    "PositionResult": ".position",
    "estimate_position": ".position",
    "load_recording": ".loaders",
    "Recording": ".recording",
    "SensorData": ".recording",
    "make_recording": ".recording",
    "save_recording": ".writers",
}

if TYPE_CHECKING:  # static analysers and IDEs see ordinary imports
    from .angles import JointAngles, joint_angles
    from .axis import AxisResult, estimate_axis
    from .calibration import Calibration, calibrate, load_calibration
    from .loaders import load_recording
    from .position import PositionResult, estimate_position
    from .recording import Recording, SensorData, make_recording
    from .writers import save_recording


#: Modules of the public API reachable as attributes after ``import imucal`` (the settings
#: objects were not until some estimator had been used: a new-user trial).
_SUBMODULES = ("settings", "simulate")


def __getattr__(name: str):
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'imucal' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY) | set(_SUBMODULES))

__all__ = [
    "AxisResult",
    "Calibration",
    "JointAngles",
    "ImucalError",
    "InputError",
    "NotIdentifiableError",
    "PositionResult",
    "Recording",
    "SensorData",
    "__version__",
    "calibrate",
    "estimate_axis",
    "estimate_position",
    "joint_angles",
    "load_calibration",
    "load_recording",
    "make_recording",
    "save_recording",
]
