"""User-written model builders for the study tests: module-level functions, so Dask workers can
import them by ``module:qualname`` as a user's own module would be."""

from __future__ import annotations

import flexclear as fc

# A crank-rocker four-bar (lengths m: ground, crank, coupler, rocker), aluminium coupler strip.
LENGTHS = (0.254, 0.0508, 0.2794, 0.2794)


def four_bar_with_clearance(
    *, clearance: float = 2.5e-4, stiffness: float = 5e7, damping: float = 500.0, crank_speed: float = 100.0
) -> fc.Model:
    """A four-bar whose flexible coupler has a clearance joint at the crank pin, built with the
    Model API (not the bundled scene)."""
    crank = fc.Rotation.constant(crank_speed)

    def frame(link: str) -> fc.Frame:
        return fc.Frame.four_bar(*LENGTHS, crank, link)

    width, depth = 0.0254, 0.003175
    m = fc.Model()
    m.add_body("crank", frame=frame("crank"))
    m.add_body("rocker", frame=frame("rocker"))
    m.add_link(
        "coupler",
        length=LENGTHS[2],
        elements=6,
        youngs_modulus=7.1e10,
        density=2710.0,
        area=width * depth,
        inertia=width * depth**3 / 12,
        frame=frame("coupler"),
    )
    m.add_joint(
        "crank_pin",
        "coupler",
        0,
        body="crank",
        point=(LENGTHS[1], 0.0),
        clearance=clearance,
        stiffness=stiffness,
        damping=damping,
    )
    m.add_pin("rocker_pin", "coupler", 6, body="rocker", point=(LENGTHS[3], 0.0))
    return m


def slider_yoke_in_moving_frames(*, clearance: float = 1e-4) -> fc.Model:
    """The paper's slider-yoke moved to the moving-frame formulation (zero gravity): the same
    dynamics, a model the constant stepper still runs."""
    m = fc.scenes.slider_yoke(clearance=clearance)
    m.add_gravity(0.0, 0.0)
    return m
