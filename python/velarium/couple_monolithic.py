"""The monolithic answer of the cushion-and-blower system (docs/coupling.md, "The monolithic
reference").

The coupled system, at a converged interface, solves per macro step [t, t+h] the backward-Euler
equations of the blower together with the cushion's equilibrium:

    N₁ = N₀ + h (Q_fan(p) - Q_valve(p, u)),   I₁ = I₀ + h (p - p_set),   u = clamp(u0 + Kp e + Ki I₁)
    (p + p_atm) V = p_atm N₁,                 V = V(membrane equilibrium under p and the snow)

Here the gas law lives inside the structure: a Velarium scene with a ``gas`` input (the
bordered system: displacements and pressure one Newton solve) is driven by the gas amount
ΔN = N₁ - V⁰, and the blower's balance is the one remaining scalar equation, in N₁, solved
around it by a safeguarded secant to round-off. There is no pressure/volume interface and no
FMU of the blower: its equations are written again below, independently of harness/blower/blower.c.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Callable, Mapping

import numpy as np
from fmpy import read_model_description

from .couple import Unit, table_function

BLOWER_DEFAULTS = ("p_atm", "dp0", "Q_max", "fan_shape", "K_valve", "p_lam", "Kp", "Ki", "u0")


class BlowerEquations:
    """The blower's right-hand side (the model of harness/blower/blower.c, written again)."""

    def __init__(self, par: Mapping[str, float]):
        self.p = dict(par)

    def fan(self, p: float) -> float:
        dp0, qmax, a = self.p["dp0"], self.p["Q_max"], self.p["fan_shape"]
        c = 1.0 - a
        if c <= 0:
            return qmax * (1.0 - p / dp0)
        disc = a * a + 4.0 * c * (1.0 - p / dp0)
        return qmax * (-a + math.sqrt(max(disc, 0.0))) / (2.0 * c)

    def inflow(self, p: float, I0: float, h: float, p_set: float) -> float:
        e = p - p_set
        u = min(max(self.p["u0"] + self.p["Kp"] * e + self.p["Ki"] * (I0 + h * e), 0.0), 1.0)
        return self.fan(p) - u * self.p["K_valve"] * p / math.sqrt(abs(p) + self.p["p_lam"])


def blower_parameters(blower_fmu: str | Path, overrides: Mapping[str, float] | None = None) -> dict[str, float]:
    md = read_model_description(str(blower_fmu))
    par = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
    par.update(overrides or {})
    return par


def _secant(f: Callable[[float], float], x0: float, dx: float, what: str) -> float:
    """Root of an increasing f near x0, to round-off."""
    a, fa = x0, f(x0)
    b, fb = x0 + dx, f(x0 + dx)
    for _ in range(60):
        if fb == fa:
            return b
        c = b - fb * (b - a) / (fb - fa)
        if abs(c - b) <= 1e-15 * max(abs(c), 1.0):
            return c
        a, fa = b, fb
        b, fb = c, f(c)
    raise RuntimeError(f"monolithic reference: {what} did not converge")


def solve(gas_fmu: str | Path, blower: Mapping[str, float], p0: float, p_set: list, snow: list,
          stop: float, step: float, gas_input: str = "dN", snow_input: str = "snow",
          initial: tuple[float, float] | None = None) -> dict[str, np.ndarray]:
    """The monolithic answer at t = 0, step, 2 step, ... stop: columns time, p, V, N, I.

    ``blower`` holds the blower's parameters (``blower_parameters``); the cushion starts at
    gauge pressure ``p0`` with the blower's integral at zero; ``p_set`` and ``snow`` are
    [[t, value], ...] tables, taken at each step's end.

    ``initial`` = (ΔN₀, V⁰) starts the scene in its initialization at that gas amount (its
    static equilibrium at rest, as a dynamic scene initializes) instead of reaching p0 in a step
    [-1, 0]: what a scene with ``dynamics.time_integration`` needs, whose step would not come to
    rest. ``initial_gas`` computes it with the quasi-static scene."""
    eq = BlowerEquations(blower)
    patm = float(blower["p_atm"])
    fset = table_function(p_set, "p_set")
    fsnow = table_function(snow, "snow")
    g = Unit("cushion_gas", gas_fmu)
    try:
        if initial is not None:
            dn0, v_ref = initial
            g.initialize(0.0, {gas_input: dn0, snow_input: fsnow(0.0)})
            p, V = g.get(["p", "V"])
        else:
            g.initialize(-1.0, {gas_input: 0.0, snow_input: fsnow(0.0)})
            p, V = g.get(["p", "V"])
            v_ref = (p + patm) * V / patm  # the gas law at ΔN = 0: the group's reference volume

        def at(state, t, h, dn, s):
            g.restore(state)
            g.set({gas_input: dn, snow_input: s})
            g.step(t, h)
            return g.get(["p", "V"])

        if initial is None:
            # the start: the ΔN that holds p0, reached in the step [-1, 0]
            s0 = g.save()
            dn0 = _secant(lambda dn: at(s0, -1.0, 1.0, dn, fsnow(0.0))[0] - p0, 0.0, 1e-3, "the initial gas amount")
            p, V = at(s0, -1.0, 1.0, dn0, fsnow(0.0))
            g.free_state(s0)
        N, I, t = dn0 + v_ref, 0.0, 0.0
        rows = [(0.0, p, V, N, I)]
        n = int(round(stop / step))
        for k in range(1, n + 1):
            t1 = k * step
            h = t1 - t
            ps, sn = fset(t1), fsnow(t1)
            st = g.save()
            N0, I0 = N, I

            def F(N1):
                pp, _ = at(st, t, h, N1 - v_ref, sn)
                return N1 - N0 - h * eq.inflow(pp, I0, h, ps)

            N = _secant(F, N0, 1e-6 * N0, f"the gas balance at t = {t1:g}")
            p, V = at(st, t, h, N - v_ref, sn)
            g.free_state(st)
            I = I0 + h * (p - ps)
            t = t1
            rows.append((t, p, V, N, I))
    finally:
        g.close()
    a = np.array(rows)
    return {"time": a[:, 0], "p": a[:, 1], "V": a[:, 2], "N": a[:, 3], "I": a[:, 4]}


def initial_gas(static_gas_fmu: str | Path, blower: Mapping[str, float], p0: float, snow: list,
                gas_input: str = "dN", snow_input: str = "snow") -> tuple[float, float]:
    """(ΔN₀, V⁰) of the quasi-static gas scene at gauge pressure ``p0``: the gas amount that
    holds p0 under the snow at t = 0, and the group's reference volume (``solve``'s
    ``initial``)."""
    r = solve(static_gas_fmu, blower, p0, [[0.0, p0]], snow, 1.0, 1.0, gas_input, snow_input)
    patm = float(blower["p_atm"])
    g = Unit("cushion_gas", static_gas_fmu)
    try:
        g.initialize(-1.0, {gas_input: 0.0, snow_input: table_function(snow, "snow")(0.0)})
        p, V = g.get(["p", "V"])
    finally:
        g.close()
    v_ref = (p + patm) * V / patm
    return float(r["N"][0] - v_ref), float(v_ref)
