"""The cushion-and-blower system (docs/coupling.md): the Blower FMU (harness/blower/) and the coupling
master (python/velarium/couple.py) against the monolithic answer.

References and tolerances:

- The blower alone at a fixed volume reaches the closed-form steady state of its PI controller:
  p = p_set (integral action) and the valve opening that passes the fan's flow there,
  u* = Q_fan(p_set) sqrt(p_set + p_lam) / (K_valve p_set), Q_fan from the fan curve's quadratic
  (harness/blower/blower.c, header). Backward Euler's fixed point is the exact steady state, so after
  60 s in 0.5 s steps the error is the transient's remainder: measured 0 (p equal to 300 Pa
  in every bit); tolerance 1e-9 relative.
- The FMI 3.0 archive (the same library) simulates to the FMI 2 archive's numbers bit for bit;
  its adjoint derivative is the transpose of its directional ones to 1e-14 (a 2 x 2 product).
- Its directional derivative dp/dV after a step equals the central difference of two steps
  from the saved state (δ = 1e-6 of V): the difference's truncation (δ² p''') and round-off
  (1e-16 |p_abs| / δ): measured 9.7e-9 relative; tolerance 1e-7.
- The coupled system against the monolithic answer (couple_monolithic.py: the gas law inside
  the Velarium scene `cushion_gas.json`, the blower's balance solved around it to round-off;
  no code shared with the master or the Blower FMU): the coupled answer is converged to an
  interface residual of 1e-10 (relative), and differs from the monolithic one by at most
  7.2e-11 relative (p, newton; measured 2.5e-11 to 2.6e-10 across the methods); tolerance
  1e-9 (5e-9 for Jacobi: 2.6e-10 measured). The issue's target is 1e-8.
- FMI 3.0: the master drives the FMI 3 archives (Velarium's and the Blower's: the same
  libraries behind fmi3* entry points) through fmi3GetFMUState/SetFMUState, Float64 values and
  fmi3GetDirectionalDerivative; every method takes the same iterations as through FMI 2 and
  gives the same numbers bit for bit (measured: equal), also with one FMU in each version, and
  rolls back and halves at the same steps. Tolerance: none (exact equality), since the same
  library computes both.
- Another SSP tool running the package (OMSimulator where it imports; fmucontainer 2.0 and
  fmpy 0.3.32 fail on it, strict xfails pinned to their errors): its answer no further from the
  monolithic one than 1.5 times the weak Jacobi scheme's error at the same 1 s step (measured by
  our master: 21.5 % in p) plus 1e-6; a sanity band that a weakly or strongly coupling tool
  meets and a wrongly started system does not (41 % with the blower started at 150 Pa).
- Plain Gauss-Seidel: the ratio of successive interface residuals equals the loop gain
  J_B J_A from the FMUs' derivatives (measured to 4 digits on h >= 0.25 s), and it diverges
  below h = 0.2 s where that gain passes 1 (measured -1.057 at 0.2 s): the test asserts the
  ratio within 1 % of the gain at h = 0.5 s and the rejection (roll back, halve, error) at 0.15 s.
"""

from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import velarium_run as vr

ROOT = vr.ROOT
SYSTEM = ROOT / "examples" / "coupling" / "cushion_blower.json"

couple = pytest.importorskip("velarium.couple")


def _blower_pack():
    spec = importlib.util.spec_from_file_location("blower_pack", ROOT / "harness" / "blower" / "pack.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="session")
def blower_fmu(tmp_path_factory) -> Path:
    """Blower.fmu built from harness/blower/blower.c (a C compiler and nothing else; well under 1 s)."""
    out = vr.FMU_DIR / "Blower.fmu"
    try:
        return _blower_pack().pack(vr.FMU_DIR)
    except (OSError, subprocess.CalledProcessError) as e:
        if out.exists():
            return out
        pytest.skip(f"cannot build harness/blower/blower.c: {e}")


@pytest.fixture(scope="session")
def system(blower_fmu, tmp_path_factory):
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    sysd = couple.load_system(SYSTEM, tmp_path_factory.mktemp("coupling"))
    sysd["fmu_paths"]["blower"] = blower_fmu
    return sysd


@pytest.fixture(scope="session")
def reference(system):
    return couple.monolithic(system)


def blower(blower_fmu, **start):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(blower_fmu))
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(blower_fmu)), modelIdentifier="Blower", instanceName="b")
    s.instantiate()
    s.setupExperiment(startTime=0)
    s.enterInitializationMode()
    vrs = {v.name: v.valueReference for v in md.modelVariables}
    for k, v in start.items():
        s.setReal([vrs[k]], [v])
    s.exitInitializationMode()
    return s, vrs, {v.name: float(v.start) for v in md.modelVariables if v.start is not None}


def test_blower_passes_fmpy_validate_and_simulates(blower_fmu):
    import fmpy
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(blower_fmu)) == []
    rows = fmpy.simulate_fmu(str(blower_fmu), stop_time=5, output_interval=0.5, start_values={"p0": 100})
    assert rows["p"][0] == pytest.approx(100, rel=1e-12)
    # the gas law of the outputs: (p + p_atm) V = p_atm N at every row (V held at its start 1 m3)
    assert np.allclose((rows["p"] + 101325.0) * 1.0, 101325.0 * rows["N"], rtol=1e-14, atol=0)


def test_blower_reaches_its_controllers_steady_state(blower_fmu):
    s, vrs, start = blower(blower_fmu, V0=0.7, p0=150.0)
    try:
        s.setReal([vrs["V"], vrs["p_set"]], [0.7, 300.0])
        t = 0.0
        for _ in range(120):
            s.doStep(t, 0.5)
            t += 0.5
        p, u = s.getReal([vrs["p"], vrs["u"]])
    finally:
        s.terminate()
        s.freeInstance()
    dp0, qmax, a = start["dp0"], start["Q_max"], start["fan_shape"]
    c = 1 - a
    q = qmax * (-a + math.sqrt(a * a + 4 * c * (1 - 300.0 / dp0))) / (2 * c)
    u_star = q * math.sqrt(300.0 + start["p_lam"]) / (start["K_valve"] * 300.0)
    assert 0 < u_star < 1
    assert p == pytest.approx(300.0, rel=1e-9)
    assert u == pytest.approx(u_star, rel=1e-9)


def test_blower_state_rollback_and_derivative(blower_fmu):
    s, vrs, _ = blower(blower_fmu, V0=0.7, p0=200.0)
    try:
        s.setReal([vrs["p_set"]], [300.0])
        s.setReal([vrs["V"]], [0.7])
        s.doStep(0.0, 0.5)
        saved = s.getFMUstate()
        blob = s.serializeFMUstate(saved)

        def p_after(V):
            s.setFMUstate(saved)
            s.setReal([vrs["V"]], [V])
            s.doStep(0.5, 0.5)
            return s.getReal([vrs["p"]])[0]

        V, d = 0.72, 0.72e-6
        p0 = p_after(V)
        dp = s.getDirectionalDerivative([vrs["p"]], [vrs["V"]], [1.0])[0]
        fd = (p_after(V + d) - p_after(V - d)) / (2 * d)
        assert dp == pytest.approx(fd, rel=1e-7)
        # rollback is exact, also through the serialized bytes
        assert p_after(V) == p0
        again = s.deSerializeFMUstate(blob)
        s.setFMUstate(again)
        s.setReal([vrs["V"]], [V])
        s.doStep(0.5, 0.5)
        assert s.getReal([vrs["p"]])[0] == p0
        s.freeFMUstate(again)
        s.freeFMUstate(saved)
    finally:
        s.terminate()
        s.freeInstance()


def test_blower_rejects_bad_input_naming_it(blower_fmu, capfd):
    from fmpy.fmi1 import FMICallException

    s, vrs, _ = blower(blower_fmu)
    try:
        with pytest.raises(FMICallException):
            s.setReal([vrs["V"]], [-1.0])
        assert "V (value reference 0): -1 is not a positive volume" in capfd.readouterr().out
        with pytest.raises(FMICallException):
            s.setReal([vrs["dp0"]], [100.0])  # a parameter after initialization
        assert "value reference 11 is a fixed parameter" in capfd.readouterr().out
    finally:
        s.terminate()
        s.freeInstance()


@pytest.mark.parametrize("method,tolerance,max_its", [
    ("newton", 1e-9, 3), ("iqn", 1e-9, 6), ("aitken", 1e-9, 5), ("gs", 1e-9, 23), ("jacobi", 5e-9, 40)])
def test_coupled_system_agrees_with_the_monolithic_answer(system, reference, method, tolerance, max_its):
    r = couple.run_system(system, method, max_iterations=60)
    assert r.rejected == []
    d = couple.difference(r, reference, system["monolithic"]["compare"])
    print(method, "iterations", r.iterations[1:].tolist(), "difference", d)
    assert all(v < tolerance for v in d.values()), d
    its = r.iterations[2:]  # the first step starts from the held, not an extrapolated, value
    assert its.max() <= max_its
    if method == "newton":
        assert r.iterations[1] <= 4


def test_newton_with_finite_differences_agrees(system, reference):
    r = couple.run_system(system, "newton", jacobian="fd")
    d = couple.difference(r, reference, system["monolithic"]["compare"])
    assert all(v < 1e-9 for v in d.values()), d
    assert r.iterations[2:].max() <= 3


@pytest.fixture(scope="session")
def system3(blower_fmu, tmp_path_factory):
    """The example system with both FMUs (and the monolithic reference) as FMI 3.0 archives."""
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    sysd = couple.load_system(SYSTEM, tmp_path_factory.mktemp("coupling3"), fmi=3)
    sysd["fmu_paths"]["blower"] = blower_fmu.with_name("Blower_fmi3.fmu")
    return sysd


@pytest.mark.parametrize("method", ["newton", "iqn", "aitken", "gs"])
@pytest.mark.parametrize("versions", [(3, 3), (3, 2)])
def test_fmi3_gives_the_fmi2_iterations_and_answer(system, system3, reference, method, versions):
    """(cushion, blower) in FMI (3, 3) and (3, 2) against both in FMI 2: the same iterations per
    macro step, residual histories and recorded values, bit for bit."""
    mixed = dict(system3, fmu_paths={"cushion": system3["fmu_paths"]["cushion"],
                                     "blower": system3["fmu_paths"]["blower"] if versions[1] == 3
                                     else system["fmu_paths"]["blower"]})
    r2 = couple.run_system(system, method, max_iterations=60)
    r3 = couple.run_system(mixed, method, max_iterations=60)
    assert r2.fmi == {"cushion": 2, "blower": 2}
    assert r3.fmi == {"cushion": versions[0], "blower": versions[1]}
    assert r3.rejected == [] and r3.iterations.tolist() == r2.iterations.tolist()
    assert [r.history for r in r3.records] == [r.history for r in r2.records]
    for col in r2.records[0].values:
        assert np.array_equal(r3.column(col), r2.column(col)), col
    if method == "newton":
        # the FMUs' own derivatives were taken (fmi3GetDirectionalDerivative), no differences
        assert all(r3.timing[n][2] > 0 for n in ("cushion", "blower")), r3.timing
        assert r3.fmu_steps == r2.fmu_steps
    d = couple.difference(r3, reference, system["monolithic"]["compare"])
    assert all(v < 1e-9 for v in d.values()), d


def test_fmi3_rolls_back_and_halves_like_fmi2(system, system3):
    one = dict(system3, stop=0.15)
    m = couple.Master(one["fmu_paths"], one["connections"], one.get("inputs"),
                      {n: s.get("start", {}) for n, s in one["fmus"].items()})
    with m:
        assert {n: u.fmi for n, u in m.units.items()} == {"cushion": 3, "blower": 3}
        with pytest.raises(couple.CouplingError, match="no macro step down to"):
            m.run(0.15, 0.15, "gs", max_iterations=30, min_step=0.05)
        assert [round(h, 6) for _, h, _, _ in m.rejected] == [0.15, 0.075]
    # the monolithic reference through the FMI 3 archive of cushion_gas.json: the FMI 2 numbers
    assert Path(system3["monolithic"]["fmu_path"]).name.endswith("_fmi3.fmu")
    ref3, ref2 = couple.monolithic(dict(system3, stop=1.0)), couple.monolithic(dict(system, stop=1.0))
    for col in ("time", "p", "V", "N", "I"):
        assert np.array_equal(ref3[col], ref2[col]), col


def test_fmi3_asked_for_an_archive_without_one_names_the_field(tmp_path, blower_fmu):
    import shutil

    shutil.copy(blower_fmu, tmp_path / "Lonely.fmu")
    (tmp_path / "s.json").write_text('{"fmus": {"a": {"fmu": "Lonely.fmu"}, "b": {"fmu": "Lonely.fmu"}}, '
                                     '"connections": [], "stop": 1, "step": 1}')
    with pytest.raises(couple.CouplingError, match=r"^fmus\.a\.fmu: FMI 3 was asked for, but there is no Lonely_fmi3\.fmu"):
        couple.load_system(tmp_path / "s.json", tmp_path, fmi=3)
    with pytest.raises(couple.CouplingError, match=r"^fmi: 4 is not 2 or 3"):
        couple.load_system(tmp_path / "s.json", tmp_path, fmi=4)


def test_gauss_seidel_contracts_by_the_loop_gain_and_fails_below_it(system):
    one = dict(system, stop=0.5)
    m = couple.Master(one["fmu_paths"], one["connections"], one.get("inputs"),
                      {n: s.get("start", {}) for n, s in one["fmus"].items()})
    with m:
        m.run(0.5, 0.5, "newton")
        gain = float(m.units["blower"].jacobian(["p"], ["V"])[0, 0] * m.units["cushion"].jacobian(["V"], ["p"])[0, 0])
    r = couple.run_system(one, "gs", 0.5, max_iterations=60)
    hist = np.array(r.records[1].history)
    ratio = np.median(hist[1:8] / hist[:7])
    assert ratio == pytest.approx(abs(gain), rel=1e-2)
    # below h = 0.2 s the gain passes 1: every attempt is rolled back and halved, then an error
    one = dict(system, stop=0.15)
    m = couple.Master(one["fmu_paths"], one["connections"], one.get("inputs"),
                      {n: s.get("start", {}) for n, s in one["fmus"].items()})
    with m:
        with pytest.raises(couple.CouplingError, match="no macro step down to"):
            m.run(0.15, 0.15, "gs", max_iterations=30, min_step=0.05)
        assert [round(h, 6) for _, h, _, _ in m.rejected] == [0.15, 0.075]
        first = m.rejected[0][3]
        assert first[-1] > first[0]  # the residual grew


def test_the_command_prints_iterations_and_the_difference(system):
    run = subprocess.run([sys.executable, "-m", "velarium.couple", str(SYSTEM), "--method", "newton",
                          "--build", str(Path(system["fmu_paths"]["cushion"]).parent)],
                         capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0].split()[:4] == ["time", "step", "iter", "residual"]
    last = lines[-1]
    assert last.startswith("difference to the monolithic answer")
    diffs = [float(w.rstrip(",")) for w in last.split(":")[1].split()[1::2]]
    assert len(diffs) == 3 and max(diffs) < 1e-9


def test_a_bad_system_file_names_the_field(tmp_path):
    bad = tmp_path / "s.json"
    bad.write_text('{"fmus": {"a": {"fmu": "x.fmu"}}, "connections": [], "stop": 1, "step": 1}')
    run = subprocess.run([sys.executable, "-m", "velarium.couple", str(bad)], capture_output=True, text=True)
    assert run.returncode == 1
    assert "fmus.a.fmu" in run.stderr or "fmus:" in run.stderr


def test_the_system_as_an_ssp_package(system, tmp_path):
    """The SSP 1.0 package (couple_ssp.py): valid against the SSP schema as fmpy's SSD reader
    checks it, and our master runs it to the same numbers, bit for bit, as the system file."""
    from fmpy.ssp.ssd import read_ssd

    from velarium import couple_ssp

    ssp = couple_ssp.write_ssp(system, tmp_path / "cushion_blower.ssp", "cushion_blower")
    ssd = read_ssd(str(ssp), validate=True)
    assert sorted(c.name for c in ssd.system.elements) == ["blower", "cushion"]
    # 2 links, 2 external inputs, 3 system outputs (the compared values)
    assert len(ssd.system.connections) == 7
    assert sorted(c.name for c in ssd.system.connectors if c.kind == "output") == ["blower_N", "cushion_V", "cushion_p"]
    back = couple.load_system(ssp)
    try:
        assert back["fmus"]["blower"]["start"]["V0"] > 0  # "cushion.V" resolved to its number
        a = couple.run_system(system, "newton")
        b = couple.run_system(back, "newton")
        for col in a.records[0].values:
            assert np.array_equal(a.column(col), b.column(col)), col
        assert a.iterations.tolist() == b.iterations.tolist()
        ref = couple.monolithic(back)
        d = couple.difference(b, ref, back["monolithic"]["compare"])
        assert all(v < 1e-9 for v in d.values()), d
    finally:
        couple_ssp.remove(back)


def test_blower_fmi3_archive(blower_fmu):
    """The FMI 3.0 archive (same library): fmpy validates it, simulates it to the FMI 2
    archive's numbers bit for bit, rolls a step back exactly, and its adjoint derivative is the
    transpose of its directional one (2 x 2, to round-off)."""
    import fmpy
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave
    from fmpy.validation import validate_fmu

    fmu3 = blower_fmu.with_name("Blower_fmi3.fmu")
    assert validate_fmu(str(fmu3)) == []
    kw = dict(stop_time=5, output_interval=0.5, start_values={"p0": 100.0})
    r2, r3 = fmpy.simulate_fmu(str(blower_fmu), **kw), fmpy.simulate_fmu(str(fmu3), **kw)
    for name in ("p", "N", "u"):
        assert np.array_equal(r2[name], r3[name])
    md = read_model_description(str(fmu3))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(fmu3)), modelIdentifier="Blower", instanceName="b3")
    s.instantiate()
    try:
        s.enterInitializationMode()
        s.setFloat64([vr["V0"], vr["p0"]], [0.7, 200.0])
        s.exitInitializationMode()
        s.setFloat64([vr["V"], vr["p_set"]], [0.71, 300.0])
        s.doStep(0.0, 0.5)
        state = s.getFMUState()
        s.doStep(0.5, 0.5)
        p1 = s.getFloat64([vr["p"]])[0]
        s.setFMUState(state)
        s.doStep(0.5, 0.5)
        assert s.getFloat64([vr["p"]])[0] == p1
        outs, ins = [vr["p"], vr["N"]], [vr["V"], vr["p_set"]]
        J = np.array([s.getDirectionalDerivative(outs, [k], [1.0]) for k in ins]).T
        w = np.array([0.3, -1.7])
        adj = np.array(s.getAdjointDerivative(outs, ins, list(w)))
        assert np.allclose(adj, J.T @ w, rtol=1e-14, atol=0)
        s.freeFMUState(state)
        s.terminate()
    finally:
        s.freeInstance()


# ----------------------------------------------------------------------------- other SSP tools

from fmpy.fmi1 import FMICallException  # noqa: E402 - the failure the xfails below pin

SSP_STEP = 1.0  # the macro step the other tools run the package at (weak Jacobi is stable there)


def _inputs_at_step_end(system, times):
    """The external inputs as the other tools set them: at the start of each step, the value of
    the step's end (our master's convention, docs/coupling.md), so the schemes match."""
    return {key.replace(".", "_"): [couple.table_function(tab, key)(t + SSP_STEP) for t in times]
            for key, tab in system["inputs"].items()}


def _run_omsimulator(ssp, system, tmp_path):
    oms = pytest.importorskip(
        "OMSimulator", reason="OMSimulator is not importable: its PyPI package (3.0.0.post198, and every older one) "
        "is an sdist whose build downloads the simulator from a host outside the package registries (measured "
        "2026-11-28), so it cannot be installed here")
    for name in ("importFile", "setTempDirectory"):
        if not hasattr(oms, name):
            pytest.skip(f"this OMSimulator has no {name}: its scripting API is not the one this test drives")
    oms.setTempDirectory(str(tmp_path / "oms"))
    model = oms.importFile(str(ssp))
    root = "cushion_blower"
    model.resultFile = ""
    model.stopTime = float(system["stop"])
    model.setFixedStepSize(root, SSP_STEP)
    model.instantiate()
    # the package's parameter bindings reach the blower
    starts = system["fmus"]["blower"]["start"]
    bound = {k: model.getReal(f"{root}.blower.{k}") for k in ("V0", "p0")}
    model.initialize()
    times = np.arange(0.0, float(system["stop"]), SSP_STEP)
    inputs = _inputs_at_step_end(system, times)
    rows = []
    for k, t in enumerate(times):
        for name, values in inputs.items():
            model.setReal(f"{root}.{name}", values[k])
        model.stepUntil(t + SSP_STEP)
        rows.append([model.getReal(f"{root}.{c}") for c in ("cushion_p", "cushion_V", "blower_N")])
    model.terminate()
    model.delete()
    return bound, starts, np.array(rows)


def _run_fmucontainer(ssp, system, tmp_path):
    import fmpy

    exe = Path(sys.executable).with_name("fmucontainer")
    if not exe.is_file():
        pytest.skip("fmucontainer (fmu-manipulation-toolbox) is not installed")
    build = subprocess.run([str(exe), "-container", f"{ssp.name}:{SSP_STEP}", "-fmu-directory", str(ssp.parent)],
                           capture_output=True, text=True, timeout=300, cwd=ssp.parent)
    assert build.returncode == 0, build.stdout + build.stderr
    times = np.arange(0.0, float(system["stop"]) + SSP_STEP / 2, SSP_STEP)
    inputs = _inputs_at_step_end(system, times)
    table = np.array(list(zip(times, *inputs.values())), dtype=[("time", float)] + [(n, float) for n in inputs])
    rows = fmpy.simulate_fmu(str(ssp.with_suffix(".fmu")), input=table, stop_time=float(system["stop"]),
                             step_size=SSP_STEP, output_interval=SSP_STEP)
    return None, None, np.array([[r["cushion_p"], r["cushion_V"], r["blower_N"]] for r in rows[1:]])


def _run_fmpy_ssp(ssp, system, tmp_path):
    from fmpy.ssp.simulation import simulate_ssp

    times = np.arange(0.0, float(system["stop"]), SSP_STEP)
    tables = {key.replace(".", "_"): couple.table_function(tab, key) for key, tab in system["inputs"].items()}
    rows = simulate_ssp(str(ssp), stop_time=float(system["stop"]), step_size=SSP_STEP,
                        input={n: (lambda t, f=f: f(t + SSP_STEP)) for n, f in tables.items()})
    assert len(rows) == len(times)
    return None, None, np.array([[r["cushion_p"], r["cushion_V"], r["blower_N"]] for r in rows])


@pytest.mark.parametrize("tool", [
    "OMSimulator",
    pytest.param("fmucontainer", marks=pytest.mark.xfail(
        strict=True, raises=FMICallException, reason="fmucontainer 2.0 starts its connections at 0 and sets them into the FMUs "
        "during initialization (its debug log): the cushion is given p = 0 and starts deflated, the blower then gives it "
        "62077 Pa, above its input's max 1500 Pa, and fmi2ExitInitializationMode fails; the same with the bound values "
        "written as the blower's own start values (measured)")),
    pytest.param("fmpy.ssp", marks=pytest.mark.xfail(
        strict=True, raises=FMICallException, reason="fmpy 0.3.32's simulate_ssp applies no component parameter bindings and "
        "starts every connector at 0: the blower rejects V = 0 at the first step (measured)")),
])
def test_the_ssp_package_in_a_second_tool(system, reference, tool, tmp_path):
    """Another SSP tool runs the package written by couple_ssp; its result (the compared values,
    system outputs of the package) against ours. These tools couple weakly (one pass per step,
    the previous step's outputs); our master measures that scheme's error (`jacobi`, weak, at
    the same step: up to 22 % in p at 1 s) and the strongly coupled answer. Reference and
    tolerance: the tool's answer must lie no further from the monolithic answer than 1.5 times
    the weak scheme's error plus 1e-6 (a tool that couples strongly is within 1e-9, one that
    couples weakly is at the weak error; a wrongly wired or wrongly started system is far
    outside); where the tool reports the blower's bound start values, they must equal the
    package's bit for bit."""
    from velarium import couple_ssp

    ssp = couple_ssp.write_ssp(system, tmp_path / "cushion_blower.ssp", "cushion_blower")
    run = {"OMSimulator": _run_omsimulator, "fmucontainer": _run_fmucontainer, "fmpy.ssp": _run_fmpy_ssp}[tool]
    bound, starts, rows = run(ssp, system, tmp_path)
    if bound is not None:
        assert bound == starts
    weak = couple.run_system(system, "jacobi", SSP_STEP, weak=True)
    strong = couple.run_system(system, "newton", SSP_STEP)
    ref = couple.monolithic(system, SSP_STEP)
    cols = ["cushion.p", "cushion.V", "blower.N"]
    assert rows.shape == (len(strong.records) - 1, 3)
    compare = system["monolithic"]["compare"]
    for j, col in enumerate(cols):
        exact = ref[compare[col]][1:]
        tool_error = np.max(np.abs(rows[:, j] - exact) / np.abs(exact))
        weak_error = np.max(np.abs(weak.column(col)[1:] - exact) / np.abs(exact))
        strong_error = np.max(np.abs(strong.column(col)[1:] - exact) / np.abs(exact))
        print(f"{tool} {col}: {tool_error:.3e} from the monolithic answer (ours: weak {weak_error:.3e}, "
              f"strong {strong_error:.3e})")
        assert tool_error <= 1.5 * weak_error + 1e-6, (col, tool_error, weak_error)


def test_an_ssp_package_of_fmi3_archives(system3, tmp_path):
    """write_ssp of the FMI 3 system: the package holds the FMI 3 archives, and our master runs
    it to the numbers of the FMI 3 system file, bit for bit."""
    from velarium import couple_ssp

    ssp = couple_ssp.write_ssp(system3, tmp_path / "cushion_blower_fmi3.ssp", "cushion_blower")
    back = couple.load_system(ssp)
    try:
        assert sorted(Path(p).name for p in back["fmu_paths"].values()) == ["Blower_fmi3.fmu", "CushionPressure_fmi3.fmu"]
        a, b = couple.run_system(system3, "newton"), couple.run_system(back, "newton")
        assert b.fmi == {"cushion": 3, "blower": 3}
        assert a.iterations.tolist() == b.iterations.tolist()
        for col in a.records[0].values:
            assert np.array_equal(a.column(col), b.column(col)), col
    finally:
        couple_ssp.remove(back)
