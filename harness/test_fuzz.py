"""Issue 11, item 6: mutation fuzzers with a fixed seed.

SCENES: every shipped scene is mutated (a leaf replaced by a hostile value, a key removed,
renamed or given twice, a list emptied, the text truncated, a byte-order mark or an invalid
byte inserted). `velarium check` must exit 0, or exit 1 with a located message in the scene's
words (no Rust/serde type names, no line over 1000 characters); a mutant that passes check and
has at most 20,000 unknowns is solved on a two-row load table and must exit 0 with finite
numbers or exit 1 with a message. Never a panic (101), an abort (134/-6) or a time-out.

STATES: a serialized FMU state of PrestressedCable is mutated (bytes flipped, f64 values
overwritten with NaN/inf/1e308/-1e308/huge, codes set to 3/7/255, truncated), resealed with a
recomputed checksum for most mutants, deserialized, set and stepped through fmpy in a
subprocess: each mutant ends in fmi2Error at DeSerialize/SetFMUstate, or in a step whose
outputs are all finite (or a Discard); the subprocess must exit normally.

CI runs VELARIUM_FUZZ_MUTANTS=400 scene mutants (default) and VELARIUM_FUZZ_STATES=1000 state
mutants; set them higher for a longer local run (e.g. 5000). Seed: VELARIUM_FUZZ_SEED (11).
"""
import json
import math
import os
import random
import subprocess
import time

import fmi_support as fs
import velarium_run as vr

SEED = int(os.environ.get("VELARIUM_FUZZ_SEED", "11"))
SCENE_MUTANTS = int(os.environ.get("VELARIUM_FUZZ_MUTANTS", "400"))
STATE_MUTANTS = int(os.environ.get("VELARIUM_FUZZ_STATES", "1000"))
SOLVE_UNKNOWNS = 20_000
SERDE_WORDS = ["usize", "u32", "f64", "untagged", "internally tagged", "NodeRef", "OneNode",
               "TriangleRef", "enum ", "struct ", "a sequence", "panicked", "RUST_BACKTRACE"]
HOSTILE = [0, -1, 1, 1e308, -1e308, 1e-308, 1e-150, 1e17, 1e19, 100000, 3000, 1.6e-11, 0.5,
           2**64, -2**63, "x", "", "midspan", "disc.rim", [], {}, None, True, [1, 2], [0, 0, 0],
           "x" * 5000, {"kind": "disc"}, [1e308, 0, 0]]


def leaves(obj, path=()):
    """Every (path, value) of a JSON document, containers included."""
    yield path, obj
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from leaves(v, path + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from leaves(v, path + (i,))


def at(obj, path):
    for p in path:
        obj = obj[p]
    return obj


def mutate(text: str, rng: random.Random) -> bytes:
    doc = json.loads(text)
    kind = rng.choice(["replace", "replace", "replace", "delete", "rename", "duplicate",
                       "empty", "truncate", "bom", "badbyte"])
    if kind == "truncate":
        return text.encode()[: rng.randrange(len(text))]
    if kind == "bom":
        return b"\xef\xbb\xbf" + text.encode()
    if kind == "badbyte":
        raw = bytearray(text.encode())
        raw.insert(rng.randrange(len(raw)), rng.choice([0xFF, 0xC0, 0x80, 0xE9]))
        return bytes(raw)
    paths = [p for p, _ in leaves(doc) if p]
    path = rng.choice(paths)
    parent, key = at(doc, path[:-1]), path[-1]
    if kind == "replace":
        parent[key] = rng.choice(HOSTILE)
    elif kind == "delete":
        del parent[key]
    elif kind == "empty":
        parent[key] = [] if isinstance(parent[key], list) else {}
    elif kind == "rename" and isinstance(parent, dict):
        parent[key + rng.choice(["s", "_", "X"])] = parent.pop(key)
    elif kind == "duplicate" and isinstance(parent, dict):
        # Write the object with `key` twice: the second value a hostile one.
        value = json.dumps(rng.choice(HOSTILE))
        marker = "\u0000DUP\u0000"
        parent[marker] = None
        out = json.dumps(doc)
        return out.replace(json.dumps(marker) + ": null", f"{json.dumps(key)}: {value}").encode()
    return json.dumps(doc).encode()


def run(args, timeout):
    start = time.perf_counter()
    try:
        r = subprocess.run([str(vr.VELARIUM), *args], capture_output=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise AssertionError(f"velarium {args} timed out after {timeout} s")
    return r, time.perf_counter() - start


def load_table(scene: dict) -> str:
    """Two rows: the start values, then each input moved towards its max (or by 1)."""
    ins = [i for i in scene.get("inputs", []) if isinstance(i, dict) and isinstance(i.get("name"), str)]
    head = ["time"] + [i["name"] for i in ins]
    start = [float(i.get("start", 0) or 0) if isinstance(i.get("start", 0), (int, float)) else 0.0 for i in ins]
    nxt = [min(s + 1.0, float(i["max"])) if isinstance(i.get("max"), (int, float)) else s + 1.0
           for s, i in zip(start, ins)]
    return "\n".join([",".join(head), ",".join(["0"] + [repr(x) for x in start]),
                      ",".join(["1"] + [repr(x) for x in nxt])]) + "\n"


def test_scene_mutants_never_crash(tmp_path):
    assert vr.VELARIUM.exists(), "run `cargo build --release`"
    rng = random.Random(SEED)
    scenes = {m: (vr.SCENES / m / "scene.json").read_text() for m in vr.shipped_models()}
    counts = {"rejected": 0, "ok": 0, "solved": 0, "not converged": 0}
    t0 = time.perf_counter()
    slowest = 0.0
    for k in range(SCENE_MUTANTS):
        model = rng.choice(sorted(scenes))
        mutant = mutate(scenes[model], rng)
        path = tmp_path / f"m{k}.json"
        path.write_bytes(mutant)
        r, dt = run(["check", str(path)], timeout=30)
        slowest = max(slowest, dt)
        out = (r.stdout + r.stderr).decode("utf-8", "replace")
        where = f"mutant {k} of {model} (seed {SEED}): {out[:2000]}"
        assert r.returncode in (0, 1), where
        for w in SERDE_WORDS:
            assert w not in out, f"{w!r} in {where}"
        assert all(len(line) <= 1000 for line in out.splitlines()), where
        if r.returncode == 1:
            counts["rejected"] += 1
            assert r.stdout.strip(), f"no located problem on stdout: {where}"
            continue
        counts["ok"] += 1
        unknowns = int(out.split(" unknowns")[0].rsplit(" ", 1)[-1])
        if unknowns > SOLVE_UNKNOWNS:
            continue
        try:
            doc = json.loads(mutant.decode("utf-8-sig"))
        except ValueError:
            continue
        loads = tmp_path / f"m{k}.csv"
        loads.write_text(load_table(doc))
        r, dt = run(["solve", str(path), "--loads", str(loads)], timeout=120)
        out = (r.stdout + r.stderr).decode("utf-8", "replace")
        assert r.returncode in (0, 1), f"solve: {where}\n{out[:2000]}"
        rows = [line.split(",") for line in r.stdout.decode().splitlines()[1:]]
        for row in rows:
            assert all(math.isfinite(float(x)) for x in row), f"non-finite output: {where}\n{out[:2000]}"
        counts["solved" if r.returncode == 0 else "not converged"] += 1
    total = time.perf_counter() - t0
    print(f"\nscene fuzzer: {SCENE_MUTANTS} mutants (seed {SEED}) in {total:.1f} s, slowest check "
          f"{slowest:.3f} s: {counts}")
    assert counts["rejected"] > 0 and counts["ok"] > 0


STATE_SCRIPT = r"""
import json, math, random, sys
import fmpy
from fmpy.fmi1 import FMICallException
import fmi_support as fs
unzipdir, n, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
md = fmpy.read_model_description(unzipdir)
refs = fs.real_output_refs(md)
rng = random.Random(seed)
SPECIAL = [float("nan"), float("inf"), -float("inf"), 1e308, -1e308, 1e30, 5e-324, -0.0, 2.0**60]

def fnv(b):
    h = 0xcbf29ce484222325
    for x in b:
        h = ((h ^ x) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h

with fs.slave(unzipdir, md) as s:
    fs.initialize(s, md, stop=1e6)
    s.setReal([fs.vref(md, "P")], [200.0])
    s.doStep(0.0, 0.1)
    good = s.getFMUstate()
    data = bytes(s.serializeFMUstate(good))
    glen = int.from_bytes(data[12:16], "little")
    payload = 24 + glen
    counts = {}
    for k in range(n):
        b = bytearray(data)
        kind = rng.choice(["f64", "f64", "f64", "byte", "code", "truncate", "noreseal"])
        if kind == "f64":
            # The payload (postcard) opens with the displacement's length, one varint byte
            # here, then its f64s: offsets 8 apart from there land on whole f64 values.
            at = payload + 1 + 8 * rng.randrange((len(b) - 9 - payload) // 8)
            b[at:at + 8] = __import__("struct").pack("<d", rng.choice(SPECIAL))
        elif kind in ("byte", "noreseal"):
            at = rng.randrange(len(b) - 8)
            b[at] ^= 1 << rng.randrange(8)
        elif kind == "code":
            at = rng.randrange(payload, len(b) - 8)
            b[at] = rng.choice([3, 7, 255])
        else:
            b = b[:rng.randrange(len(b))]
        if kind not in ("noreseal", "truncate") and len(b) > 8:
            b[-8:] = fnv(bytes(b[:-8])).to_bytes(8, "little")
        s.setFMUstate(good)
        try:
            st = s.deSerializeFMUstate(bytes(b))
        except FMICallException:
            counts["deserialize error"] = counts.get("deserialize error", 0) + 1
            continue
        try:
            s.setFMUstate(st)
        except FMICallException:
            counts["set error"] = counts.get("set error", 0) + 1
            s.freeFMUstate(st)
            continue
        s.freeFMUstate(st)
        try:
            values = s.getReal(refs)
        except FMICallException:
            # A state in which outputs cannot be read (e.g. a saved state machine state of
            # Instantiated or Error): the call is refused, as FMI requires.
            counts["get error"] = counts.get("get error", 0) + 1
            continue
        if not all(math.isfinite(v) for v in values):
            print(json.dumps({"mutant": k, "kind": kind, "bad": "non-finite outputs after set", "values": values}))
            sys.exit(3)
        try:
            s.setReal([fs.vref(md, "P")], [250.0])
            s.doStep(0.1, 0.1)
            values = s.getReal(refs)
            if not all(math.isfinite(v) for v in values):
                print(json.dumps({"mutant": k, "kind": kind, "bad": "non-finite outputs after step", "values": values}))
                sys.exit(3)
            counts["stepped"] = counts.get("stepped", 0) + 1
        except FMICallException:
            counts["step error or discard"] = counts.get("step error or discard", 0) + 1
    s.freeFMUstate(good)
    print(json.dumps(counts))
"""


def test_state_mutants_end_in_error_or_finite_outputs(extract_root, tmp_path):
    fmu = vr.FMU_DIR / "PrestressedCable.fmu"
    assert fmu.exists(), "run `bash .ci/run` (packs build/fmus)"
    unzipdir = fs.extracted(fmu, extract_root)
    t0 = time.perf_counter()
    run = fs.run_python(STATE_SCRIPT, str(unzipdir), str(STATE_MUTANTS), str(SEED), timeout=600)
    assert run.returncode == 0, f"state fuzzer (seed {SEED}) exit {run.returncode}:\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"
    counts = json.loads(run.stdout.strip().splitlines()[-1])
    print(f"\nstate fuzzer: {STATE_MUTANTS} mutants (seed {SEED}) in {time.perf_counter() - t0:.1f} s: {counts}")
    assert sum(counts.values()) == STATE_MUTANTS
    assert counts.get("set error", 0) > 0, counts
