//! GOAL: the slip history (slips and stick/slip states) is part of the FMU state: get state,
//!       step, set state, step again gives bit-identical outputs (slips included), and a
//!       serialized state restored in a fresh process continues the run identically.
//! MESH: the shipped SlidingCable scene (seed Fig. 6) with μ = 0.25 (every node sticks up to
//!       P = 160 N; nodes 7 and 9 slip when P jumps from 24 to 200 N, then stick again: with
//!       the tethers gone, μ = 0.1-0.2 makes the sliding nodes run into node 8, which frictional
//!       sleeve points cannot do yet, docs/mechanics.md §2.3).
//! BOUNDARY CONDITIONS: as shipped.
//! PARAMETERS: P through 60, 160, 100, 24, 200, 120 N (load, unload, reload: stick and slip
//!       both occur); p = 20 N.
//! REFERENCE: FMI 2.0.4 §2.1.8 (get/set/serialize FMU state); docs/fmu.md "State" and docs/mechanics.md §5
//!       "FMI note": history variables must roll back with the state. Comparison: bit equality.

#![cfg(unix)]

use std::ffi::{c_int, CString};
use std::ptr::null_mut;
use velarium::fmi::{self, CallbackFunctions, Component, FmuState, Status};
use velarium::variables::{Causality, VarType};
use velarium::{Engine, Scene};

const OK: Status = Status::Ok;
const LOADS: [f64; 6] = [60.0, 160.0, 100.0, 24.0, 200.0, 120.0];

struct Fmu {
    c: Component,
    engine: Engine,
    _root: std::path::PathBuf,
}

impl Fmu {
    fn new(tag: &str) -> Fmu {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/modelDescription/SlidingCable");
        let text = std::fs::read_to_string(format!("{path}/scene.json")).unwrap();
        let mut scene = Scene::from_json(&text).unwrap();
        scene.cables[0].sleeve.as_mut().unwrap().mu = 0.25;
        let root =
            std::env::temp_dir().join(format!("velarium-sleeve-{tag}-{}", std::process::id()));
        let resources = root.join("resources");
        std::fs::create_dir_all(&resources).unwrap();
        std::fs::write(resources.join("scene.json"), scene.to_json()).unwrap();
        let engine = Engine::try_new(scene).unwrap();
        let guid = CString::new(velarium::description::guid(
            engine.scene(),
            engine.variables(),
        ))
        .unwrap();
        let uri = CString::new(format!("file://{}", resources.display())).unwrap();
        let cb = CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: null_mut(),
        };
        let c = unsafe {
            fmi::fmi2Instantiate(
                c"sleeve".as_ptr(),
                1,
                guid.as_ptr(),
                uri.as_ptr(),
                &cb,
                0,
                0,
            )
        };
        assert!(!c.is_null());
        Fmu {
            c,
            engine,
            _root: root,
        }
    }
    fn vr(&self, name: &str) -> u32 {
        self.engine
            .variables()
            .iter()
            .find(|v| v.name == name)
            .unwrap()
            .value_reference
    }
    fn init(&self) {
        unsafe {
            assert_eq!(fmi::fmi2SetupExperiment(self.c, 0, 0.0, 0.0, 1, 1.0), OK);
            assert_eq!(fmi::fmi2EnterInitializationMode(self.c), OK);
            let (vr, p) = (self.vr("p"), 20.0);
            assert_eq!(fmi::fmi2SetReal(self.c, &vr, 1, &p), OK);
            assert_eq!(fmi::fmi2ExitInitializationMode(self.c), OK);
        }
    }
    fn load_step(&self, k: usize) {
        let vr = self.vr("P");
        unsafe {
            assert_eq!(fmi::fmi2SetReal(self.c, &vr, 1, &LOADS[k]), OK);
            assert_eq!(
                fmi::fmi2DoStep(self.c, k as f64 * 0.1, 0.1, 1),
                OK,
                "step {k}"
            );
        }
    }
    /// Every Real and Integer output as bits.
    fn outputs(&self) -> Vec<u64> {
        self.engine
            .variables()
            .iter()
            .filter(|v| v.causality == Causality::Output)
            .map(|v| unsafe {
                match v.var_type {
                    VarType::Real => {
                        let mut x = f64::NAN;
                        assert_eq!(fmi::fmi2GetReal(self.c, &v.value_reference, 1, &mut x), OK);
                        x.to_bits()
                    }
                    VarType::Integer | VarType::UInt8 => {
                        let mut i: c_int = -1;
                        assert_eq!(
                            fmi::fmi2GetInteger(self.c, &v.value_reference, 1, &mut i),
                            OK
                        );
                        i as u64
                    }
                }
            })
            .collect()
    }
    fn serialize(&self) -> Vec<u8> {
        let (mut state, mut size): (FmuState, usize) = (null_mut(), 0);
        unsafe {
            assert_eq!(fmi::fmi2GetFMUstate(self.c, &mut state), OK);
            assert_eq!(
                fmi::fmi2SerializedFMUstateSize(self.c, state, &mut size),
                OK
            );
            let mut bytes = vec![0u8; size];
            assert_eq!(
                fmi::fmi2SerializeFMUstate(self.c, state, bytes.as_mut_ptr().cast(), size),
                OK
            );
            assert_eq!(fmi::fmi2FreeFMUstate(self.c, &mut state), OK);
            bytes
        }
    }
    fn restore(&self, bytes: &[u8]) {
        let mut state: FmuState = null_mut();
        unsafe {
            assert_eq!(
                fmi::fmi2DeSerializeFMUstate(
                    self.c,
                    bytes.as_ptr().cast(),
                    bytes.len(),
                    &mut state
                ),
                OK
            );
            assert_eq!(fmi::fmi2SetFMUstate(self.c, state), OK);
            assert_eq!(fmi::fmi2FreeFMUstate(self.c, &mut state), OK);
        }
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi::fmi2FreeInstance(self.c) };
        let _ = std::fs::remove_dir_all(&self._root);
    }
}

fn counts(f: &Fmu) -> (i32, i32) {
    let get = |n: &str| {
        let (vr, mut i) = (f.vr(n), -1);
        unsafe { assert_eq!(fmi::fmi2GetInteger(f.c, &vr, 1, &mut i), OK) };
        i
    };
    (get("sticking"), get("slipping"))
}

fn slips(f: &Fmu) -> [u64; 3] {
    ["slip7", "slip8", "slip9"].map(|n| {
        let (vr, mut x) = (f.vr(n), f64::NAN);
        unsafe { assert_eq!(fmi::fmi2GetReal(f.c, &vr, 1, &mut x), OK) };
        x.to_bits()
    })
}

#[test]
fn get_step_set_step_is_bit_identical_with_slip() {
    let f = Fmu::new("getset");
    f.init();
    let mut seen = Vec::new();
    for k in 0..3 {
        f.load_step(k);
        seen.push(counts(&f));
    }
    let mut state: FmuState = null_mut();
    unsafe { assert_eq!(fmi::fmi2GetFMUstate(f.c, &mut state), OK) };
    f.load_step(3);
    seen.push(counts(&f));
    f.load_step(4);
    seen.push(counts(&f));
    println!("(sticking, slipping) per step: {seen:?}");
    assert!(
        seen.iter().any(|c| c.0 > 0) && seen.iter().any(|c| c.1 > 0),
        "both stick and slip occur"
    );
    let first = (f.outputs(), slips(&f));
    assert!(
        slips(&f).iter().any(|&b| f64::from_bits(b) != 0.0),
        "the run slips"
    );
    unsafe { assert_eq!(fmi::fmi2SetFMUstate(f.c, state), OK) };
    f.load_step(3);
    f.load_step(4);
    assert_eq!((f.outputs(), slips(&f)), first);
    unsafe { assert_eq!(fmi::fmi2FreeFMUstate(f.c, &mut state), OK) };
}

/// Environment variable that turns `child_continues_from_file` into the fresh process's run.
const CHILD: &str = "VELARIUM_SLEEVE_STATE_FILE";

#[test]
fn serialized_state_continues_identically_in_a_fresh_process() {
    let f = Fmu::new("parent");
    f.init();
    for k in 0..3 {
        f.load_step(k);
    }
    let file = std::env::temp_dir().join(format!("velarium-sleeve-state-{}", std::process::id()));
    std::fs::write(&file, f.serialize()).unwrap();
    for k in 3..6 {
        f.load_step(k);
    }
    let expected: Vec<String> = f.outputs().iter().map(|b| b.to_string()).collect();
    // libtest's name of the child test: this module's path without the crate's (the binary's).
    let child = format!(
        "{}::child_continues_from_file",
        module_path!().split_once("::").unwrap().1
    );
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", child.as_str(), "--nocapture", "--test-threads=1"])
        .env(CHILD, &file)
        .output()
        .unwrap();
    let _ = std::fs::remove_file(&file);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout
        .lines()
        .find_map(|l| l.split_once("OUTPUTS ").map(|(_, rest)| rest))
        .unwrap_or_else(|| {
            panic!(
                "child printed no outputs: {stdout}\n{}",
                String::from_utf8_lossy(&out.stderr)
            )
        });
    assert_eq!(line, expected.join(","));
}

/// Runs only as the child of the test above (in a fresh process): restore and continue.
#[test]
fn child_continues_from_file() {
    let Ok(file) = std::env::var(CHILD) else {
        return;
    };
    let bytes = std::fs::read(file).unwrap();
    let f = Fmu::new("child");
    f.restore(&bytes);
    for k in 3..6 {
        f.load_step(k);
    }
    let outputs: Vec<String> = f.outputs().iter().map(|b| b.to_string()).collect();
    println!("OUTPUTS {}", outputs.join(","));
}
