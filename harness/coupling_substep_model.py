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

The remedy (docs/coupling.md, "The remedy: the gas law inside the sub-steps"): ``spring``, the
coupled scheme with a gas spring in the sub-steps, p(t) = p_lin(t) + k (u(t) − u_lin(t)), u_lin
going to the interface's end volume (or held at the start: ``anchor``), k the gas's stiffness,
the blower's dp/dV over the macro step or any other. Its blower may relieve the gas (``RELIEF``:
the real blower's fan and valve, which make its dp/dV over a step softer than the gas's); the
state is then (u, v, a, p, w) with w the gas amount, and ``monolithic_relief`` is the
monolithic scheme with it (the gas law in every sub-step, w linear over them, as the monolithic
reference drives its `gas` scene). With k the gas's stiffness, ``spring`` is that monolithic
scheme: the same maps.

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


# ---- the gas spring in the sub-steps, and a blower that relieves the gas ----
#
# The real blower is not memoryless: over a macro step its fan and valve let gas in and out, so
# the derivative the master gets from it, dp/dV over the step, is softer than the gas's own
# stiffness -(p + p_atm)/V (docs/coupling.md: -1.29e5 Pa/m^3 at h = 1 ms, -1.14e5 at 2 ms,
# -5.8e4 at 10 ms, -3.4e4 at 50 ms against about -1.43e5 for the gas). The model's blower:
# the gas amount w (counted in u's units) and p = k_g (w - u), w relieved by
# dw/dt = -c p (backward Euler over the macro step, as the Blower FMU integrates its balance).
# Over a macro step h its map is p_{n+1} = k_g (w_n - U) / (1 + h c k_g): dp/dV =
# -k_g / (1 + h c k_g). RELIEF = c k_g = 145/s gives dp/dV / k_g = 0.87, 0.78, 0.41, 0.12 at
# h = 1, 2, 10, 50 ms, near the real blower's 0.90, 0.80, 0.41, 0.24. With RELIEF = 0 the
# blower is the memoryless p = -k_g u of the schemes above.

RELIEF = 145.0


def blower_stiffness(h: float, relief: float = RELIEF) -> float:
    """-dp/dV of the model's blower over a macro step h (what the master's derivative gives)."""
    return K_G / (1 + h * relief)


def _affine_solve(run: Callable[[np.ndarray], np.ndarray], residual: Callable[[np.ndarray, np.ndarray], np.ndarray],
                  m: int) -> np.ndarray:
    """The unknowns z (m of them) with residual(z, run(z)) = 0, everything affine in z."""
    z0 = np.zeros(m)
    r0 = residual(z0, run(z0))
    jac = np.column_stack([residual(e, run(e)) - r0 for e in np.eye(m)])
    return np.linalg.solve(jac, -r0)


def spring(x: np.ndarray, h: float, n: int, stiffness: str = "blower", anchor: str = "iterate",
           relief: float = RELIEF) -> np.ndarray:
    """The coupled scheme with the gas spring in the cushion's sub-steps, state (u, v, a, p, w).

    The cushion applies p(t) = p_lin(t) + k (V(t) - V_lin(t)) with k = dp/dV < 0, p_lin linear
    from p_n to the interface's p_{n+1} and
      ``anchor="iterate"``: V_lin linear from V_n to the interface's end volume U (the value the
        master gives the blower): at a converged interface U = V_{n+1}, the correction is 0 at
        the macro step's end and the cushion's end load is p_{n+1}, what the blower's law gives;
      ``anchor="start"``: V_lin = V_n held: the end load is p_{n+1} + k (V_{n+1} - V_n), the
        gas's stiffness counted twice over the step (another fixed point, even with one
        sub-step).
    ``stiffness``: "blower" k = the blower's dp/dV over the macro step (its derivative: what the
    master has), "gas" k = -k_g (the gas's own stiffness), "none" k = 0 (the plain scheme, the
    pressure linear over the sub-steps), or a number (k = -that).
    The interface (p_{n+1} from the blower at U, U = u_{n+1}) is converged exactly."""
    if stiffness == "blower":
        ks = blower_stiffness(h, relief)
    elif stiffness == "gas":
        ks = K_G
    elif stiffness == "none":
        ks = 0.0
    else:
        ks = float(stiffness)
    u0, p0, w0 = x[0], x[3], x[4]

    def run(z: np.ndarray) -> np.ndarray:
        p1, big_u = z
        s = x[:3].copy()
        for i in range(n):
            t0, t1 = i / n, (i + 1) / n
            ul0, ul1 = ((u0 + (big_u - u0) * t0, u0 + (big_u - u0) * t1) if anchor == "iterate"
                        else (u0, u0))
            # the load p_lin + k (u - u_lin) = (p_lin + ks u_lin) - ks u: the given part, and
            # the spring -ks u in the sub-step's stiffness (its start value the carried one)
            f0 = p0 + (p1 - p0) * t0 + ks * ul0
            f1 = p0 + (p1 - p0) * t1 + ks * ul1
            s = substep(s, h / n, K_S + ks, f0, f1)
        return s

    def residual(z: np.ndarray, s: np.ndarray) -> np.ndarray:
        p1, big_u = z
        return np.array([p1 - K_G * (w0 - big_u) / (1 + h * relief), big_u - s[0]])

    p1, big_u = _affine_solve(run, residual, 2)
    w1 = w0 - h * relief / K_G * p1
    return np.concatenate([run(np.array([p1, big_u])), [p1, w1]])


def monolithic_relief(x: np.ndarray, h: float, n: int, relief: float = RELIEF) -> np.ndarray:
    """The monolithic reference with the relieving blower, state (u, v, a, p, w): the gas law
    p = k_g (w - u) in every sub-step (its stiffness in the sub-step), the gas amount w linear
    from w_n to w_{n+1} over them (the `gas` scene's input goes linearly over a step), and the
    blower's balance w_{n+1} = w_n - h c p_{n+1} at the macro step's end (couple_monolithic.solve
    solves it around the gas scene)."""
    w0 = x[4]

    def run(z: np.ndarray) -> np.ndarray:
        s = x[:3].copy()
        for i in range(n):
            t0, t1 = i / n, (i + 1) / n
            s = substep(s, h / n, K_S + K_G, K_G * (w0 + (z[0] - w0) * t0), K_G * (w0 + (z[0] - w0) * t1))
        return s

    def residual(z: np.ndarray, s: np.ndarray) -> np.ndarray:
        p1 = K_G * (z[0] - s[0])
        return np.array([z[0] - w0 + h * relief / K_G * p1])

    (w1,) = _affine_solve(run, residual, 1)
    s = run(np.array([w1]))
    return np.concatenate([s, [K_G * (w1 - s[0]), w1]])


def amplification(scheme: Callable[[np.ndarray, float, int], np.ndarray], h: float, n: int
                  ) -> np.ndarray:
    """The scheme's (linear) map of (u, v, a, p) over one macro step."""
    m = len(scheme(np.zeros(5), h, n))  # 4: (u, v, a, p); 5: with the blower's gas amount w
    return np.column_stack([scheme(e, h, n) for e in np.eye(m)])


def radius(scheme: Callable[[np.ndarray, float, int], np.ndarray], h: float, n: int) -> float:
    return float(max(abs(np.linalg.eigvals(amplification(scheme, h, n)))))


def _row(h: float, cells) -> str:
    return f"{h:<8g}" + "".join(f"| {c:<27}" for c in cells)


def main() -> None:
    hs, ns = (1e-3, 2.5e-3, 5e-3, 1e-2, 2e-2, 5e-2, 0.1), (1, 2, 4, 8)
    print(f"omega {OMEGA:g} rad/s, k_g/k_s {GAIN:g}, rho_inf {RHO_INF}, damping {DAMPING:g}/s")
    print("1. memoryless gas; spectral radius per macro step: monolithic / coupled, p linear / coupled, p held")
    print("h (s)   " + "".join(f"| n = {n:<23}" for n in ns))
    for h in hs:
        print(_row(h, [f"{radius(monolithic, h, n):.3f} / {radius(linear, h, n):.3f} / {radius(hold, h, n):.3f}"
                       for n in ns]))
    print(f"2. the blower relieves the gas (RELIEF {RELIEF:g}/s: dp/dV over h is -k_g/(1 + h RELIEF));")
    print("   monolithic (= gas spring with the gas's stiffness, = the gas-amount interface) / plain (p linear)"
          " / gas spring with the blower's dp/dV")
    print("h (s)   " + "".join(f"| n = {n:<23}" for n in ns))
    for h in hs:
        print(_row(h, [f"{radius(monolithic_relief, h, n):.3f} / "
                       f"{radius(lambda x, h, n: spring(x, h, n, 'none'), h, n):.3f} / "
                       f"{radius(spring, h, n):.3f}" for n in ns]))
    print("3. worst radius over h and n = 2, 4, 8 of the gas spring with k = theta k_g (relieving blower)")
    for theta in (0.3, 0.5, 0.7, 0.8, 0.9, 1.0, 1.2, 1.5, 2.0):
        w = max(radius(lambda x, h, n: spring(x, h, n, theta * K_G), h, n) for h in hs for n in ns[1:])
        print(f"   theta {theta:<4g} {w:.3f}")
    print("4. the anchor V_lin = V_n held (relieving blower, the blower's dp/dV): radius with one sub-step"
          " (the other schemes' equal the monolithic one there)")
    for h in hs:
        print(f"   h {h:<7g} {radius(lambda x, h, n: spring(x, h, n, anchor='start'), h, 1):.3f} against"
              f" {radius(monolithic_relief, h, 1):.3f}")


if __name__ == "__main__":
    main()
