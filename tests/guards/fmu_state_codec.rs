//! GOAL: serialized FMU states are read through `fmi2DeSerializeFMUstate` without trusting
//!       the lengths they announce. Payloads behind a valid header and a recomputed checksum
//!       (what a hostile or corrupted writer that reseals can send): a displacement length
//!       prefix of u64::MAX, 2^40, 2^20 or 2^17, every truncation, trailing bytes. Each is
//!       fmi2Error with "payload check failed" in the log (a caught panic would log something
//!       else and move the instance to Error), and the bytes allocated during the call stay
//!       within the bound below whatever length they announce. A state of format version 2
//!       (the fixed-width payload before postcard) is refused by the version check.
//! MESH: the shipped PrestressedCable scene (3 nodes, 9 displacements), P = 200 N, one step.
//! REFERENCE: FMI 2.0.4 §2.1.8 (serialized FMU state); src/fmi/snapshot.rs (the byte layout).
//!       Bound: peak bytes allocated during one fmi2DeSerializeFMUstate call (a counting global
//!       allocator) <= 2 n + 16 KiB for n bytes given: the call's memory probe reserves 2 n
//!       (`Instance::deserialize_fmu_state`), the decoded state takes about n, the messages a
//!       few hundred bytes. Measured with the good bytes, and for the hostile ones it leaves
//!       out what the old format allowed: serde preallocated up to 1 MiB for an announced
//!       length it could not check.

use std::ffi::{c_char, c_void, CStr, CString};
use std::ptr::null_mut;
use std::sync::atomic::{AtomicUsize, Ordering::SeqCst};
use std::sync::Mutex;
use velarium::fmi::{self, CallbackFunctions, Component, FmuState, LoggerFn, Status};
use velarium::{Engine, Scene};

/// Bytes allocated and not yet freed, and the most since the last reset.
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

/// `size` bytes allocated (the binary's counting allocator, `guards/main.rs`).
pub fn alloc(size: usize) {
    let live = LIVE.fetch_add(size, SeqCst) + size;
    PEAK.fetch_max(live, SeqCst);
}

/// `size` bytes freed.
pub fn dealloc(size: usize) {
    let _ = LIVE.fetch_update(SeqCst, SeqCst, |v| Some(v.saturating_sub(size)));
}

/// The tests of this file run one at a time: the counters are global (and each runs
/// [`alone`](crate::alone) in a process of its own, so no other test allocates beside it).
static SERIAL: Mutex<()> = Mutex::new(());

/// The messages logged, captured by a logger with a fixed sixth parameter for the first
/// variadic one (the FMU always logs with the format "%s"; the same trick as the logger of
/// tests/fmi_abi.rs, on the same targets).
#[derive(Default)]
struct Log(Mutex<Vec<String>>);

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
    _: *const c_char,
    _: Status,
    _: *const c_char,
    _: *const c_char,
    msg: *const c_char,
) {
    let log = &*(env as *const Log);
    let text = CStr::from_ptr(msg).to_string_lossy().into_owned();
    log.0.lock().unwrap().push(text);
}

struct Fmu {
    c: Component,
    /// Value reference of the input P.
    p: u32,
    _root: std::path::PathBuf,
}

impl Fmu {
    fn new(tag: &str, log: &Log) -> Fmu {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/modelDescription/PrestressedCable/scene.json"
        );
        let text = std::fs::read_to_string(path).unwrap();
        let engine = Engine::try_new(Scene::from_json(&text).unwrap()).unwrap();
        let guid = CString::new(velarium::description::guid(
            engine.scene(),
            engine.variables(),
        ))
        .unwrap();
        let root =
            std::env::temp_dir().join(format!("velarium-state-codec-{tag}-{}", std::process::id()));
        let resources = root.join("resources");
        std::fs::create_dir_all(&resources).unwrap();
        std::fs::write(resources.join("scene.json"), text).unwrap();
        let uri = CString::new(format!("file://{}", resources.display())).unwrap();
        // SAFETY: see `Log` (a fixed sixth argument for the first variadic one).
        let logger = unsafe { std::mem::transmute::<FixedLogger, LoggerFn>(capture) };
        let cb = CallbackFunctions {
            logger: Some(logger),
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: log as *const Log as *mut c_void,
        };
        let c = unsafe {
            fmi::fmi2Instantiate(c"codec".as_ptr(), 1, guid.as_ptr(), uri.as_ptr(), &cb, 0, 1)
        };
        assert!(!c.is_null());
        let p = engine.variables().iter().find(|v| v.name == "P").unwrap();
        Fmu {
            c,
            p: p.value_reference,
            _root: root,
        }
    }

    /// Initialize, step once under P = 200 N, and serialize.
    fn stepped_state(&self) -> Vec<u8> {
        let (mut state, mut size): (FmuState, usize) = (null_mut(), 0);
        unsafe {
            assert_eq!(
                fmi::fmi2SetupExperiment(self.c, 0, 0.0, 0.0, 1, 1.0),
                Status::Ok
            );
            assert_eq!(fmi::fmi2EnterInitializationMode(self.c), Status::Ok);
            assert_eq!(fmi::fmi2ExitInitializationMode(self.c), Status::Ok);
            assert_eq!(fmi::fmi2SetReal(self.c, &self.p, 1, &200.0), Status::Ok);
            assert_eq!(fmi::fmi2DoStep(self.c, 0.0, 0.1, 1), Status::Ok);
            assert_eq!(fmi::fmi2GetFMUstate(self.c, &mut state), Status::Ok);
            assert_eq!(
                fmi::fmi2SerializedFMUstateSize(self.c, state, &mut size),
                Status::Ok
            );
            let mut bytes = vec![0u8; size];
            let buffer = bytes.as_mut_ptr().cast();
            assert_eq!(
                fmi::fmi2SerializeFMUstate(self.c, state, buffer, size),
                Status::Ok
            );
            assert_eq!(fmi::fmi2FreeFMUstate(self.c, &mut state), Status::Ok);
            bytes
        }
    }

    /// Deserialize (and free the state made, if any): the status and the peak bytes allocated
    /// during the call.
    fn deserialize(&self, bytes: &[u8]) -> (Status, usize) {
        let mut state: FmuState = null_mut();
        let base = LIVE.load(SeqCst);
        PEAK.store(base, SeqCst);
        let status = unsafe {
            fmi::fmi2DeSerializeFMUstate(self.c, bytes.as_ptr().cast(), bytes.len(), &mut state)
        };
        let peak = PEAK.load(SeqCst) - base;
        if !state.is_null() {
            unsafe { assert_eq!(fmi::fmi2FreeFMUstate(self.c, &mut state), Status::Ok) };
        }
        (status, peak)
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi::fmi2FreeInstance(self.c) };
        let _ = std::fs::remove_dir_all(&self._root);
    }
}

/// `bytes` (a state written by the FMU) with another version and payload, the payload length
/// and the checksum (FNV-1a 64) recomputed.
fn reseal(bytes: &[u8], version: u32, payload: &[u8]) -> Vec<u8> {
    let guid_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut out = bytes[..16 + guid_len].to_vec();
    out[8..12].copy_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(payload);
    let sum = out.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, x| {
        (h ^ u64::from(*x)).wrapping_mul(0x0000_0100_0000_01b3)
    });
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// The payload of a state written by the FMU.
fn payload(bytes: &[u8]) -> &[u8] {
    let guid_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    &bytes[24 + guid_len..bytes.len() - 8]
}

/// A varint (LEB128, what postcard writes) of `n`.
fn varint(mut n: u64) -> Vec<u8> {
    let mut out = Vec::new();
    while n >= 0x80 {
        out.push(n as u8 | 0x80);
        n >>= 7;
    }
    out.push(n as u8);
    out
}

#[test]
#[cfg(all(
    unix,
    any(target_arch = "x86_64", target_arch = "aarch64"),
    not(target_vendor = "apple")
))]
fn hostile_payloads_are_refused_within_a_bounded_allocation() {
    if !crate::alone(
        module_path!(),
        "hostile_payloads_are_refused_within_a_bounded_allocation",
    ) {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let log = Log::default();
    let fmu = Fmu::new("hostile", &log);
    let good = fmu.stepped_state();
    assert_eq!(good[8..12], fmi::STATE_FORMAT_VERSION.to_le_bytes());
    let bound = |n: usize| 2 * n + 16 * 1024;
    let (status, peak) = fmu.deserialize(&good);
    assert_eq!(status, Status::Ok);
    println!(
        "good state: {} bytes, peak {peak} bytes allocated",
        good.len()
    );
    assert!(peak <= bound(good.len()), "{peak}");

    let body = payload(&good);
    assert_eq!(
        body[0], 9,
        "the payload opens with the displacement's length"
    );
    let mut hostile: Vec<(String, Vec<u8>)> = Vec::new();
    for length in [u64::MAX, 1 << 40, 1 << 20, 1 << 17] {
        let p = [&varint(length)[..], &body[1..]].concat();
        hostile.push((format!("length {length}"), p));
    }
    for cut in 0..body.len() {
        hostile.push((format!("cut at {cut}"), body[..cut].to_vec()));
    }
    hostile.push(("trailing".into(), [body, &[0u8; 16][..]].concat()));
    let mut worst = 0;
    for (what, p) in &hostile {
        log.0.lock().unwrap().clear();
        let bytes = reseal(&good, fmi::STATE_FORMAT_VERSION, p);
        let (status, peak) = fmu.deserialize(&bytes);
        assert_eq!(status, Status::Error, "{what}");
        let messages = log.0.lock().unwrap().clone();
        assert!(
            messages
                .iter()
                .any(|m| m.contains("fmi2DeSerializeFMUstate: payload check failed")),
            "{what}: {messages:?}"
        );
        assert!(peak <= bound(bytes.len()), "{what}: {peak} bytes allocated");
        worst = worst.max(peak);
    }
    println!(
        "{} hostile payloads: peak {worst} bytes allocated at most",
        hostile.len()
    );
    // The instance is unharmed: the good bytes still deserialize.
    assert_eq!(fmu.deserialize(&good).0, Status::Ok);
}

#[test]
#[cfg(all(
    unix,
    any(target_arch = "x86_64", target_arch = "aarch64"),
    not(target_vendor = "apple")
))]
fn a_state_of_format_version_2_is_refused() {
    if !crate::alone(module_path!(), "a_state_of_format_version_2_is_refused") {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let log = Log::default();
    let fmu = Fmu::new("version", &log);
    let good = fmu.stepped_state();
    let old = reseal(&good, 2, payload(&good));
    assert_eq!(fmu.deserialize(&old).0, Status::Error);
    let messages = log.0.lock().unwrap().clone();
    assert!(
        messages
            .iter()
            .any(|m| m.contains("version check failed: format version 2, this FMU reads 3")),
        "{messages:?}"
    );
}
