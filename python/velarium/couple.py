"""A coupling master for two Co-Simulation FMUs, FMI 2.0 or FMI 3.0 (each its own), wired by a
connection list (docs/coupling.md).

Each macro step [t, t+h] is repeated from the saved FMU states until the interface residual
converges (strong coupling). The interface unknown x is the vector of the first FMU's inputs that
the second FMU's outputs feed; one coupling iteration evaluates the Gauss-Seidel map

    H(x):  step A from its saved state with inputs x   -> A's outputs y_A
           step B from its saved state with inputs y_A -> B's outputs, mapped to x' = H(x)

and the residual r = H(x) - x. The methods differ in the next x:

- ``gs``:     x <- H(x)                               (plain Gauss-Seidel);
- ``jacobi``: A and B both step from the last iterate's values (x, z) <- (B(z), A(x));
- ``aitken``: x <- x + ω r, ω by Aitken's Δ² rule (Irons-Tuck), ω₀ = ``omega0``;
- ``iqn``:    IQN-ILS (interface quasi-Newton, inverse Jacobian by least squares on the
              differences of residuals and of H's values within the macro step);
- ``newton``: x <- x + (I - J_B J_A)⁻¹ r with J_A, J_B the FMUs' interface Jacobians from
              ``fmi2GetDirectionalDerivative`` / ``fmi3GetDirectionalDerivative`` (after the
              step, with respect to that step's inputs), or finite differences of steps from the
              saved states when an FMU does not provide derivatives or refuses them with an
              Error (then said on stderr and in ``Master.notes``; ``jacobian="fd"`` forces them).

Both FMI versions are driven through the same calls: get/set FMU state (``fmi2GetFMUstate`` /
``fmi3GetFMUState``...), Real / Float64 values, ``doStep`` (FMI 3 with
``noSetFMUStatePriorToCurrentPoint`` false, since the master rolls back; a step that returns
early or asks to terminate counts as refused).

External inputs (set points, loads) are given as piecewise-linear tables and set at the end
of each macro step (t+h): a quasi-static FMU's step reaches the equilibrium under the inputs
set before it. A macro step whose residual did not converge within ``max_iterations``, or in
which an FMU refused the step, is rolled back and halved (said on stderr); ``iterations=1``
with ``weak=True`` is weak (explicit) coupling: one pass, accepted as it is.

``python -m velarium.couple SYSTEM.json --method newton|iqn|aitken|gs|jacobi`` runs a system file
and prints per macro step the iterations and the interface residual, and the difference to the
monolithic answer when the system names one.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time as _time
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

METHODS = ("newton", "iqn", "aitken", "gs", "jacobi")


class CouplingError(RuntimeError):
    """The master cannot go on: a macro step did not converge down to the smallest step, or the
    system is ill-formed (the message names the field)."""


def _fmi3_provides_derivatives(path: Path) -> bool:
    """providesDirectionalDerivatives of an FMI 3 archive's CoSimulation element (fmpy 0.3 reads
    only the FMI 2 attribute, providesDirectionalDerivative)."""
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    cs = root.find("CoSimulation")
    return cs is not None and cs.get("providesDirectionalDerivatives") in ("true", "1")


class Unit:
    """One FMU instance, FMI 2.0 or 3.0 Co-Simulation: set/get by name, step, save/restore its
    state, interface Jacobians."""

    def __init__(self, name: str, path: str | Path, start: Mapping[str, float] | None = None):
        self.name = name
        self.path = Path(path)
        if not self.path.exists():
            raise CouplingError(f"fmus.{name}.fmu: {self.path} does not exist")
        self.md = read_model_description(str(self.path))
        if self.md.coSimulation is None:
            raise CouplingError(f"fmus.{name}: {self.path} is not a Co-Simulation FMU")
        if self.md.fmiVersion not in ("2.0", "3.0"):
            raise CouplingError(f"fmus.{name}: {self.path} is FMI {self.md.fmiVersion}; the master drives FMI 2.0 "
                                "and 3.0")
        self.fmi = 3 if self.md.fmiVersion == "3.0" else 2
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        if self.fmi == 3:
            self.provides_derivatives = _fmi3_provides_derivatives(self.path)
        else:
            self.provides_derivatives = bool(self.md.coSimulation.providesDirectionalDerivative)
        self.can_save = bool(self.md.coSimulation.canGetAndSetFMUstate)
        if not self.can_save:
            flag = "canGetAndSetFMUState" if self.fmi == 3 else "canGetAndSetFMUstate"
            raise CouplingError(f"fmus.{name}: {self.path} cannot get and set its FMU state ({flag})")
        self._dir = tempfile.mkdtemp(prefix=f"couple-{name}-")
        extract(str(self.path), self._dir)
        kwargs = dict(guid=self.md.guid, unzipDirectory=self._dir,
                      modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.slave = FMU3Slave(**kwargs) if self.fmi == 3 else FMU2Slave(**kwargs)
        self.slave.instantiate()
        self.start = dict(start or {})
        self.steps = 0
        self.step_seconds = 0.0
        self.jacobian_seconds = 0.0
        self.jacobians = 0

    def check(self, names: Sequence[str], what: str, causality: tuple[str, ...]) -> None:
        for n in names:
            v = self.vars.get(n)
            if v is None:
                raise CouplingError(f"{what}: {self.name} has no variable {n!r} (it has {sorted(self.vars)})")
            if v.causality not in causality:
                raise CouplingError(f"{what}: {self.name}.{n} is a {v.causality}, not an {'/'.join(causality)}")

    def initialize(self, t0: float, inputs: Mapping[str, float]) -> None:
        if self.fmi == 3:
            self.slave.enterInitializationMode(startTime=t0)
        else:
            self.slave.setupExperiment(startTime=t0)
            self.slave.enterInitializationMode()
        values = {**self.start, **inputs}
        if values:
            self.set(values)
        self.slave.exitInitializationMode()

    def set(self, values: Mapping[str, float]) -> None:
        names = list(values)
        refs, numbers = [self.vr[n] for n in names], [float(values[n]) for n in names]
        if self.fmi == 3:
            self.slave.setFloat64(refs, numbers)
        else:
            self.slave.setReal(refs, numbers)

    def get(self, names: Sequence[str]) -> np.ndarray:
        refs = [self.vr[n] for n in names]
        return np.array(self.slave.getFloat64(refs) if self.fmi == 3 else self.slave.getReal(refs))

    def step(self, t: float, h: float) -> None:
        self.steps += 1
        t0 = _time.perf_counter()
        try:
            if self.fmi == 3:
                # the master restores states from before t: not "no set FMU state prior to t"
                _, terminate, early, reached = self.slave.doStep(
                    currentCommunicationPoint=t, communicationStepSize=h, noSetFMUStatePriorToCurrentPoint=False)
                if terminate or early:
                    raise RuntimeError(f"{self.name}: fmi3DoStep from t = {t:g} ended at {reached:g} "
                                       f"({'terminateSimulation' if terminate else 'earlyReturn'})")
            else:
                self.slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        finally:
            self.step_seconds += _time.perf_counter() - t0

    def save(self):
        return self.slave.getFMUState() if self.fmi == 3 else self.slave.getFMUstate()

    def restore(self, state) -> None:
        if self.fmi == 3:
            self.slave.setFMUState(state)
        else:
            self.slave.setFMUstate(state)

    def free_state(self, state) -> None:
        if self.fmi == 3:
            self.slave.freeFMUState(state)
        else:
            self.slave.freeFMUstate(state)

    def jacobian(self, outs: Sequence[str], ins: Sequence[str]) -> np.ndarray:
        """d outs / d ins of the last step, from fmi2/fmi3GetDirectionalDerivative (one seed per
        input)."""
        t0 = _time.perf_counter()
        self.jacobians += 1
        J = np.zeros((len(outs), len(ins)))
        uo = [self.vr[n] for n in outs]
        ui = [self.vr[n] for n in ins]
        for j in range(len(ins)):
            seed = [0.0] * len(ins)
            seed[j] = 1.0
            J[:, j] = self.slave.getDirectionalDerivative(uo, ui, seed)
        self.jacobian_seconds += _time.perf_counter() - t0
        return J

    def close(self) -> None:
        try:
            self.slave.terminate()
        finally:
            self.slave.freeInstance()
            shutil.rmtree(self._dir, ignore_errors=True)


def table_function(points: Sequence[Sequence[float]], what: str) -> Callable[[float], float]:
    """A piecewise-linear function of time from [[t, value], ...] (held beyond the ends)."""
    try:
        a = np.asarray(points, dtype=float)
    except (TypeError, ValueError) as e:
        raise CouplingError(f"{what}: {e}") from None
    if a.ndim != 2 or a.shape[1] != 2 or len(a) == 0 or np.any(np.diff(a[:, 0]) < 0):
        raise CouplingError(f"{what}: expected [[time, value], ...] with increasing times")
    return lambda t: float(np.interp(t, a[:, 0], a[:, 1]))


@dataclass
class StepRecord:
    time: float
    step: float
    iterations: int
    residual: float
    history: list[float] = field(default_factory=list)
    values: dict[str, float] = field(default_factory=dict)


@dataclass
class Result:
    method: str
    records: list[StepRecord]
    rejected: list[tuple[float, float, str, list[float]]]
    fmu_steps: dict[str, int]
    seconds: float
    #: per FMU: (seconds in DoStep, seconds in GetDirectionalDerivative, Jacobians taken)
    timing: dict[str, tuple[float, float, int]] = field(default_factory=dict)
    #: per FMU: the FMI version it was driven in (2 or 3)
    fmi: dict[str, int] = field(default_factory=dict)

    def column(self, name: str) -> np.ndarray:
        return np.array([r.values[name] for r in self.records])

    @property
    def times(self) -> np.ndarray:
        return np.array([r.time for r in self.records])

    @property
    def iterations(self) -> np.ndarray:
        return np.array([r.iterations for r in self.records])


class Master:
    """Two FMUs A and B wired by ``connections`` [("A.out", "B.in"), ("B.out", "A.in"), ...]
    (both directions needed); ``inputs`` maps "fmu.var" to a [[t, value], ...] table;
    ``start`` maps FMU names to start values (a string "fmu.var" is that FMU's output after
    its initialization; FMUs are initialized in the order of ``fmus``)."""

    def __init__(self, fmus: Mapping[str, str | Path], connections: Sequence[Sequence[str]],
                 inputs: Mapping[str, Any] | None = None, start: Mapping[str, Mapping[str, Any]] | None = None):
        if len(fmus) != 2:
            raise CouplingError(f"fmus: the master couples exactly two FMUs, got {len(fmus)}")
        start = dict(start or {})
        for k in start:
            if k not in fmus:
                raise CouplingError(f"start.{k}: no FMU of that name (FMUs: {list(fmus)})")
        self.order = list(fmus)
        #: what the master decided on its own (an FMU's refused derivatives replaced by differences)
        self.notes: list[str] = []
        self.units: dict[str, Unit] = {}
        try:
            for n, p in fmus.items():
                self.units[n] = Unit(n, p)
            self._start = start
            self.a, self.b = self.order
            self.a_in, self.b_out = [], []   # B -> A: B.out feeds A.in
            self.b_in, self.a_out = [], []   # A -> B
            for k, c in enumerate(connections):
                if len(c) != 2:
                    raise CouplingError(f"connections[{k}]: expected [\"fmu.output\", \"fmu.input\"]")
                (fu, fv), (tu, tv) = (self._split(s, f"connections[{k}]") for s in c)
                if fu == tu:
                    raise CouplingError(f"connections[{k}]: {c[0]} -> {c[1]} connects an FMU to itself")
                self.units[fu].check([fv], f"connections[{k}]", ("output",))
                self.units[tu].check([tv], f"connections[{k}]", ("input",))
                if tu == self.a:
                    self.b_out.append(fv)
                    self.a_in.append(tv)
                else:
                    self.a_out.append(fv)
                    self.b_in.append(tv)
            if not self.a_in or not self.b_in:
                raise CouplingError("connections: the two FMUs must feed each other (a loop), one way is missing")
            self.inputs: dict[str, tuple[str, str, Callable[[float], float]]] = {}
            for key, pts in (inputs or {}).items():
                u, v = self._split(key, f"inputs.{key}")
                self.units[u].check([v], f"inputs.{key}", ("input",))
                self.inputs[key] = (u, v, table_function(pts, f"inputs.{key}"))
        except BaseException:
            self.close()
            raise

    def _split(self, s: str, what: str) -> tuple[str, str]:
        u, _, v = str(s).partition(".")
        if u not in self.units or not v:
            raise CouplingError(f"{what}: {s!r} is not \"fmu.variable\" with fmu one of {list(self.units)}")
        return u, v

    def external(self, unit: str, t: float) -> dict[str, float]:
        return {v: f(t) for (u, v, f) in self.inputs.values() if u == unit}

    def close(self) -> None:
        for u in self.units.values():
            try:
                u.close()
            except Exception:  # noqa: BLE001 - closing is best effort
                pass
        self.units = {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---- one macro step ----

    def _step_a(self, sa, x, t, h) -> np.ndarray:
        A = self.units[self.a]
        A.restore(sa)
        A.set({**self.external(self.a, t + h), **dict(zip(self.a_in, x))})
        A.step(t, h)
        return A.get(self.a_out)

    def _step_b(self, sb, z, t, h) -> np.ndarray:
        B = self.units[self.b]
        B.restore(sb)
        B.set({**self.external(self.b, t + h), **dict(zip(self.b_in, z))})
        B.step(t, h)
        return B.get(self.b_out)

    def _fd_jacobian(self, step, state, v, t, h, base) -> np.ndarray:
        J = np.zeros((len(base), len(v)))
        for j in range(len(v)):
            d = 1e-6 * max(abs(v[j]), 1.0)
            w = v.copy()
            w[j] += d
            J[:, j] = (step(state, w, t, h) - base) / d
        return J

    def _derivative(self, unit: Unit, outs: Sequence[str], ins: Sequence[str]) -> np.ndarray | None:
        """The FMU's interface Jacobian from its directional derivatives, or None when it refuses
        them (Velarium refuses them for scenes with dynamics.time_integration): then the FMU is
        marked as not providing them, so that this and every later Jacobian of it is taken by
        finite differences of steps from the saved states; said once on stderr and kept in
        ``self.notes``."""
        try:
            return unit.jacobian(outs, ins)
        except Exception as e:  # an Error status from GetDirectionalDerivative
            unit.provides_derivatives = False
            msg = (f"{unit.name}: directional derivatives refused ({e}); its interface Jacobian is taken "
                   "by finite differences of steps from the saved states from now on")
            self.notes.append(msg)
            print(msg, file=sys.stderr)
            return None

    def macro_step(self, t: float, h: float, x0: np.ndarray, method: str, tol: float, max_iterations: int,
                   jacobian: str, omega0: float, weak: bool, hist: list[float]
                   ) -> tuple[bool, int, float, np.ndarray, str]:
        """Repeat [t, t+h] from the saved states; returns (converged, iterations, residual, x, why)
        and appends each iteration's residual to ``hist``.
        On return both FMUs are at t+h after their last evaluation (x's)."""
        A, B = self.units[self.a], self.units[self.b]
        sa, sb = A.save(), B.save()
        ok = False
        try:
            x = np.array(x0, dtype=float)
            z = None
            scale = max(float(np.linalg.norm(x)), 1.0)
            hist_x: list[np.ndarray] = []   # H(x_k) for IQN
            hist_r: list[np.ndarray] = []
            omega = omega0
            r_prev = None
            res = np.inf
            for k in range(1, max_iterations + 1):
                if method == "jacobi":
                    if z is None:
                        z = A.get(self.a_out)  # A's outputs at t (A is at its saved state)
                    y_a = self._step_a(sa, x, t, h)
                    hx = self._step_b(sb, z, t, h)
                    rz = y_a - z
                    r = hx - x
                    res = max(float(np.linalg.norm(r)) / scale,
                              float(np.linalg.norm(rz)) / max(float(np.linalg.norm(z)), 1.0))
                else:
                    y_a = self._step_a(sa, x, t, h)
                    hx = self._step_b(sb, y_a, t, h)
                    r = hx - x
                    res = float(np.linalg.norm(r)) / scale
                hist.append(res)
                if not np.all(np.isfinite(r)):
                    return False, k, float("nan"), x, "the interface values are not finite"
                if res <= tol or (weak and k == 1):
                    ok = True
                    # weak coupling carries B's fresh outputs into the next step
                    return True, k, res, (hx if weak else x), ""
                if k == max_iterations:
                    break
                if method == "gs":
                    x = hx
                elif method == "jacobi":
                    x, z = hx, y_a
                elif method == "aitken":
                    if r_prev is not None:
                        dr = r - r_prev
                        den = float(dr @ dr)
                        if den > 0:
                            omega = -omega * float(r_prev @ dr) / den
                    x = x + omega * r
                    r_prev = r
                elif method == "iqn":
                    hist_x.append(hx)
                    hist_r.append(r)
                    if len(hist_r) == 1:
                        x = x + omega0 * r
                    else:
                        Vm = np.column_stack([hist_r[i + 1] - hist_r[i] for i in range(len(hist_r) - 1)])
                        Wm = np.column_stack([hist_x[i + 1] - hist_x[i] for i in range(len(hist_x) - 1)])
                        c, *_ = np.linalg.lstsq(Vm, -r, rcond=None)
                        x = hx + Wm @ c
                elif method == "newton":
                    # the derivatives first (each FMU is at its step at this iterate), then the
                    # finite differences of steps from the saved states for an FMU without them
                    jb = self._derivative(B, self.b_out, self.b_in) if (
                        jacobian != "fd" and B.provides_derivatives) else None
                    ja = self._derivative(A, self.a_out, self.a_in) if (
                        jacobian != "fd" and A.provides_derivatives) else None
                    if ja is None:
                        ja = self._fd_jacobian(self._step_a, sa, x, t, h, y_a)
                    if jb is None:
                        jb = self._fd_jacobian(self._step_b, sb, y_a, t, h, hx)
                    M = np.eye(len(x)) - jb @ ja
                    x = x + np.linalg.solve(M, r)
                else:
                    raise CouplingError(f"method: {method!r} is not one of {METHODS}")
            return False, max_iterations, res, x, f"the interface residual {res:.3g} is above {tol:g} after {max_iterations} iterations"
        except CouplingError:
            raise
        except Exception as e:  # an FMU refused the step (Discard/Error)
            return False, 0, float("nan"), np.asarray(x0, dtype=float), f"an FMU refused the step: {e}"
        finally:
            if not ok:  # roll back to t
                A.restore(sa)
                B.restore(sb)
            A.free_state(sa)
            B.free_state(sb)

    def run(self, stop: float, step: float, method: str = "newton", *, start: float = 0.0, tol: float = 1e-10,
            max_iterations: int = 20, jacobian: str = "auto", omega0: float = 0.5, weak: bool = False,
            min_step: float | None = None, record: Sequence[str] = (), log: Callable[[str], None] | None = None
            ) -> Result:
        """Run from ``start`` to ``stop`` in macro steps of ``step``; ``record`` names "fmu.var"
        values kept per accepted step (the interface values always are)."""
        if method not in METHODS:
            raise CouplingError(f"method: {method!r} is not one of {', '.join(METHODS)}")
        if not (step > 0 and stop > start):
            raise CouplingError(f"step/stop: need step > 0 and stop > start (step {step}, start {start}, stop {stop})")
        if jacobian not in ("auto", "fd"):
            raise CouplingError(f"jacobian: {jacobian!r} is not 'auto' or 'fd'")
        min_step = min_step if min_step is not None else step / 1024
        t0 = _time.perf_counter()
        # initialize in order, each with the values its partner already has
        done: dict[str, Unit] = {}
        for n in self.order:
            u = self.units[n]
            vals = {}
            for k, v in self._start.get(n, {}).items():
                if isinstance(v, str):
                    su, sv = self._split(v, f"start.{n}.{k}")
                    if su not in done:
                        raise CouplingError(f"start.{n}.{k}: {v} is read before {su} is initialized (order of fmus)")
                    v = float(done[su].get([sv])[0])
                vals[k] = v
            u.start = vals
            conn = {}
            if n == self.b and self.a in done:
                conn = dict(zip(self.b_in, done[self.a].get(self.a_out)))
            if n == self.a and self.b in done:
                conn = dict(zip(self.a_in, done[self.b].get(self.b_out)))
            u.initialize(start, {**self.external(n, start), **conn})
            done[n] = u
        A, B = self.units[self.a], self.units[self.b]
        keys = [f"{self.a}.{v}" for v in self.a_in] + [f"{self.a}.{v}" for v in self.a_out] + list(record)

        def values() -> dict[str, float]:
            out = {}
            for key in keys:
                uu, vv = self._split(key, "record")
                out[key] = float(self.units[uu].get([vv])[0])
            return out

        x = B.get(self.b_out)
        x_prev, h_prev = None, None
        records = [StepRecord(start, 0.0, 0, 0.0, [], values())]
        #: the rejected attempts so far (t, h, why, residuals), kept when run raises
        self.rejected = rejected = []
        t, h = start, step
        while t < stop - 1e-12 * max(1.0, abs(stop)):
            h = min(h, stop - t)
            guess = x if (x_prev is None or weak) else x + (x - x_prev) * (h / h_prev)
            hist: list[float] = []
            ok, its, res, xk, why = self.macro_step(t, h, guess, method, tol, max_iterations, jacobian, omega0, weak,
                                                    hist)
            if not ok:
                rejected.append((t, h, why, hist))
                msg = f"t = {t:.6g}: macro step {h:.6g} rejected ({why}); rolled back, trying {h / 2:.6g}"
                print(msg, file=sys.stderr)
                if log:
                    log(msg)
                h /= 2
                if h < min_step:
                    raise CouplingError(f"t = {t:.6g}: no macro step down to {min_step:g} converged ({why})")
                continue
            x_prev, h_prev = x, h
            x = xk
            t += h
            records.append(StepRecord(t, h, its, res, hist, values()))
            if log:
                log(f"t = {t:.6g}  h = {h:.4g}  iterations {its}  residual {res:.3e}")
            h = min(step, 2 * h)
        return Result(method, records, rejected, {n: u.steps for n, u in self.units.items()},
                      _time.perf_counter() - t0,
                      {n: (u.step_seconds, u.jacobian_seconds, u.jacobians) for n, u in self.units.items()},
                      {n: u.fmi for n, u in self.units.items()})


# ---- system files and the command line ----

def _fmu_path(name: str, spec: Mapping[str, Any], base: Path, build: Path, fmi: int | None = None) -> Path:
    """The archive of ``fmus.<name>``: its ``fmu`` (with ``fmi=3``, the FMI 3 archive beside it,
    ``<stem>_fmi3.fmu`` as `velarium pack` and harness/blower/pack.py name them), or its ``scene``
    packed into ``build`` as FMI ``spec["fmi"]`` (2 by default; ``fmi`` overrides)."""
    if not isinstance(spec, Mapping) or ("fmu" in spec) == ("scene" in spec):
        raise CouplingError(f"fmus.{name}: give exactly one of \"fmu\" (an archive) or \"scene\" (a Velarium scene)")
    version = spec.get("fmi", 2) if fmi is None else fmi
    if version not in (2, 3):
        raise CouplingError(f"{'fmi' if fmi is not None else f'fmus.{name}.fmi'}: {version!r} is not 2 or 3")
    if "fmu" in spec:
        path = (base / spec["fmu"]).resolve()
        if fmi == 3 and not path.stem.endswith("_fmi3"):
            fmi3 = path.with_name(f"{path.stem}_fmi3.fmu")
            if not fmi3.exists():
                raise CouplingError(f"fmus.{name}.fmu: FMI 3 was asked for, but there is no {fmi3.name} beside {path} "
                                    "(the FMI 3 archive's name as velarium pack and harness/blower/pack.py write it)")
            path = fmi3
        return path
    from .engine import pack

    scene = (base / spec["scene"]).resolve()
    if not scene.exists():
        raise CouplingError(f"fmus.{name}.scene: {scene} does not exist")
    return pack(scene, build, fmi=version)[0]


def load_system(path: str | Path, build: str | Path = "build/coupling", fmi: int | None = None) -> dict[str, Any]:
    """Read a system file (docs/coupling.md, "System files"): FMU paths resolved (scenes packed
    into ``build``), everything else as written; ``fmi=3`` (or 2) takes every FMU, the
    monolithic reference's too, in that FMI version (scenes packed so, archives' FMI 3 siblings).
    An ``.ssp`` package is read by ``couple_ssp.read_ssp`` (its archives as they are)."""
    path = Path(path)
    if path.suffix == ".ssp":
        from .couple_ssp import read_ssp

        return read_ssp(path)
    try:
        sysd = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise CouplingError(f"{path}: {e}") from None
    for key in ("fmus", "connections", "stop", "step"):
        if key not in sysd:
            raise CouplingError(f"{path}: missing field {key!r}")
    base = path.resolve().parent
    sysd["fmu_paths"] = {n: _fmu_path(n, s, base, Path(build), fmi) for n, s in sysd["fmus"].items()}
    mono = sysd.get("monolithic")
    if mono is not None:
        if mono.get("kind") != "cushion_gas":
            raise CouplingError(f"monolithic.kind: {mono.get('kind')!r} is not \"cushion_gas\"")
        mono["fmu_path"] = _fmu_path("monolithic", mono, base, Path(build), fmi)
    return sysd


def run_system(sysd: Mapping[str, Any], method: str, step: float | None = None, log=None,
               **options) -> Result:
    m = Master(sysd["fmu_paths"], sysd["connections"], sysd.get("inputs"),
               {n: s.get("start", {}) for n, s in sysd["fmus"].items()})
    with m:
        record = list(sysd.get("monolithic", {}).get("compare", {}))
        return m.run(float(sysd["stop"]), float(step or sysd["step"]), method, record=record, log=log,
                     **{**sysd.get("options", {}), **options})


def monolithic(sysd: Mapping[str, Any], step: float | None = None) -> dict[str, np.ndarray]:
    """The monolithic answer of a system file's ``monolithic`` entry (couple_monolithic.py)."""
    from . import couple_monolithic as cm

    mono = sysd["monolithic"]
    blower = mono["blower"]
    par = cm.blower_parameters(sysd["fmu_paths"][blower],
                               {k: v for k, v in sysd["fmus"][blower].get("start", {}).items()
                                if not isinstance(v, str)})
    inputs = sysd.get("inputs", {})
    return cm.solve(mono["fmu_path"], par, float(mono["p0"]), inputs[mono["p_set"]], inputs[mono["snow"]],
                    float(sysd["stop"]), float(step or sysd["step"]))


def difference(result: Result, ref: Mapping[str, np.ndarray], compare: Mapping[str, str]) -> dict[str, float]:
    """Largest relative difference per compared column, on the times both have."""
    out = {}
    times = result.times
    idx = [int(np.argmin(np.abs(ref["time"] - t))) for t in times]
    ok = np.abs(ref["time"][idx] - times) <= 1e-9
    for col, rc in compare.items():
        a = result.column(col)[ok]
        b = ref[rc][idx][ok]
        out[col] = float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300)))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m velarium.couple",
                                 description="Couple two FMUs of a system file strongly, macro step by macro step "
                                             "(docs/coupling.md).")
    ap.add_argument("system", help="system file (JSON: fmus, connections, inputs, step, stop, monolithic)")
    ap.add_argument("--method", choices=METHODS, default="newton")
    ap.add_argument("--step", type=float, help="macro step, s (default: the system's)")
    ap.add_argument("--tol", type=float, help="interface residual tolerance, relative (default 1e-10)")
    ap.add_argument("--max-iterations", type=int, help="coupling iterations per macro step before it is halved (20)")
    ap.add_argument("--jacobian", choices=("auto", "fd"), help="newton: the FMUs' derivatives or finite differences")
    ap.add_argument("--weak", action="store_true", help="weak coupling: one pass per macro step, accepted as it is")
    ap.add_argument("--build", default="build/coupling", help="where scenes are packed (build/coupling)")
    ap.add_argument("--fmi", type=int, choices=(2, 3),
                    help="run every FMU in this FMI version (scenes packed so; an archive's X_fmi3.fmu sibling)")
    ap.add_argument("--write-ssp", metavar="OUT.ssp", help="write the system as an SSP 1.0 package and stop")
    a = ap.parse_args(argv)
    opts: dict[str, Any] = {}
    if a.tol is not None:
        opts["tol"] = a.tol
    if a.max_iterations is not None:
        opts["max_iterations"] = a.max_iterations
    if a.jacobian is not None:
        opts["jacobian"] = a.jacobian
    if a.weak:
        opts["weak"] = True
    try:
        if a.fmi is not None and a.system.endswith(".ssp"):
            raise CouplingError("--fmi: an .ssp package holds its own archives; it is run as it is")
        sysd = load_system(a.system, a.build, a.fmi)
        if a.write_ssp:
            from .couple_ssp import write_ssp

            print(write_ssp(sysd, a.write_ssp, Path(a.system).stem))
            return 0
        res = run_system(sysd, a.method, a.step, **opts)
        print(f"{'time':>10} {'step':>8} {'iter':>4} {'residual':>10}  " + "  ".join(f"{k:>14}" for k in res.records[0].values))
        for r in res.records[1:]:
            print(f"{r.time:10.6g} {r.step:8.4g} {r.iterations:4d} {r.residual:10.3e}  "
                  + "  ".join(f"{v:14.8g}" for v in r.values.values()))
        its = res.iterations[1:]
        versions = ", ".join(f"{n} FMI {u}" for n, u in res.fmi.items())
        print(f"{a.method} ({versions}): {len(its)} macro steps, iterations per step {its.min()}-{its.max()} (mean {its.mean():.2f}), "
              f"{len(res.rejected)} rejected, FMU steps {res.fmu_steps}, {res.seconds:.2f} s")
        if "monolithic" in sysd:
            ref = monolithic(sysd, a.step)
            d = difference(res, ref, sysd["monolithic"]["compare"])
            print("difference to the monolithic answer (largest relative): "
                  + ", ".join(f"{k} {v:.2e}" for k, v in d.items()))
    except CouplingError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
