//! The FMI 2.0 Co-Simulation C ABI, tested from inside: the `extern "C"` functions called
//! through the rlib exactly as a master calls them (docs/fmu.md, "The conformance checklist"; the fmpy tests drive the
//! packaged FMU from outside).
//!
//! SCENE: `modelDescription/PrestressedCable/scene.json` when present, else an equivalent
//! pretensioned cable written here (input `P`, fixed parameter `EA`, tunable `pretension`,
//! outputs `midspan_uz`, `tension`, `newton_iterations`). Each test writes it into its own
//! temporary resources directory.
//!
//! LOGGER: the FMI 2 logger is variadic C, `logger(env, name, status, category, fmt, ...)`.
//! Stable Rust cannot define a variadic function, so the capturing logger below has a fixed
//! sixth parameter `msg: *const c_char`. On x86_64 System V (and AArch64 Linux) the first
//! variadic pointer argument travels in the same register as a sixth fixed pointer argument,
//! so `msg` receives the argument of the FMU's `"%s"` format: the trick fmpy-style logger
//! proxies rely on. This file therefore only builds on those targets.

#![cfg(all(
    unix,
    any(target_arch = "x86_64", target_arch = "aarch64"),
    not(target_vendor = "apple")
))]

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::path::PathBuf;
use std::ptr::{null, null_mut};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use velarium::fmi::{self, CallbackFunctions, Component, FmuState, LoggerFn, Status};
use velarium::variables::{Causality, VarType};
use velarium::{Engine, Scene};

const OK: Status = Status::Ok;
const ERROR: Status = Status::Error;
const DISCARD: Status = Status::Discard;

const FALLBACK_SCENE: &str = r#"{
  "format": 1, "name": "PrestressedCable",
  "geometry": {"nodes": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]},
  "cables": [{"name": "cable", "nodes": [0, 1, 2], "EA": 1e5, "pretension": 100}],
  "supports": [{"nodes": [0, 2], "fix": ["x", "y", "z"]}, {"nodes": [1], "fix": ["y"]}],
  "inputs": [{"name": "P", "start": 0,
              "load": {"kind": "point_force", "nodes": [1], "direction": [0, 0, -1]}}],
  "outputs": [
    {"name": "midspan_uz", "probe": {"kind": "displacement", "node": 1, "component": "z"}},
    {"name": "tension", "probe": {"kind": "cable_tension", "cable": "cable"}},
    {"name": "newton_iterations", "probe": {"kind": "newton_iterations"}}
  ],
  "parameters": [
    {"name": "EA", "target": "cables.cable.EA", "variability": "fixed"},
    {"name": "pretension", "target": "cables.cable.pretension", "variability": "tunable"}
  ]
}"#;

fn scene_text() -> String {
    let shipped = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/modelDescription/PrestressedCable"
    );
    std::fs::read_to_string(format!("{shipped}/scene.json")).unwrap_or(FALLBACK_SCENE.into())
}

/// The same scene with a solver that cannot take a real load step: one Newton iteration per
/// increment and no cut-back, so a DoStep with a load change does not converge.
fn fragile_scene_text() -> String {
    let mut scene: serde_json::Value = serde_json::from_str(&scene_text()).unwrap();
    let solver = r#"{"max_iterations": 1, "initial_increment": 1.0, "min_increment": 0.5}"#;
    scene["solver"] = serde_json::from_str(solver).unwrap();
    scene.to_string()
}

/// The load history of the run tests: P(t_k) for t_k = 0, 0.1, ...
fn load(k: usize) -> f64 {
    [150.0, 400.0, 800.0, 500.0, 200.0, 50.0][k % 6]
}

// ---------------------------------------------------------------------------------------------
// Fixture: a resources directory with the scene, its URI, the GUID.

static COUNTER: AtomicUsize = AtomicUsize::new(0);

struct Fixture {
    root: PathBuf,
    uri: CString,
    guid: CString,
    engine: Engine,
}

impl Fixture {
    fn new(dir_name: &str, scene: &str) -> Fixture {
        let n = COUNTER.fetch_add(1, Ordering::SeqCst);
        let root = std::env::temp_dir().join(format!("{dir_name}-{}-{n}", std::process::id()));
        let resources = root.join("resources");
        std::fs::create_dir_all(&resources).unwrap();
        std::fs::write(resources.join("scene.json"), scene).unwrap();
        let engine = Engine::try_new(Scene::from_json(scene).unwrap()).unwrap();
        let guid = CString::new(velarium::description::guid(
            engine.scene(),
            engine.variables(),
        ))
        .unwrap();
        let uri = CString::new(file_uri(&resources)).unwrap();
        Fixture {
            root,
            uri,
            guid,
            engine,
        }
    }

    fn standard() -> Fixture {
        Fixture::new("velarium-fmi", &scene_text())
    }

    fn vr(&self, name: &str) -> u32 {
        let var = self.engine.variables().iter().find(|v| v.name == name);
        var.unwrap_or_else(|| panic!("no variable {name}"))
            .value_reference
    }

    /// Instantiate with the capturing logger (asserting success).
    fn fmu<'a>(&'a self, log: &'a Log, logging_on: bool) -> Fmu<'a> {
        let c = instantiate(&self.guid, &self.uri, log, logging_on);
        assert!(!c.is_null(), "instantiation failed: {:?}", log.messages());
        Fmu {
            c,
            fx: self,
            _log: log,
        }
    }
}

impl Drop for Fixture {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

/// `file:///...` with every byte outside [A-Za-z0-9-._~/] percent-encoded (as fmpy's
/// `Path.as_uri()` does).
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

fn instantiate(guid: &CStr, uri: &CStr, log: &Log, logging_on: bool) -> Component {
    let cb = log.callbacks();
    let on = logging_on as c_int;
    unsafe { fmi::fmi2Instantiate(c"inst".as_ptr(), 1, guid.as_ptr(), uri.as_ptr(), &cb, 0, on) }
}

// ---------------------------------------------------------------------------------------------
// Capturing logger (see the module docs for the fixed sixth argument).

#[derive(Clone, Debug)]
struct Record {
    instance: String,
    status: Status,
    category: String,
    format: String,
    message: String,
}

#[derive(Default)]
struct Log(Mutex<Vec<Record>>);

/// The logger signature with the first variadic argument as a fixed one.
type FixedLogger = unsafe extern "C" fn(
    *mut c_void,
    *const c_char,
    Status,
    *const c_char,
    *const c_char,
    *const c_char,
);

unsafe extern "C" fn capture(
    env: *mut c_void,
    instance: *const c_char,
    status: Status,
    category: *const c_char,
    format: *const c_char,
    msg: *const c_char,
) {
    let text = |p: *const c_char| CStr::from_ptr(p).to_str().expect("UTF-8").to_string();
    let log = &*(env as *const Log);
    log.0.lock().unwrap().push(Record {
        instance: text(instance),
        status,
        category: text(category),
        format: text(format),
        message: text(msg),
    });
}

impl Log {
    fn callbacks(&self) -> CallbackFunctions {
        // SAFETY: see the module docs (a fixed sixth argument for the first variadic one).
        let logger = unsafe { std::mem::transmute::<FixedLogger, LoggerFn>(capture) };
        CallbackFunctions {
            logger: Some(logger),
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: self as *const Log as *mut c_void,
        }
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

    /// Assert that some message contains `needle`.
    fn expect(&self, needle: &str) {
        let messages = self.messages();
        assert!(
            messages.iter().any(|m| m.contains(needle)),
            "{needle:?} not in {messages:?}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// An instance, freed on drop; each method is one FMI call.

struct Fmu<'a> {
    c: Component,
    fx: &'a Fixture,
    _log: &'a Log,
}

impl Drop for Fmu<'_> {
    fn drop(&mut self) {
        unsafe { fmi::fmi2FreeInstance(self.c) };
    }
}

impl Fmu<'_> {
    fn setup(&self, start: f64, stop: f64) -> Status {
        unsafe { fmi::fmi2SetupExperiment(self.c, 0, 0.0, start, 1, stop) }
    }
    fn enter(&self) -> Status {
        unsafe { fmi::fmi2EnterInitializationMode(self.c) }
    }
    fn exit(&self) -> Status {
        unsafe { fmi::fmi2ExitInitializationMode(self.c) }
    }
    fn terminate(&self) -> Status {
        unsafe { fmi::fmi2Terminate(self.c) }
    }
    fn reset(&self) -> Status {
        unsafe { fmi::fmi2Reset(self.c) }
    }
    fn init(&self, start: f64, stop: f64) {
        assert_eq!(
            [self.setup(start, stop), self.enter(), self.exit()],
            [OK; 3]
        );
    }
    fn set(&self, name: &str, value: f64) -> Status {
        self.set_vr(&[self.fx.vr(name)], &[value])
    }
    fn set_vr(&self, vr: &[u32], values: &[f64]) -> Status {
        unsafe { fmi::fmi2SetReal(self.c, vr.as_ptr(), vr.len(), values.as_ptr()) }
    }
    fn get_vr(&self, vr: u32) -> Result<f64, Status> {
        let mut value = f64::NAN;
        match unsafe { fmi::fmi2GetReal(self.c, &vr, 1, &mut value) } {
            OK => Ok(value),
            status => Err(status),
        }
    }
    fn get(&self, name: &str) -> f64 {
        self.get_vr(self.fx.vr(name)).expect("fmi2GetReal")
    }
    fn step(&self, t: f64, h: f64) -> Status {
        unsafe { fmi::fmi2DoStep(self.c, t, h, 1) }
    }
    /// Set P = load(k) and step from t = 0.1 k.
    fn load_step(&self, k: usize) -> Status {
        assert_eq!(self.set("P", load(k)), OK);
        self.step(k as f64 * 0.1, 0.1)
    }
    /// Every Real output, as bits (for bit-identical comparisons).
    fn outputs(&self) -> Vec<u64> {
        let vars = self.fx.engine.variables().iter();
        let real_outputs =
            vars.filter(|v| v.causality == Causality::Output && v.var_type == VarType::Real);
        real_outputs
            .map(|v| self.get_vr(v.value_reference).unwrap().to_bits())
            .collect()
    }
    fn debug_logging(&self, on: bool, names: &[&CStr]) -> Status {
        let names: Vec<*const c_char> = names.iter().map(|n| n.as_ptr()).collect();
        unsafe { fmi::fmi2SetDebugLogging(self.c, on as c_int, names.len(), names.as_ptr()) }
    }
    fn get_state(&self, state: &mut FmuState) -> Status {
        unsafe { fmi::fmi2GetFMUstate(self.c, state) }
    }
    fn set_state(&self, state: FmuState) -> Status {
        unsafe { fmi::fmi2SetFMUstate(self.c, state) }
    }
    fn free_state(&self, state: &mut FmuState) -> Status {
        unsafe { fmi::fmi2FreeFMUstate(self.c, state) }
    }
    fn real_status(&self, kind: c_int) -> Result<f64, Status> {
        let mut value = f64::NAN;
        match unsafe { fmi::fmi2GetRealStatus(self.c, kind, &mut value) } {
            OK => Ok(value),
            status => Err(status),
        }
    }
    fn terminated(&self) -> Result<bool, Status> {
        let mut value = -1;
        match unsafe { fmi::fmi2GetBooleanStatus(self.c, fmi::FMI2_TERMINATED, &mut value) } {
            OK => Ok(value != 0),
            status => Err(status),
        }
    }

    /// Serialize the current state (checking the size protocol on the way).
    fn serialize(&self) -> Vec<u8> {
        let (mut state, mut size) = (null_mut(), 0usize);
        assert_eq!(self.get_state(&mut state), OK);
        unsafe {
            assert_eq!(
                fmi::fmi2SerializedFMUstateSize(self.c, state, &mut size),
                OK
            );
            let mut bytes = vec![0u8; size];
            let buffer = bytes.as_mut_ptr().cast();
            assert_eq!(
                fmi::fmi2SerializeFMUstate(self.c, state, buffer, size - 1),
                ERROR
            );
            assert_eq!(fmi::fmi2SerializeFMUstate(self.c, state, buffer, size), OK);
            assert_eq!(self.free_state(&mut state), OK);
            bytes
        }
    }

    /// Deserialize and set a state; the status of the first call that fails.
    fn restore(&self, bytes: &[u8]) -> Status {
        let mut state: FmuState = null_mut();
        let status = unsafe {
            fmi::fmi2DeSerializeFMUstate(self.c, bytes.as_ptr().cast(), bytes.len(), &mut state)
        };
        if status != OK {
            assert!(state.is_null());
            return status;
        }
        let status = self.set_state(state);
        assert_eq!(self.free_state(&mut state), OK);
        status
    }
}

// ---------------------------------------------------------------------------------------------
// Loading and instantiation.

#[test]
fn version_and_platform() {
    let text = |p: *const c_char| unsafe { CStr::from_ptr(p) }.to_str().unwrap().to_string();
    assert_eq!(text(fmi::fmi2GetVersion()), "2.0");
    assert_eq!(text(fmi::fmi2GetTypesPlatform()), "default");
}

#[test]
fn wrong_guid_gives_null_and_names_both_guids() {
    let fx = Fixture::standard();
    let log = Log::default();
    assert!(instantiate(c"{not-the-guid}", &fx.uri, &log, false).is_null());
    let records = log.records();
    let error = records
        .iter()
        .find(|r| r.status == ERROR)
        .expect("errors always log");
    let guid = fx.guid.to_str().unwrap();
    assert!(
        error.message.contains("{not-the-guid}") && error.message.contains(guid),
        "{error:?}"
    );
    assert_eq!(
        (error.category.as_str(), error.instance.as_str()),
        ("logStatusError", "inst")
    );
}

#[test]
fn model_exchange_empty_name_and_bad_location_give_null() {
    let fx = Fixture::standard();
    let log = Log::default();
    let cb = log.callbacks();
    let (guid, uri) = (fx.guid.as_ptr(), fx.uri.as_ptr());
    let bad_dir = c"file:///no/such/dir".as_ptr();
    unsafe {
        assert!(fmi::fmi2Instantiate(c"inst".as_ptr(), 0, guid, uri, &cb, 0, 0).is_null());
        assert!(fmi::fmi2Instantiate(c"".as_ptr(), 1, guid, uri, &cb, 0, 0).is_null());
        assert!(fmi::fmi2Instantiate(null(), 1, guid, uri, &cb, 0, 0).is_null());
        assert!(fmi::fmi2Instantiate(c"inst".as_ptr(), 1, guid, bad_dir, &cb, 0, 0).is_null());
        assert!(fmi::fmi2Instantiate(c"inst".as_ptr(), 1, guid, null(), &cb, 0, 0).is_null());
        // NULL callbacks: still NULL, no crash, nothing logged.
        assert!(fmi::fmi2Instantiate(c"inst".as_ptr(), 0, guid, uri, null(), 0, 1).is_null());
    }
    let messages = log.messages();
    assert_eq!(messages.len(), 5, "{messages:?}");
    assert!(messages[0].contains("fmuType = 0"), "{messages:?}");
    assert!(
        messages[1].contains("instanceName is empty"),
        "{messages:?}"
    );
    assert!(messages[2].contains("instanceName is NULL"), "{messages:?}");
    assert!(
        messages[3].contains("/no/such/dir/scene.json"),
        "{messages:?}"
    );
}

#[test]
fn null_callbacks_or_null_logger_still_run() {
    let fx = Fixture::standard();
    let log = Log::default();
    let mut no_logger = log.callbacks();
    no_logger.logger = None;
    let (guid, uri) = (fx.guid.as_ptr(), fx.uri.as_ptr());
    for cb in [null(), &no_logger as *const CallbackFunctions] {
        let c = unsafe { fmi::fmi2Instantiate(c"i".as_ptr(), 1, guid, uri, cb, 0, 1) };
        assert!(!c.is_null());
        let fmu = Fmu {
            c,
            fx: &fx,
            _log: &log,
        };
        fmu.init(0.0, 1.0);
        assert_eq!(fmu.step(0.5, 0.1), ERROR); // an error with nobody to tell
        assert_eq!(fmu.step(0.0, 0.1), OK);
    }
    assert!(log.records().is_empty());
}

#[test]
fn percent_encoded_location_with_space_and_non_ascii() {
    let fx = Fixture::new("velarium fmi ä 100%", &scene_text());
    let uri = fx.uri.to_str().unwrap();
    assert!(
        uri.contains("%20") && uri.contains("%C3%A4") && uri.contains("%25"),
        "{uri}"
    );
    let log = Log::default();
    drop(fx.fmu(&log, false));
    // The short form file:/path works too.
    let short = CString::new(uri.replacen("file://", "file:", 1)).unwrap();
    let c = instantiate(&fx.guid, &short, &log, false);
    assert!(!c.is_null(), "{:?}", log.messages());
    unsafe { fmi::fmi2FreeInstance(c) };
}

#[test]
fn null_instance_is_an_error_everywhere() {
    let n = null_mut();
    let mut state: FmuState = null_mut();
    let (mut r, mut i, mut b, mut size, mut st) = (0.0, 0, 0, 0usize, OK);
    let mut s: *const c_char = null();
    unsafe {
        fmi::fmi2FreeInstance(n); // a no-op
        let all = [
            fmi::fmi2SetDebugLogging(n, 1, 0, null()),
            fmi::fmi2SetupExperiment(n, 0, 0.0, 0.0, 0, 0.0),
            fmi::fmi2EnterInitializationMode(n),
            fmi::fmi2ExitInitializationMode(n),
            fmi::fmi2Terminate(n),
            fmi::fmi2Reset(n),
            fmi::fmi2GetReal(n, null(), 0, null_mut()),
            fmi::fmi2GetInteger(n, null(), 0, null_mut()),
            fmi::fmi2GetBoolean(n, null(), 0, null_mut()),
            fmi::fmi2GetString(n, null(), 0, null_mut()),
            fmi::fmi2SetReal(n, null(), 0, null()),
            fmi::fmi2SetInteger(n, null(), 0, null()),
            fmi::fmi2SetBoolean(n, null(), 0, null()),
            fmi::fmi2SetString(n, null(), 0, null()),
            fmi::fmi2GetFMUstate(n, &mut state),
            fmi::fmi2SetFMUstate(n, state),
            fmi::fmi2FreeFMUstate(n, &mut state),
            fmi::fmi2SerializedFMUstateSize(n, state, &mut size),
            fmi::fmi2SerializeFMUstate(n, state, null_mut(), 0),
            fmi::fmi2DeSerializeFMUstate(n, null(), 0, &mut state),
            fmi::fmi2GetDirectionalDerivative(n, null(), 0, null(), 0, null(), null_mut()),
            fmi::fmi2SetRealInputDerivatives(n, null(), 0, null(), null()),
            fmi::fmi2GetRealOutputDerivatives(n, null(), 0, null(), null_mut()),
            fmi::fmi2DoStep(n, 0.0, 0.1, 1),
            fmi::fmi2CancelStep(n),
            fmi::fmi2GetStatus(n, 0, &mut st),
            fmi::fmi2GetRealStatus(n, 2, &mut r),
            fmi::fmi2GetIntegerStatus(n, 0, &mut i),
            fmi::fmi2GetBooleanStatus(n, 3, &mut b),
            fmi::fmi2GetStringStatus(n, 1, &mut s),
        ];
        assert!(all.iter().all(|s| *s == ERROR), "{all:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// State machine.

#[test]
fn do_step_before_init_is_an_error_then_reset_and_run() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    assert_eq!(fmu.step(0.0, 0.1), ERROR);
    log.expect("fmi2DoStep: illegal call in state Instantiated");
    assert_eq!(fmu.reset(), OK);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.load_step(0), OK);
    assert!(fmu.get("midspan_uz") < 0.0);
}

#[test]
fn calling_sequence_is_enforced() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    assert_eq!(fmu.exit(), ERROR);
    assert_eq!(fmu.enter(), ERROR); // no SetupExperiment yet
    assert_eq!(fmu.terminate(), ERROR);
    assert_eq!(fmu.setup(0.0, -1.0), ERROR); // stop before start
    assert_eq!(fmu.setup(0.0, 1.0), OK);
    assert_eq!(fmu.enter(), OK);
    assert_eq!(fmu.setup(0.0, 2.0), ERROR);
    assert_eq!(fmu.exit(), OK);
    assert_eq!(fmu.step(0.0, 0.25), OK);
    let uz = fmu.get("midspan_uz");
    assert_eq!([fmu.terminate(), fmu.terminate()], [OK, ERROR]);
    assert_eq!(fmu.step(0.25, 0.25), ERROR);
    assert_eq!(fmu.get("midspan_uz").to_bits(), uz.to_bits()); // final values stay readable
    log.expect("fmi2Terminate: illegal call in state Terminated");
    log.expect("fmi2SetupExperiment must be called before");
}

#[test]
fn communication_points_are_checked() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.step(0.0, 0.0), ERROR);
    assert_eq!(fmu.step(0.0, -0.1), ERROR);
    assert_eq!(fmu.step(0.3, 0.1), ERROR);
    log.expect("expected 0, got 0.3");
    assert_eq!(fmu.step(0.0, 1.5), ERROR);
    log.expect("after stopTime = 1");
    // None of that changed anything; the master's round-off is tolerated.
    let mut t = 0.0;
    for _ in 0..10 {
        assert_eq!(fmu.step(t, 0.1), OK);
        t += 0.1; // 0.9999999999999999 after ten steps
    }
    assert_eq!(fmu.step(1.0, 1e-12), OK); // ends within round-off of stopTime
}

#[test]
fn status_queries_and_unsupported_functions() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    let c = fmu.c;
    assert_eq!(fmu.real_status(fmi::FMI2_LAST_SUCCESSFUL_TIME), Err(ERROR));
    fmu.init(2.0, 3.0);
    assert_eq!(fmu.step(2.0, 0.5), OK);
    assert_eq!(fmu.real_status(fmi::FMI2_LAST_SUCCESSFUL_TIME), Ok(2.5));
    assert_eq!(fmu.terminated(), Ok(false));
    assert_eq!(fmu.real_status(fmi::FMI2_TERMINATED), Err(ERROR));
    let mut st = OK;
    unsafe {
        assert_eq!(
            fmi::fmi2GetStatus(c, fmi::FMI2_DO_STEP_STATUS, &mut st),
            ERROR
        );
        assert_eq!(
            fmi::fmi2GetBooleanStatus(c, fmi::FMI2_TERMINATED, null_mut()),
            ERROR
        );
        assert_eq!(fmi::fmi2CancelStep(c), ERROR);
        let unsupported = [
            fmi::fmi2SetRealInputDerivatives(c, null(), 0, null(), null()),
            fmi::fmi2GetRealOutputDerivatives(c, null(), 0, null(), null_mut()),
        ];
        assert_eq!(unsupported, [ERROR; 2]);
        // Supported now (providesDirectionalDerivative): an empty call is OK.
        assert_eq!(
            fmi::fmi2GetDirectionalDerivative(c, null(), 0, null(), 0, null(), null_mut()),
            OK
        );
    }
    log.expect("fmi2CancelStep: not supported");
    log.expect("fmi2SetRealInputDerivatives: not supported");
}

// ---------------------------------------------------------------------------------------------
// Variables.

#[test]
fn full_run_equals_the_engine() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    let mut engine = Engine::try_new(fx.engine.scene().clone()).unwrap();
    assert!(engine.solve().converged());
    let real_outputs = |e: &Engine| -> Vec<u64> {
        let vars = e
            .variables()
            .iter()
            .filter(|v| v.causality == Causality::Output);
        let reals = vars.filter(|v| v.var_type == VarType::Real);
        reals
            .map(|v| e.get_real(v.value_reference).unwrap().to_bits())
            .collect()
    };
    assert_eq!(fmu.outputs(), real_outputs(&engine));
    let iterations = fx.vr("newton_iterations");
    for k in 0..10 {
        assert_eq!(fmu.load_step(k), OK);
        engine.set_real(fx.vr("P"), load(k)).unwrap();
        assert!(engine.solve().converged());
        assert_eq!(fmu.outputs(), real_outputs(&engine), "step {k}");
        let mut n = -1;
        assert_eq!(
            unsafe { fmi::fmi2GetInteger(fmu.c, &iterations, 1, &mut n) },
            OK
        );
        assert_eq!(n, engine.get_integer(iterations).unwrap());
    }
}

#[test]
fn outputs_in_initialization_mode_are_the_initial_equilibrium() {
    let fx = Fixture::standard();
    let log = Log::default();
    let (a, b) = (fx.fmu(&log, false), fx.fmu(&log, false));
    for fmu in [&a, &b] {
        assert_eq!([fmu.setup(0.0, 1.0), fmu.enter()], [OK; 2]);
    }
    assert_eq!(a.set("P", 300.0), OK);
    assert!(a.get("midspan_uz") < 0.0); // solved on demand
    assert_eq!(a.set("P", 500.0), OK);
    let uz = a.get("midspan_uz");
    assert_eq!(b.set("P", 500.0), OK);
    assert_eq!([a.exit(), b.exit()], [OK; 2]);
    assert_eq!(a.get("midspan_uz").to_bits(), uz.to_bits());
    assert_eq!(
        a.outputs(),
        b.outputs(),
        "reading early does not change the result"
    );
}

#[test]
fn set_and_get_are_checked() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    let (c, p, uz) = (fmu.c, fx.vr("P"), fx.vr("midspan_uz"));
    let mut value = 0.0;
    unsafe {
        assert_eq!(fmi::fmi2GetReal(c, null(), 0, null_mut()), ERROR); // Instantiated
        assert_eq!(fmu.set("EA", 2e5), OK); // a fixed parameter before init
        fmu.init(0.0, 1.0);
        assert_eq!(fmi::fmi2GetReal(c, null(), 0, null_mut()), OK);
        assert_eq!(fmi::fmi2SetReal(c, null(), 0, null()), OK);
        assert_eq!(fmi::fmi2GetReal(c, &uz, 1, null_mut()), ERROR);
        assert_eq!(fmi::fmi2SetReal(c, null(), 1, &value), ERROR);
        assert_eq!(fmi::fmi2GetReal(c, &9999, 1, &mut value), ERROR);
    }
    assert_eq!(fmu.set_vr(&[9999], &[1.0]), ERROR);
    assert_eq!(fmu.set("midspan_uz", 1.0), ERROR);
    assert_eq!(fmu.set("EA", 3e5), ERROR);
    assert_eq!(fmu.set("P", f64::NAN), ERROR);
    assert_eq!(fmu.set("P", f64::INFINITY), ERROR);
    assert_eq!(fmu.get("EA"), 2e5);
    assert_eq!(fmu.set("pretension", 150.0), OK); // tunable at a communication point
                                                  // All or nothing: P keeps its value when the second one is rejected.
    assert_eq!(fmu.set_vr(&[p, p], &[50.0, f64::NAN]), ERROR);
    assert_eq!(fmu.get("P"), 0.0);
    let (mut flag, iterations) = (0, fx.vr("newton_iterations"));
    unsafe {
        assert_eq!(fmi::fmi2GetBoolean(c, &p, 1, &mut flag), ERROR);
        assert_eq!(fmi::fmi2SetString(c, &p, 1, null()), ERROR);
        assert_eq!(fmi::fmi2GetBoolean(c, null(), 0, null_mut()), OK);
        assert_eq!(fmi::fmi2SetInteger(c, &iterations, 1, &3), ERROR);
    }
    let messages = log.messages().join("\n");
    let expected = [
        "value reference 9999",
        "midspan_uz",
        "is an output",
        "fixed parameter",
    ];
    for needle in expected
        .iter()
        .chain(&["NaN", "inf", "no Boolean variable"])
    {
        assert!(
            messages.contains(needle),
            "{needle} missing in:\n{messages}"
        );
    }
}

#[test]
fn tunable_parameter_acts_on_the_next_step_and_instances_are_independent() {
    let fx = Fixture::standard();
    let log = Log::default();
    let (a, b) = (fx.fmu(&log, false), fx.fmu(&log, false));
    for fmu in [&a, &b] {
        fmu.init(0.0, 1.0);
        assert_eq!(fmu.set("P", 300.0), OK);
    }
    assert_eq!(b.set("pretension", 400.0), OK);
    assert_eq!([a.step(0.0, 0.1), b.step(0.0, 0.1)], [OK; 2]);
    let (ua, ub) = (a.get("midspan_uz"), b.get("midspan_uz"));
    assert!(
        ub.abs() < ua.abs(),
        "more pretension, less sag: {ua} vs {ub}"
    );
}

#[test]
fn reset_gives_the_same_run_as_a_fresh_instance() {
    let fx = Fixture::standard();
    let log = Log::default();
    let run = |fmu: &Fmu| -> Vec<Vec<u64>> {
        fmu.init(0.0, 1.0);
        let step = |k| (fmu.load_step(k), fmu.outputs());
        (0..4)
            .map(step)
            .map(|(s, o)| if s == OK { o } else { panic!("{s:?}") })
            .collect()
    };
    let fmu = fx.fmu(&log, false);
    let first = run(&fmu);
    for _ in 0..3 {
        assert_eq!(fmu.reset(), OK);
        assert_eq!(run(&fmu), first);
    }
    assert_eq!(run(&fx.fmu(&log, false)), first);
}

// ---------------------------------------------------------------------------------------------
// FMU state.

#[test]
fn get_step_set_step_is_bit_identical() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.load_step(0), OK);
    let mut state: FmuState = null_mut();
    assert_eq!(fmu.get_state(&mut state), OK);
    assert!(!state.is_null());
    assert_eq!(fmu.load_step(1), OK);
    let first = fmu.outputs();
    assert_eq!(fmu.set_state(state), OK);
    assert_eq!(fmu.get("P"), load(0));
    assert_eq!(fmu.load_step(1), OK); // the restored time is accepted
    assert_eq!(fmu.outputs(), first);
    // A second get with the same handle overwrites it in place.
    let same = state;
    assert_eq!(fmu.get_state(&mut state), OK);
    assert_eq!(state, same);
    assert_eq!(fmu.free_state(&mut state), OK);
    assert!(state.is_null());
    assert_eq!(fmu.free_state(&mut state), OK); // NULL: a no-op
    assert_eq!(unsafe { fmi::fmi2FreeFMUstate(fmu.c, null_mut()) }, OK);
    assert_eq!(fmu.set_state(null_mut()), ERROR);
}

/// Issue 28: the Reference-FMUs' `fmusim --final-fmu-state-file` / `--initial-fmu-state-file`
/// pass the FMU state to fmi2FreeFMUstate where its address belongs (`FMI2FreeFMUstate(S,
/// FMUState)`); the tag word of the state was then read as a pointer and dereferenced (a
/// segfault). Reproduced here without fmusim, with its calls in its order, and the other
/// pointers no instance handed out: each is fmi2Error with a message naming the argument, is
/// never dereferenced (the addresses 0x8 and usize::MAX - 7 would fault if read), and leaves
/// the state and the instance usable.
#[test]
fn foreign_and_misplaced_state_pointers_are_errors_not_crashes() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, true);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.load_step(0), OK);
    // fmusim --final-fmu-state-file: get, size, serialize, then free with the state itself.
    let mut state: FmuState = null_mut();
    assert_eq!(fmu.get_state(&mut state), OK);
    let mut size = 0usize;
    let mut bytes;
    unsafe {
        assert_eq!(fmi::fmi2SerializedFMUstateSize(fmu.c, state, &mut size), OK);
        bytes = vec![0u8; size];
        assert_eq!(
            fmi::fmi2SerializeFMUstate(fmu.c, state, bytes.as_mut_ptr().cast(), size),
            OK
        );
        log.clear();
        assert_eq!(fmi::fmi2FreeFMUstate(fmu.c, state.cast()), ERROR);
    }
    log.expect("fmi2FreeFMUstate: the FMU state argument 0x");
    log.expect("is an FMU state itself, where the address of an FMU state variable belongs");
    // The state is untouched and still this instance's.
    assert_eq!(fmu.set_state(state), OK);
    assert_eq!(fmu.free_state(&mut state), OK);
    // The same mistake in fmi2GetFMUstate.
    let mut kept: FmuState = null_mut();
    assert_eq!(fmu.get_state(&mut kept), OK);
    log.clear();
    assert_eq!(unsafe { fmi::fmi2GetFMUstate(fmu.c, kept.cast()) }, ERROR);
    log.expect("fmi2GetFMUstate: the FMU state argument 0x");
    // fmusim --initial-fmu-state-file: deserialize, set, free with the state itself.
    let mut loaded: FmuState = null_mut();
    unsafe {
        assert_eq!(
            fmi::fmi2DeSerializeFMUstate(fmu.c, bytes.as_ptr().cast(), size, &mut loaded),
            OK
        );
    }
    assert_eq!(fmu.set_state(loaded), OK);
    log.clear();
    assert_eq!(
        unsafe { fmi::fmi2FreeFMUstate(fmu.c, loaded.cast()) },
        ERROR
    );
    log.expect("is an FMU state itself");
    // Pointers this instance never handed out, or freed: not read.
    let mut freed: FmuState = null_mut();
    assert_eq!(fmu.get_state(&mut freed), OK);
    let dangling = freed;
    assert_eq!(fmu.free_state(&mut freed), OK);
    let mut forged = [0x5645_4c41_5253_5441u64; 64]; // the old state tag, then garbage
    let other = fx.fmu(&log, false);
    let mut theirs: FmuState = null_mut();
    assert_eq!(other.get_state(&mut theirs), OK);
    for foreign in [
        8 as FmuState,
        (usize::MAX - 7) as FmuState,
        forged.as_mut_ptr().cast(),
        dangling,
        theirs,
    ] {
        log.clear();
        assert_eq!(fmu.set_state(foreign), ERROR, "{foreign:p}");
        log.expect("is not a live FMU state of this instance");
        let mut slot = foreign;
        assert_eq!(fmu.free_state(&mut slot), ERROR, "{foreign:p}");
        assert_eq!(slot, foreign, "a rejected state is left as it was");
        assert_eq!(fmu.get_state(&mut slot), ERROR, "{foreign:p}");
        unsafe {
            assert_eq!(
                fmi::fmi2SerializedFMUstateSize(fmu.c, foreign, &mut size),
                ERROR
            );
            assert_eq!(
                fmi::fmi2SerializeFMUstate(fmu.c, foreign, bytes.as_mut_ptr().cast(), size),
                ERROR
            );
        }
    }
    // The other instance's state is still its own; the instance still steps.
    assert_eq!(other.free_state(&mut theirs), OK);
    assert_eq!(fmu.set_state(kept), OK);
    assert_eq!(fmu.load_step(1), OK);
    // `kept` and `loaded` are still held: fmi2FreeInstance frees them (Fmu's drop).
}

#[test]
fn serialized_state_continues_identically_in_a_fresh_instance() {
    let fx = Fixture::standard();
    let log = Log::default();
    let a = fx.fmu(&log, false);
    a.init(0.0, 1.0);
    for k in 0..3 {
        assert_eq!(a.load_step(k), OK);
    }
    let bytes = a.serialize();
    assert_eq!(&bytes[..8], b"VLRMSTAT");
    let b = fx.fmu(&log, false); // not initialized
    assert_eq!(b.restore(&bytes), OK);
    for k in 3..6 {
        assert_eq!([a.load_step(k), b.load_step(k)], [OK; 2]);
        assert_eq!(a.outputs(), b.outputs(), "step {k}");
    }
}

fn fnv1a64(bytes: &[u8]) -> u64 {
    let prime = 0x0000_0100_0000_01b3;
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(prime)
    })
}

#[test]
fn damaged_state_bytes_are_rejected() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    let bytes = fmu.serialize();
    let n = bytes.len();
    let changed = |at: usize, value: u8| {
        let mut b = bytes.clone();
        b[at] = value;
        b
    };
    // Another FMU's GUID with a valid checksum: only the GUID check can catch it.
    let mut foreign = bytes[..n - 8].to_vec();
    foreign[17] = if foreign[17] == b'0' { b'1' } else { b'0' };
    foreign.extend_from_slice(&fnv1a64(&foreign).to_le_bytes());
    let cases = [
        (Vec::new(), "length check failed"),
        (bytes[..n / 2].to_vec(), "length check failed"),
        (bytes[..n - 1].to_vec(), "length check failed"),
        ([bytes.clone(), vec![0]].concat(), "length check failed"),
        (changed(n - 20, bytes[n - 20] ^ 1), "checksum check failed"),
        (changed(0, b'X'), "magic check failed"),
        (changed(8, 99), "version check failed"),
        (foreign, "GUID check failed"),
    ];
    for (case, word) in &cases {
        log.clear();
        assert_eq!(fmu.restore(case), ERROR, "{word}");
        log.expect(word);
    }
    for cut in 0..n {
        assert_eq!(fmu.restore(&bytes[..cut]), ERROR);
    }
    assert_eq!(fmu.restore(&bytes), OK);
}

// ---------------------------------------------------------------------------------------------
// Failure handling.

#[test]
fn non_convergence_discards_and_terminates() {
    let fx = Fixture::new("velarium-fmi-fragile", &fragile_scene_text());
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    assert_eq!(fmu.debug_logging(true, &[c"logStatusDiscard"]), OK);
    fmu.init(0.0, 1.0);
    let before = fmu.outputs();
    let mut saved: FmuState = null_mut();
    assert_eq!(fmu.get_state(&mut saved), OK);
    assert_eq!(fmu.set("P", 5000.0), OK);
    assert_eq!(fmu.step(0.0, 0.1), DISCARD);
    assert_eq!(fmu.outputs(), before, "the last converged state is kept");
    assert_eq!(fmu.terminated(), Ok(true));
    assert_eq!(fmu.real_status(fmi::FMI2_LAST_SUCCESSFUL_TIME), Ok(0.0));
    let records = log.records();
    let discard = records
        .iter()
        .find(|r| r.status == DISCARD)
        .expect("a message");
    assert_eq!(discard.category, "logStatusDiscard");
    let reference = format!("P (#r{}#) = ", fx.vr("P"));
    assert!(
        discard.message.contains("% of the load change"),
        "{}",
        discard.message
    );
    assert!(discard.message.contains(&reference), "{}", discard.message);
    assert_eq!(fmu.step(0.0, 0.1), ERROR, "no silent retry in StepFailed");
    // Rolling back returns to StepComplete, where a tiny load change converges.
    assert_eq!(fmu.set_state(saved), OK);
    assert_eq!(fmu.terminated(), Ok(false));
    assert_eq!(fmu.set("P", 1e-9), OK);
    assert_eq!(fmu.step(0.0, 0.1), OK);
    assert_eq!(fmu.free_state(&mut saved), OK);
    assert_eq!(fmu.set("P", 5000.0), OK);
    assert_eq!(fmu.step(0.1, 0.1), DISCARD);
    assert_eq!(fmu.terminate(), OK);
}

/// The standard scene with a `debug` section, each switch also exposed as a tunable parameter
/// `debug_<field>` (what the harness's debug variants do).
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

#[test]
fn debug_fail_after_time_discards_the_step_that_passes_it_even_without_logging() {
    let fx = Fixture::new(
        "velarium-fmi-debug-fail",
        &debug_scene_text(&[("fail_after_time", 0.25)]),
    );
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.load_step(0), OK);
    assert_eq!(
        fmu.load_step(1),
        OK,
        "the step ending at 0.2 is before 0.25"
    );
    let before = fmu.outputs();
    assert_eq!(fmu.load_step(2), DISCARD);
    assert_eq!(fmu.outputs(), before);
    assert_eq!(fmu.terminated(), Ok(true));
    assert_eq!(fmu.real_status(fmi::FMI2_LAST_SUCCESSFUL_TIME), Ok(0.2));
    log.expect("forced by debug.fail_after_time = 0.25");
    assert!(log
        .records()
        .iter()
        .all(|r| r.category == "logStatusDiscard"));
}

#[test]
fn debug_switch_is_a_tunable_parameter() {
    let fx = Fixture::new(
        "velarium-fmi-debug-tune",
        &debug_scene_text(&[("fail_after_time", 1e9)]),
    );
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.load_step(0), OK);
    assert_eq!(fmu.set("debug_fail_after_time", 0.1), OK);
    assert_eq!(fmu.load_step(1), DISCARD);
}

#[test]
fn debug_panic_after_time_is_an_error_and_reset_recovers() {
    let fx = Fixture::new(
        "velarium-fmi-debug-panic",
        &debug_scene_text(&[("panic_after_time", 0.15)]),
    );
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.load_step(0), OK);
    assert_eq!(fmu.load_step(1), ERROR);
    log.expect("forced panic");
    assert_eq!(fmu.step(0.1, 0.1), ERROR, "the instance is in state Error");
    assert_eq!(fmu.reset(), OK);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.load_step(0), OK);
}

#[test]
fn a_debug_parameter_needs_a_value_in_the_scene() {
    let mut scene: serde_json::Value = serde_json::from_str(&scene_text()).unwrap();
    let parameter = serde_json::json!({"name": "f", "target": "debug.fail_after_time"});
    scene["parameters"].as_array_mut().unwrap().push(parameter);
    let scene = Scene::from_json(&scene.to_string()).unwrap();
    let message = Engine::try_new(scene).err().expect("rejected").to_string();
    assert!(
        message.contains("debug.fail_after_time must be given a value"),
        "{message}"
    );
}

// ---------------------------------------------------------------------------------------------
// Logging.

#[test]
fn messages_use_percent_s_and_keep_percent_literal() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    assert_eq!(fmu.debug_logging(true, &[c"log%s%n#1"]), ERROR);
    let records = log.records();
    assert_eq!(records.len(), 1, "{records:?}");
    let r = &records[0];
    assert_eq!(
        (r.format.as_str(), r.instance.as_str(), r.status),
        ("%s", "inst", ERROR)
    );
    assert!(
        r.message.contains("\"log%s%n##1\""),
        "'#' doubled, '%' literal: {}",
        r.message
    );
    assert!(!r.message.ends_with('\n'));
}

/// With logging on, instantiation logs the model's memory on logSolver: the engine's estimate
/// for model and solver and the host's peak resident set, both positive.
#[test]
fn instantiation_logs_the_memory_estimate_and_peak() {
    let fx = Fixture::standard();
    let log = Log::default();
    let _fmu = fx.fmu(&log, true);
    let records = log.records();
    let memory = records
        .iter()
        .find(|r| r.message.starts_with("memory: estimated "))
        .unwrap_or_else(|| panic!("no memory line in {records:?}"));
    assert_eq!((memory.category.as_str(), memory.status), ("logSolver", OK));
    let numbers: Vec<f64> = memory
        .message
        .split([' ', ';', ','])
        .filter_map(|w| w.parse::<f64>().ok())
        .collect();
    assert!(
        numbers.len() >= 2 && numbers[0] > 0.0 && numbers[1] > 0.0,
        "{}",
        memory.message
    );
    assert!(
        memory.message.contains("peak resident"),
        "{}",
        memory.message
    );
}

#[test]
fn categories_are_switched_as_asked() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, false);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.load_step(0), OK);
    assert!(
        log.records().is_empty(),
        "loggingOn = 0: an OK run is silent"
    );
    // Only the solver.
    assert_eq!(fmu.debug_logging(true, &[c"logSolver"]), OK);
    assert_eq!(fmu.load_step(1), OK);
    let categories: Vec<String> = log.records().into_iter().map(|r| r.category).collect();
    assert!(!categories.is_empty(), "the solver logs its iterations");
    assert!(
        categories.iter().all(|c| c == "logSolver"),
        "{categories:?}"
    );
    // All on (no names): the call trace appears.
    log.clear();
    assert_eq!(fmu.debug_logging(true, &[]), OK);
    assert_eq!(fmu.load_step(2), OK);
    log.expect("fmi2DoStep(currentCommunicationPoint=0.2");
    // All off: errors are still logged.
    assert_eq!(fmu.debug_logging(false, &[]), OK);
    log.clear();
    assert_eq!(fmu.load_step(3), OK);
    assert_eq!(fmu.step(9.0, 0.1), ERROR);
    let records = log.records();
    assert_eq!(records.len(), 1, "{records:?}");
    assert_eq!(records[0].category, "logStatusError");
    assert_eq!(
        unsafe { fmi::fmi2SetDebugLogging(fmu.c, 1, 2, null()) },
        ERROR
    );
}

#[test]
fn declared_categories_and_flags() {
    let names: Vec<&str> = fmi::log_categories().iter().map(|(n, _)| *n).collect();
    let expected = [
        "logStatusWarning",
        "logStatusDiscard",
        "logStatusError",
        "logStatusFatal",
    ];
    assert_eq!(names, [&expected[..], &["logSolver", "logCalls"]].concat());
    let flags: std::collections::HashMap<_, _> = fmi::capability_flags().iter().copied().collect();
    for on in [
        "canGetAndSetFMUstate",
        "canSerializeFMUstate",
        "canNotUseMemoryManagementFunctions",
    ] {
        assert!(flags[on], "{on}");
    }
    assert!(flags["canHandleVariableCommunicationStepSize"]);
    assert!(!flags["canInterpolateInputs"] && flags["providesDirectionalDerivative"]);
}

// ---------------------------------------------------------------------------------------------
// Issue 11: hostile input never takes the host down (FMI side).

/// Time rules of fmi2DoStep (docs/fmu.md, "Stepping"): time must move, end finite, and a step may
/// end past stopTime by at most 1e-9 · max(|stopTime|, h).
#[test]
fn do_step_time_rules() {
    let fx = Fixture::standard();
    let log = Log::default();
    // No stopTime: h = 1e308 from 0 is accepted once; a second one would reach +inf.
    let fmu = fx.fmu(&log, true);
    let no_stop = unsafe { fmi::fmi2SetupExperiment(fmu.c, 0, 0.0, 0.0, 0, 0.0) };
    assert_eq!([no_stop, fmu.enter(), fmu.exit()], [OK, OK, OK]);
    assert_eq!(fmu.step(0.0, 1e308), OK);
    assert_eq!(fmu.step(1e308, 1e308), ERROR);
    log.expect("non-finite time");
    drop(fmu);
    let fmu = fx.fmu(&log, true);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.step(0.0, 0.5), OK);
    // t + h == t at t = 0.5: an error, and time stays.
    assert_eq!(fmu.step(0.5, 1e-300), ERROR);
    log.expect("t + h == t");
    // Ending 0.5e-9 past stopTime (tolerance 1e-9 · max(1, h)) is accepted; 1e-7 is not.
    drop(fmu);
    let fmu = fx.fmu(&log, true);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.step(0.0, 1.0 + 0.5e-9), OK);
    drop(fmu);
    let fmu = fx.fmu(&log, true);
    fmu.init(0.0, 1.0);
    assert_eq!(fmu.step(0.0, 1.0 + 1e-7), ERROR);
    log.expect("ends after stopTime");
}

/// A scene above the size limits: Instantiate returns NULL and the logger says why; so does a
/// scene whose generated triangles have zero area.
#[test]
fn instantiate_refuses_a_scene_too_large_or_degenerate_with_a_message() {
    let fx = Fixture::standard();
    let disc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/modelDescription/HenckyDisc/scene.json"
    ))
    .unwrap();
    for (scene, needle) in [
        (
            disc.replace("\"rings\": 16", "\"rings\": 100000"),
            "max_nodes",
        ),
        (
            disc.replace("\"center\": [0, 0, 0]", "\"center\": [0, 1e19, 0]"),
            "zero area in floating point",
        ),
    ] {
        std::fs::write(fx.root.join("resources/scene.json"), scene).unwrap();
        let log = Log::default();
        let c = instantiate(&fx.guid, &fx.uri, &log, false);
        assert!(c.is_null());
        log.expect("fmi2Instantiate");
        log.expect(needle);
    }
}

/// The varint (LEB128: postcard's lengths) at `*at`; moves `*at` past it.
fn varint(bytes: &[u8], at: &mut usize) -> usize {
    let (mut n, mut shift) = (0, 0);
    loop {
        let b = bytes[*at];
        *at += 1;
        n |= usize::from(b & 0x7f) << shift;
        if b < 0x80 {
            return n;
        }
        shift += 7;
    }
}

/// Serialized states resealed after a value edit (checksum recomputed): NaN, inf and 1e308 in
/// a displacement and a NaN parameter are fmi2Error naming the field, and the instance keeps
/// its state and outputs.
#[test]
fn resealed_states_with_bad_values_are_rejected_and_change_nothing() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, true);
    fmu.init(0.0, 10.0);
    assert_eq!(fmu.load_step(0), OK);
    let bytes = fmu.serialize();
    let before = fmu.outputs();
    let guid_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    // The payload (postcard) opens with EngineState: displacement (varint n + f64s),
    // slip_state (varint n + u8s), applied, inputs, parameters (varint n + f64s each).
    let mut at = 24 + guid_len;
    let n_dofs = varint(&bytes, &mut at);
    let u = at + 8 * 3; // displacement[3], node 1 x
    at += 8 * n_dofs;
    let n_slips = varint(&bytes, &mut at);
    at += n_slips;
    for _applied_then_inputs in 0..2 {
        let n_in = varint(&bytes, &mut at);
        at += 8 * n_in;
    }
    varint(&bytes, &mut at);
    let parameter = at; // parameter[0]
    let reseal = |at: usize, value: f64| {
        let mut b = bytes.clone();
        b[at..at + 8].copy_from_slice(&value.to_le_bytes());
        let n = b.len();
        let sum = b[..n - 8].iter().fold(0xcbf2_9ce4_8422_2325u64, |h, x| {
            (h ^ u64::from(*x)).wrapping_mul(0x0000_0100_0000_01b3)
        });
        b[n - 8..].copy_from_slice(&sum.to_le_bytes());
        b
    };
    for (at, value, needle) in [
        (u, f64::NAN, "displacement[3]"),
        (u, f64::INFINITY, "displacement[3]"),
        (u, 1e308, "displacement[3]"),
        (parameter, f64::NAN, "parameter"),
    ] {
        log.clear();
        assert_eq!(fmu.restore(&reseal(at, value)), ERROR, "{needle}");
        log.expect(needle);
        assert_eq!(fmu.outputs(), before);
    }
    // The untouched bytes still restore.
    assert_eq!(
        fmu.restore(&reseal(
            u,
            f64::from_le_bytes(bytes[u..u + 8].try_into().unwrap())
        )),
        OK
    );
}

/// Issue 28: a serialized state resealed with vectors of the wrong length (one displacement
/// too many, one applied input value too few, no parameters) used to panic inside
/// fmi2SetFMUstate (an index out of range in the value checks): the panic was caught, but its
/// text landed on the host's stderr and the instance went to Error. Now the lengths are
/// checked first: fmi2Error with a message naming the vector and both lengths, no panic (the
/// instance is not moved to Error and still steps), and the outputs are unchanged.
#[test]
fn resealed_states_with_wrong_lengths_are_rejected_without_a_panic() {
    let fx = Fixture::standard();
    let log = Log::default();
    let fmu = fx.fmu(&log, true);
    fmu.init(0.0, 10.0);
    assert_eq!(fmu.load_step(0), OK);
    let bytes = fmu.serialize();
    let before = fmu.outputs();
    let guid_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let payload_at = 24 + guid_len;
    let payload = &bytes[payload_at..bytes.len() - 8];
    // postcard: displacement, slip_state, applied, inputs, parameters (varint n + items).
    let mut at = 0;
    let mut vectors = Vec::new(); // (start of the varint, start of the items, n, item size)
    for size in [8, 1, 8, 8, 8] {
        let start = at;
        let n = varint(payload, &mut at);
        vectors.push((start, at, n, size));
        at += n * size;
    }
    // A payload with vector `k` given `n` items (the first ones, or zeros appended).
    let resized = |k: usize, n: usize| {
        let (start, items, old, size) = vectors[k];
        assert!(n < 128 && old < 128, "one-byte varints");
        let mut p = payload[..start].to_vec();
        p.push(n as u8);
        let mut body = payload[items..items + old.min(n) * size].to_vec();
        body.resize(n * size, 0);
        p.extend_from_slice(&body);
        p.extend_from_slice(&payload[items + old * size..]);
        let mut b = bytes[..16 + guid_len].to_vec();
        b.extend_from_slice(&(p.len() as u64).to_le_bytes());
        b.extend_from_slice(&p);
        b.extend_from_slice(&fnv1a64(&b).to_le_bytes());
        b
    };
    let (n_dofs, n_applied, n_parameters) = (vectors[0].2, vectors[2].2, vectors[4].2);
    assert!(n_applied >= 1 && n_parameters >= 1);
    for (forged, needle) in [
        (
            resized(0, n_dofs + 1),
            format!(
                "displacement has {} values, this model has {n_dofs} unknowns",
                n_dofs + 1
            ),
        ),
        (
            resized(2, n_applied - 1),
            format!(
                "applied has {} values, this model has {n_applied} input values",
                n_applied - 1
            ),
        ),
        (
            resized(4, 0),
            format!("parameters has 0 values, this model has {n_parameters} parameters"),
        ),
    ] {
        log.clear();
        assert_eq!(fmu.restore(&forged), ERROR, "{needle}");
        log.expect(&needle);
        assert!(
            !log.messages().iter().any(|m| m.contains("panic")),
            "{:?}",
            log.messages()
        );
        assert_eq!(fmu.outputs(), before);
    }
    // Not in Error (a caught panic would have put it there): it steps on.
    assert_eq!(fmu.load_step(1), OK);
}

// ---------------------------------------------------------------------------------------------
// Issue 27: solver settings out of range and plausibility warnings at Instantiate.

/// The two `solver.max_iterations` of issue 27 (4294967296 made the Newton history ask for
/// 34 GB and the host abort in fmi2ExitInitializationMode; 18446744073709551615 made a failing
/// step loop forever): fmi2Instantiate returns NULL and logs the path and the range.
#[test]
fn instantiate_refuses_max_iterations_out_of_range_with_a_message() {
    let fx = Fixture::standard();
    for value in ["4294967296", "18446744073709551615"] {
        let mut scene: serde_json::Value = serde_json::from_str(&scene_text()).unwrap();
        scene["solver"] =
            serde_json::from_str(&format!("{{\"max_iterations\": {value}}}")).unwrap();
        std::fs::write(fx.root.join("resources/scene.json"), scene.to_string()).unwrap();
        let log = Log::default();
        let c = instantiate(&fx.guid, &fx.uri, &log, false);
        assert!(c.is_null(), "{value}");
        let records = log.records();
        assert_eq!(records.len(), 1, "{records:?}");
        assert_eq!(records[0].status, ERROR);
        for needle in [
            "fmi2Instantiate",
            "solver.max_iterations",
            value,
            "1..=10000",
        ] {
            assert!(records[0].message.contains(needle), "{needle}: {records:?}");
        }
    }
}

/// A valid scene with an implausible number (the Hencky disc with E = 600 Pa, 1667x below the
/// usual range of a sheet) instantiates, and with logging on the warning is logged on
/// logStatusWarning with fmi2Warning, naming the path; with logging off nothing is logged.
#[test]
fn instantiate_logs_plausibility_warnings_and_builds_the_instance() {
    let disc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/modelDescription/HenckyDisc/scene.json"
    ))
    .unwrap();
    assert!(disc.contains("\"E\": 2e8"));
    let fx = Fixture::new(
        "velarium-fmi-warning",
        &disc.replace("\"E\": 2e8", "\"E\": 600"),
    );
    let log = Log::default();
    let fmu = fx.fmu(&log, true);
    let warnings: Vec<Record> = log
        .records()
        .into_iter()
        .filter(|r| r.category == "logStatusWarning")
        .collect();
    assert_eq!(warnings.len(), 1, "{:?}", log.records());
    assert_eq!(warnings[0].status, Status::Warning);
    assert!(
        warnings[0]
            .message
            .starts_with("fmi2Instantiate: membranes[0].material.E: 6e2 Pa"),
        "{warnings:?}"
    );
    drop(fmu);
    let quiet = Log::default();
    let _fmu = fx.fmu(&quiet, false);
    assert!(quiet.records().is_empty(), "{:?}", quiet.records());
    // The shipped disc: no warning.
    let fx = Fixture::new("velarium-fmi-warning", &disc);
    let log = Log::default();
    let _fmu = fx.fmu(&log, true);
    assert!(
        log.records()
            .iter()
            .all(|r| r.category != "logStatusWarning"),
        "{:?}",
        log.records()
    );
}
