"""flexclear: elastodynamics of flexible planar mechanisms with joint clearance.

Beam finite elements in moving frames, Newmark time integration, and clearance joints entered
as forces (force reaction method), through the stiffness and damping matrices (the modified-matrix
method of Hong & Kim 1993) or as gap elements. SI units throughout.

Every mechanism is a :class:`Model` with one :meth:`Model.simulate` returning one
:class:`Result`; ready ones are in :mod:`flexclear.scenes`:

>>> import flexclear
>>> model = flexclear.scenes.slider_yoke(clearance=1e-4)
>>> res = model.simulate(0.2, 1e-5)
>>> res.joint("bearing").max_penetration  # m
>>> crank = flexclear.scenes.slider_crank(clearance_at="crank_pin")
>>> res = crank.simulate(0.02, 1e-5)
>>> res.joint("crank_pin").max_force  # N

Monte Carlo studies of any model are in :mod:`flexclear.study`.
"""

from . import contact, design, motion, scenes, study
from ._core import __version__
from .errors import (
    ConvergenceError,
    FlexclearError,
    InvalidParameterError,
    ModelError,
    NewmarkStabilityWarning,
    RecordingError,
    ResourceError,
    SimulationDivergedError,
    SimulationInterrupted,
    SingularMatrixError,
    StoreError,
    StoreLockedError,
)
from .frames import Frame, Rotation
from .linkage import Linkage
from .model import Model
from .result import ImpactLog, JointResult, LinkResult, NodeResult, Record, Result, SliderResult

__all__ = [
    "ConvergenceError",
    "FlexclearError",
    "Frame",
    "ImpactLog",
    "InvalidParameterError",
    "JointResult",
    "LinkResult",
    "Linkage",
    "Model",
    "ModelError",
    "NewmarkStabilityWarning",
    "NodeResult",
    "Record",
    "RecordingError",
    "ResourceError",
    "Result",
    "Rotation",
    "SimulationDivergedError",
    "SimulationInterrupted",
    "SingularMatrixError",
    "SliderResult",
    "StoreError",
    "StoreLockedError",
    "__version__",
    "contact",
    "design",
    "motion",
    "scenes",
    "study",
]
