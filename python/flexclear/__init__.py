"""flexclear: elastodynamics of flexible planar mechanisms with joint clearance.

Beam finite elements in a floating frame, Newmark time integration, and clearance joints entered
as forces (force reaction method), through the stiffness and damping matrices (the modified-matrix
method of Hong & Kim 1993) or as gap elements. SI units throughout.

>>> import flexclear
>>> model = flexclear.scenes.slider_yoke(clearance=1e-4)
>>> res = model.simulate(0.2, 1e-5)
>>> res.joint("bearing").max_penetration  # m

Mechanisms of flexible links in moving frames (kineto-elastodynamics) are :class:`Mechanism`
objects; ready ones are in :mod:`flexclear.scenes` (``spin_up``, ``slider_crank``, ``four_bar``):

>>> mech = flexclear.scenes.spin_up()
>>> res = mech.simulate(20.0, 1e-3)
>>> res.link("beam").tip  # m, in the hub frame
"""

from . import motion, scenes, study
from ._core import __version__
from .errors import (
    ConvergenceError,
    FlexclearError,
    InvalidParameterError,
    ModelError,
    SimulationDivergedError,
    SimulationInterrupted,
    SingularMatrixError,
)
from .mechanism import Frame, LinkResult, Mechanism, MechanismJointResult, MechanismResult, Rotation
from .model import ImpactLog, JointResult, Model, NodeResult, Record, Result

__all__ = [
    "ConvergenceError",
    "FlexclearError",
    "Frame",
    "ImpactLog",
    "InvalidParameterError",
    "JointResult",
    "LinkResult",
    "Mechanism",
    "MechanismJointResult",
    "MechanismResult",
    "Model",
    "ModelError",
    "NodeResult",
    "Record",
    "Result",
    "Rotation",
    "SimulationDivergedError",
    "SimulationInterrupted",
    "SingularMatrixError",
    "__version__",
    "motion",
    "scenes",
    "study",
]
