"""A Watt six-bar of one's own, built with flexclear.Linkage, for benches/studies/watt_six_bar_clearance.toml.

Two four-bars in series (lengths in m; illustrative data): the crank O2-A (0.0508) drives the
coupler A-B (0.2794) and the ternary rocker O4-B-C (O4-B 0.2794, C at (0.1, 0.08) in its frame);
the rod C-D (0.25, flexible: aluminium, 6 elements, the four-bar scene's section) drives the
output link O6-D (0.15). The rod's end C sits in a clearance joint on the rocker, its end D is
pinned to the output. The study file names this module's ``build`` (``"watt_six_bar:build"``):
a study file finds a builder module beside it.
"""

from flexclear import Linkage, Rotation

#: The rod's section and material: the four-bar scene's coupler (aluminium, 8.06e-5 m^2).
ROD = dict(elements=6, youngs_modulus=7.1e10, density=2710.0, area=8.06e-5, inertia=6.78e-11)


def linkage(crank_speed: float = 60.0) -> Linkage:
    """The six-bar's rigid-body kinematics, the crank turning at ``crank_speed`` (rad/s) from
    the x axis."""
    six = Linkage()
    six.ground("O2", (0.0, 0.0)).ground("O4", (0.254, 0.0)).ground("O6", (0.45, 0.05))
    six.crank("crank", "O2", "A", length=0.0508, driver=Rotation.constant(crank_speed))
    six.point("B", near=(0.15, 0.26)).point("C", near=(0.14, 0.06)).point("D", near=(0.35, 0.2))
    six.link("coupler", "A", "B", length=0.2794)
    six.body("rocker", {"O4": (0.0, 0.0), "B": (0.2794, 0.0), "C": (0.1, 0.08)})
    six.link("rod", "C", "D", length=0.25)
    six.link("output", "O6", "D", length=0.15)
    return six


def build(
    clearance: float = 2.5e-4,
    bearing_stiffness: float = 5e7,
    bearing_damping: float = 500.0,
    crank_speed: float = 60.0,
    span: float = 0.1,
):
    """The six-bar's model over ``[0, span]`` (s; at least the study's ``t_end``): the flexible
    rod with a clearance joint ``"C"`` (radial clearance m, stiffness N/m, damping N s/m) on the
    rocker and a pin ``"D"`` on the output link."""
    return linkage(crank_speed).model(
        span,
        flexible={"rod": ROD},
        clearances={"C": dict(clearance=clearance, stiffness=bearing_stiffness, damping=bearing_damping)},
    )
