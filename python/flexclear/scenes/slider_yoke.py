"""The paper's slider-yoke (Hong & Kim 1993, Fig. 4), as reconstructed in docs/scenes.md section 1,
and its stiff-bearing variant."""

from __future__ import annotations

import inspect
from typing import Optional

from .. import _core
from ..model import Model
from ._checks import _elements, _types


def slider_yoke(
    *,
    clearance: float = 0.0,
    amplitude: float = 0.010,
    frequency: float = 6.0,
    bearing_stiffness: Optional[float] = None,
    bearing_damping: Optional[float] = None,
    elements: int = 12,
    length: float = 0.269,
    side: float = 0.0127,
    density: float = 7850.0,
    youngs_modulus: Optional[float] = None,
    first_frequency: float = 880.0,
    damping_ratio: float = 0.01,
    stiffness_ratio: float = 100.0,
    bearing_damping_ratio: float = 0.5,
    damping_law: str = "viscous",
    no_tension: bool = False,
    geometry: str = "end",
    rotary_inertia: bool = False,
) -> Model:
    """The paper's slider-yoke mechanism (Hong & Kim 1993, Fig. 4), as reconstructed in docs/scenes.md.

    A free-free steel slider (``length`` x ``side`` x ``side``) joined at its end x = 0 by a
    clearance bearing named ``"bearing"`` to a rigid yoke ``"yoke"`` moving
    ``Y(t) = amplitude sin(2 pi frequency t)`` transversely. The original parameters (Dubowsky,
    Deck & Costello 1987) are not available: this is a **reconstruction** that reproduces the
    paper's Table 1 analytic column within 1 dB with one parameter set.

    Parameters
    ----------
    clearance : float
        Radial clearance delta_c, m. Table 1 rows use ``r * amplitude``, r in {0, 0.001, 0.01, 0.1}.
    amplitude : float
        Yoke amplitude Y, m.
    frequency : float
        Yoke frequency f, Hz.
    bearing_stiffness : float, optional
        K_B, N/m. **Derived** when omitted: ``(m/4) (stiffness_ratio 2 pi f)^2`` with the slider
        mass m = rho A L (about 1.21e6 N/m); ``stiffness_ratio = 100`` gives the -80.0 dB row.
    bearing_damping : float, optional
        C_B, N s/m. **Derived** when omitted: ``2 bearing_damping_ratio sqrt(K_B m / 4)``
        (about 321 N s/m at 50 %).
    elements : int
        Beam elements (12 are converged for this scene).
    length, side : float
        Slider length and square-section side, m.
    density : float
        kg/m^3.
    youngs_modulus : float, optional
        Pa. **Derived** when omitted so that the first free-free bending frequency is
        ``first_frequency`` (Hz) with (beta1 L)^2 = 22.3733 (about 1.868e11 Pa).
    damping_ratio : float
        Kelvin-Voigt damping as a fraction of critical at ``first_frequency``
        (eta/E = 2 zeta / (2 pi f1)).
    damping_law : {"viscous", "radial", "literal"}
        Bearing damping form (see :meth:`flexclear.Model.add_joint`).
    no_tension : bool
        Forbid tensile contact force.
    geometry : {"end", "both_ends", "mid_span"}
        One bearing at x = 0 (default), one at each end (``"bearing"``, ``"bearing_2"``), or one
        at mid-span.
    rotary_inertia : bool
        Include rotary inertia.

    Returns
    -------
    Model
        With ``model.parameters`` holding the inputs and the derived values (``youngs_modulus``,
        ``eta``, ``bearing_stiffness``, ``bearing_damping``, ``mass``, ``area``, ``inertia``).

    Notes
    -----
    Initial state: the zero-clearance steady motion (absolute transverse velocity
    ``Y 2 pi f (1 - 1.5 x / L)``, rotation rate ``-1.5 Y 2 pi f / L``, no deformation). The slider
    frame translates with the yoke, whose motion enters as the inertia load ``-M_R a_R``.
    """
    _types(
        numbers=dict(
            clearance=clearance,
            amplitude=amplitude,
            frequency=frequency,
            length=length,
            side=side,
            density=density,
            first_frequency=first_frequency,
            damping_ratio=damping_ratio,
            stiffness_ratio=stiffness_ratio,
            bearing_damping_ratio=bearing_damping_ratio,
        ),
        optional_numbers=dict(
            youngs_modulus=youngs_modulus,
            bearing_stiffness=bearing_stiffness,
            bearing_damping=bearing_damping,
        ),
        strings=dict(damping_law=damping_law, geometry=geometry),
        flags=dict(no_tension=no_tension, rotary_inertia=rotary_inertia),
    )
    inputs = dict(
        clearance=clearance,
        amplitude=amplitude,
        frequency=frequency,
        length=length,
        side=side,
        density=density,
        youngs_modulus=youngs_modulus,
        first_frequency=first_frequency,
        damping_ratio=damping_ratio,
        elements=_elements("elements", elements),
        bearing_stiffness=bearing_stiffness,
        stiffness_ratio=stiffness_ratio,
        bearing_damping=bearing_damping,
        bearing_damping_ratio=bearing_damping_ratio,
        damping_law=damping_law,
        no_tension=no_tension,
        geometry=geometry,
        rotary_inertia=rotary_inertia,
    )
    core, derived = _core.slider_yoke(**inputs)
    params = {**inputs, **derived}
    return Model._wrap(core, params)


def slider_yoke_stiff(**overrides) -> Model:
    """The stiff-bearing (steel-on-steel) variant for the paper's Fig. 5(b): K_B = 1e10 N/m,
    C_B for 50 % damping of the end mass (2 x 0.5 x sqrt(K_B m/4), about 2.9e4 N s/m), clearance
    1e-5 m."""
    kw = dict(clearance=1e-5, bearing_stiffness=1e10)
    kw.update(overrides)
    return slider_yoke(**kw)


def _stiff_signature() -> inspect.Signature:
    sig = inspect.signature(slider_yoke)
    params = [
        p.replace(default=1e-5)
        if p.name == "clearance"
        else p.replace(default=1e10)
        if p.name == "bearing_stiffness"
        else p
        for p in sig.parameters.values()
    ]
    return sig.replace(parameters=params)


# The keywords (and their defaults) of the stiff variant, for introspection (flexclear.study).
slider_yoke_stiff.__signature__ = _stiff_signature()  # type: ignore[attr-defined]
