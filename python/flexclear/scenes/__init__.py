"""The test mechanisms flexclear ships (see ``docs/scenes.md``). Each returns a ready
:class:`flexclear.Model` (run it with ``.simulate(t_end, dt)``, or add to it). Every number is a
default that can be overridden by keyword; SI units (``clearance`` in metres, not a ratio).

* :func:`slider_yoke`, :func:`slider_yoke_stiff`: the paper's slider-yoke.
* :func:`spin_up`: a cantilever on a hub spun up in the plane.
* :func:`slider_crank`, :func:`four_bar`: flexible links in mechanism frames, each with an optional
  clearance joint at one of its pins (``clearance_at``).
* :func:`flores_slider_crank`: the Flores et al. benchmark, rigid crank, rod and slider with a
  clearance joint at the piston pin.
"""

from .flores import FLORES_DATA, flores_slider_crank
from .four_bar import four_bar
from .slider_crank import slider_crank
from .slider_yoke import slider_yoke, slider_yoke_stiff
from .spin_up import SPIN_UP_DATA, spin_up

# The scenes are flexclear.scenes' API: name it as their home, so a study stores a scene as
# "flexclear.scenes:<name>" whichever file defines it.
for _f in (flores_slider_crank, four_bar, slider_crank, slider_yoke, slider_yoke_stiff, spin_up):
    _f.__module__ = __name__
del _f

__all__ = [
    "FLORES_DATA",
    "SPIN_UP_DATA",
    "flores_slider_crank",
    "four_bar",
    "slider_crank",
    "slider_yoke",
    "slider_yoke_stiff",
    "spin_up",
]
