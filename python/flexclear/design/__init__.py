"""Design methods around the simulator (issue 16): contact-loss prediction from a zero-clearance
run, the continuous-contact model run on the whole mechanism, statistical tolerance allocation and
optimization on the study runner. See docs/design.md.
"""

from .contact_loss import ContactLoss, contact_loss, continuous_contact, wall_departures
from .continuous import continuous_loss
from .optimize import Optimum, optimize
from .preload import preloaded_slider_crank
from .tolerance import Allocation, allocate_tolerances

__all__ = [
    "Allocation",
    "ContactLoss",
    "Optimum",
    "allocate_tolerances",
    "contact_loss",
    "continuous_contact",
    "continuous_loss",
    "optimize",
    "preloaded_slider_crank",
    "wall_departures",
]
