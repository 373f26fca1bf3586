"""Exudyn reference model of the "slider-yoke" scene (SI units).

A free-free steel beam ("slider", ANCFCable2D, along x) is driven at its x=0 end
by a rigid yoke moving in y with Y(t) = Y0 sin(2 pi f t) through a 2D clearance
bearing (penalty spring-damper, active only when the radial gap is closed).

The bearing force is a Cartesian spring-damper between a ground marker at the
origin and the beam's node-0 position marker, with a *symbolic* (compiled, no
Python callback) user function. The yoke motion is put into the user function:
q = node_pos - (0, Y(t)), qdot = node_vel - (0, Ydot(t)).

Used by benches/exudyn_slider_yoke.py; `run_exudyn` is the entry point.
"""

from __future__ import annotations

import math
import sys
import time

# exudynCPPfast (no range checks, AVX2) is the fastest Exudyn build; it is only
# selected if requested *before* the first `import exudyn`.
if "exudyn" not in sys.modules:
    sys.exudynFast = True

import exudyn as exu
import numpy as np
from exudyn.advancedUtilities import CreateSymbolicUserFunction
from exudyn.itemInterface import (
    Cable2D,
    CartesianSpringDamper,
    MarkerBodyPosition,
    MarkerNodePosition,
    NodePoint2DSlope1,
    ObjectGround,
    SensorNode,
)

esym = exu.symbolic

# Newton absolute tolerance (Exudyn measure: |residual|_2 / n_coordinates, in N).
# The default 1e-10 is below the round-off floor of the stiff ANCF axial forces
# (EA ~ 3e7 N) and makes Newton fail in the first steps; 1e-6 is reachable and
# results agree with 1e-5 to ~1e-11 m.
NEWTON_ABS_TOL = 1e-6

# Filled by run_exudyn: details about the last run (for reporting).
LAST_RUN_INFO: dict = {}


def scene_parameters(clearance: float = 1e-5) -> dict:
    """All physical parameters of the slider-yoke scene (SI units)."""
    L = 0.269
    a = 0.0127
    A = a * a
    I = a**4 / 12.0
    rho = 7850.0
    f1 = 880.0  # first free-free bending frequency the beam is calibrated to
    E = rho * A * (2 * math.pi * f1) ** 2 * L**4 / (22.3733**2 * I)
    eta_over_E = 2 * 0.01 / (2 * math.pi * f1)  # 1 % critical at 880 Hz, stiffness-prop.
    Y0 = 0.010
    f = 6.0
    omega = 2 * math.pi * f
    m = rho * A * L
    K_B = (m / 4) * (100 * omega) ** 2
    C_B = 2 * 0.5 * math.sqrt(K_B * m / 4)
    return {
        "L": L,
        "a": a,
        "A": A,
        "I": I,
        "rho": rho,
        "E": E,
        "eta_over_E": eta_over_E,
        "Y0": Y0,
        "f": f,
        "omega": omega,
        "m": m,
        "K_B": K_B,
        "C_B": C_B,
        "clearance": float(clearance),
    }


def exudyn_info() -> str:
    """Exudyn version and which compiled module is loaded."""
    module = getattr(exu, "_compiledModuleName", None) or exu.SystemContainer.__module__
    return f"exudyn {exu.__version__} ({module})"


def _bearing_force_function(p: dict, sym):
    """User function for ObjectConnectorCartesianSpringDamper.

    Exudyn passes u = p(m1) - p(m0) = node position (ground marker at origin) and
    v = node velocity; the force applied on marker 1 (the beam node) is -UF, so
    UF = +K_B delta q/|q| + C_B qdot (when delta > 0) gives
    f_node = -K_B delta q/|q| - C_B qdot.

    `sym` is exudyn.symbolic (symbolic recording) or None (plain Python floats).
    """
    Y0, om, dc, K, C = p["Y0"], p["omega"], p["clearance"], p["K_B"], p["C_B"]

    if sym is not None:
        one, zero = sym.Real(1.0), sym.Real(0.0)

        def springForceUserFunction(mbs, t, itemNumber, u, v, k, d, offset):
            qx = u[0]
            qy = u[1] - Y0 * sym.sin(om * t)
            vx = v[0]
            vy = v[1] - Y0 * om * sym.cos(om * t)
            dr = sym.sqrt(qx * qx + qy * qy)
            pen = dr - dc
            # max(dr, tiny) avoids 0/0 at the bearing centre (pen <= 0 there anyway)
            fac = K * sym.max(pen, zero) / sym.max(dr, sym.Real(1e-300))
            act = sym.IfThenElse(pen > 0.0, one, zero)
            return [fac * qx + act * C * vx, fac * qy + act * C * vy, 0.0]

        return springForceUserFunction

    def springForceUserFunctionPy(mbs, t, itemNumber, u, v, k, d, offset):
        qx = u[0]
        qy = u[1] - Y0 * math.sin(om * t)
        dr = math.hypot(qx, qy)
        pen = dr - dc
        if pen <= 0.0:
            return [0.0, 0.0, 0.0]
        vx = v[0]
        vy = v[1] - Y0 * om * math.cos(om * t)
        fac = K * pen / dr
        return [fac * qx + C * vx, fac * qy + C * vy, 0.0]

    return springForceUserFunctionPy


def build_model(clearance: float = 1e-5, elements: int = 12):
    """Build the scene; returns (SystemContainer, mbs, node-0 sensor, keep-alive, uf kind)."""
    p = scene_parameters(clearance)
    L, A, I, E, rho = p["L"], p["A"], p["I"], p["E"], p["rho"]
    vamp = p["Y0"] * p["omega"]

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()

    le = L / elements
    nodes = []
    for i in range(elements + 1):
        x = i * le
        # coordinates [x, y, x', y']; undeformed straight beam, initial velocity
        # v_y(x) = Y0 w (1 - 1.5 x/L), slope velocity dv_y/dx = -1.5 Y0 w / L
        nodes.append(
            mbs.AddNode(
                NodePoint2DSlope1(
                    referenceCoordinates=[x, 0.0, 1.0, 0.0],
                    initialCoordinates=[0.0, 0.0, 0.0, 0.0],
                    initialVelocities=[
                        0.0,
                        vamp * (1 - 1.5 * x / L),
                        0.0,
                        -1.5 * vamp / L,
                    ],
                )
            )
        )
    for i in range(elements):
        mbs.AddObject(
            Cable2D(
                physicsLength=le,
                physicsMassPerLength=rho * A,
                physicsBendingStiffness=E * I,
                physicsAxialStiffness=E * A,
                # Kelvin-Voigt: d_K = (eta/E) EI, d_eps = (eta/E) EA
                physicsBendingDamping=p["eta_over_E"] * E * I,
                physicsAxialDamping=p["eta_over_E"] * E * A,
                nodeNumbers=[nodes[i], nodes[i + 1]],
            )
        )

    ground = mbs.AddObject(ObjectGround())
    m_ground = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[0.0, 0.0, 0.0]))
    m_node0 = mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[0]))
    connector = mbs.AddObject(
        CartesianSpringDamper(
            markerNumbers=[m_ground, m_node0],
            stiffness=[0.0, 0.0, 0.0],
            damping=[0.0, 0.0, 0.0],
            offset=[0.0, 0.0, 0.0],
        )
    )

    keep_alive = None  # the symbolic function must outlive the simulation
    try:
        keep_alive = CreateSymbolicUserFunction(
            mbs,
            _bearing_force_function(p, esym),
            "springForceUserFunction",
            connector,
        )
        mbs.SetObjectParameter(connector, "springForceUserFunction", keep_alive)
        uf_kind = "symbolic"
    except (RuntimeError, ValueError, TypeError, AttributeError, KeyError) as err:
        print("!" * 78, file=sys.stderr)
        print(
            f"!!! WARNING: symbolic user function failed ({err!r});\n"
            "!!! FALLING BACK TO A PYTHON USER FUNCTION (slow Python callbacks, timing unfair)",
            file=sys.stderr,
        )
        print("!" * 78, file=sys.stderr)
        mbs.SetObjectParameter(connector, "springForceUserFunction", _bearing_force_function(p, None))
        uf_kind = "python"

    sensor = mbs.AddSensor(
        SensorNode(
            nodeNumber=nodes[0],
            storeInternal=True,
            writeToFile=False,
            outputVariableType=exu.OutputVariableType.Position,
        )
    )
    mbs.Assemble()
    return SC, mbs, sensor, keep_alive, uf_kind


def simulation_settings(dt: float, t_end: float, newton_abs_tol: float = NEWTON_ABS_TOL):
    """Newmark (beta=1/4, gamma=1/2), fixed step, modified Newton, no file output."""
    steps = round(t_end / dt)
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = steps * dt
    ti.adaptiveStep = False  # fixed step: fail rather than silently reduce dt
    ti.automaticStepSize = False
    ti.verboseMode = 0
    ti.generalizedAlpha.useNewmark = True
    ti.generalizedAlpha.newmarkBeta = 0.25
    ti.generalizedAlpha.newmarkGamma = 0.5
    ti.generalizedAlpha.spectralRadius = 1.0
    ti.newton.useModifiedNewton = True
    ti.newton.absoluteTolerance = newton_abs_tol
    try:  # Exudyn >= 1.12 names
        s.solution.file.write = False
        s.solution.sensors.writePeriod = 0.5 * dt  # store node-0 position every step
    except AttributeError:  # older names
        s.solutionSettings.writeSolutionToFile = False
        s.solutionSettings.sensorsWritePeriod = 0.5 * dt
    # sparse LU is ~10-15 % faster than the default dense solver for this model
    try:
        s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    except AttributeError:  # Exudyn < 1.12
        s.linearSolverType = exu.LinearSolverType.EigenSparse
    s.displayStatistics = False
    s.displayComputationTime = False
    return s, steps


def max_penetration(data: np.ndarray, p: dict) -> float:
    """max(delta) from stored sensor rows [t, x, y, z] of node 0."""
    t = data[:, 0]
    qx = data[:, 1]
    qy = data[:, 2] - p["Y0"] * np.sin(p["omega"] * t)
    return float(np.max(np.hypot(qx, qy) - p["clearance"]))


def run_exudyn(clearance=1e-5, elements=12, dt=1e-6, t_end=0.1) -> dict:
    """Simulate the scene in Exudyn; time SolveDynamic only.

    Returns {"seconds", "max_penetration", "steps"}; extra details of the run
    (user function kind, module, Newton iterations) go to LAST_RUN_INFO.
    """
    p = scene_parameters(clearance)
    _sc, mbs, sensor, keep_alive, uf_kind = build_model(clearance, elements)
    settings, steps = simulation_settings(dt, t_end)

    t0 = time.perf_counter()
    mbs.SolveDynamic(settings)
    seconds = time.perf_counter() - t0

    data = mbs.GetSensorStoredData(sensor)
    if data.shape[0] < steps + 1:
        raise RuntimeError(f"sensor stored {data.shape[0]} rows, expected {steps + 1}")
    stats = mbs.sys.get("dynamicSolver", None)
    n_it = None
    if stats is not None:
        try:
            n_it = stats.it.newtonStepsCount
        except AttributeError:
            n_it = None
    LAST_RUN_INFO.clear()
    LAST_RUN_INFO.update(
        user_function=uf_kind,
        exudyn=exudyn_info(),
        newton_iterations=n_it,
        sensor_rows=int(data.shape[0]),
    )
    del keep_alive
    return {
        "seconds": seconds,
        "max_penetration": max_penetration(data, p),
        "steps": steps,
    }


def run_exudyn_outputs(clearance=1e-5, elements=12, dt=1e-5, t_end=0.5, adaptive=True) -> dict:
    """One Monte Carlo sample in Exudyn: the study's outputs from the node-0 position and velocity
    sensors (max penetration in m, max contact force magnitude in N, impacts).

    ``adaptive``: Exudyn's step reduction when Newton fails. With a fixed 1e-5 s step Exudyn's
    Newton fails at the first impacts for clearances of a few 1e-4 m, so the Monte Carlo
    comparison lets Exudyn cut the step where it must (what an Exudyn user would do); the step
    count is reported in ``steps``.
    """
    p = scene_parameters(clearance)
    _sc, mbs, sensor, keep_alive, _uf = build_model(clearance, elements)
    vel = mbs.AddSensor(
        SensorNode(
            nodeNumber=0,
            storeInternal=True,
            writeToFile=False,
            outputVariableType=exu.OutputVariableType.Velocity,
        )
    )
    mbs.Assemble()
    settings, _ = simulation_settings(dt, t_end)
    settings.timeIntegration.adaptiveStep = adaptive
    t0 = time.perf_counter()
    mbs.SolveDynamic(settings)
    seconds = time.perf_counter() - t0
    x = mbs.GetSensorStoredData(sensor)
    v = mbs.GetSensorStoredData(vel)
    t = x[:, 0]
    qx = x[:, 1]
    qy = x[:, 2] - p["Y0"] * np.sin(p["omega"] * t)
    vx = v[:, 1]
    vy = v[:, 2] - p["Y0"] * p["omega"] * np.cos(p["omega"] * t)
    dr = np.hypot(qx, qy)
    pen = dr - p["clearance"]
    closed = pen > 0
    fx = np.where(closed, p["K_B"] * pen * qx / np.maximum(dr, 1e-300) + p["C_B"] * vx, 0.0)
    fy = np.where(closed, p["K_B"] * pen * qy / np.maximum(dr, 1e-300) + p["C_B"] * vy, 0.0)
    del keep_alive
    return {
        "seconds": seconds,
        "max_penetration": float(pen.max()),
        "max_force": float(np.hypot(fx, fy).max()),
        "impacts": int(np.sum(closed[1:] & ~closed[:-1])),
        "steps": int(x.shape[0] - 1),
    }


def parameter_function(parameters: dict) -> list:
    """For ``exudyn.processing.ParameterVariation``: one sample with ``parameters["clearance"]``
    (m) and ``parameters["functionData"]`` = dict(dt, t_end, elements); returns
    [max_penetration, max_force, impacts, steps, seconds]."""
    data = parameters.get("functionData", {})
    r = run_exudyn_outputs(
        clearance=parameters["clearance"],
        elements=data.get("elements", 12),
        dt=data.get("dt", 1e-5),
        t_end=data.get("t_end", 0.5),
    )
    return [r["max_penetration"], r["max_force"], r["impacts"], r["steps"], r["seconds"]]


if __name__ == "__main__":
    print(exudyn_info())
    print(run_exudyn(t_end=0.01), LAST_RUN_INFO)
