"""Newton convergence with friction in a clearance joint (docs/contact.md, section 4.1): the
iterations per step (mean and largest) of the scene of that section's table, the last column
(friction implicit, its slip and normal-force tangents in the Jacobian, the secant after six
iterations of a step). Iteration counts, not speed.

Two free steel links (0.1 m, 2 elements) joined at node 0 by a clearance joint (c = 0.1 mm,
K = 1e6 N/m, radial dashpot 2 N s/m, R_J = 5 mm, mu = 0.3): the journal link starts with a rigid
rotation at ``w`` rad/s and moves at 0.1 m/s towards the bearing link; one impact in 3 ms.

    python benches/friction_newton.py
"""

from __future__ import annotations

import math

import flexclear as fc
import numpy as np
from flexclear import Frame, Record, Rotation

STEEL = dict(length=0.1, elements=2, youngs_modulus=2e11, density=7800.0, area=1e-4, inertia=1e-8)


def two_links(law, w: float, vy: float = 0.1) -> fc.Model:
    m = fc.Model()
    iv = np.zeros(9)
    iv[1::3] = -vy + w * np.array([0.0, 0.05, 0.1])
    iv[2::3] = w
    m.add_link("a", initial_velocity=iv, **STEEL)
    m.add_link("b", frame=Frame.rotating(Rotation.fixed(math.pi)), **STEEL)
    m.add_joint(
        "joint",
        "a",
        0,
        target=("b", 0),
        clearance=1e-4,
        stiffness=1e6,
        damping=2.0,
        damping_law="radial",
        friction=law,
        journal_radius=5e-3,
    )
    return m


def main() -> None:
    laws = {
        "Ambrosio": fc.contact.Coulomb(0.3),
        "linear v_reg=1e-4": fc.contact.Coulomb(0.3, regularization="linear", v_reg=1e-4),
        "LuGre": fc.contact.LuGre(mu=0.3, mu_static=0.4, stribeck_speed=1e-3),
    }
    print(f"{'law':20s} {'w':>5s} {'dt':>6s}  iterations/step  largest  factorizations")
    for name, law in laws.items():
        for w in (5.0, 1.0, 0.2):
            for dt in (1e-6, 1e-5):
                m = two_links(law, w)
                try:
                    r = m.simulate(3e-3, dt, record=Record(histories=False), method="modified", iterate=True)
                except fc.ConvergenceError as e:
                    print(f"{name:20s} {w:5.1f} {dt:6.0e}  fails: {e}")
                    continue
                s = r.stats
                print(
                    f"{name:20s} {w:5.1f} {dt:6.0e}  {s['iterations'] / s['steps']:15.3f}  "
                    f"{s['max_iterations']:7d}  {s['factorizations']:14d}"
                )


if __name__ == "__main__":
    main()
