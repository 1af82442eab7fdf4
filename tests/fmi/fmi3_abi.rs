//! The FMI 3.0 Co-Simulation C ABI, tested from inside: the `extern "C"` `fmi3*` functions
//! called through the rlib as a master calls them (the FMI 3.0 standard and checklist items 37,
//! 52-55; `harness/test_fmi3.py` drives the packed FMI 3 archive through fmpy from outside).
//!
//! SCENE: `modelDescription/PrestressedCable/scene.json` (input `P`, fixed parameter `EA`,
//! tunable `pretension`, Real outputs and the Integer output `newton_iterations`), written into
//! a temporary resources directory per test. The FMI 3 resource path is a native path with a
//! trailing separator.
//!
//! REFERENCE: the FMI 2 functions of the same library on the same scene. Both versions drive the
//! same engine with the same f64 inputs, so every comparison below is bit-identical; a
//! difference would be a defect of the FMI 3 layer, not round-off.

use std::ffi::{c_char, c_void, CStr, CString};
use std::path::PathBuf;
use std::ptr::{null, null_mut};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use velarium::fmi::{self, Component, FmuState, Status};
use velarium::variables::{Causality, VarType};
use velarium::{Engine, Scene};

const OK: Status = Status::Ok;
const ERROR: Status = Status::Error;
const DISCARD: Status = Status::Discard;

fn scene_text() -> String {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/modelDescription/PrestressedCable/scene.json"
    );
    std::fs::read_to_string(path).expect("the shipped PrestressedCable scene")
}

fn with_solver(solver: &str) -> String {
    let mut scene: serde_json::Value = serde_json::from_str(&scene_text()).unwrap();
    scene["solver"] = serde_json::from_str(solver).unwrap();
    scene.to_string()
}

/// One Newton iteration per increment and no cut-back: a DoStep with a real load change does
/// not converge (a genuine non-convergence of the engine, not a debug switch).
fn fragile_scene_text() -> String {
    with_solver(r#"{"max_iterations": 1, "initial_increment": 1.0, "min_increment": 0.5}"#)
}

/// The scene with debug switches, each also a tunable parameter `debug_<field>`.
fn debug_scene_text(switches: &[(&str, f64)]) -> String {
    let mut scene: serde_json::Value = serde_json::from_str(&scene_text()).unwrap();
    let mut debug = serde_json::Map::new();
    for (field, value) in switches {
        debug.insert(field.to_string(), serde_json::json!(value));
        let parameter = serde_json::json!({"name": format!("debug_{field}"),
            "target": format!("debug.{field}"), "variability": "tunable"});
        scene["parameters"].as_array_mut().unwrap().push(parameter);
    }
    scene["debug"] = serde_json::Value::Object(debug);
    scene.to_string()
}

fn load(k: usize) -> f64 {
    [150.0, 400.0, 800.0, 500.0, 200.0, 50.0][k % 6]
}

// ---------------------------------------------------------------------------------------------
// Fixture: resources directory, native path, FMI 3 token, FMI 2 GUID and URI.

static COUNTER: AtomicUsize = AtomicUsize::new(0);

struct Fixture {
    root: PathBuf,
    path: CString,
    uri: CString,
    token: CString,
    guid: CString,
    engine: Engine,
}

impl Fixture {
    fn new(dir_name: &str, scene: &str) -> Fixture {
        let n = COUNTER.fetch_add(1, Ordering::SeqCst);
        let root = std::env::temp_dir().join(format!("{dir_name}-{}-{n}", std::process::id()));
        let resources = root.join("resources dir ä");
        std::fs::create_dir_all(&resources).unwrap();
        std::fs::write(resources.join("scene.json"), scene).unwrap();
        let engine = Engine::try_new(Scene::from_json(scene).unwrap()).unwrap();
        let token = CString::new(velarium::description3::instantiation_token(
            engine.scene(),
            engine.arrays(),
        ))
        .unwrap();
        let guid = CString::new(velarium::description::guid(
            engine.scene(),
            engine.variables(),
        ))
        .unwrap();
        let path = CString::new(format!("{}/", resources.display())).unwrap();
        let uri = CString::new(file_uri(&resources)).unwrap();
        Fixture {
            root,
            path,
            uri,
            token,
            guid,
            engine,
        }
    }

    fn standard() -> Fixture {
        Fixture::new("velarium-fmi3", &scene_text())
    }

    fn vr(&self, name: &str) -> u32 {
        let var = self.engine.variables().iter().find(|v| v.name == name);
        var.unwrap_or_else(|| panic!("no variable {name}"))
            .value_reference
    }

    fn real_outputs(&self) -> Vec<u32> {
        self.engine
            .variables()
            .iter()
            .filter(|v| v.causality == Causality::Output && v.var_type == VarType::Real)
            .map(|v| v.value_reference)
            .collect()
    }

    fn integer_outputs(&self) -> Vec<u32> {
        self.engine
            .variables()
            .iter()
            .filter(|v| v.causality == Causality::Output && v.var_type == VarType::Integer)
            .map(|v| v.value_reference)
            .collect()
    }

    fn fmu<'a>(&'a self, log: &'a Log, logging_on: bool) -> Fmu3<'a> {
        let c = instantiate(&self.token, &self.path, log, logging_on, false);
        assert!(!c.is_null(), "instantiation failed: {:?}", log.messages());
        Fmu3 { c, fx: self }
    }
}

impl Drop for Fixture {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

fn file_uri(path: &std::path::Path) -> String {
    use std::os::unix::ffi::OsStrExt;
    let mut uri = String::from("file://");
    for &b in path.as_os_str().as_bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            uri.push(b as char);
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    uri
}

fn instantiate(
    token: &CStr,
    path: &CStr,
    log: &Log,
    logging_on: bool,
    event_mode_used: bool,
) -> Component {
    unsafe {
        fmi::fmi3InstantiateCoSimulation(
            c"inst3".as_ptr(),
            token.as_ptr(),
            path.as_ptr(),
            false,
            logging_on,
            event_mode_used,
            false,
            null(),
            0,
            log.env(),
            Some(capture),
            None,
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Capturing FMI 3 logger (not variadic: the message arrives formatted).

#[derive(Clone, Debug)]
struct Record {
    status: Status,
    category: String,
    message: String,
}

#[derive(Default)]
struct Log(Mutex<Vec<Record>>);

unsafe extern "C" fn capture(
    env: *mut c_void,
    status: Status,
    category: *const c_char,
    message: *const c_char,
) {
    let text = |p: *const c_char| CStr::from_ptr(p).to_str().expect("UTF-8").to_string();
    let log = &*(env as *const Log);
    log.0.lock().unwrap().push(Record {
        status,
        category: text(category),
        message: text(message),
    });
}

impl Log {
    fn env(&self) -> *mut c_void {
        self as *const Log as *mut c_void
    }
    fn records(&self) -> Vec<Record> {
        self.0.lock().unwrap().clone()
    }
    fn messages(&self) -> Vec<String> {
        self.records().into_iter().map(|r| r.message).collect()
    }
    fn clear(&self) {
        self.0.lock().unwrap().clear();
    }
    fn expect(&self, needle: &str) {
        let messages = self.messages();
        assert!(
            messages.iter().any(|m| m.contains(needle)),
            "{needle:?} not in {messages:?}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// An FMI 3 instance, freed on drop.

struct Fmu3<'a> {
    c: Component,
    fx: &'a Fixture,
}

impl Drop for Fmu3<'_> {
    fn drop(&mut self) {
        unsafe { fmi::fmi3FreeInstance(self.c) };
    }
}

/// What fmi3DoStep wrote.
#[derive(Debug, PartialEq)]
struct StepOut {
    event: bool,
    terminate: bool,
    early: bool,
    last: f64,
}

impl Fmu3<'_> {
    fn enter(&self, start: f64, stop: f64) -> Status {
        unsafe { fmi::fmi3EnterInitializationMode(self.c, false, 0.0, start, true, stop) }
    }
    fn exit(&self) -> Status {
        unsafe { fmi::fmi3ExitInitializationMode(self.c) }
    }
    fn init(&self, start: f64, stop: f64) {
        assert_eq!([self.enter(start, stop), self.exit()], [OK; 2]);
    }
    fn set(&self, name: &str, value: f64) -> Status {
        let vr = self.fx.vr(name);
        unsafe { fmi::fmi3SetFloat64(self.c, &vr, 1, &value, 1) }
    }
    fn get_vr(&self, vr: u32) -> Result<f64, Status> {
        let mut value = f64::NAN;
        match unsafe { fmi::fmi3GetFloat64(self.c, &vr, 1, &mut value, 1) } {
            OK => Ok(value),
            status => Err(status),
        }
    }
    fn time(&self) -> f64 {
        self.get_vr(fmi::TIME_VALUE_REFERENCE).expect("time")
    }
    fn step(&self, t: f64, h: f64) -> (Status, StepOut) {
        let mut out = StepOut {
            event: true,
            terminate: true,
            early: true,
            last: f64::NAN,
        };
        let status = unsafe {
            fmi::fmi3DoStep(
                self.c,
                t,
                h,
                true,
                &mut out.event,
                &mut out.terminate,
                &mut out.early,
                &mut out.last,
            )
        };
        (status, out)
    }
    /// Every Real output as bits, then every Integer output.
    fn outputs(&self) -> (Vec<u64>, Vec<i32>) {
        let vr = self.fx.real_outputs();
        let mut reals = vec![0.0; vr.len()];
        let status = unsafe {
            fmi::fmi3GetFloat64(self.c, vr.as_ptr(), vr.len(), reals.as_mut_ptr(), vr.len())
        };
        assert_eq!(status, OK);
        let ivr = self.fx.integer_outputs();
        let mut ints = vec![0; ivr.len()];
        let status = unsafe {
            fmi::fmi3GetInt32(
                self.c,
                ivr.as_ptr(),
                ivr.len(),
                ints.as_mut_ptr(),
                ivr.len(),
            )
        };
        assert_eq!(status, OK);
        (reals.iter().map(|v| v.to_bits()).collect(), ints)
    }
    fn get_state(&self, state: &mut FmuState) -> Status {
        unsafe { fmi::fmi3GetFMUState(self.c, state) }
    }
    fn set_state(&self, state: FmuState) -> Status {
        unsafe { fmi::fmi3SetFMUState(self.c, state) }
    }
    fn free_state(&self, state: &mut FmuState) -> Status {
        unsafe { fmi::fmi3FreeFMUState(self.c, state) }
    }
    fn serialize(&self) -> Vec<u8> {
        let (mut state, mut size) = (null_mut(), 0usize);
        assert_eq!(self.get_state(&mut state), OK);
        unsafe {
            assert_eq!(
                fmi::fmi3SerializedFMUStateSize(self.c, state, &mut size),
                OK
            );
            let mut bytes = vec![0u8; size];
            assert_eq!(
                fmi::fmi3SerializeFMUState(self.c, state, bytes.as_mut_ptr(), size - 1),
                ERROR
            );
            assert_eq!(
                fmi::fmi3SerializeFMUState(self.c, state, bytes.as_mut_ptr(), size),
                OK
            );
            assert_eq!(self.free_state(&mut state), OK);
            bytes
        }
    }
    fn restore(&self, bytes: &[u8]) -> Status {
        let mut state: FmuState = null_mut();
        let status = unsafe {
            fmi::fmi3DeserializeFMUState(self.c, bytes.as_ptr(), bytes.len(), &mut state)
        };
        if status != OK {
            return status;
        }
        let status = self.set_state(state);
        assert_eq!(self.free_state(&mut state), OK);
        status
    }
}

/// The FMI 2 reference run: outputs after initialization and after each of `steps` load steps.
fn fmi2_run(fx: &Fixture, steps: usize) -> Vec<(Vec<u64>, Vec<i32>)> {
    let cb = fmi::CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: null_mut(),
    };
    let c = unsafe {
        fmi::fmi2Instantiate(
            c"ref".as_ptr(),
            1,
            fx.guid.as_ptr(),
            fx.uri.as_ptr(),
            &cb,
            0,
            0,
        )
    };
    assert!(!c.is_null());
    let outputs = || {
        let vr = fx.real_outputs();
        let mut reals = vec![0.0; vr.len()];
        assert_eq!(
            unsafe { fmi::fmi2GetReal(c, vr.as_ptr(), vr.len(), reals.as_mut_ptr()) },
            OK
        );
        let ivr = fx.integer_outputs();
        let mut ints = vec![0; ivr.len()];
        assert_eq!(
            unsafe { fmi::fmi2GetInteger(c, ivr.as_ptr(), ivr.len(), ints.as_mut_ptr()) },
            OK
        );
        (
            reals.iter().map(|v| v.to_bits()).collect::<Vec<u64>>(),
            ints,
        )
    };
    let mut rows = Vec::new();
    unsafe {
        assert_eq!(fmi::fmi2SetupExperiment(c, 0, 0.0, 0.0, 1, 1.0), OK);
        assert_eq!(fmi::fmi2EnterInitializationMode(c), OK);
        assert_eq!(fmi::fmi2ExitInitializationMode(c), OK);
        rows.push(outputs());
        let p = fx.vr("P");
        for k in 0..steps {
            assert_eq!(fmi::fmi2SetReal(c, &p, 1, &load(k)), OK);
            assert_eq!(fmi::fmi2DoStep(c, k as f64 * 0.1, 0.1, 1), OK);
            rows.push(outputs());
        }
        fmi::fmi2FreeInstance(c);
    }
    rows
}

// ---------------------------------------------------------------------------------------------
// Version and instantiation (items 54, 55).

#[test]
fn version_is_3_0() {
    let version = unsafe { CStr::from_ptr(fmi::fmi3GetVersion()) };
    assert_eq!(version.to_str().unwrap(), "3.0");
}

#[test]
fn wrong_token_event_mode_and_other_interface_types_give_null_with_a_message() {
    let fx = Fixture::standard();
    let log = Log::default();
    assert!(instantiate(c"{not-the-token}", &fx.path, &log, false, false).is_null());
    let records = log.records();
    assert_eq!(records.len(), 1, "{records:?}");
    let token = fx.token.to_str().unwrap();
    assert!(
        records[0].message.contains("{not-the-token}") && records[0].message.contains(token),
        "{records:?}"
    );
    assert_eq!(
        (records[0].status, records[0].category.as_str()),
        (ERROR, "logStatusError")
    );
    assert!(records[0]
        .message
        .starts_with("fmi3InstantiateCoSimulation: "));

    // The FMI 2 GUID is not the FMI 3 token.
    log.clear();
    assert!(instantiate(&fx.guid, &fx.path, &log, false, false).is_null());
    log.expect("instantiationToken mismatch");

    // Item 54: eventModeUsed = true with hasEventMode = false -> NULL and a message.
    log.clear();
    assert!(instantiate(&fx.token, &fx.path, &log, false, true).is_null());
    log.expect("eventModeUsed = true");

    // A URI is not a native path.
    log.clear();
    assert!(instantiate(&fx.token, &fx.uri, &log, false, false).is_null());
    log.expect("cannot read");

    log.clear();
    unsafe {
        let me = fmi::fmi3InstantiateModelExchange(
            c"me".as_ptr(),
            fx.token.as_ptr(),
            fx.path.as_ptr(),
            false,
            false,
            log.env(),
            Some(capture),
        );
        assert!(me.is_null());
        let se = fmi::fmi3InstantiateScheduledExecution(
            c"se".as_ptr(),
            fx.token.as_ptr(),
            fx.path.as_ptr(),
            false,
            false,
            log.env(),
            Some(capture),
            None,
            None,
            None,
        );
        assert!(se.is_null());
        // Empty and NULL instance names, NULL resource path, NULL logger: NULL, no crash.
        for (name, path) in [
            (c"".as_ptr(), fx.path.as_ptr()),
            (null(), fx.path.as_ptr()),
            (c"x".as_ptr(), null()),
        ] {
            let c = fmi::fmi3InstantiateCoSimulation(
                name,
                fx.token.as_ptr(),
                path,
                false,
                false,
                false,
                false,
                null(),
                0,
                log.env(),
                Some(capture),
                None,
            );
            assert!(c.is_null());
        }
        let c = fmi::fmi3InstantiateCoSimulation(
            c"".as_ptr(),
            fx.token.as_ptr(),
            fx.path.as_ptr(),
            false,
            true,
            false,
            false,
            null(),
            0,
            null_mut(),
            None,
            None,
        );
        assert!(c.is_null());
    }
    let messages = log.messages();
    assert_eq!(messages.len(), 5, "{messages:?}");
    assert!(
        messages[0].starts_with("fmi3InstantiateModelExchange: "),
        "{messages:?}"
    );
    assert!(
        messages[1].starts_with("fmi3InstantiateScheduledExecution: "),
        "{messages:?}"
    );
    assert!(
        messages[2].contains("instanceName is empty"),
        "{messages:?}"
    );
    assert!(messages[3].contains("instanceName is NULL"), "{messages:?}");
    assert!(messages[4].contains("resourcePath is NULL"), "{messages:?}");
}

// ---------------------------------------------------------------------------------------------
// The numbers: FMI 3 equals FMI 2 bit for bit (item 53 from inside).

#[test]
fn a_load_history_gives_the_fmi2_numbers_and_the_step_outputs_are_set() {
    let fx = Fixture::standard();
    let reference = fmi2_run(&fx, 6);
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.time(), 0.0);
    let mut rows = vec![fmu.outputs()];
    for k in 0..6 {
        let t = k as f64 * 0.1;
        assert_eq!(fmu.set("P", load(k)), OK);
        let (status, out) = fmu.step(t, 0.1);
        assert_eq!(status, OK, "{:?}", log.messages());
        let expected = StepOut {
            event: false,
            terminate: false,
            early: false,
            last: t + 0.1,
        };
        assert_eq!(out, expected);
        assert_eq!(fmu.time(), t + 0.1);
        rows.push(fmu.outputs());
    }
    assert_eq!(rows, reference);
    // A real load: the midspan moved and the cable carries more than its pretension.
    assert!(fmu.get_vr(fx.vr("midspan_uz")).unwrap() < 0.0);
    assert!(fmu.get_vr(fx.vr("tension")).unwrap() > 100.0);
    assert_eq!(unsafe { fmi::fmi3Terminate(fmu.c) }, OK);
    assert!(
        log.records().is_empty(),
        "an OK run logs nothing: {:?}",
        log.messages()
    );
}

#[test]
fn outputs_read_in_initialization_mode_are_the_initial_equilibrium() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    assert_eq!(fmu.enter(0.5, 1.0), OK);
    assert_eq!(fmu.time(), 0.5);
    assert_eq!(fmu.set("P", 300.0), OK);
    let early = fmu.outputs();
    assert_eq!(fmu.exit(), OK);
    assert_eq!(fmu.outputs(), early);
    let (status, _) = fmu.step(0.5, 0.25);
    assert_eq!(status, OK);
    assert_eq!(fmu.time(), 0.75);
}

// ---------------------------------------------------------------------------------------------
// Argument checks (item 52) and the state machine.

#[test]
fn n_values_time_and_unknown_references_are_errors_with_messages() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    let vr = [fx.vr("midspan_uz"), fx.vr("tension")];
    let mut values = [0.0; 3];
    let status = unsafe { fmi::fmi3GetFloat64(fmu.c, vr.as_ptr(), 2, values.as_mut_ptr(), 3) };
    assert_eq!(status, ERROR);
    log.expect("fmi3GetFloat64: nValues = 3, expected 2");
    let status = unsafe { fmi::fmi3SetFloat64(fmu.c, vr.as_ptr(), 1, values.as_ptr(), 2) };
    assert_eq!(status, ERROR);
    log.expect("fmi3SetFloat64: nValues = 2, expected 1");
    let time = fmi::TIME_VALUE_REFERENCE;
    let status = unsafe { fmi::fmi3SetFloat64(fmu.c, &time, 1, &1.0, 1) };
    assert_eq!(status, ERROR);
    log.expect("it is the independent variable");
    let status = unsafe { fmi::fmi3GetFloat64(fmu.c, &999, 1, values.as_mut_ptr(), 1) };
    assert_eq!(status, ERROR);
    log.expect("999");
    let mut ints = [0i32; 2];
    let ivr = fx.integer_outputs();
    let status = unsafe { fmi::fmi3GetInt32(fmu.c, ivr.as_ptr(), 1, ints.as_mut_ptr(), 2) };
    assert_eq!(status, ERROR);
    log.expect("fmi3GetInt32: nValues = 2, expected 1");
    // An output is not settable; nothing changed.
    let before = fmu.outputs();
    assert_eq!(fmu.set("tension", 1.0), ERROR);
    log.expect("fmi3SetFloat64: variable tension");
    assert_eq!(fmu.outputs(), before);
    // Types without variables: any reference is unknown, an empty call is OK.
    let mut bytes = [0u8; 1];
    let p = fx.vr("P");
    let status = unsafe { fmi::fmi3GetUInt8(fmu.c, &p, 1, bytes.as_mut_ptr(), 1) };
    assert_eq!(status, ERROR);
    log.expect("fmi3GetUInt8: no UInt8 variable has value reference");
    let status = unsafe { fmi::fmi3GetUInt8(fmu.c, null(), 0, null_mut(), 0) };
    assert_eq!(status, OK);
    let mut flag = false;
    let status = unsafe { fmi::fmi3GetBoolean(fmu.c, &p, 1, &mut flag, 1) };
    assert_eq!(status, ERROR);
    let no_names = log.messages().into_iter().find(|m| m.contains("fmi2"));
    assert_eq!(no_names, None, "FMI 3 messages use FMI 3 names");
}

#[test]
fn illegal_calls_are_errors_named_in_fmi3_terms_and_reset_recovers() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    let (status, _) = fmu.step(0.0, 0.1);
    assert_eq!(status, ERROR);
    log.expect("fmi3DoStep: illegal call in state Instantiated");
    assert_eq!(fmu.exit(), ERROR);
    log.expect("fmi3ExitInitializationMode: illegal call in state Instantiated");
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.enter(0.0, 1.0), ERROR);
    // Fixed parameter after initialization.
    assert_eq!(fmu.set("EA", 2e5), ERROR);
    log.expect("fmi3SetFloat64: variable EA");
    log.expect("settable only before fmi3ExitInitializationMode");
    // Wrong communication point, non-positive step, past the stop time.
    assert_eq!(fmu.step(0.3, 0.1).0, ERROR);
    assert_eq!(fmu.step(0.0, 0.0).0, ERROR);
    assert_eq!(fmu.step(0.0, 2.0).0, ERROR);
    // NULL out-arguments.
    let mut b = false;
    let status = unsafe {
        fmi::fmi3DoStep(
            fmu.c,
            0.0,
            0.1,
            true,
            &mut b,
            null_mut(),
            &mut b,
            null_mut(),
        )
    };
    assert_eq!(status, ERROR);
    log.expect("out-argument");
    assert_eq!(unsafe { fmi::fmi3Reset(fmu.c) }, OK);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.step(0.0, 0.1).0, OK);
    let no_names = log.messages().into_iter().find(|m| m.contains("fmi2"));
    assert_eq!(no_names, None, "FMI 3 messages use FMI 3 names");
    // NULL instances.
    unsafe {
        fmi::fmi3FreeInstance(null_mut());
        assert_eq!(fmi::fmi3Reset(null_mut()), ERROR);
        assert_eq!(fmi::fmi3EnterEventMode(null_mut()), ERROR);
    }
}

#[test]
fn unsupported_functions_are_errors_with_a_reason() {
    // Item 55 from inside: ME, SE, event-mode, clock and derivative functions on the CS
    // instance return fmi3Error and log why.
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    let c = fmu.c;
    let (mut b, mut f, mut n) = (false, 0.0f64, 0usize);
    let vr = fx.vr("P");
    unsafe {
        let calls: Vec<(&str, Status)> = vec![
            ("fmi3EnterEventMode", fmi::fmi3EnterEventMode(c)),
            ("fmi3EnterStepMode", fmi::fmi3EnterStepMode(c)),
            (
                "fmi3EnterConfigurationMode",
                fmi::fmi3EnterConfigurationMode(c),
            ),
            (
                "fmi3ExitConfigurationMode",
                fmi::fmi3ExitConfigurationMode(c),
            ),
            (
                "fmi3EvaluateDiscreteStates",
                fmi::fmi3EvaluateDiscreteStates(c),
            ),
            (
                "fmi3UpdateDiscreteStates",
                fmi::fmi3UpdateDiscreteStates(c, &mut b, &mut b, &mut b, &mut b, &mut b, &mut f),
            ),
            (
                "fmi3EnterContinuousTimeMode",
                fmi::fmi3EnterContinuousTimeMode(c),
            ),
            (
                "fmi3CompletedIntegratorStep",
                fmi::fmi3CompletedIntegratorStep(c, true, &mut b, &mut b),
            ),
            ("fmi3SetTime", fmi::fmi3SetTime(c, 0.5)),
            (
                "fmi3GetNumberOfContinuousStates",
                fmi::fmi3GetNumberOfContinuousStates(c, &mut n),
            ),
            (
                "fmi3GetNumberOfVariableDependencies",
                fmi::fmi3GetNumberOfVariableDependencies(c, vr, &mut n),
            ),
            (
                "fmi3GetIntervalDecimal",
                fmi::fmi3GetIntervalDecimal(c, &vr, 1, &mut f, null_mut()),
            ),
            (
                "fmi3ActivateModelPartition",
                fmi::fmi3ActivateModelPartition(c, vr, 0.0),
            ),
            (
                "fmi3GetOutputDerivatives",
                fmi::fmi3GetOutputDerivatives(c, &vr, 1, &1, &mut f, 1),
            ),
        ];
        for (name, status) in calls {
            assert_eq!(status, ERROR, "{name}");
            log.expect(&format!("{name}: not supported: "));
        }
    }
    // None of them changed anything: the run goes on.
    assert_eq!(fmu.set("P", 100.0), OK);
    assert_eq!(fmu.step(0.0, 0.1).0, OK);
}

// ---------------------------------------------------------------------------------------------
// Failure policy (item 37): Discard leaves the state unchanged.

#[test]
fn non_convergence_is_a_discard_that_leaves_the_state_unchanged() {
    let fx = Fixture::new("velarium-fmi3-fragile", &fragile_scene_text());
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.set("P", 1e-9), OK);
    assert_eq!(fmu.step(0.0, 0.1).0, OK);
    let outputs = fmu.outputs();
    let state = fmu.serialize();
    assert_eq!(fmu.set("P", 5000.0), OK);
    let inputs_set = fmu.serialize();
    let (status, out) = fmu.step(0.1, 0.1);
    assert_eq!(status, DISCARD);
    assert_eq!(
        out.last, 0.1,
        "lastSuccessfulTime = currentCommunicationPoint"
    );
    assert!(!out.early && !out.event);
    assert_eq!(
        fmu.outputs(),
        outputs,
        "the outputs are those before the call"
    );
    assert_eq!(fmu.time(), 0.1, "the time is that before the call");
    assert_eq!(
        fmu.serialize(),
        inputs_set,
        "the whole FMU state (equilibrium, history, inputs, time, state machine) is as before the call"
    );
    assert_ne!(
        state, inputs_set,
        "the input set before the call is part of that state"
    );
    let records = log.records();
    let discard = records
        .iter()
        .find(|r| r.status == DISCARD)
        .expect("logged");
    assert_eq!(discard.category, "logStatusDiscard");
    assert!(
        discard
            .message
            .starts_with("fmi3DoStep: the step from 0.1 to 0.2"),
        "{}",
        discard.message
    );
    assert!(discard.message.contains("P = 5000"), "{}", discard.message);
    // Still in Step Mode at t = 0.1: the master may retry with another input.
    assert_eq!(fmu.set("P", 2e-9), OK);
    let (status, out) = fmu.step(0.1, 0.1);
    assert_eq!(status, OK, "{:?}", log.messages());
    assert_eq!(out.last, 0.2);
    // Or roll back to a saved state and go on from there.
    assert_eq!(fmu.restore(&state), OK);
    assert_eq!(fmu.time(), 0.1);
    assert_eq!(fmu.outputs(), outputs);
    assert_eq!(unsafe { fmi::fmi3Terminate(fmu.c) }, OK);
}

#[test]
fn the_debug_failure_switch_discards_the_step_that_passes_it() {
    let fx = Fixture::new(
        "velarium-fmi3-debug-fail",
        &debug_scene_text(&[("fail_after_time", 0.25)]),
    );
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    for k in 0..2 {
        assert_eq!(fmu.set("P", load(k)), OK);
        assert_eq!(fmu.step(k as f64 * 0.1, 0.1).0, OK);
    }
    assert_eq!(fmu.set("P", load(2)), OK);
    let before = (fmu.outputs(), fmu.serialize());
    let (status, out) = fmu.step(0.2, 0.1);
    assert_eq!(status, DISCARD);
    assert_eq!(out.last, 0.2);
    assert_eq!((fmu.outputs(), fmu.serialize()), before);
    log.expect("forced by debug.fail_after_time = 0.25");
    // A shorter step that ends before the switch succeeds (variable step size).
    assert_eq!(fmu.step(0.2, 0.05).0, OK);
    assert_eq!(fmu.time(), 0.25);
}

#[test]
fn a_panic_is_an_error_and_reset_recovers() {
    let fx = Fixture::new(
        "velarium-fmi3-debug-panic",
        &debug_scene_text(&[("panic_after_time", 0.15)]),
    );
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.step(0.0, 0.1).0, OK);
    assert_eq!(fmu.step(0.1, 0.1).0, ERROR);
    log.expect("fmi3DoStep: internal error");
    log.expect("fmi3Reset or fmi3SetFMUState recovers it");
    assert_eq!(fmu.step(0.1, 0.01).0, ERROR, "state Error");
    assert_eq!(unsafe { fmi::fmi3Reset(fmu.c) }, OK);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.step(0.0, 0.1).0, OK);
}

// ---------------------------------------------------------------------------------------------
// FMU state (items 42-45 in FMI 3 form).

#[test]
fn states_round_trip_in_place_and_through_bytes_into_a_fresh_instance() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    for k in 0..3 {
        assert_eq!(fmu.set("P", load(k)), OK);
        assert_eq!(fmu.step(k as f64 * 0.1, 0.1).0, OK);
    }
    let mut saved: FmuState = null_mut();
    assert_eq!(fmu.get_state(&mut saved), OK);
    let bytes = fmu.serialize();
    let mut continued = Vec::new();
    for k in 3..6 {
        assert_eq!(fmu.set("P", load(k)), OK);
        assert_eq!(fmu.step(k as f64 * 0.1, 0.1).0, OK);
        continued.push(fmu.outputs());
    }
    // In place: back to t = 0.3 and the same steps again.
    let handle = saved;
    assert_eq!(
        fmu.get_state(&mut saved),
        OK,
        "a second get reuses the handle"
    );
    assert_eq!(saved, handle);
    assert_eq!(fmu.restore(&bytes), OK);
    assert_eq!(fmu.time(), 0.2 + 0.1);
    let mut again = Vec::new();
    for k in 3..6 {
        assert_eq!(fmu.set("P", load(k)), OK);
        assert_eq!(fmu.step(k as f64 * 0.1, 0.1).0, OK);
        again.push(fmu.outputs());
    }
    assert_eq!(again, continued);
    assert_eq!(fmu.free_state(&mut saved), OK);
    assert!(saved.is_null());
    assert_eq!(fmu.free_state(&mut saved), OK, "freeing NULL is a no-op");

    // Through bytes into a fresh, not yet initialized instance.
    let log2 = Log::default();
    let fresh = fx.fmu(&log2, false);
    assert_eq!(fresh.restore(&bytes), OK);
    let mut resumed = Vec::new();
    for k in 3..6 {
        assert_eq!(fresh.set("P", load(k)), OK);
        assert_eq!(fresh.step(k as f64 * 0.1, 0.1).0, OK);
        resumed.push(fresh.outputs());
    }
    assert_eq!(resumed, continued);

    // Corrupted, truncated and FMI 2 bytes are errors with a message.
    let mut bad = bytes.clone();
    let n = bad.len();
    bad[n - 12] ^= 1;
    assert_eq!(fresh.restore(&bad), ERROR);
    log2.expect("fmi3DeserializeFMUState: checksum check failed");
    for cut in [0, 7, 20, bytes.len() - 1] {
        assert_eq!(fresh.restore(&bytes[..cut]), ERROR);
    }
    let fmi2_bytes = fmi2_state_bytes(&fx);
    assert_eq!(fresh.restore(&fmi2_bytes), ERROR);
    log2.expect("GUID check failed");
}

/// Issue 28, FMI 3 form: fmusim's `FMI3FreeFMUState(S, FMUState)` passes the state where its
/// address belongs; a foreign, freed or other instance's state is never dereferenced (0x8 and
/// usize::MAX - 7 would fault if read). Each is fmi3Error with a message; the state and the
/// instance stay usable.
#[test]
fn foreign_and_misplaced_state_pointers_are_errors_not_crashes() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, true);
    fmu.init(0.0, 1.0);
    let bytes = fmu.serialize();
    let mut state: FmuState = null_mut();
    assert_eq!(fmu.get_state(&mut state), OK);
    log.clear();
    assert_eq!(unsafe { fmi::fmi3FreeFMUState(fmu.c, state.cast()) }, ERROR);
    log.expect("fmi3FreeFMUState: the FMU state argument 0x");
    log.expect("is an FMU state itself");
    assert_eq!(unsafe { fmi::fmi3GetFMUState(fmu.c, state.cast()) }, ERROR);
    let mut loaded: FmuState = null_mut();
    unsafe {
        assert_eq!(
            fmi::fmi3DeserializeFMUState(fmu.c, bytes.as_ptr(), bytes.len(), &mut loaded),
            OK
        );
    }
    assert_eq!(fmu.set_state(loaded), OK);
    assert_eq!(
        unsafe { fmi::fmi3FreeFMUState(fmu.c, loaded.cast()) },
        ERROR
    );
    let mut freed: FmuState = null_mut();
    assert_eq!(fmu.get_state(&mut freed), OK);
    let dangling = freed;
    assert_eq!(fmu.free_state(&mut freed), OK);
    let mut forged = [0x5645_4c41_5253_5441u64; 64];
    let other = fx.fmu(&log, false);
    let mut theirs: FmuState = null_mut();
    assert_eq!(other.get_state(&mut theirs), OK);
    let mut size = 0usize;
    for foreign in [
        8 as FmuState,
        (usize::MAX - 7) as FmuState,
        forged.as_mut_ptr().cast(),
        dangling,
        theirs,
    ] {
        log.clear();
        assert_eq!(fmu.set_state(foreign), ERROR, "{foreign:p}");
        log.expect("fmi3SetFMUState: the FMU state 0x");
        log.expect("is not a live FMU state of this instance");
        let mut slot = foreign;
        assert_eq!(fmu.free_state(&mut slot), ERROR, "{foreign:p}");
        assert_eq!(slot, foreign);
        assert_eq!(
            unsafe { fmi::fmi3SerializedFMUStateSize(fmu.c, foreign, &mut size) },
            ERROR
        );
    }
    assert_eq!(other.free_state(&mut theirs), OK);
    assert_eq!(fmu.set_state(state), OK);
    assert_eq!(fmu.set("P", load(1)), OK);
    assert_eq!(fmu.step(0.0, 0.1).0, OK);
    // `state` and `loaded` are still held: fmi3FreeInstance frees them.
}

/// A serialized state of an FMI 2 instance of the same scene (carries the FMI 2 GUID).
fn fmi2_state_bytes(fx: &Fixture) -> Vec<u8> {
    let cb = fmi::CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: null_mut(),
    };
    unsafe {
        let c = fmi::fmi2Instantiate(
            c"ref".as_ptr(),
            1,
            fx.guid.as_ptr(),
            fx.uri.as_ptr(),
            &cb,
            0,
            0,
        );
        assert!(!c.is_null());
        let (mut state, mut size) = (null_mut(), 0usize);
        assert_eq!(fmi::fmi2GetFMUstate(c, &mut state), OK);
        assert_eq!(fmi::fmi2SerializedFMUstateSize(c, state, &mut size), OK);
        let mut bytes = vec![0u8; size];
        assert_eq!(
            fmi::fmi2SerializeFMUstate(c, state, bytes.as_mut_ptr().cast(), size),
            OK
        );
        assert_eq!(fmi::fmi2FreeFMUstate(c, &mut state), OK);
        fmi::fmi2FreeInstance(c);
        bytes
    }
}

// ---------------------------------------------------------------------------------------------
// Directional and adjoint derivatives (issue 12 item 3): the C functions give the engine's
// numbers, check their counts and arguments.

#[test]
fn derivatives_through_the_c_functions_are_the_engines() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    let c = fmu.c;
    assert_eq!(fmu.enter(0.0, 1.0), OK);
    assert_eq!(fmu.set("P", 1000.0), OK);
    assert_eq!(fmu.exit(), OK);
    let (w, p, t) = (fx.vr("midspan_uz"), fx.vr("P"), fx.vr("tension"));
    let unknowns = [w, t];
    let mut forward = [0.0f64; 2];
    let mut adjoint = [0.0f64];
    unsafe {
        assert_eq!(
            fmi::fmi3GetDirectionalDerivative(
                c,
                unknowns.as_ptr(),
                2,
                &p,
                1,
                &1.0,
                1,
                forward.as_mut_ptr(),
                2
            ),
            OK
        );
        let seed = [1.0, 0.0];
        assert_eq!(
            fmi::fmi3GetAdjointDerivative(
                c,
                unknowns.as_ptr(),
                2,
                &p,
                1,
                seed.as_ptr(),
                2,
                adjoint.as_mut_ptr(),
                1
            ),
            OK
        );
    }
    // The engine on the same scene and load.
    let mut engine = Engine::try_new(Scene::from_json(&scene_text()).unwrap()).unwrap();
    engine.set_real(p, 1000.0).unwrap();
    assert!(engine.solve().converged());
    let slot = |vr: u32| match engine
        .variables()
        .iter()
        .find(|v| v.value_reference == vr)
        .unwrap()
        .binding
    {
        velarium::variables::Binding::Output(k) | velarium::variables::Binding::Input(k) => k,
        _ => panic!(),
    };
    let (sw, st, sp) = (slot(w), slot(t), slot(p));
    let expected = engine
        .directional_derivative(
            &[velarium::engine::derivatives::Known::Input(sp)],
            &[1.0],
            &[sw, st],
        )
        .unwrap();
    assert_eq!(forward.to_vec(), expected);
    assert!(forward[0] < 0.0 && forward[1] > 0.0, "{forward:?}");
    assert!((adjoint[0] - forward[0]).abs() <= 1e-15 * forward[0].abs());
    // Counts and kinds are checked.
    unsafe {
        let mut out = [0.0f64; 2];
        assert_eq!(
            fmi::fmi3GetDirectionalDerivative(
                c,
                unknowns.as_ptr(),
                2,
                &p,
                1,
                &1.0,
                1,
                out.as_mut_ptr(),
                1
            ),
            ERROR
        );
        log.expect("sensitivity has 1 values, expected 2");
        assert_eq!(
            fmi::fmi3GetDirectionalDerivative(c, &p, 1, &w, 1, &1.0, 1, out.as_mut_ptr(), 1),
            ERROR
        );
        log.expect("is not a continuous Real output");
        assert_eq!(
            fmi::fmi3GetDirectionalDerivative(c, &w, 1, &t, 1, &1.0, 1, out.as_mut_ptr(), 1),
            ERROR
        );
        log.expect("knowns are inputs and parameters");
    }
}

// ---------------------------------------------------------------------------------------------
// Intermediate update and early return (issue 12 item 4).

/// The instance environment of the intermediate-update tests: the logger's `Log` first (the
/// logger callback reads the environment as a `Log`), then what the update callback records.
#[repr(C)]
#[derive(Default)]
struct UpdateEnv {
    log: Log,
    /// (time, intermediateStepFinished, canReturnEarly) of every call.
    calls: Mutex<Vec<(f64, bool, bool)>>,
    /// Ask for an early return at the first call that may return early.
    request: std::sync::atomic::AtomicBool,
}

unsafe extern "C" fn record_update(
    env: *mut c_void,
    time: f64,
    set_requested: bool,
    get_allowed: bool,
    finished: bool,
    can_return_early: bool,
    early_return_requested: *mut bool,
    _early_return_time: *mut f64,
) {
    let env = &*(env as *const UpdateEnv);
    assert!(!set_requested && !get_allowed);
    env.calls
        .lock()
        .unwrap()
        .push((time, finished, can_return_early));
    *early_return_requested = can_return_early && env.request.load(Ordering::SeqCst);
}

fn instantiate_with_updates(
    fx: &Fixture,
    env: &UpdateEnv,
    early_return_allowed: bool,
) -> Component {
    let c = unsafe {
        fmi::fmi3InstantiateCoSimulation(
            c"updates".as_ptr(),
            fx.token.as_ptr(),
            fx.path.as_ptr(),
            false,
            false,
            false,
            early_return_allowed,
            null(),
            0,
            env as *const UpdateEnv as *mut c_void,
            Some(capture),
            Some(record_update),
        )
    };
    assert!(!c.is_null(), "{:?}", env.log.messages());
    c
}

/// The engine's midspan deflection under P (the reference of the stepped runs).
fn engine_deflection(p: f64) -> f64 {
    let mut engine = Engine::try_new(Scene::from_json(&scene_text()).unwrap()).unwrap();
    let vr = |name: &str| {
        engine
            .variables()
            .iter()
            .find(|v| v.name == name)
            .unwrap()
            .value_reference
    };
    let (load, w) = (vr("P"), vr("midspan_uz"));
    engine.set_real(load, p).unwrap();
    assert!(engine.solve().converged());
    engine.get_real(w).unwrap()
}

/// With a callback, every load increment of a step is reported at its pseudo-time t + λ h,
/// and the equilibrium is the plain step's to the solver tolerance (the increments are solved
/// one per call, so their convergence scale differs: 1e-10 relative, measured 8.8e-12);
/// without earlyReturnAllowed, `canReturnEarly` is false and requests are ignored.
#[test]
fn intermediate_updates_report_every_increment() {
    let fx = Fixture::new(
        "velarium-fmi3-updates",
        &with_solver(r#"{"initial_increment": 0.125}"#),
    );
    let env = UpdateEnv::default();
    env.request.store(true, Ordering::SeqCst);
    let c = instantiate_with_updates(&fx, &env, false);
    let (p, w) = (fx.vr("P"), fx.vr("midspan_uz"));
    let (mut event, mut terminate, mut early, mut last) = (false, false, false, 0.0);
    unsafe {
        assert_eq!(
            fmi::fmi3EnterInitializationMode(c, false, 0.0, 0.0, true, 1.0),
            OK
        );
        assert_eq!(fmi::fmi3ExitInitializationMode(c), OK);
        assert_eq!(fmi::fmi3SetFloat64(c, &p, 1, &5000.0, 1), OK);
        let status = fmi::fmi3DoStep(
            c,
            0.0,
            0.5,
            true,
            &mut event,
            &mut terminate,
            &mut early,
            &mut last,
        );
        assert_eq!(status, OK);
    }
    assert!(!early && last == 0.5);
    let calls = env.calls.lock().unwrap().clone();
    assert!(calls.len() >= 3, "{calls:?}");
    assert!(calls.windows(2).all(|p| p[0].0 <= p[1].0), "{calls:?}");
    assert_eq!(calls.last().unwrap(), &(0.5, true, false));
    assert!(calls.iter().all(|c| !c.2), "earlyReturnAllowed is false");
    let mut value = 0.0;
    unsafe {
        assert_eq!(fmi::fmi3GetFloat64(c, &w, 1, &mut value, 1), OK);
        fmi::fmi3FreeInstance(c);
    }
    let reference = engine_deflection(5000.0);
    let err = (value - reference).abs() / reference.abs();
    eprintln!("stepped vs plain: {err:e}");
    assert!(err < 1e-10, "{value} vs {reference}");
}

/// earlyReturnAllowed and a request at the first increment: DoStep returns there with
/// earlyReturn, lastSuccessfulTime = t + λ h and the equilibrium at λ of the load change; the
/// next DoStep from that time applies the rest.
#[test]
fn early_return_stops_at_the_requested_increment() {
    let fx = Fixture::new(
        "velarium-fmi3-early",
        &with_solver(r#"{"initial_increment": 0.125}"#),
    );
    let env = UpdateEnv::default();
    env.request.store(true, Ordering::SeqCst);
    let c = instantiate_with_updates(&fx, &env, true);
    let (p, w) = (fx.vr("P"), fx.vr("midspan_uz"));
    let (mut event, mut terminate, mut early, mut last) = (false, false, false, 0.0);
    let mut value = 0.0;
    unsafe {
        assert_eq!(
            fmi::fmi3EnterInitializationMode(c, false, 0.0, 0.0, true, 1.0),
            OK
        );
        assert_eq!(fmi::fmi3ExitInitializationMode(c), OK);
        assert_eq!(fmi::fmi3SetFloat64(c, &p, 1, &5000.0, 1), OK);
        let status = fmi::fmi3DoStep(
            c,
            0.0,
            0.5,
            true,
            &mut event,
            &mut terminate,
            &mut early,
            &mut last,
        );
        assert_eq!(status, OK);
        assert!(early, "early return");
        assert_eq!(last, 0.5 * 0.125);
        assert_eq!(fmi::fmi3GetFloat64(c, &w, 1, &mut value, 1), OK);
        let reference = engine_deflection(5000.0 * 0.125);
        let err = (value - reference).abs() / reference.abs();
        eprintln!("early return at λ = 0.125 vs plain: {err:e}");
        assert!(err < 1e-10, "{value} vs {reference}");
        // The rest of the step from the returned time.
        env.request.store(false, Ordering::SeqCst);
        let h = 0.5 - last;
        let status = fmi::fmi3DoStep(
            c,
            last,
            h,
            true,
            &mut event,
            &mut terminate,
            &mut early,
            &mut last,
        );
        assert_eq!(status, OK);
        assert!(!early && last == 0.5);
        assert_eq!(fmi::fmi3GetFloat64(c, &w, 1, &mut value, 1), OK);
        fmi::fmi3FreeInstance(c);
    }
    let reference = engine_deflection(5000.0);
    let err = (value - reference).abs() / reference.abs();
    eprintln!("after the rest of the step vs plain: {err:e}");
    assert!(err < 1e-10);
}

/// Issue 27 through FMI 3: `solver.max_iterations` 4294967296 makes
/// fmi3InstantiateCoSimulation return NULL with the path and the range logged; an implausible
/// modulus (E = 600 Pa) is a logged warning (FMI 3 names) and the instance is built.
#[test]
fn instantiate_refuses_a_bad_setting_and_logs_a_plausibility_warning() {
    let fx = Fixture::standard();
    let mut scene: serde_json::Value = serde_json::from_str(&scene_text()).unwrap();
    scene["solver"] = serde_json::json!({"max_iterations": 4294967296u64});
    std::fs::write(
        fx.root.join("resources dir ä/scene.json"),
        scene.to_string(),
    )
    .unwrap();
    let log = Log::default();
    assert!(instantiate(&fx.token, &fx.path, &log, false, false).is_null());
    log.expect("fmi3InstantiateCoSimulation");
    log.expect("solver.max_iterations: 4294967296 is not in 1..=10000");
    let disc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/modelDescription/HenckyDisc/scene.json"
    ))
    .unwrap()
    .replace("\"E\": 2e8", "\"E\": 600");
    let fx = Fixture::new("velarium-fmi3-warning", &disc);
    let log = Log::default();
    let _fmu = fx.fmu(&log, true);
    let warning = log
        .records()
        .into_iter()
        .find(|r| r.category == "logStatusWarning")
        .unwrap_or_else(|| panic!("{:?}", log.records()));
    assert_eq!(warning.status, Status::Warning);
    assert!(
        warning
            .message
            .starts_with("fmi3InstantiateCoSimulation: membranes[0].material.E"),
        "{warning:?}"
    );
}
