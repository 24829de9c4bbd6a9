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

Units everywhere: rad/s, m/s^2, Hz, s, m.
"""

from .axis import AxisResult, estimate_axis
from .errors import ImucalError, InputError, NotIdentifiableError
from .loaders import load_recording
from .position import PositionResult, estimate_position
from .recording import Recording, SensorData, make_recording

__version__ = "0.1.0"

__all__ = [
    "AxisResult",
    "ImucalError",
    "InputError",
    "NotIdentifiableError",
    "PositionResult",
    "Recording",
    "SensorData",
    "__version__",
    "estimate_axis",
    "estimate_position",
    "load_recording",
    "make_recording",
]
