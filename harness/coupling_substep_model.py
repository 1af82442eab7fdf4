"""Why the coupled cushion drifts from the monolithic answer with sub-steps inside the macro
step (docs/coupling.md, "Sub-steps inside the macro step"): a one-degree-of-freedom model of the
cushion's air-spring (pumping) mode, stepped three ways, and the spectral radius of each
scheme's map over one macro step.

The model: a skin of mass m = 1 on its own stiffness k_s and on the trapped gas's stiffness k_g,
mass-proportional damping c = 20 m (the dynamic example's Rayleigh α 20/s). The split between
the two stiffnesses is the example's static loop gain, k_g / k_s = 38 (docs/coupling.md, "When
weak coupling fails": J_B J_A ≈ −38 near 200 Pa), and the mode's frequency ω = √((k_s + k_g)/m)
= 1.5e3 rad/s is the one read from the dynamic loop gain there (about 240 Hz). The skin's
displacement u stands for the volume; the gas pushes it out with p = −k_g u.

Each sub-step of length Δt is a generalized-α step (Chung & Hulbert 1993, J. Appl. Mech.
60:371-375; ρ∞ 0.9, as src/solver/dynamic.rs and docs/dynamics.md write it), the load at
t_{n+1−αf} the αf-weighted mean of its values at the sub-step's ends. The three schemes over a
macro step h of n sub-steps:

- ``monolithic``: the gas's stiffness inside every sub-step (what couple_monolithic.solve does
  on the `gas` scene: the gas law solved at every sub-step);
- ``linear``: the coupled scheme as the master runs it: the cushion sees the pressure go
  linearly from the macro step's start value p_n to its end value p_{n+1} over its sub-steps
  (a Velarium FMU's loads go linearly over a step, docs/dynamics.md), and the converged
  interface enforces p_{n+1} = −k_g u_{n+1} at the macro step's end only (the coupling
  iteration converged exactly: the model is linear, so the fixed point is solved directly);
- ``hold``: the same with the end value p_{n+1} held over the whole macro step (a zero-order
  hold), the alternative a master could ask for.

The state of a coupled scheme is (u, v, a, p): the pressure at the step's start is an input of
the next step. With one sub-step the three schemes are the same discrete equations.

    .venv/bin/python harness/coupling_substep_model.py
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

RHO_INF = 0.9
OMEGA = 1.5e3
GAIN = 38.0
DAMPING = 20.0

AM = (2 * RHO_INF - 1) / (RHO_INF + 1)
AF = RHO_INF / (RHO_INF + 1)
GAMMA = 0.5 - AM + AF
BETA = 0.25 * (1 - AM + AF) ** 2
K_G = OMEGA**2 * GAIN / (GAIN + 1)
K_S = OMEGA**2 / (GAIN + 1)


def substep(s: np.ndarray, dt: float, k: float, f0: float, f1: float,
            c: float = DAMPING) -> np.ndarray:
    """One generalized-α step of m a + c v + k u = f (m = 1) from s = (u, v, a), the load f0 at
    its start and f1 at its end; returns (u, v, a) at its end."""
    u, v, a = s

    def residual(u1: float) -> tuple[float, float, float]:
        a1 = (u1 - u - dt * v) / (BETA * dt * dt) - (1 - 2 * BETA) / (2 * BETA) * a
        v1 = v + dt * ((1 - GAMMA) * a + GAMMA * a1)
        r = ((1 - AM) * a1 + AM * a + c * ((1 - AF) * v1 + AF * v)
             + k * ((1 - AF) * u1 + AF * u) - ((1 - AF) * f1 + AF * f0))
        return r, v1, a1

    r0, r1 = residual(0.0)[0], residual(1.0)[0]
    u1 = -r0 / (r1 - r0)  # the residual is affine in u1
    _, v1, a1 = residual(u1)
    return np.array([u1, v1, a1])


def _coupled(x: np.ndarray, h: float, n: int, load: Callable[[float, float, int], tuple[float, float]]
             ) -> np.ndarray:
    def run(p1: float) -> np.ndarray:
        s = x[:3].copy()
        for i in range(n):
            s = substep(s, h / n, K_S, *load(x[3], p1, i))
        return s

    s0, s1 = run(0.0), run(1.0)
    p1 = -K_G * s0[0] / (1 + K_G * (s1[0] - s0[0]))  # p1 = -k_g u1, u1 affine in p1
    return np.append(run(p1), p1)


def linear(x: np.ndarray, h: float, n: int) -> np.ndarray:
    """The coupled scheme, the pressure linear over the sub-steps (what the master does)."""
    return _coupled(x, h, n, lambda p0, p1, i: (p0 + (p1 - p0) * i / n, p0 + (p1 - p0) * (i + 1) / n))


def hold(x: np.ndarray, h: float, n: int) -> np.ndarray:
    """The coupled scheme, the end pressure held over the macro step."""
    return _coupled(x, h, n, lambda p0, p1, i: (p0 if i == 0 else p1, p1))


def monolithic(x: np.ndarray, h: float, n: int) -> np.ndarray:
    """The gas's stiffness in every sub-step."""
    s = x[:3].copy()
    for _ in range(n):
        s = substep(s, h / n, K_S + K_G, 0.0, 0.0)
    return np.append(s, -K_G * s[0])


def amplification(scheme: Callable[[np.ndarray, float, int], np.ndarray], h: float, n: int
                  ) -> np.ndarray:
    """The scheme's (linear) map of (u, v, a, p) over one macro step."""
    return np.column_stack([scheme(e, h, n) for e in np.eye(4)])


def radius(scheme: Callable[[np.ndarray, float, int], np.ndarray], h: float, n: int) -> float:
    return float(max(abs(np.linalg.eigvals(amplification(scheme, h, n)))))


def main() -> None:
    print(f"omega {OMEGA:g} rad/s, k_g/k_s {GAIN:g}, rho_inf {RHO_INF}, damping {DAMPING:g}/s")
    print("spectral radius per macro step: monolithic / coupled, p linear / coupled, p held")
    print("h (s)     " + "".join(f"| n = {n:<25}" for n in (1, 2, 4, 8)))
    for h in (1e-3, 2.5e-3, 5e-3, 1e-2, 2e-2, 5e-2, 0.1):
        row = [f"{radius(monolithic, h, n):.3f} / {radius(linear, h, n):.3f} / {radius(hold, h, n):.3f}"
               for n in (1, 2, 4, 8)]
        print(f"{h:<10g}" + "".join(f"| {r:<29}" for r in row))


if __name__ == "__main__":
    main()
