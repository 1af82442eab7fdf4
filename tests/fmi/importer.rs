//! A second FMI importer that is not fmpy (issue 12, item 5c): our own minimal master, written
//! here from the FMI 2.0.4 and FMI 3.0 standards' C headers, that loads the packed archives the
//! way a simulation tool does.
//!
//! For each scene: `velarium pack` writes both archives into a scratch directory; each archive is
//! unzipped, its `modelDescription.xml` parsed by the small parser below (model identifier,
//! GUID / instantiation token, every variable's name, value reference, causality, type and, in
//! FMI 3, its `<Dimension>`s), `binaries/<platform>/<id>.so` is opened with `dlopen`, and the
//! functions are resolved by name with `dlsym` and called through the C signatures written by
//! hand below (nothing of the velarium crate is linked into this test). The run: instantiate
//! (FMI 2 with a callback structure, FMI 3 `fmi3InstantiateCoSimulation`), set the first load
//! row's inputs in initialization mode, exit initialization, then per further row set the inputs
//! (an FMI 3 array input as a whole, `nValues` = its element count) and `DoStep` from the
//! previous row's time to this row's, read every output (FMI 2 `fmi2GetReal`/`fmi2GetInteger`;
//! FMI 3 `fmi3GetFloat64` of each array by its one value reference, `fmi3GetUInt8`,
//! `fmi3GetInt32`), then `Terminate`, `FreeInstance`, `dlclose`, and check that the library is no
//! longer mapped into the process.
//!
//! SCENES: the shipped `PrestressedCable` (scalars; its input `P` ramped and unloaded),
//! the shipped `SlidingCable` (two inputs, friction) and `modelDescription/ZonedCushion/scene.json` (array
//! inputs `wind` [2] and `corners` [4, 3], array outputs `u` [81, 3], `corner_x` [4, 3],
//! `edge_tension` [8], `stress` [128, 2], `wrinkle` [128] of UInt8) with
//! `examples/ZonedCushion-loads.csv`.
//!
//! REFERENCE: `velarium solve` of the same scene and load table, an independent path through the
//! engine (no FMI layer). Row 0 of its CSV is the equilibrium under row 0's loads, row k the
//! equilibrium under row k's loads reached from row k-1's: exactly what the master above reads
//! after initialization and after the k-th step. Both call the same engine with the same f64
//! inputs in the same order and the CSV prints shortest round-trip decimals, so the TOLERANCE
//! is zero: every output element of every row must be bit-identical (measured: the largest
//! difference over all outputs, rows, scenes and both FMI versions is 0). Every output column of
//! the CSV must be read through the FMU and every FMU output must have its column.
//!
//! `velarium pack` ships its default library: the portable glibc 2.17 build when
//! `harness/portable.sh` has built it (what `bash .ci/run` does), so this test runs on the
//! library the shipped FMUs hold; `VELARIUM_LIB=path/to/libvelarium.so` picks another
//! (docs/fmu.md, "Portable FMUs").

use std::collections::HashMap;
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::process::Command;

const VELARIUM: &str = env!("CARGO_BIN_EXE_velarium");

// ---------------------------------------------------------------------------------------------
// Scratch directories.

fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("velarium-importer-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn run(args: &[&str]) -> String {
    let out = Command::new(VELARIUM)
        .args(args)
        .output()
        .expect("velarium runs");
    assert!(
        out.status.success(),
        "velarium {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// `velarium pack` into `dir`: (FMI 2 archive, FMI 3 archive).
fn pack(scene: &Path, name: &str, dir: &Path) -> (PathBuf, PathBuf) {
    run(&[
        "pack",
        scene.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    (
        dir.join(format!("{name}.fmu")),
        dir.join(format!("{name}_fmi3.fmu")),
    )
}

fn unzip(archive: &Path, into: &Path) {
    let file = std::fs::File::open(archive).unwrap();
    let mut zip = zip::ZipArchive::new(file).unwrap();
    for i in 0..zip.len() {
        let mut entry = zip.by_index(i).unwrap();
        let relative = entry.enclosed_name().expect("a safe entry name");
        let path = into.join(relative);
        if entry.is_dir() {
            std::fs::create_dir_all(&path).unwrap();
            continue;
        }
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        let mut out = std::fs::File::create(&path).unwrap();
        std::io::copy(&mut entry, &mut out).unwrap();
    }
}

// ---------------------------------------------------------------------------------------------
// A small XML reader: the tags of a document, with their attributes (entities decoded).

#[derive(Debug)]
struct Tag {
    name: String,
    attrs: Vec<(String, String)>,
    closing: bool,
    self_closing: bool,
}

impl Tag {
    fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

fn decode_entities(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

fn tags(xml: &str) -> Vec<Tag> {
    let mut out = Vec::new();
    let mut rest = xml;
    while let Some(start) = rest.find('<') {
        rest = &rest[start..];
        if rest.starts_with("<!--") {
            let end = rest.find("-->").expect("a closed comment");
            rest = &rest[end + 3..];
            continue;
        }
        if rest.starts_with("<?") {
            let end = rest.find("?>").expect("a closed declaration");
            rest = &rest[end + 2..];
            continue;
        }
        // Attribute values may hold '>' only escaped, so the first '>' outside quotes ends it.
        let bytes = rest.as_bytes();
        let mut i = 1;
        let mut quote = None;
        while i < bytes.len() {
            match (quote, bytes[i]) {
                (None, b'"') | (None, b'\'') => quote = Some(bytes[i]),
                (Some(q), c) if c == q => quote = None,
                (None, b'>') => break,
                _ => {}
            }
            i += 1;
        }
        let inner = &rest[1..i];
        rest = &rest[i + 1..];
        let closing = inner.starts_with('/');
        let self_closing = inner.ends_with('/');
        let inner = inner.trim_start_matches('/').trim_end_matches('/');
        let name_end = inner
            .find(|c: char| c.is_whitespace())
            .unwrap_or(inner.len());
        let name = inner[..name_end].to_string();
        let mut attrs = Vec::new();
        let mut a = inner[name_end..].trim_start();
        while !a.is_empty() {
            let eq = a.find('=').expect("attribute =");
            let key = a[..eq].trim().to_string();
            let after = a[eq + 1..].trim_start();
            let q = after.chars().next().expect("a quoted value");
            let close = after[1..].find(q).expect("a closing quote") + 1;
            attrs.push((key, decode_entities(&after[1..close])));
            a = after[close + 1..].trim_start();
        }
        out.push(Tag {
            name,
            attrs,
            closing,
            self_closing,
        });
    }
    out
}

#[derive(Debug, Clone)]
struct Variable {
    name: String,
    vr: u32,
    causality: String,
    /// FMI 2: Real, Integer, Boolean, String, Enumeration. FMI 3: Float64, Int32, UInt8, ...
    ty: String,
    /// FMI 3 dimensions (empty for a scalar).
    dims: Vec<usize>,
    start: Option<String>,
}

impl Variable {
    fn len(&self) -> usize {
        self.dims.iter().product()
    }
}

#[derive(Debug)]
struct ModelDescription {
    fmi_version: String,
    model_identifier: String,
    token: String,
    variables: Vec<Variable>,
}

const FMI3_TYPES: &[&str] = &[
    "Float32",
    "Float64",
    "Int8",
    "UInt8",
    "Int16",
    "UInt16",
    "Int32",
    "UInt32",
    "Int64",
    "UInt64",
    "Boolean",
    "String",
    "Binary",
    "Clock",
    "Enumeration",
];

fn read_model_description(xml: &str) -> ModelDescription {
    let tags = tags(xml);
    let root = tags
        .iter()
        .find(|t| t.name == "fmiModelDescription")
        .expect("<fmiModelDescription>");
    let fmi_version = root.attr("fmiVersion").unwrap().to_string();
    let token = root
        .attr("guid")
        .or_else(|| root.attr("instantiationToken"))
        .expect("guid or instantiationToken")
        .to_string();
    let model_identifier = tags
        .iter()
        .find(|t| t.name == "CoSimulation")
        .and_then(|t| t.attr("modelIdentifier"))
        .expect("<CoSimulation modelIdentifier>")
        .to_string();
    let mut variables: Vec<Variable> = Vec::new();
    let mut inside = false;
    let mut open: Option<usize> = None; // the FMI 3 variable whose children are being read
    for tag in &tags {
        if tag.name == "ModelVariables" {
            inside = !tag.closing;
            continue;
        }
        if !inside {
            continue;
        }
        let new_variable = |tag: &Tag, ty: &str| Variable {
            name: tag.attr("name").expect("name").to_string(),
            vr: tag
                .attr("valueReference")
                .expect("valueReference")
                .parse()
                .unwrap(),
            causality: tag.attr("causality").unwrap_or("local").to_string(),
            ty: ty.to_string(),
            dims: Vec::new(),
            start: tag.attr("start").map(str::to_string),
        };
        if fmi_version.starts_with("2.") {
            // <ScalarVariable ...> <Real start=.../> </ScalarVariable>
            if tag.name == "ScalarVariable" && !tag.closing {
                variables.push(new_variable(tag, ""));
            } else if !tag.closing
                && ["Real", "Integer", "Boolean", "String", "Enumeration"]
                    .contains(&tag.name.as_str())
            {
                let v = variables
                    .last_mut()
                    .expect("a type inside <ScalarVariable>");
                v.ty = tag.name.clone();
                v.start = tag.attr("start").map(str::to_string);
            }
        } else if FMI3_TYPES.contains(&tag.name.as_str()) {
            if tag.closing {
                open = None;
            } else {
                variables.push(new_variable(tag, &tag.name));
                open = (!tag.self_closing).then(|| variables.len() - 1);
            }
        } else if tag.name == "Dimension" {
            let i = open.expect("<Dimension> inside a variable");
            let n = tag
                .attr("start")
                .expect("a fixed dimension (start)")
                .parse()
                .unwrap();
            variables[i].dims.push(n);
        }
    }
    ModelDescription {
        fmi_version,
        model_identifier,
        token,
        variables,
    }
}

// ---------------------------------------------------------------------------------------------
// CSV (the load tables and `velarium solve`'s result): a header of possibly quoted names, then
// numbers.

fn split_csv(line: &str) -> Vec<String> {
    let mut cells = Vec::new();
    let mut cell = String::new();
    let mut quoted = false;
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => cells.push(std::mem::take(&mut cell)),
            _ => cell.push(c),
        }
    }
    cells.push(cell);
    cells
}

struct Table {
    names: Vec<String>,
    rows: Vec<Vec<f64>>,
}

fn read_csv(text: &str) -> Table {
    let mut lines = text
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'));
    let names = split_csv(lines.next().expect("a header"));
    let rows = lines
        .map(|l| {
            split_csv(l)
                .iter()
                .map(|c| {
                    c.trim()
                        .parse::<f64>()
                        .unwrap_or_else(|e| panic!("{c}: {e}"))
                })
                .collect()
        })
        .collect();
    Table { names, rows }
}

/// Where a CSV column lives in the FMU: the variable and the element's row-major offset.
/// FMI 2 names every element (`u[1,2]`); FMI 3 has one array `u` with dimensions.
fn locate(md: &ModelDescription, column: &str) -> (usize, usize) {
    if let Some(i) = md.variables.iter().position(|v| v.name == column) {
        return (i, 0);
    }
    let open = column
        .find('[')
        .unwrap_or_else(|| panic!("no variable {column}"));
    let base = &column[..open];
    let indices: Vec<usize> = column[open + 1..column.len() - 1]
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let i = md
        .variables
        .iter()
        .position(|v| v.name == base)
        .unwrap_or_else(|| panic!("no variable {column} nor an array {base}"));
    let dims = &md.variables[i].dims;
    assert_eq!(dims.len(), indices.len(), "{column}: rank of {base}");
    let mut offset = 0;
    for (d, k) in dims.iter().zip(&indices) {
        assert!(*k >= 1 && k <= d, "{column}: index out of {dims:?}");
        offset = offset * d + (k - 1);
    }
    (i, offset)
}

// ---------------------------------------------------------------------------------------------
// dlopen / dlsym.

struct Library {
    handle: *mut c_void,
    path: PathBuf,
}

impl Library {
    fn open(path: &Path) -> Library {
        let c = CString::new(path.to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path; RTLD_LOCAL keeps its symbols to this handle.
        let handle = unsafe { libc::dlopen(c.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
        if handle.is_null() {
            // SAFETY: dlerror returns a C string describing the last failure.
            let why = unsafe { CStr::from_ptr(libc::dlerror()) };
            panic!("dlopen {}: {}", path.display(), why.to_string_lossy());
        }
        Library {
            handle,
            path: path.to_path_buf(),
        }
    }

    /// The function `name` as the function pointer type `F` (the caller states its C signature).
    fn get<F: Copy>(&self, name: &str) -> F {
        assert_eq!(std::mem::size_of::<F>(), std::mem::size_of::<*mut c_void>());
        let c = CString::new(name).unwrap();
        // SAFETY: a valid handle and name.
        let symbol = unsafe { libc::dlsym(self.handle, c.as_ptr()) };
        assert!(
            !symbol.is_null(),
            "{name} not exported by {}",
            self.path.display()
        );
        // SAFETY: F is a function pointer type with the signature of the standard's header.
        unsafe { std::mem::transmute_copy::<*mut c_void, F>(&symbol) }
    }

    /// dlclose, and check that no mapping of the file is left in this process.
    fn close(self) {
        // SAFETY: the handle came from dlopen and every instance was freed.
        let rc = unsafe { libc::dlclose(self.handle) };
        assert_eq!(rc, 0, "dlclose {}", self.path.display());
        let maps = std::fs::read_to_string("/proc/self/maps").unwrap();
        let path = self.path.to_str().unwrap();
        assert!(
            !maps.lines().any(|l| l.ends_with(path)),
            "{path} is still mapped after dlclose"
        );
    }
}

fn messages() -> &'static std::sync::Mutex<Vec<String>> {
    static LOG: std::sync::OnceLock<std::sync::Mutex<Vec<String>>> = std::sync::OnceLock::new();
    LOG.get_or_init(Default::default)
}

unsafe fn text(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        CStr::from_ptr(p).to_string_lossy().into_owned()
    }
}

// ---------------------------------------------------------------------------------------------
// FMI 2.0 (fmi2FunctionTypes.h, fmi2TypesPlatform.h): fmi2Component = void*, fmi2Real = double,
// fmi2Integer = fmi2Boolean = int, fmi2ValueReference = unsigned int, fmi2Status an int enum
// (OK 0, Warning 1, Discard 2, Error 3, Fatal 4, Pending 5), fmi2Type (ModelExchange 0,
// CoSimulation 1).

const FMI2_OK: c_int = 0;
const FMI2_CO_SIMULATION: c_int = 1;

/// `void logger(fmi2ComponentEnvironment, fmi2String instanceName, fmi2Status, fmi2String
/// category, fmi2String message, ...)`. A stable Rust function cannot be variadic; on x86-64
/// System V the first variadic argument is passed like a sixth fixed one, and Velarium always
/// logs with the format "%s" and the message as that argument.
unsafe extern "C" fn fmi2_logger(
    _env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    format: *const c_char,
    first: *const c_char,
) {
    let format = text(format);
    let message = if format == "%s" { text(first) } else { format };
    let line = format!(
        "[{}] {} status {status}: {message}",
        text(instance),
        text(category)
    );
    messages().lock().unwrap().push(line);
}

#[repr(C)]
struct Fmi2CallbackFunctions {
    logger: *const c_void,
    allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    component_environment: *mut c_void,
}

unsafe extern "C" fn fmi2_calloc(n: usize, size: usize) -> *mut c_void {
    libc::calloc(n, size)
}

unsafe extern "C" fn fmi2_free(p: *mut c_void) {
    libc::free(p)
}

type Fmi2Instantiate = unsafe extern "C" fn(
    *const c_char,
    c_int,
    *const c_char,
    *const c_char,
    *const Fmi2CallbackFunctions,
    c_int,
    c_int,
) -> *mut c_void;
type Fmi2SetupExperiment = unsafe extern "C" fn(*mut c_void, c_int, f64, f64, c_int, f64) -> c_int;
type Fmi2Component = unsafe extern "C" fn(*mut c_void) -> c_int;
type Fmi2FreeInstance = unsafe extern "C" fn(*mut c_void);
type Fmi2SetReal = unsafe extern "C" fn(*mut c_void, *const u32, usize, *const f64) -> c_int;
type Fmi2GetReal = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut f64) -> c_int;
type Fmi2GetInteger = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut c_int) -> c_int;
type Fmi2DoStep = unsafe extern "C" fn(*mut c_void, f64, f64, c_int) -> c_int;

// ---------------------------------------------------------------------------------------------
// FMI 3.0 (fmi3FunctionTypes.h, fmi3PlatformTypes.h): fmi3Instance = void*, fmi3Boolean =
// bool, fmi3ValueReference = uint32_t, fmi3Status an int enum (OK 0 ... Fatal 4).

const FMI3_OK: c_int = 0;

/// `void logMessage(fmi3InstanceEnvironment, fmi3Status, fmi3String category, fmi3String message)`.
unsafe extern "C" fn fmi3_log_message(
    _env: *mut c_void,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let line = format!("{} status {status}: {}", text(category), text(message));
    messages().lock().unwrap().push(line);
}

type Fmi3LogMessage = unsafe extern "C" fn(*mut c_void, c_int, *const c_char, *const c_char);
type Fmi3InstantiateCoSimulation = unsafe extern "C" fn(
    *const c_char, // instanceName
    *const c_char, // instantiationToken
    *const c_char, // resourcePath
    bool,          // visible
    bool,          // loggingOn
    bool,          // eventModeUsed
    bool,          // earlyReturnAllowed
    *const u32,    // requiredIntermediateVariables
    usize,         // nRequiredIntermediateVariables
    *mut c_void,   // instanceEnvironment
    Option<Fmi3LogMessage>,
    *const c_void, // intermediateUpdate (none)
) -> *mut c_void;
type Fmi3EnterInitializationMode =
    unsafe extern "C" fn(*mut c_void, bool, f64, f64, bool, f64) -> c_int;
type Fmi3Instance = unsafe extern "C" fn(*mut c_void) -> c_int;
type Fmi3FreeInstance = unsafe extern "C" fn(*mut c_void);
type Fmi3SetFloat64 =
    unsafe extern "C" fn(*mut c_void, *const u32, usize, *const f64, usize) -> c_int;
type Fmi3GetFloat64 =
    unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut f64, usize) -> c_int;
type Fmi3GetUInt8 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut u8, usize) -> c_int;
type Fmi3GetInt32 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut i32, usize) -> c_int;
type Fmi3DoStep = unsafe extern "C" fn(
    *mut c_void,
    f64,  // currentCommunicationPoint
    f64,  // communicationStepSize
    bool, // noSetFMUStatePriorToCurrentPoint
    *mut bool,
    *mut bool,
    *mut bool,
    *mut f64,
) -> c_int;

// ---------------------------------------------------------------------------------------------
// The master.

fn file_uri(path: &Path) -> String {
    let mut uri = String::from("file://");
    for b in path.to_str().unwrap().bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            uri.push(b as char);
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    uri
}

/// What the master read: per load row, every output element as (CSV column name, value).
type Readings = Vec<Vec<(String, f64)>>;

/// The CSV column names of one variable's elements (`name`, `name[i]`, `name[i,j]`).
fn element_names(v: &Variable) -> Vec<String> {
    if v.dims.is_empty() {
        return vec![v.name.clone()];
    }
    let n = v.len();
    (0..n)
        .map(|flat| {
            let mut idx = Vec::new();
            let mut r = flat;
            for d in v.dims.iter().rev() {
                idx.push(r % d + 1);
                r /= d;
            }
            idx.reverse();
            let idx: Vec<String> = idx.iter().map(usize::to_string).collect();
            format!("{}[{}]", v.name, idx.join(","))
        })
        .collect()
}

/// The input values the loads table sets per row, as (variable index, element values).
fn input_rows(md: &ModelDescription, loads: &Table) -> Vec<Vec<(usize, Vec<f64>)>> {
    // Start values of every input, then overwrite the table's columns row by row (an array
    // input is set as a whole; elements the table does not name keep their start).
    let mut current: HashMap<usize, Vec<f64>> = HashMap::new();
    for (i, v) in md.variables.iter().enumerate() {
        if v.causality == "input" {
            let starts: Vec<f64> = v
                .start
                .as_deref()
                .expect("an input has a start")
                .split_whitespace()
                .map(|s| s.parse().unwrap())
                .collect();
            let n = v.len();
            let values = if starts.len() == n {
                starts
            } else {
                vec![starts[0]; n]
            };
            current.insert(i, values);
        }
    }
    let columns: Vec<(usize, usize)> = loads.names[1..].iter().map(|c| locate(md, c)).collect();
    loads
        .rows
        .iter()
        .map(|row| {
            for ((i, offset), value) in columns.iter().zip(&row[1..]) {
                assert_eq!(md.variables[*i].causality, "input");
                current.get_mut(i).unwrap()[*offset] = *value;
            }
            let mut set: Vec<(usize, Vec<f64>)> =
                current.iter().map(|(i, v)| (*i, v.clone())).collect();
            set.sort_by_key(|(i, _)| *i);
            set
        })
        .collect()
}

fn run_fmi2(dir: &Path, md: &ModelDescription, loads: &Table) -> Readings {
    assert_eq!(md.fmi_version, "2.0");
    let lib = Library::open(
        &dir.join("binaries/linux64")
            .join(format!("{}.so", md.model_identifier)),
    );
    let instantiate: Fmi2Instantiate = lib.get("fmi2Instantiate");
    let setup: Fmi2SetupExperiment = lib.get("fmi2SetupExperiment");
    let enter: Fmi2Component = lib.get("fmi2EnterInitializationMode");
    let exit: Fmi2Component = lib.get("fmi2ExitInitializationMode");
    let terminate: Fmi2Component = lib.get("fmi2Terminate");
    let free: Fmi2FreeInstance = lib.get("fmi2FreeInstance");
    let set_real: Fmi2SetReal = lib.get("fmi2SetReal");
    let get_real: Fmi2GetReal = lib.get("fmi2GetReal");
    let get_integer: Fmi2GetInteger = lib.get("fmi2GetInteger");
    let do_step: Fmi2DoStep = lib.get("fmi2DoStep");

    let callbacks = Fmi2CallbackFunctions {
        logger: fmi2_logger as *const c_void,
        allocate_memory: Some(fmi2_calloc),
        free_memory: Some(fmi2_free),
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    };
    let name = CString::new("importer2").unwrap();
    let guid = CString::new(md.token.as_str()).unwrap();
    let uri = CString::new(file_uri(&dir.join("resources"))).unwrap();
    let inputs = input_rows(md, loads);
    let outputs: Vec<&Variable> = md
        .variables
        .iter()
        .filter(|v| v.causality == "output")
        .collect();
    let mut readings = Readings::new();
    // SAFETY: the signatures above are those of fmi2Functions.h; every pointer passed lives
    // across the call and every array has the length passed with it.
    unsafe {
        let c = instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            uri.as_ptr(),
            &callbacks,
            0,
            0,
        );
        assert!(
            !c.is_null(),
            "fmi2Instantiate: {:?}",
            messages().lock().unwrap()
        );
        assert_eq!(setup(c, 0, 0.0, loads.rows[0][0], 0, 0.0), FMI2_OK);
        assert_eq!(enter(c), FMI2_OK);
        for (k, row) in inputs.iter().enumerate() {
            let vrs: Vec<u32> = row.iter().map(|(i, _)| md.variables[*i].vr).collect();
            let values: Vec<f64> = row.iter().map(|(_, v)| v[0]).collect();
            assert_eq!(
                set_real(c, vrs.as_ptr(), vrs.len(), values.as_ptr()),
                FMI2_OK
            );
            if k == 0 {
                assert_eq!(exit(c), FMI2_OK, "{:?}", messages().lock().unwrap());
            } else {
                let t = loads.rows[k - 1][0];
                let h = loads.rows[k][0] - t;
                let status = do_step(c, t, h, 0);
                assert_eq!(status, FMI2_OK, "fmi2DoStep row {k}");
            }
            let mut read = Vec::new();
            for v in &outputs {
                let value = match v.ty.as_str() {
                    "Real" => {
                        let mut x = f64::NAN;
                        assert_eq!(get_real(c, &v.vr, 1, &mut x), FMI2_OK, "{}", v.name);
                        x
                    }
                    "Integer" => {
                        let mut x: c_int = -1;
                        assert_eq!(get_integer(c, &v.vr, 1, &mut x), FMI2_OK, "{}", v.name);
                        f64::from(x)
                    }
                    other => panic!("{}: type {other} not read by this importer", v.name),
                };
                read.push((v.name.clone(), value));
            }
            readings.push(read);
        }
        assert_eq!(terminate(c), FMI2_OK);
        free(c);
    }
    lib.close();
    readings
}

fn run_fmi3(dir: &Path, md: &ModelDescription, loads: &Table) -> Readings {
    assert_eq!(md.fmi_version, "3.0");
    let lib = Library::open(
        &dir.join("binaries/x86_64-linux")
            .join(format!("{}.so", md.model_identifier)),
    );
    let instantiate: Fmi3InstantiateCoSimulation = lib.get("fmi3InstantiateCoSimulation");
    let enter: Fmi3EnterInitializationMode = lib.get("fmi3EnterInitializationMode");
    let exit: Fmi3Instance = lib.get("fmi3ExitInitializationMode");
    let terminate: Fmi3Instance = lib.get("fmi3Terminate");
    let free: Fmi3FreeInstance = lib.get("fmi3FreeInstance");
    let set_float64: Fmi3SetFloat64 = lib.get("fmi3SetFloat64");
    let get_float64: Fmi3GetFloat64 = lib.get("fmi3GetFloat64");
    let get_uint8: Fmi3GetUInt8 = lib.get("fmi3GetUInt8");
    let get_int32: Fmi3GetInt32 = lib.get("fmi3GetInt32");
    let do_step: Fmi3DoStep = lib.get("fmi3DoStep");

    let name = CString::new("importer3").unwrap();
    let token = CString::new(md.token.as_str()).unwrap();
    // FMI 3: a native path to the resources directory with a trailing separator.
    let resources = CString::new(format!("{}/", dir.join("resources").display())).unwrap();
    let inputs = input_rows(md, loads);
    let outputs: Vec<&Variable> = md
        .variables
        .iter()
        .filter(|v| v.causality == "output")
        .collect();
    let mut readings = Readings::new();
    // SAFETY: the signatures above are those of fmi3Functions.h; every pointer passed lives
    // across the call and every array has the element count passed with it.
    unsafe {
        let c = instantiate(
            name.as_ptr(),
            token.as_ptr(),
            resources.as_ptr(),
            false,
            false,
            false,
            false,
            std::ptr::null(),
            0,
            std::ptr::null_mut(),
            Some(fmi3_log_message),
            std::ptr::null(),
        );
        assert!(
            !c.is_null(),
            "fmi3InstantiateCoSimulation: {:?}",
            messages().lock().unwrap()
        );
        let t0 = loads.rows[0][0];
        assert_eq!(enter(c, false, 0.0, t0, false, 0.0), FMI3_OK);
        for (k, row) in inputs.iter().enumerate() {
            for (i, values) in row {
                let v = &md.variables[*i];
                assert_eq!(v.ty, "Float64", "{}", v.name);
                let status = set_float64(c, &v.vr, 1, values.as_ptr(), values.len());
                assert_eq!(status, FMI3_OK, "fmi3SetFloat64 {}", v.name);
            }
            if k == 0 {
                assert_eq!(exit(c), FMI3_OK, "{:?}", messages().lock().unwrap());
            } else {
                let t = loads.rows[k - 1][0];
                let h = loads.rows[k][0] - t;
                let (mut event, mut terminate_sim, mut early) = (true, true, true);
                let mut last = f64::NAN;
                let status = do_step(
                    c,
                    t,
                    h,
                    false,
                    &mut event,
                    &mut terminate_sim,
                    &mut early,
                    &mut last,
                );
                assert_eq!(status, FMI3_OK, "fmi3DoStep row {k}");
                assert!(!event && !terminate_sim && !early, "row {k}");
                assert_eq!(last, t + h, "lastSuccessfulTime, row {k}");
            }
            let mut read = Vec::new();
            for v in &outputs {
                let n = v.len();
                let values: Vec<f64> = match v.ty.as_str() {
                    "Float64" => {
                        let mut x = vec![f64::NAN; n];
                        let status = get_float64(c, &v.vr, 1, x.as_mut_ptr(), n);
                        assert_eq!(status, FMI3_OK, "{}", v.name);
                        x
                    }
                    "UInt8" => {
                        let mut x = vec![u8::MAX; n];
                        let status = get_uint8(c, &v.vr, 1, x.as_mut_ptr(), n);
                        assert_eq!(status, FMI3_OK, "{}", v.name);
                        x.into_iter().map(f64::from).collect()
                    }
                    "Int32" => {
                        let mut x = vec![i32::MIN; n];
                        let status = get_int32(c, &v.vr, 1, x.as_mut_ptr(), n);
                        assert_eq!(status, FMI3_OK, "{}", v.name);
                        x.into_iter().map(f64::from).collect()
                    }
                    other => panic!("{}: type {other} not read by this importer", v.name),
                };
                read.extend(element_names(v).into_iter().zip(values));
            }
            readings.push(read);
        }
        assert_eq!(terminate(c), FMI3_OK);
        free(c);
    }
    lib.close();
    readings
}

/// Pack, import both archives, compare with `velarium solve`; returns the largest absolute
/// difference (asserted to be 0) and the number of values compared.
fn import_and_compare(test: &str, scene: &Path, name: &str, loads_csv: &str) -> (f64, usize) {
    let dir = scratch(test);
    let loads_path = dir.join("loads.csv");
    std::fs::write(&loads_path, loads_csv).unwrap();
    let solved = read_csv(&run(&[
        "solve",
        scene.to_str().unwrap(),
        "--loads",
        loads_path.to_str().unwrap(),
        "--quiet",
    ]));
    let loads = read_csv(loads_csv);
    assert_eq!(solved.rows.len(), loads.rows.len());
    let (fmi2, fmi3) = pack(scene, name, &dir);
    let mut largest = 0.0f64;
    let mut compared = 0;
    for (archive, version) in [(fmi2, 2), (fmi3, 3)] {
        let unpacked = dir.join(format!("fmi{version}"));
        unzip(&archive, &unpacked);
        let xml = std::fs::read_to_string(unpacked.join("modelDescription.xml")).unwrap();
        let md = read_model_description(&xml);
        assert_eq!(md.model_identifier, name);
        let readings = if version == 2 {
            run_fmi2(&unpacked, &md, &loads)
        } else {
            run_fmi3(&unpacked, &md, &loads)
        };
        // Every column of the solve CSV but time is an output element the master read, and
        // nothing else.
        let mut read_names: Vec<&str> = readings[0].iter().map(|(n, _)| n.as_str()).collect();
        let mut solve_names: Vec<&str> = solved.names[1..].iter().map(String::as_str).collect();
        read_names.sort_unstable();
        solve_names.sort_unstable();
        assert_eq!(read_names, solve_names, "{name} FMI {version}: outputs");
        for (k, (read, row)) in readings.iter().zip(&solved.rows).enumerate() {
            for (column, value) in read {
                let j = solved.names.iter().position(|n| n == column).unwrap();
                let expected = row[j];
                let diff = (value - expected).abs();
                largest = largest.max(diff);
                compared += 1;
                assert!(
                    value.to_bits() == expected.to_bits() || *value == expected,
                    "{name} FMI {version} row {k} {column}: FMU {value:e} vs solve {expected:e}"
                );
            }
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
    println!(
        "{name}: {compared} values compared over FMI 2 and FMI 3, largest difference {largest:e}"
    );
    (largest, compared)
}

fn shipped(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("modelDescription/{name}/scene.json"))
}

#[test]
fn model_description_parser_reads_arrays_entities_and_comments() {
    let xml = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="3.0" instantiationToken="{t}" description="x &lt; 2 &amp; y &gt; 1">
  <CoSimulation modelIdentifier="M"/>
  <ModelVariables>
    <!-- <Float64 name="commented" valueReference="9"/> -->
    <Float64 name="time" valueReference="0" causality="independent"/>
    <Float64 name="a&apos;" valueReference="1" causality="input" start="1 2 3 4 5 6">
      <Dimension start="2"/>
      <Dimension start="3"/>
    </Float64>
    <UInt8 name="w" valueReference="7" causality="output"><Dimension start="4"/></UInt8>
    <Int32 name="n" valueReference="11" causality="output"/>
  </ModelVariables>
</fmiModelDescription>"#;
    let md = read_model_description(xml);
    assert_eq!(md.token, "{t}");
    assert_eq!(md.model_identifier, "M");
    let names: Vec<&str> = md.variables.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["time", "a'", "w", "n"]);
    assert_eq!(md.variables[1].dims, [2, 3]);
    assert_eq!(md.variables[2].dims, [4]);
    assert!(md.variables[3].dims.is_empty());
    assert_eq!(locate(&md, "a'[2,1]"), (1, 3));
    assert_eq!(locate(&md, "n"), (3, 0));
    assert_eq!(element_names(&md.variables[1])[4], "a'[2,2]");
}

#[test]
fn prestressed_cable_through_both_archives_equals_solve() {
    // Loading, a larger step, unloading: 6 rows, 5 outputs each.
    let loads = "time,P\n0,0\n0.25,2500\n0.5,5000\n1,10000\n1.5,4000\n2,0\n";
    let (largest, compared) = import_and_compare(
        "cable",
        &shipped("PrestressedCable"),
        "PrestressedCable",
        loads,
    );
    assert_eq!(largest, 0.0);
    assert_eq!(compared, 2 * 6 * 5);
}

#[test]
fn sliding_cable_with_friction_through_both_archives_equals_solve() {
    let loads = "time,P,p\n0,0,0\n0.5,80,5\n1,200,20\n1.5,120,0\n";
    let (largest, _) =
        import_and_compare("sliding", &shipped("SlidingCable"), "SlidingCable", loads);
    assert_eq!(largest, 0.0);
}

#[test]
fn zoned_cushion_arrays_through_both_archives_equal_solve() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let loads = std::fs::read_to_string(root.join("examples/ZonedCushion-loads.csv")).unwrap();
    let (largest, compared) = import_and_compare(
        "cushion",
        &root.join("modelDescription/ZonedCushion/scene.json"),
        "ZonedCushion",
        &loads,
    );
    assert_eq!(largest, 0.0);
    // u 243, corner_x 12, edge_tension 8, stress 256, wrinkle 128, 2 scalars: 649 per row.
    assert_eq!(compared, 2 * 5 * 649);
}
