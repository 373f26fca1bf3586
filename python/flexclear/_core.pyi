"""Type stubs of the compiled core ``flexclear._core`` (hand-written; see rust/python/mod.rs)."""

from typing import Any, Callable, Optional, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "Motion",
    "Rotation",
    "Frame",
    "Mechanism",
    "RunOutput",
    "JointExtremes",
    "JointHistory",
    "ImpactLog",
    "NodeHistory",
    "LinkHistory",
    "SliderHistory",
    "SliderReference",
    "slider_yoke",
    "slider_crank",
    "flores_slider_crank",
    "four_bar",
    "spin_up",
    "spin_up_data",
    "run_batch",
    "solve_linkage",
    "NormalLaw",
    "CoulombFriction",
    "LuGreFriction",
    "RETRY_MIN_STEP_RATIO",
    "TRUNCATION_FRACTION",
    "MAX_ITER",
    "REBOUND_DEPTH",
    "LINKAGE_TOLERANCE",
    "LINKAGE_MAX_CONDITION",
    "__version__",
    "SIMD_PATHS",
]

__version__: str
#: The widest SIMD paths the core takes on this CPU: "avx512", "avx2" or "baseline" (bitwise the
#: same results on each; they differ in speed only).
SIMD_PATHS: str
#: Retries of a diverged sample stop before the step falls below this fraction of its own.
RETRY_MIN_STEP_RATIO: float
#: Default fraction of a fixed step's local truncation error at which its Newton iterations stop
#: (where it is above their tolerance).
TRUNCATION_FRACTION: float
#: Largest iteration cap (`max_iter`) of a step, Newton's or the contact iteration's.
MAX_ITER: int
#: A closing is an impact after a separation deeper than this fraction of the radial clearance;
#: after a shallower one it is a rebound of the impact going on.
REBOUND_DEPTH: float
#: Newton's tolerance on a linkage's constraints, as a fraction of the linkage's size.
LINKAGE_TOLERANCE: float
#: Largest condition number of a linkage's constraint Jacobian before a position counts as a
#: dead point.
LINKAGE_MAX_CONDITION: float

@final
class Motion:
    @staticmethod
    def fixed(position: tuple[float, float]) -> Motion: ...
    @staticmethod
    def harmonic(
        amplitude: tuple[float, float],
        frequency: float,
        offset: tuple[float, float] = ...,
        phase: Optional[float] = ...,
    ) -> Motion: ...
    @staticmethod
    def tabulated(
        time: list[float],
        position: list[tuple[float, float]],
        velocity: Optional[list[tuple[float, float]]] = ...,
        acceleration: Optional[list[tuple[float, float]]] = ...,
    ) -> Motion: ...
    def at(self, t: float) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]: ...

@final
class Rotation:
    """A prescribed angle phi(t) (rad) with its rate (rad/s) and acceleration (rad/s^2)."""

    @staticmethod
    def fixed(angle: float) -> Rotation: ...
    @staticmethod
    def constant(rate: float, angle0: Optional[float] = ...) -> Rotation: ...
    @staticmethod
    def spin_up(final_rate: float, ramp_time: float, angle0: Optional[float] = ...) -> Rotation: ...
    @staticmethod
    def harmonic(
        amplitude: float, frequency: float, mean: Optional[float] = ..., phase: Optional[float] = ...
    ) -> Rotation: ...
    @staticmethod
    def tabulated(
        time: list[float],
        angle: list[float],
        rate: Optional[list[float]] = ...,
        accel: Optional[list[float]] = ...,
    ) -> Rotation: ...
    def at(self, t: float) -> tuple[float, float, float]: ...

@final
class Frame:
    """The prescribed motion of a link frame or rigid body."""

    @staticmethod
    def rotating(rotation: Rotation, origin: Optional[Motion] = ...) -> Frame: ...
    @staticmethod
    def slider_crank(
        crank: float, rod: float, driver: Rotation, link: str, offset: Optional[float] = ...
    ) -> Frame: ...
    @staticmethod
    def four_bar(
        ground: float,
        crank: float,
        coupler: float,
        rocker: float,
        driver: Rotation,
        link: str,
        branch: Optional[float] = ...,
    ) -> Frame: ...
    def at(
        self, t: float
    ) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float], float, float, float]: ...
    @property
    def rotates(self) -> bool: ...
    def check(self, t_end: float) -> None: ...

@final
class Mechanism:
    """A kineto-elastodynamic mechanism under construction (wrapped by flexclear.Mechanism)."""

    def __init__(self) -> None: ...
    def add_link(
        self,
        name: str,
        length: float,
        elements: int,
        youngs_modulus: float,
        density: float,
        area: float,
        inertia: float,
        frame: Frame,
        damping: float = ...,
        coriolis: Optional[bool] = ...,
        inertia_coupling: Optional[bool] = ...,
        geometric: Optional[bool] = ...,
        inertia_load: Optional[bool] = ...,
        initial_displacement: Optional[npt.NDArray[np.float64]] = ...,
        initial_velocity: Optional[npt.NDArray[np.float64]] = ...,
        rotary_inertia: bool = ...,
    ) -> int: ...
    def add_rigid_link(
        self, name: str, length: float, mass: float, inertia: float, centroid: float, frame: Frame
    ) -> int: ...
    def add_slider(self, name: str, mass: float, angle: float, path: Frame) -> int: ...
    def add_pin(
        self,
        name: str,
        link: int,
        node: int,
        target: str,
        target_link: Optional[int] = ...,
        target_node: Optional[int] = ...,
        frame: Optional[Frame] = ...,
        point: tuple[float, float] = ...,
        slider: Optional[int] = ...,
        body: str = ...,
    ) -> None: ...
    def add_clearance(
        self,
        name: str,
        link: int,
        node: int,
        target: str,
        clearance: float,
        stiffness: float,
        damping: float,
        target_link: Optional[int] = ...,
        target_node: Optional[int] = ...,
        frame: Optional[Frame] = ...,
        point: tuple[float, float] = ...,
        slider: Optional[int] = ...,
        body: str = ...,
        damping_law: str = ...,
        no_tension: bool = ...,
        law: Optional[NormalLaw] = ...,
        friction: Optional[CoulombFriction | LuGreFriction] = ...,
        journal_radius: Optional[float] = ...,
    ) -> None: ...
    def add_support(self, link: int, node: int, u: bool = ..., v: bool = ..., theta: bool = ...) -> None: ...
    def add_mass(self, link: int, node: int, mass: float) -> None: ...
    def add_load(
        self, link: int, node: int, fu: float = ..., fv: float = ..., moment: float = ...
    ) -> None: ...
    def set_gravity(self, gx: float, gy: float) -> None: ...
    @property
    def link_names(self) -> list[str]: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def joint_friction(self) -> list[bool]: ...
    @property
    def pin_names(self) -> list[str]: ...
    @property
    def link_rigid(self) -> list[bool]: ...
    @property
    def link_elements(self) -> list[int]: ...
    @property
    def link_lengths(self) -> list[float]: ...
    @property
    def bodies(self) -> list[tuple[str, Frame]]: ...
    @property
    def link_axial_stiffness(self) -> list[float]: ...
    @property
    def link_frames(self) -> list[Frame]: ...
    def natural_frequencies(self, count: int) -> npt.NDArray[np.float64]: ...
    @property
    def slider_names(self) -> list[str]: ...
    @property
    def joint_rotating(self) -> list[bool]: ...
    def validate(self, t_end: float) -> None: ...
    def dof_map(self) -> list[tuple[int, int, str]]: ...
    def linearize(
        self,
        t: float,
        y: npt.NDArray[np.float64],
        yd: Optional[npt.NDArray[np.float64]] = ...,
        contacts: bool = ...,
    ) -> tuple[
        npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]
    ]:
        """`(M, C, K, r)` at time `t` (s) and state `y` (velocities `yd`, zero when None)."""
    @property
    def stepper(self) -> str: ...
    @property
    def translates(self) -> bool: ...
    def tolerance_settings(
        self, tol: float, t_end: float, dt: float, max_step: Optional[float] = ...
    ) -> tuple[float, float, float, float, float]:
        """`(rtol, atol, h_min, h_max, newton_tol)` of a run asked for the relative accuracy
        `tol` (h_min, h_max in s; atol in m; newton_tol: the Newton stepper's iteration
        tolerance when `iter_tol` is not given)."""
    def simulate(
        self,
        t_end: float,
        dt: float,
        method: str = ...,
        iterate: bool = ...,
        tol: Optional[float] = ...,
        max_iter: int = ...,
        step_halving: int = ...,
        beta: float = ...,
        gamma: float = ...,
        alpha_m: float = ...,
        alpha_f: float = ...,
        divergence_limit: Optional[float] = ...,
        every: int = ...,
        displacements: bool = ...,
        axial_force: bool = ...,
        midspan: bool = ...,
        energy: bool = ...,
        progress: Optional[Callable[[float], Any]] = ...,
        events: bool = ...,
        joints: Optional[list[int]] = ...,
        joint_position: bool = ...,
        histories: bool = ...,
        start: float = ...,
        impact_log: bool = ...,
        stepper: Optional[str] = ...,
        solver: str = ...,
        gap_stiffness: Optional[float] = ...,
        gap_damping: float = ...,
        nodes: list[tuple[int, int]] = ...,
        contact_modes: bool = ...,
        adaptive: Optional[tuple[float, float, float, float]] = ...,
        sliders: bool = ...,
        slider_reference: Optional[SliderReference] = ...,
        truncation_fraction: Optional[float] = ...,
        link_peaks: bool = ...,
    ) -> RunOutput:
        """Runs the model; returns its output (what `flexclear.Result` reads). A failed run raises
        the matching `flexclear` exception with what it recorded as `exc.partial` (a
        `RunOutput`). `tol` (default 1e-8) is the within-step iteration's tolerance; left at its
        default, a fixed Newton step also stops at `truncation_fraction` (default
        `TRUNCATION_FRACTION`) of its truncation error, given, it is met as given (fraction 0)."""

@final
class JointExtremes:
    """Running extremes of one clearance joint (SI units; the contact-mode fractions and
    `dissipated_energy` (J) are NaN unless the run tracked contact modes)."""
    @property
    def max_penetration(self) -> float: ...
    @property
    def time_of_max_penetration(self) -> float: ...
    @property
    def max_force(self) -> float: ...
    @property
    def impacts(self) -> int: ...
    @property
    def contact_episodes(self) -> int: ...
    @property
    def contact_time(self) -> float: ...
    @property
    def max_velocity(self) -> float: ...
    @property
    def max_impact_velocity(self) -> float: ...
    @property
    def contact_period(self) -> float: ...
    @property
    def rms_penetration(self) -> float: ...
    @property
    def rms_force(self) -> float: ...
    @property
    def free_flight_fraction(self) -> float: ...
    @property
    def impact_fraction(self) -> float: ...
    @property
    def continuous_fraction(self) -> float: ...
    @property
    def dissipated_energy(self) -> float: ...
    @property
    def friction_energy(self) -> float: ...

@final
class JointHistory:
    """Histories of one recorded joint: penetration (m), force (N), journal centre relative to
    the bearing `qx`, `qy` (m, empty unless recorded), friction force `friction` (N) and slip
    speed `slip` (m/s; empty for a joint without friction)."""
    @property
    def joint(self) -> int: ...
    @property
    def penetration(self) -> npt.NDArray[np.float64]: ...
    @property
    def force(self) -> npt.NDArray[np.float64]: ...
    @property
    def qx(self) -> npt.NDArray[np.float64]: ...
    @property
    def qy(self) -> npt.NDArray[np.float64]: ...
    @property
    def friction(self) -> npt.NDArray[np.float64]: ...
    @property
    def slip(self) -> npt.NDArray[np.float64]: ...

@final
class ImpactLog:
    """Per impact of one joint: entry `time` (s), approach `speed` (m/s), `peak_force` (N),
    `peak_penetration` (m), `duration` (s)."""
    @property
    def joint(self) -> int: ...
    @property
    def time(self) -> npt.NDArray[np.float64]: ...
    @property
    def speed(self) -> npt.NDArray[np.float64]: ...
    @property
    def peak_force(self) -> npt.NDArray[np.float64]: ...
    @property
    def peak_penetration(self) -> npt.NDArray[np.float64]: ...
    @property
    def duration(self) -> npt.NDArray[np.float64]: ...

@final
class NodeHistory:
    """Displacements of one node in its link frame: `u`, `v` (m), `theta` (rad)."""
    @property
    def link(self) -> int: ...
    @property
    def node(self) -> int: ...
    @property
    def u(self) -> npt.NDArray[np.float64]: ...
    @property
    def v(self) -> npt.NDArray[np.float64]: ...
    @property
    def theta(self) -> npt.NDArray[np.float64]: ...

@final
class LinkHistory:
    """Histories of one link: `frame` (records x 4), `displacements` (records x 3 (N + 1)),
    `axial_force` (records x N, N), `midspan` (m), `kinetic`, `strain` (J), `momentum`;
    `max_midspan` (m) and `max_axial_force` (N), the running peaks over every step with
    `link_peaks`, NaN otherwise and for a rigid link."""
    @property
    def max_midspan(self) -> float: ...
    @property
    def max_axial_force(self) -> float: ...
    @property
    def frame(self) -> npt.NDArray[np.float64]: ...
    @property
    def displacements(self) -> npt.NDArray[np.float64]: ...
    @property
    def axial_force(self) -> npt.NDArray[np.float64]: ...
    @property
    def midspan(self) -> npt.NDArray[np.float64]: ...
    @property
    def kinetic(self) -> npt.NDArray[np.float64]: ...
    @property
    def strain(self) -> npt.NDArray[np.float64]: ...
    @property
    def momentum(self) -> npt.NDArray[np.float64]: ...

@final
class SliderHistory:
    """One slider along its guide: `position` (m), `velocity` (m/s), `acceleration` (m/s^2) on the
    output grid, `max_acceleration` (m/s^2, every step)."""
    @property
    def name(self) -> str: ...
    @property
    def position(self) -> npt.NDArray[np.float64]: ...
    @property
    def velocity(self) -> npt.NDArray[np.float64]: ...
    @property
    def acceleration(self) -> npt.NDArray[np.float64]: ...
    @property
    def max_acceleration(self) -> float: ...
    @property
    def deviation(self) -> bool: ...
    @property
    def deviation_mean(self) -> tuple[float, float, float]: ...
    @property
    def deviation_max(self) -> tuple[float, float, float]: ...

@final
class SliderReference:
    """The sliders' motion on an output grid, shared by the runs that compare with it: `time` (s)
    and per slider `(name, position m, velocity m/s, acceleration m/s^2)` on it."""
    def __new__(
        cls,
        time: npt.NDArray[np.float64],
        sliders: list[tuple[str, npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]],
    ) -> SliderReference: ...
    def __len__(self) -> int: ...

@final
class RunOutput:
    """The output of one run (rust/python/output.rs)."""
    @property
    def time(self) -> npt.NDArray[np.float64]: ...
    @property
    def joints(self) -> list[JointHistory]: ...
    @property
    def nodes(self) -> list[NodeHistory]: ...
    @property
    def links(self) -> list[LinkHistory]: ...
    @property
    def sliders(self) -> list[SliderHistory]: ...
    @property
    def extremes(self) -> list[JointExtremes]: ...
    @property
    def impact_log(self) -> list[ImpactLog]: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    @property
    def state(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    @property
    def t(self) -> float: ...

def slider_yoke(
    clearance: float = ...,
    amplitude: float = ...,
    frequency: float = ...,
    length: float = ...,
    side: float = ...,
    density: float = ...,
    youngs_modulus: Optional[float] = ...,
    first_frequency: float = ...,
    damping_ratio: float = ...,
    elements: int = ...,
    bearing_stiffness: Optional[float] = ...,
    stiffness_ratio: float = ...,
    bearing_damping: Optional[float] = ...,
    bearing_damping_ratio: float = ...,
    damping_law: str = ...,
    no_tension: bool = ...,
    geometry: str = ...,
    rotary_inertia: bool = ...,
) -> tuple[Mechanism, dict[str, float]]: ...
def slider_crank(
    *,
    crank_length: float,
    rod_length: float,
    crank_speed: float,
    side: float,
    youngs_modulus: float,
    density: float,
    slider_mass: float,
    elements: int,
    damping: float,
    offset: float,
    clearance_at: Optional[str],
    clearance: float,
    bearing_stiffness: Optional[float],
    bearing_damping: Optional[float],
    pin_radius: float,
    poisson_ratio: float,
    reference_penetration: float,
    bearing_damping_ratio: float,
    damping_law: str,
    geometric: Optional[bool],
) -> tuple[Mechanism, dict[str, float]]: ...
def flores_slider_crank(
    clearance: Optional[float],
    law: Optional[NormalLaw],
    crank_speed: float,
    flexible_rod: bool,
    rod_elements: int,
    friction: Optional[Any] = ...,
) -> tuple[Mechanism, dict[str, float]]: ...
def four_bar(
    *,
    ground_length: float,
    crank_length: float,
    coupler_length: float,
    rocker_length: float,
    crank_speed: float,
    branch: float,
    youngs_modulus: float,
    density: float,
    width: float,
    depth: float,
    elements: int,
    flexible_rocker: bool,
    rocker_elements: Optional[int],
    damping: float,
    clearance_at: Optional[str],
    clearance: float,
    bearing_stiffness: Optional[float],
    bearing_damping: Optional[float],
    pin_radius: float,
    poisson_ratio: float,
    reference_penetration: float,
    bearing_damping_ratio: float,
    damping_law: str,
) -> tuple[Mechanism, dict[str, float]]: ...
def spin_up(
    *,
    data: str,
    length: Optional[float],
    youngs_modulus: Optional[float],
    density: Optional[float],
    area: Optional[float],
    inertia: Optional[float],
    final_rate: Optional[float],
    ramp_time: Optional[float],
    elements: int,
    geometric: bool,
    damping: float,
    rotation: Optional[Rotation],
) -> Mechanism: ...
def spin_up_data() -> dict[str, dict[str, float]]: ...
def solve_linkage(
    times: npt.ArrayLike,
    near: list[float],
    moving: int,
    points: int,
    distances: list[tuple[int, int, float]],
    lines: list[tuple[int, tuple[float, float], tuple[float, float]]],
    slots: list[tuple[int, int, int, float]],
    ground: list[tuple[int, tuple[float, float]]],
    cranks: list[tuple[str, tuple[float, float], int, float, Rotation]],
    scale: float,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Positions (m), velocities (m/s) and accelerations (m/s^2) of a linkage's points at
    ``times`` (s), each of shape ``(len(times), points, 2)`` (``flexclear.Linkage.solve``)."""

def run_batch(
    models: list[Mechanism],
    t_end: list[float],
    dt: list[float],
    *,
    threads: int = ...,
    lanes: int = ...,
    retries: int = ...,
    retry_factor: float = ...,
    method: str = ...,
    iterate: Optional[bool] = ...,
    tol: Optional[float] = ...,
    max_iter: Optional[int] = ...,
    step_halving: int = ...,
    gap_stiffness: Optional[float] = ...,
    gap_damping: float = ...,
    beta: float = ...,
    gamma: float = ...,
    alpha_m: float = ...,
    alpha_f: float = ...,
    solver: str = ...,
    divergence_limit: Optional[float] = ...,
    joints: Optional[list[int]] = ...,
    every: int = ...,
    histories: bool = ...,
    start: float = ...,
    progress: Optional[Callable[[int], Any]] = ...,
    events: bool = ...,
    joint_position: bool = ...,
    contact_modes: bool = ...,
    accuracy: Optional[float] = ...,
    max_step: Optional[float] = ...,
    link_peaks: bool = ...,
) -> tuple[list[dict[str, Any]], dict[str, int], Optional[BaseException]]:
    """Runs `models[i]` to `t_end[i]` at step `dt[i]` on a thread pool, GIL released, each on the
    stepper its plan picks (lockstep lanes for the constant stepper, one lane each otherwise);
    `iterate`, `tol`, `max_iter` None = that stepper's default, as in `Model.simulate`. With
    `accuracy` (a relative tolerance) the samples take adaptive steps, `dt[i]` being the output
    grid and `max_step` the longest step (s; None: the whole run).

    Returns one dict per sample (status, message, dt, retries, wall_time, steps, t, extremes
    (one `JointExtremes` per joint), time, joints, links (per link `(max_midspan m,
    max_axial_force N)`, NaN unless `link_peaks`)), the batch counters (analyses,
    threads, lockstep_groups, lockstep_samples) and the exception that stopped the batch
    (KeyboardInterrupt, or one raised by `progress(done)`), else None. `lanes` is the largest
    lockstep group (0 = default 8, 1 = none, at most 8). `joint_position` also keeps the
    journal positions `qx`, `qy` (m) in the joint histories (the orbit; with `histories`).
    """

# Contact laws (rust/python/contact.rs); the public API is flexclear.contact. Array arguments are
# one-dimensional float64 arrays of one length.

_F64 = npt.NDArray[np.float64]

@final
class NormalLaw:
    def __new__(
        cls,
        kind: str,
        stiffness: float,
        exponent: float = ...,
        restitution: float = ...,
        min_approach_speed: float = ...,
        clip_tension: bool = ...,
        damping: float = ...,
        damping_law: str = ...,
    ) -> NormalLaw: ...
    @property
    def name(self) -> str: ...
    @property
    def velocity_dependent(self) -> bool: ...
    @property
    def needs_approach_speed(self) -> bool: ...
    def force(self, penetration: _F64, rate: _F64, approach_speed: _F64) -> _F64: ...
    def tangent(self, penetration: _F64, rate: _F64, approach_speed: _F64) -> tuple[_F64, _F64]: ...
    def effective_restitution(self, mass: float, approach_speed: float) -> tuple[float, float, float]: ...

@final
class CoulombFriction:
    def __new__(
        cls,
        mu: float,
        regularization: str = ...,
        v0: float = ...,
        v1: float = ...,
        v_reg: float = ...,
        mu_static: Optional[float] = ...,
        stribeck_speed: float = ...,
        stribeck_exponent: float = ...,
    ) -> CoulombFriction: ...
    def force(self, slip_speed: _F64, normal_force: _F64) -> _F64: ...
    def tangent(self, slip_speed: _F64, normal_force: _F64) -> tuple[_F64, _F64]: ...

@final
class LuGreFriction:
    def __new__(
        cls,
        mu: float,
        mu_static: float,
        stribeck_speed: float,
        sigma0: float = ...,
        sigma1: float = ...,
        sigma2: float = ...,
    ) -> LuGreFriction: ...
    def derivative(self, state: _F64, slip_speed: _F64) -> _F64: ...
    def advance(self, state: _F64, slip_speed: _F64, dt: _F64) -> _F64: ...
    def steady_state(self, slip_speed: _F64) -> _F64: ...
    def force(self, state: _F64, slip_speed: _F64, normal_force: _F64) -> _F64: ...
    def tangent(self, state: _F64, slip_speed: _F64, normal_force: _F64) -> tuple[_F64, _F64, _F64]: ...
