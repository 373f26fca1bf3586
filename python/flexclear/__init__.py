"""flexclear: elastodynamics of flexible planar mechanisms with joint clearance.

Beam finite elements in a floating frame, Newmark time integration, and clearance joints entered
as forces (force reaction method), through the stiffness and damping matrices (the modified-matrix
method of Hong & Kim 1993) or as gap elements. SI units throughout.

>>> import flexclear
>>> model = flexclear.scenes.slider_yoke(clearance=1e-4)
>>> res = model.simulate(0.2, 1e-5)
>>> res.joint("bearing").max_penetration  # m
"""

from . import motion, scenes, study
from ._core import __version__
from .errors import (
    FlexclearError,
    InvalidParameterError,
    ModelError,
    SimulationDivergedError,
    SimulationInterrupted,
    SingularMatrixError,
)
from .model import JointResult, Model, NodeResult, Record, Result

__all__ = [
    "FlexclearError",
    "InvalidParameterError",
    "JointResult",
    "Model",
    "ModelError",
    "NodeResult",
    "Record",
    "Result",
    "SimulationDivergedError",
    "SimulationInterrupted",
    "SingularMatrixError",
    "__version__",
    "motion",
    "scenes",
    "study",
]
