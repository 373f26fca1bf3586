"""Prescribed frame motions of links and bodies: :class:`Frame` and its angle drivers
:class:`Rotation` (translations are :mod:`flexclear.motion`).

* ``Frame.rotating(rotation, origin=None)``: a frame whose angle follows ``rotation`` and whose
  origin follows a :class:`flexclear.motion.Motion` (fixed at (0, 0) by default); with
  ``Rotation.fixed(angle)`` it only translates.
* ``Frame.slider_crank(crank, rod, driver, link, offset=0.0)``: the crank, rod or slider of a
  slider-crank (crank pivot at the origin, guide along x at height ``offset``), m.
* ``Frame.four_bar(ground, crank, coupler, rocker, driver, link, branch=1.0)``: the crank,
  coupler or rocker of a four-bar (pivots at (0, 0) and (ground, 0)), m.
* ``Rotation.fixed(angle)``, ``Rotation.constant(rate, angle0=0)``,
  ``Rotation.spin_up(final_rate, ramp_time, angle0=0)`` (Kane's smooth ramp),
  ``Rotation.harmonic(amplitude, frequency, mean=0, phase=0)``,
  ``Rotation.tabulated(time, angle, rate=None, accel=None)``: rad, rad/s, s, Hz. Tabulated
  angles (and ``motion.tabulated`` origins) are interpolated by quintic Hermite polynomials
  through the samples' values, rates and accelerations (by cubic ones through values and rates
  when the accelerations are not given; rates by central differences when not given either):
  a linkage of one's own runs on its links' kinematics tabulated from any solver
  (:class:`flexclear.Linkage` solves them).

``frame.at(t)`` gives ``(origin, origin velocity, origin acceleration, angle, rate,
acceleration)`` at ``t`` (SI); ``frame.rotates`` says whether its angle changes.
"""

from __future__ import annotations

from . import _core

Frame = _core.Frame
Rotation = _core.Rotation

__all__ = ["Frame", "Rotation"]
