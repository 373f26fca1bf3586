"""Exudyn reference model of Simeon's flexible slider-crank (SI units), optionally with a
clearance joint at the crank pin: the scene of ``flexclear.scenes.slider_crank``.

Crank pivot at the origin, crank of length r turning at the constant rate w (angle w t), rod of
length l (square steel section, ``ANCFCable2D`` elements, undamped) from the crank pin A to the
slider pin B, slider a mass point on the x axis (a ``CoordinateConstraint`` holds its y at 0)
joined to the rod's last node by an ideal pin (``RevoluteJoint2D``). No gravity.

The crank is rigid and driven, so its pin is a prescribed point A(t) = r (cos w t, sin w t):

- with a clearance (``clearance=c``), a ``CartesianSpringDamper`` between a ground marker at the
  origin and rod node 0 whose *symbolic* (compiled, no Python callback) user function puts the
  crank motion in: q = node_0 - A(t), qdot = v_0 - Adot(t), and the bearing law of flexclear's
  ``SpringDamper`` (viscous damping law, not clipped): f_node = -K_B (|q| - c) q/|q| - C_B qdot
  while |q| > c, 0 otherwise;
- ideal (``clearance=None``), two ``CoordinateConstraint``s hold node 0's x and y on A(t) (symbolic
  offset user functions).

Initial state, as flexclear's moving-frame scene: the undeformed straight rod on the rigid
mechanism at t = 0 (A = (r, 0), B = (r + l, 0)) with the rigid mechanism's velocities (the rod
turns about B at -r w / l: v_y(s) = r w (1 - s/l), slope rate -r w / l; the slider at rest), the
journal centred (node 0 on A).

K_B and C_B are derived as ``flexclear.scenes.slider_crank`` documents (and
``rust/scenes/slider_crank.rs`` computes): the Hertz secant at the reference penetration and
``2 zeta sqrt(K_B m_eff)``, m_eff half the rod mass (crank pin). ``scene_parameters`` repeats
that derivation so that this module runs without flexclear; the benchmark checks it against
flexclear's own ``Model.parameters``.

Used by benches/exudyn_slider_crank.py; ``run_exudyn`` is the entry point.
"""

from __future__ import annotations

import math
import sys
import time

# exudynCPPfast (no range checks, AVX2) is the fastest Exudyn build; it is only selected if
# requested *before* the first `import exudyn`.
if "exudyn" not in sys.modules:
    sys.exudynFast = True

import exudyn as exu
import numpy as np
from exudyn.advancedUtilities import CreateSymbolicUserFunction
from exudyn.itemInterface import (
    Cable2D,
    CartesianSpringDamper,
    CoordinateConstraint,
    MarkerBodyPosition,
    MarkerNodeCoordinate,
    MarkerNodePosition,
    MassPoint2D,
    NodePoint2D,
    NodePoint2DSlope1,
    NodePointGround,
    ObjectGround,
    RevoluteJoint2D,
    SensorNode,
)

esym = exu.symbolic

# Newton tolerances as an Exudyn user would set them for this scene (the configuration):
# absolute (Exudyn measure: |residual|_2 / n_coordinates, in N) and relative.
NEWTON_ABS_TOL = 1e-5
NEWTON_REL_TOL = 1e-8


def scene_parameters(
    clearance: float | None = 5e-4,
    elements: int = 8,
    bearing_stiffness: float | None = None,
    crank_speed: float = 150.0,
) -> dict:
    """All parameters of the scene at flexclear's defaults (SI units); ``clearance=None`` for
    ideal pins. K_B and C_B as ``flexclear.scenes.slider_crank`` derives them (a given
    ``bearing_stiffness`` K_B, N/m, replaces the Hertz secant; C_B follows it); ``crank_speed``
    in rad/s."""
    r, l, w = 0.15, 0.30, float(crank_speed)
    side, E, rho = 0.008, 2.0e11, 7870.0
    A = side * side
    I = side**4 / 12.0
    p = {
        "crank_length": r,
        "rod_length": l,
        "crank_speed": w,
        "side": side,
        "youngs_modulus": E,
        "density": rho,
        "slider_mass": 0.075552,
        "elements": int(elements),
        "area": A,
        "inertia": I,
        "rod_mass": rho * A * l,
        "clearance": None if clearance is None else float(clearance),
    }
    if clearance is not None:
        nu, radius, ref_pen, zeta = 0.3, 5e-3, 1e-5, 0.2
        c_ref = max(float(clearance), 1e-9)
        e_star = E / (2.0 * (1.0 - nu * nu))
        r_star = radius * (radius + c_ref) / c_ref
        K_B = 4.0 / 3.0 * e_star * math.sqrt(r_star) * math.sqrt(ref_pen)
        if bearing_stiffness is not None:
            K_B = float(bearing_stiffness)
        m_eff = p["rod_mass"] / 2.0
        p.update(
            bearing_stiffness=K_B, bearing_damping=2.0 * zeta * math.sqrt(K_B * m_eff), effective_mass=m_eff
        )
    return p


def exudyn_info() -> str:
    """Exudyn version and which compiled module is loaded."""
    module = getattr(exu, "_compiledModuleName", None) or exu.SystemContainer.__module__
    return f"exudyn {exu.__version__} ({module})"


def _bearing_force_function(p: dict):
    """Symbolic user function of the ``CartesianSpringDamper`` (ground marker at the origin,
    marker 1 = rod node 0): Exudyn passes u = node position, v = node velocity and applies -UF on
    the node, so UF = K_B delta q/|q| + C_B qdot (in contact) gives f_node = -K_B delta n -
    C_B qdot."""
    r, w = p["crank_length"], p["crank_speed"]
    c, K, C = p["clearance"], p["bearing_stiffness"], p["bearing_damping"]
    one, zero = esym.Real(1.0), esym.Real(0.0)

    def springForceUserFunction(mbs, t, itemNumber, u, v, k, d, offset):
        qx = u[0] - r * esym.cos(w * t)
        qy = u[1] - r * esym.sin(w * t)
        vx = v[0] + r * w * esym.sin(w * t)
        vy = v[1] - r * w * esym.cos(w * t)
        dr = esym.sqrt(qx * qx + qy * qy)
        pen = dr - c
        # max(dr, tiny) avoids 0/0 at the bearing centre (pen <= 0 there anyway)
        fac = K * esym.max(pen, zero) / esym.max(dr, esym.Real(1e-300))
        act = esym.IfThenElse(pen > 0.0, one, zero)
        return [fac * qx + act * C * vx, fac * qy + act * C * vy, 0.0]

    return springForceUserFunction


def _pin_offset_function(p: dict, axis: int):
    """Symbolic offset user function of a ``CoordinateConstraint`` holding node 0's displacement
    coordinate ``axis`` on the crank pin A(t) (reference position (r, 0))."""
    r, w = p["crank_length"], p["crank_speed"]
    if axis == 0:

        def offsetUserFunction(mbs, t, itemNumber, lOffset):
            return r * esym.cos(w * t) - r

    else:

        def offsetUserFunction(mbs, t, itemNumber, lOffset):
            return r * esym.sin(w * t)

    return offsetUserFunction


def build_model(
    clearance: float | None = 5e-4,
    elements: int = 8,
    bearing_stiffness: float | None = None,
    crank_speed: float = 150.0,
):
    """Build the scene; returns (SystemContainer, mbs, sensors dict, keep-alive list)."""
    p = scene_parameters(clearance, elements, bearing_stiffness, crank_speed)
    r, l, w = p["crank_length"], p["rod_length"], p["crank_speed"]
    E, A, I, rho = p["youngs_modulus"], p["area"], p["inertia"], p["density"]

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()

    le = l / elements
    va = r * w  # crank pin speed (along +y at t = 0)
    rate = -va / l  # rod angular velocity at t = 0 (turns about B)
    nodes = []
    for i in range(elements + 1):
        s = i * le
        nodes.append(
            mbs.AddNode(
                NodePoint2DSlope1(
                    referenceCoordinates=[r + s, 0.0, 1.0, 0.0],
                    initialCoordinates=[0.0, 0.0, 0.0, 0.0],
                    initialVelocities=[0.0, va + rate * s, 0.0, rate],
                )
            )
        )
    for i in range(elements):
        mbs.AddObject(
            Cable2D(
                length=le,
                massPerLength=rho * A,
                bendingStiffness=E * I,
                axialStiffness=E * A,
                nodeNumbers=[nodes[i], nodes[i + 1]],
            )
        )

    # slider: a mass point on the guide y = 0, pinned to the rod's last node
    slider = mbs.AddNode(NodePoint2D(referenceCoordinates=[r + l, 0.0]))
    mbs.AddObject(MassPoint2D(mass=p["slider_mass"], nodeNumber=slider))
    ground_node = mbs.AddNode(NodePointGround())
    m_ground_coord = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    m_slider_y = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=slider, coordinate=1))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[m_ground_coord, m_slider_y]))
    m_end = mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[-1]))
    m_slider = mbs.AddMarker(MarkerNodePosition(nodeNumber=slider))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[m_end, m_slider]))

    keep_alive = []  # the symbolic functions must outlive the simulation
    if clearance is None:
        for axis in (0, 1):
            m_node = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=axis))
            con = mbs.AddObject(CoordinateConstraint(markerNumbers=[m_ground_coord, m_node]))
            uf = CreateSymbolicUserFunction(mbs, _pin_offset_function(p, axis), "offsetUserFunction", con)
            mbs.SetObjectParameter(con, "offsetUserFunction", uf)
            keep_alive.append(uf)
    else:
        ground = mbs.AddObject(ObjectGround())
        m_origin = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[0.0, 0.0, 0.0]))
        m_node0 = mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[0]))
        con = mbs.AddObject(
            CartesianSpringDamper(
                markerNumbers=[m_origin, m_node0],
                stiffness=[0.0, 0.0, 0.0],
                damping=[0.0, 0.0, 0.0],
                offset=[0.0, 0.0, 0.0],
            )
        )
        uf = CreateSymbolicUserFunction(mbs, _bearing_force_function(p), "springForceUserFunction", con)
        mbs.SetObjectParameter(con, "springForceUserFunction", uf)
        keep_alive.append(uf)

    sensors = {
        name: mbs.AddSensor(
            SensorNode(nodeNumber=node, storeInternal=True, writeToFile=False, outputVariableType=kind)
        )
        for name, node, kind in (
            ("pos0", nodes[0], exu.OutputVariableType.Position),
            ("vel0", nodes[0], exu.OutputVariableType.Velocity),
            ("mid", nodes[elements // 2], exu.OutputVariableType.Position),
            ("end", nodes[-1], exu.OutputVariableType.Position),
            ("slider", slider, exu.OutputVariableType.Position),
        )
    }
    mbs.Assemble()
    return SC, mbs, sensors, keep_alive


def simulation_settings(dt: float, t_end: float, adaptive: bool = True):
    """Newmark (beta=1/4, gamma=1/2: trapezoidal, no numerical damping), step dt, modified Newton
    with NEWTON_ABS_TOL / NEWTON_REL_TOL, Exudyn's step reduction where Newton fails
    (``adaptive``), sensors stored every step, no file output, Exudyn's default dense LU."""
    steps = round(t_end / dt)
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = steps * dt
    ti.adaptiveStep = adaptive
    ti.automaticStepSize = False
    ti.verboseMode = 0
    ti.generalizedAlpha.useNewmark = True
    ti.generalizedAlpha.newmarkBeta = 0.25
    ti.generalizedAlpha.newmarkGamma = 0.5
    ti.generalizedAlpha.spectralRadius = 1.0
    ti.newton.useModifiedNewton = True
    ti.newton.absoluteTolerance = NEWTON_ABS_TOL
    ti.newton.relativeTolerance = NEWTON_REL_TOL
    s.solution.file.write = False
    s.solution.sensors.writePeriod = 0.0  # every step, also the halved ones
    # Exudyn's default linear solver (EXUdense): on this model it is the faster one, 2.2 % faster
    # than EigenSparse over 0.1 s (medians of 11 alternating fresh-process runs, 0.459 against
    # 0.469 s of SolveSteps, 2026-11-29); for the slider-yoke, sparse is (exudyn_scene.py)
    s.linearSolver.solverType = exu.LinearSolverType.EXUdense
    return s, steps


def run_exudyn(clearance=5e-4, elements=8, dt=1e-5, t_end=0.1, window=0.02, adaptive=True) -> dict:
    """Simulate the scene in Exudyn.

    Times ``SolveSteps`` (the integration: ``seconds``) and the whole of ``SolveDynamic``'s work
    (``InitializeSolver`` + ``SolveSteps`` + ``FinalizeSolver``: ``seconds_total``). Returns those,
    the steps taken (more than ``t_end/dt`` when Newton failed and the step was halved), Newton
    iterations and Jacobians, the slider's position at t_end, and ``window``: the histories over
    [0, window] at every step taken (times ``t``, s; the rod's midspan deflection from the chord
    ``midspan``, m; with a clearance the crank pin's ``penetration``, m, and contact ``force``
    magnitude, N, from node 0's position and velocity by the law above).
    """
    p = scene_parameters(clearance, elements)
    _sc, mbs, sensors, keep_alive = build_model(clearance, elements)
    settings, steps = simulation_settings(dt, t_end, adaptive)

    solver = exu.MainSolverImplicitSecondOrder()
    t0 = time.perf_counter()
    solver.InitializeSolver(mbs, settings)
    t1 = time.perf_counter()
    ok = solver.SolveSteps(mbs, settings)
    t2 = time.perf_counter()
    solver.FinalizeSolver(mbs, settings)
    t3 = time.perf_counter()
    if not ok:
        raise RuntimeError(f"Exudyn failed at t = {solver.it.currentTime}: {solver.GetErrorString()}")
    out = {
        "tool": exudyn_info(),
        "seconds": t2 - t1,
        "seconds_total": t3 - t0,
        "steps": None,  # from the sensor rows below
        "nominal_steps": steps,
        "newton_iterations": int(solver.it.newtonStepsCount),
        "jacobians": int(solver.it.newtonJacobiCount),
        "end_time": float(solver.it.currentTime),
    }
    # histories over [0, window] at every step taken, for the comparison
    x = mbs.GetSensorStoredData(sensors["pos0"])
    t = x[:, 0]
    win = t <= window * (1 + 1e-9)
    xm, xe = mbs.GetSensorStoredData(sensors["mid"]), mbs.GetSensorStoredData(sensors["end"])
    cx, cy = xe[:, 1] - x[:, 1], xe[:, 2] - x[:, 2]
    midspan = (-(xm[:, 1] - x[:, 1]) * cy + (xm[:, 2] - x[:, 2]) * cx) / np.hypot(cx, cy)
    out["slider_x_end"] = float(mbs.GetSensorStoredData(sensors["slider"])[-1, 1])
    # the sensors store every step taken (write period 0) and the initial state
    out["steps"] = int(np.unique(t).size - 1)
    out["window"] = {"t": t[win].tolist(), "midspan": midspan[win].tolist()}
    if clearance is not None:
        v = mbs.GetSensorStoredData(sensors["vel0"])
        r, w = p["crank_length"], p["crank_speed"]
        qx = x[:, 1] - r * np.cos(w * t)
        qy = x[:, 2] - r * np.sin(w * t)
        vx = v[:, 1] + r * w * np.sin(w * t)
        vy = v[:, 2] - r * w * np.cos(w * t)
        dr = np.hypot(qx, qy)
        pen = dr - p["clearance"]
        closed = pen > 0
        K, C = p["bearing_stiffness"], p["bearing_damping"]
        fx = np.where(closed, K * pen * qx / np.maximum(dr, 1e-300) + C * vx, 0.0)
        fy = np.where(closed, K * pen * qy / np.maximum(dr, 1e-300) + C * vy, 0.0)
        out["window"].update(penetration=pen[win].tolist(), force=np.hypot(fx, fy)[win].tolist())
    del keep_alive
    return out


def parameter_function(parameters: dict) -> list:
    """For ``exudyn.processing.ParameterVariation``: one sample of the reference slider-crank
    study with ``parameters["clearance"]`` (m), ``["bearing_stiffness"]`` (N/m) and
    ``["crank_speed"]`` (rad/s); ``parameters["functionData"]`` = dict(dt, t_end, elements).
    Runs to ``t_end`` with the sensors at every step; returns [max_penetration (m), max_force
    (N), impacts, steps taken, SolveSteps seconds] over the whole run."""
    data = parameters.get("functionData", {})
    dt, t_end, elements = data.get("dt", 1e-5), data.get("t_end", 0.1), data.get("elements", 8)
    clearance = float(parameters["clearance"])
    K = float(parameters["bearing_stiffness"])
    w = float(parameters["crank_speed"])
    p = scene_parameters(clearance, elements, K, w)
    _sc, mbs, sensors, keep_alive = build_model(clearance, elements, K, w)
    settings, _steps = simulation_settings(dt, t_end, True)
    solver = exu.MainSolverImplicitSecondOrder()
    solver.InitializeSolver(mbs, settings)
    t0 = time.perf_counter()
    ok = solver.SolveSteps(mbs, settings)
    seconds = time.perf_counter() - t0
    solver.FinalizeSolver(mbs, settings)
    if not ok:
        return [float("nan")] * 4 + [seconds]
    x = mbs.GetSensorStoredData(sensors["pos0"])
    v = mbs.GetSensorStoredData(sensors["vel0"])
    t = x[:, 0]
    r = p["crank_length"]
    qx = x[:, 1] - r * np.cos(w * t)
    qy = x[:, 2] - r * np.sin(w * t)
    vx = v[:, 1] + r * w * np.sin(w * t)
    vy = v[:, 2] - r * w * np.cos(w * t)
    dr = np.hypot(qx, qy)
    pen = dr - clearance
    closed = pen > 0
    Kb, C = p["bearing_stiffness"], p["bearing_damping"]
    fx = np.where(closed, Kb * pen * qx / np.maximum(dr, 1e-300) + C * vx, 0.0)
    fy = np.where(closed, Kb * pen * qy / np.maximum(dr, 1e-300) + C * vy, 0.0)
    del keep_alive
    return [
        float(pen.max()),
        float(np.hypot(fx, fy).max()),
        int(np.sum(closed[1:] & ~closed[:-1])),
        int(np.unique(t).size - 1),
        seconds,
    ]


if __name__ == "__main__":
    import json

    print(exudyn_info())
    print(json.dumps(run_exudyn(t_end=0.02), indent=1))
