//! FMU archives: `velarium pack` writes `<out>/<Name>.fmu` (FMI 2.0) and
//! `<out>/<Name>_fmi3.fmu` (FMI 3.0) for a scene; both hold the same library.
//!
//! ```text
//! <Name>.fmu (ZIP, deflate only, forward slashes, every entry dated 1980-01-01 00:00:00)
//!   modelDescription.xml            crate::description, generated from the variable table
//!   binaries/linux64/<Name>.so      a copy of the built cdylib libvelarium.so
//!   resources/scene.json            the scene, re-serialized with Scene::to_json
//!   resources/mesh.vtu              the reference mesh and where the rows of the array
//!                                   outputs go on it (crate::vtu::Grid::mesh), so that a
//!                                   master's outputs can be drawn without solving again
//!
//! <Name>_fmi3.fmu (same conventions)
//!   modelDescription.xml            crate::description3 (fmiVersion 3.0)
//!   binaries/x86_64-linux/<Name>.so the same library (it exports fmi2* and fmi3* functions)
//!   resources/scene.json, resources/mesh.vtu
//! ```
//!
//! Both archives also carry the result of the default experiment as FMI-LS-REF reference
//! results (the layered standard "References", 1.0.0-alpha.1, as the Reference FMUs ship them),
//! and the load history it ran under when the scene has one (`experiment.loads`):
//!
//! ```text
//!   extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml   <Related role="result">, and
//!                                                           <Related role="input"> with loads
//!   extra/org.fmi-standard.fmi-ls-ref/<Name>_ref.csv        "time" and at most 10 Real
//!                                                           outputs (table order), quoted
//!                                                           names, no units, one row per
//!                                                           stepSize from startTime to stopTime
//!   extra/org.fmi-standard.fmi-ls-ref/<Name>_in.csv         "time" and the loaded inputs at the
//!                                                           table's times (FMI 2: scalars
//!                                                           name[i]; FMI 3: one column per
//!                                                           variable, elements space-separated)
//! ```
//! The rows are what `simulate_fmu(fmu, input=read_csv(<Name>_in.csv))` records (without loads:
//! `simulate_fmu(fmu)`, inputs at their start values): the initial equilibrium under the first
//! input row at startTime, then one step per row under the input interpolated as fmpy does it
//! (harness/test_reference.py compares them with a fresh run). A scene whose default experiment
//! does not converge ships no reference result.
//!
//! One archive holds one modelDescription.xml, hence two archives. The same scene and library
//! give byte-identical archives. Each archive is written by [`write_atomically`] (a temporary
//! file renamed at the end), so a failed pack leaves no partial `.fmu` behind, and what a
//! killed one leaves is removed by the next run.

use crate::description::model_description;
use crate::description3::model_description_fmi3;
use crate::engine::Engine;
use crate::error::Error;
use crate::format::{csv_quoted, xs_double};
use crate::scene::Scene;
use std::io::Write;
use std::path::{Path, PathBuf};
use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

/// The scene's file name inside the FMU's `resources/` folder.
pub const SCENE_RESOURCE: &str = "scene.json";

/// The reference mesh's file name inside the FMU's `resources/` folder.
pub const MESH_RESOURCE: &str = "mesh.vtu";

/// The file name cargo gives the cdylib.
pub const LIBRARY_FILE: &str = "libvelarium.so";

/// The FMI version of an archive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FmiVersion {
    Fmi2,
    Fmi3,
}

impl FmiVersion {
    /// The archive's file name for a scene.
    pub fn file_name(self, scene: &Scene) -> String {
        match self {
            FmiVersion::Fmi2 => format!("{}.fmu", scene.name),
            FmiVersion::Fmi3 => format!("{}_fmi3.fmu", scene.name),
        }
    }

    /// The platform folder under `binaries/`.
    pub fn platform(self) -> &'static str {
        match self {
            FmiVersion::Fmi2 => "linux64",
            FmiVersion::Fmi3 => "x86_64-linux",
        }
    }
}

/// Write the FMI 2.0 archive `<out_dir>/<scene.name>.fmu` and return its path. The scene is
/// validated first (every problem is reported); `library` is the built `libvelarium.so`.
pub fn pack(scene: &Scene, out_dir: &Path, library: &Path) -> Result<PathBuf, Error> {
    Ok(pack_versions(scene, out_dir, library, &[FmiVersion::Fmi2])?.remove(0))
}

/// Write one archive per version (in the order given) and return their paths. Nothing is
/// written unless the scene is valid and the library readable; each archive is written
/// atomically.
pub fn pack_versions(
    scene: &Scene,
    out_dir: &Path,
    library: &Path,
    versions: &[FmiVersion],
) -> Result<Vec<PathBuf>, Error> {
    let engine = Engine::try_new(scene.clone())?;
    let binary =
        std::fs::read(library).map_err(|e| io_error(library, "cannot read the FMU library", e))?;
    let references = reference_results(scene, versions)?;
    let mesh = crate::vtu::Grid::mesh(&engine).binary();
    let mut archives = Vec::with_capacity(versions.len());
    for (i, &version) in versions.iter().enumerate() {
        let description = match version {
            FmiVersion::Fmi2 => model_description(engine.scene(), engine.variables()),
            FmiVersion::Fmi3 => model_description_fmi3(engine.scene(), engine.arrays()),
        };
        let reference = references.as_ref().map(|r| r[i].clone());
        let input = reference_input(scene, version)?;
        let bytes = archive(
            scene,
            version,
            &description,
            &binary,
            reference.as_deref(),
            input.as_deref(),
            &mesh,
        )
        .map_err(|e| Error::Io {
            path: library.display().to_string(),
            message: format!("cannot build the FMU archive: {e}"),
        })?;
        archives.push((out_dir.join(version.file_name(scene)), bytes));
    }
    std::fs::create_dir_all(out_dir)
        .map_err(|e| io_error(out_dir, "cannot create the output directory", e))?;
    for (target, bytes) in &archives {
        write_atomically(target, bytes)?;
    }
    Ok(archives.into_iter().map(|(path, _)| path).collect())
}

/// The environment variable naming the library to ship when `--lib` is not given.
pub const LIBRARY_ENV: &str = "VELARIUM_LIB";

/// The Rust target of the portable library: glibc 2.17 symbols (manylinux2014), built by
/// `harness/portable.sh` with cargo-zigbuild into `<target dir>/x86_64-unknown-linux-gnu/release/`.
pub const PORTABLE_TARGET: &str = "x86_64-unknown-linux-gnu";

/// The oldest glibc the portable library loads on.
pub const PORTABLE_GLIBC: &str = "2.17";

/// The library to ship and, when it is not the portable one, a notice saying so and why.
#[derive(Clone, Debug, PartialEq)]
pub struct LibraryChoice {
    pub path: PathBuf,
    pub notice: Option<String>,
}

/// The library to ship: `explicit` if given (it must exist), else the file named by the
/// environment variable `VELARIUM_LIB` if set and not empty (it must exist), else the portable
/// build (`../x86_64-unknown-linux-gnu/release/libvelarium.so` from the running executable's
/// directory, what `harness/portable.sh` builds) when it is there and not older than the native
/// build, else `libvelarium.so` next to the running executable (cargo puts both in
/// `target/release` or `target/debug`) with a notice that the FMUs then need the glibc it was
/// built against.
pub fn find_library(explicit: Option<&Path>) -> Result<PathBuf, Error> {
    Ok(choose_library(explicit)?.path)
}

/// [`find_library`] with the notice to print when the native library is shipped by default.
pub fn choose_library(explicit: Option<&Path>) -> Result<LibraryChoice, Error> {
    let from_env = std::env::var_os(LIBRARY_ENV).filter(|v| !v.is_empty());
    let given = match (explicit, &from_env) {
        (Some(path), _) => Some((path.to_path_buf(), "given with --lib".to_string())),
        (None, Some(path)) => Some((PathBuf::from(path), format!("given by {LIBRARY_ENV}"))),
        (None, None) => None,
    };
    if let Some((path, source)) = given {
        return if path.is_file() {
            Ok(LibraryChoice { path, notice: None })
        } else {
            Err(Error::Io {
                path: path.display().to_string(),
                message: format!("no such library file ({source})"),
            })
        };
    }
    let exe = std::env::current_exe().map_err(|e| Error::Io {
        path: "velarium".into(),
        message: format!("cannot locate the running executable to find {LIBRARY_FILE}: {e}"),
    })?;
    let beside = exe.with_file_name(LIBRARY_FILE);
    if !beside.is_file() {
        return Err(Error::Io {
            path: beside.display().to_string(),
            message: format!(
                "{LIBRARY_FILE} not found next to the velarium executable; run `cargo build --release` \
                 (it builds both) or pass --lib PATH"
            ),
        });
    }
    Ok(default_library(&beside))
}

/// The portable library beside a native one (`<dir>/../<target>/<profile>/libvelarium.so`).
pub fn portable_library(native: &Path) -> Option<PathBuf> {
    let profile_dir = native.parent()?;
    let profile = profile_dir.file_name()?;
    Some(
        profile_dir
            .parent()?
            .join(PORTABLE_TARGET)
            .join(profile)
            .join(LIBRARY_FILE),
    )
}

/// The default choice between the native library `native` and its portable build.
fn default_library(native: &Path) -> LibraryChoice {
    let how = "build it with `bash harness/portable.sh` (docs/fmu.md, \"Portable FMUs\")";
    let shipping = format!(
        "shipping {}, the native build: the FMUs need the glibc it was linked against (2.35 on \
         Debian 12, for `hypot`) or newer",
        native.display()
    );
    let Some(portable) = portable_library(native).filter(|p| p.is_file()) else {
        return LibraryChoice {
            path: native.to_path_buf(),
            notice: Some(format!(
                "note: {shipping}; the portable glibc {PORTABLE_GLIBC} library is not built: {how}"
            )),
        };
    };
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    match (modified(&portable), modified(native)) {
        (Some(p), Some(n)) if p >= n => LibraryChoice {
            path: portable,
            notice: None,
        },
        _ => LibraryChoice {
            path: native.to_path_buf(),
            notice: Some(format!(
                "note: {shipping}; the portable glibc {PORTABLE_GLIBC} library {} is older than it \
                 (built from older sources): rebuild it with `bash harness/portable.sh`",
                portable.display()
            )),
        },
    }
}

/// Write `bytes` to `path` so that the file at `path` is either the old one or the complete
/// new one, and whatever a killed process leaves is removed by the next run.
///
/// ```text
/// write    `.<name>.<pid>.partial` in the target's directory, synced, renamed over `path`;
///          on an error it is removed
/// killed   (SIGKILL, power loss: nothing of the process runs) the partial stays until the
///          next write of any velarium process into that directory, which removes every
///          `.<name>.<pid>.partial` there whose process no longer runs
/// ```
///
/// An unnamed file (Linux's O_TMPFILE) linked into place at the end would leave no name at
/// all, but linking it needs `linkat` with AT_SYMLINK_FOLLOW, which std does not offer (its
/// `hard_link` does not follow /proc/self/fd/N: EXDEV), and raw libc calls stay in src/fmi.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    remove_stale_partials_once(dir);
    let temp = dir.join(partial_name(&name, std::process::id()));
    let result = std::fs::File::create(&temp)
        .and_then(|mut f| f.write_all(bytes).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(&temp, path));
    result.map_err(|e| {
        let _ = std::fs::remove_file(&temp);
        io_error(path, "cannot write", e)
    })
}

/// The temporary name of `name` written by process `pid`.
fn partial_name(name: &str, pid: u32) -> String {
    format!(".{name}.{pid}.partial")
}

/// The process id in a name of the `.<name>.<pid>.partial` pattern.
fn partial_pid(file_name: &str) -> Option<u32> {
    let stem = file_name.strip_prefix('.')?.strip_suffix(".partial")?;
    let (name, pid) = stem.rsplit_once('.')?;
    if name.is_empty() || pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    pid.parse().ok()
}

/// Whether process `pid` may run: anything but "/proc is there and has no such process" counts
/// as running (without /proc nothing is known, so nothing is removed).
fn process_runs(pid: u32) -> bool {
    let proc = Path::new("/proc");
    !proc.join("self").exists() || proc.join(pid.to_string()).exists()
}

/// Remove the partial files in `dir` left by processes that no longer run; returns how many
/// were removed. Other files, and partials of running processes (this one included), stay.
pub fn remove_stale_partials(dir: &Path) -> usize {
    let own = std::process::id();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(partial_pid) else {
            continue;
        };
        let is_file = entry.file_type().is_ok_and(|t| t.is_file());
        if is_file && pid != own && !process_runs(pid) && std::fs::remove_file(entry.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

/// [`remove_stale_partials`] the first time this process writes into `dir` (a series of many
/// files reads the directory once).
fn remove_stale_partials_once(dir: &Path) {
    static DONE: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
    let mut done = DONE
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if !done.iter().any(|d| d == dir) {
        remove_stale_partials(dir);
        done.push(dir.to_path_buf());
    }
}

/// The folder of the FMI-LS-REF files inside an archive.
pub const REFERENCE_FOLDER: &str = "extra/org.fmi-standard.fmi-ls-ref";

/// Most outputs in the reference result (besides time).
pub const REFERENCE_OUTPUTS: usize = 10;

/// A scene's `experiment.loads` resolved against its variables (the FMI 3 table: one entry per
/// input variable, an array with all its elements).
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceLoads {
    /// The table's times.
    pub time: Vec<f64>,
    /// Per loaded input (variable table order): the variable and, per time, its element values.
    pub inputs: Vec<(crate::variables::Variable, Vec<Vec<f64>>)>,
}

impl ReferenceLoads {
    /// The elements' values at `t` as fmpy's `Input.apply` computes them (held before the first
    /// and after the last time, else `w0 v0 + w1 v1` with `w0 = (t1 - t) / (t1 - t0)`,
    /// `w1 = 1 - w0`, the same floating-point operations in the same order), so a master
    /// reading the shipped input file sets bit for bit the values the reference run used.
    pub fn values_at(&self, t: f64) -> Vec<(u32, f64)> {
        let n = self.time.len();
        // numpy's searchsorted (left): the first index whose time is >= t.
        let i0 = self.time.partition_point(|&x| x < t);
        // The rows around t and the weights (None: hold one row).
        let (lo, hi, weights) = if n < 2 || i0 == 0 {
            (0, 0, None)
        } else if i0 == n {
            (n - 1, n - 1, None)
        } else {
            let (t0, t1) = (self.time[i0 - 1], self.time[i0]);
            let w0 = (t1 - t) / (t1 - t0);
            (i0 - 1, i0, Some((w0, 1.0 - w0)))
        };
        let mut out = Vec::new();
        for (var, rows) in &self.inputs {
            for (e, (a, b)) in rows[lo].iter().zip(&rows[hi]).enumerate() {
                let value = match weights {
                    None => *a,
                    Some((w0, w1)) => w0 * a + w1 * b,
                };
                out.push((var.value_reference + e as u32, value));
            }
        }
        out
    }
}

/// The scene's load history resolved against `engine`'s variables; None without
/// `experiment.loads`. An array input's list must have as many values as the array has
/// elements (the error names the field).
pub fn reference_loads(engine: &Engine) -> Result<Option<ReferenceLoads>, Error> {
    let Some(loads) = &engine.scene().experiment.loads else {
        return Ok(None);
    };
    let mut inputs = Vec::new();
    let mut problems = Vec::new();
    for var in engine.arrays() {
        if var.causality != crate::variables::Causality::Input {
            continue;
        }
        let Some(values) = loads.inputs.get(&var.name) else {
            continue;
        };
        let mut rows = Vec::with_capacity(values.len());
        for (k, value) in values.iter().enumerate() {
            match value {
                crate::scene::LoadValue::All(v) => rows.push(vec![*v; var.len()]),
                crate::scene::LoadValue::Each(list) if list.len() == var.len() => {
                    rows.push(list.clone())
                }
                crate::scene::LoadValue::Each(list) => problems.push(crate::scene::Problem {
                    path: format!("experiment.loads.inputs.{}[{k}]", var.name),
                    message: format!(
                        "has {} values; the input {} has {} element{} (shape {:?}): give one number for every element or a list of all of them, row-major",
                        list.len(),
                        var.name,
                        var.len(),
                        if var.len() == 1 { "" } else { "s" },
                        var.dims
                    ),
                }),
            }
        }
        inputs.push((var.clone(), rows));
    }
    if !problems.is_empty() {
        return Err(Error::Scene(problems));
    }
    Ok(Some(ReferenceLoads {
        time: loads.time.clone(),
        inputs,
    }))
}

/// The communication points of the default experiment as fmpy's `simulate_fmu` steps them:
/// `start + k h`, and the last one `start + n h` itself where that is close to the stop time
/// (Python's `math.isclose`, relative 1e-9, as fmpy tests it), else the stop time. (With 17
/// steps of 0.1 fmpy ends at 1.7000000000000002, not at 1.7.)
fn communication_points(scene: &Scene) -> Vec<f64> {
    let e = &scene.experiment;
    let steps = ((e.stop_time - e.start_time) / e.step_size)
        .round()
        .max(0.0) as usize;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
    (0..=steps)
        .map(|k| {
            let t = e.start_time + k as f64 * e.step_size;
            if k == steps && !close(t, e.stop_time) {
                e.stop_time
            } else {
                t
            }
        })
        .collect()
}

/// The default experiment's result as CSV for one archive version (see the module docs);
/// None when it does not converge. FMI 2: the first (at most) 10 Real scalars; FMI 3: the
/// first 10 Float64 variables, an array's elements space-separated in one cell (fmpy's CSV
/// convention).
pub fn reference_result(scene: &Scene, version: FmiVersion) -> Result<Option<String>, Error> {
    Ok(reference_results(scene, &[version])?.map(|mut v| v.remove(0)))
}

/// [`reference_result`] for several versions from one run.
pub fn reference_results(
    scene: &Scene,
    versions: &[FmiVersion],
) -> Result<Option<Vec<String>>, Error> {
    let mut engine = Engine::try_new(scene.clone())?;
    let loads = reference_loads(&engine)?;
    let mut tables: Vec<(Vec<crate::variables::Variable>, String)> = versions
        .iter()
        .map(|version| {
            let table = match version {
                FmiVersion::Fmi2 => engine.variables(),
                FmiVersion::Fmi3 => engine.arrays(),
            };
            let outputs: Vec<crate::variables::Variable> = table
                .iter()
                .filter(|v| {
                    v.causality == crate::variables::Causality::Output
                        && v.var_type == crate::variables::VarType::Real
                })
                .take(REFERENCE_OUTPUTS)
                .cloned()
                .collect();
            let quoted: Vec<String> = std::iter::once("time".to_string())
                .chain(outputs.iter().map(|v| v.name.clone()))
                .map(|n| csv_quoted(&n))
                .collect();
            let mut csv = quoted.join(",");
            csv.push('\n');
            (outputs, csv)
        })
        .collect();
    let points = communication_points(scene);
    for (k, t) in points.iter().enumerate() {
        // Row 0: the initial equilibrium under u(t_0); row k: the step from t_{k-1} under
        // u(t_{k-1}) (the one-step lag, docs/fmu.md). An unchanged load keeps the equilibrium,
        // as the FMU's step does.
        if let Some(loads) = &loads {
            for (vr, value) in loads.values_at(points[k.saturating_sub(1)]) {
                engine.set_real(vr, value)?;
            }
        }
        // With time integration the step from t_{k-1} advances time by t_k - t_{k-1}.
        engine.set_step_duration(if k == 0 { 0.0 } else { t - points[k - 1] });
        let converged = match engine.keep() {
            Some(report) => report.converged(),
            None => engine.solve().converged(),
        };
        if !converged {
            return Ok(None);
        }
        for (outputs, csv) in &mut tables {
            csv.push_str(&xs_double(*t));
            for v in outputs.iter() {
                csv.push(',');
                let cells: Vec<String> = engine.values(v).iter().map(|x| xs_double(*x)).collect();
                csv.push_str(&cells.join(" "));
            }
            csv.push('\n');
        }
    }
    Ok(Some(tables.into_iter().map(|(_, csv)| csv).collect()))
}

/// The reference input file of one archive version: `"time"` and the loaded inputs at the
/// table's times (FMI 2: one column per scalar, `name[i]`; FMI 3: one column per variable, an
/// array's elements space-separated). None without `experiment.loads`.
pub fn reference_input(scene: &Scene, version: FmiVersion) -> Result<Option<String>, Error> {
    let engine = Engine::try_new(scene.clone())?;
    let Some(loads) = reference_loads(&engine)? else {
        return Ok(None);
    };
    let mut header = vec![csv_quoted("time")];
    for (var, _) in &loads.inputs {
        match version {
            FmiVersion::Fmi3 => header.push(csv_quoted(&var.name)),
            FmiVersion::Fmi2 => {
                for e in 0..var.len() {
                    let name = if var.is_array() {
                        format!(
                            "{}[{}]",
                            var.name,
                            crate::variables::element_index(&var.dims, e)
                        )
                    } else {
                        var.name.clone()
                    };
                    header.push(csv_quoted(&name));
                }
            }
        }
    }
    let mut csv = header.join(",");
    csv.push('\n');
    for (k, t) in loads.time.iter().enumerate() {
        csv.push_str(&xs_double(*t));
        for (_, rows) in &loads.inputs {
            let cells: Vec<String> = rows[k].iter().map(|x| xs_double(*x)).collect();
            match version {
                FmiVersion::Fmi3 => {
                    csv.push(',');
                    csv.push_str(&cells.join(" "));
                }
                FmiVersion::Fmi2 => {
                    for c in cells {
                        csv.push(',');
                        csv.push_str(&c);
                    }
                }
            }
        }
        csv.push('\n');
    }
    Ok(Some(csv))
}

/// The FMI-LS-REF manifest naming the reference result (and the reference input, if any).
fn reference_manifest(scene: &Scene, with_input: bool) -> String {
    let input = if with_input {
        format!(
            "    <Related type=\"text/csv\" source=\"{}_in.csv\" role=\"input\" description=\"Input of the default experiment (the load history; linear between the rows, held after the last)\"/>\n",
            scene.name
        )
    } else {
        String::new()
    };
    let result_description = if with_input {
        "Outputs of the default experiment under the input file"
    } else {
        "Outputs of the default experiment (inputs at their start values)"
    };
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiReferences\n    xmlns:fmi-ls=\"http://fmi-standard.org/fmi-ls-manifest\"\n    fmi-ls:fmi-ls-name=\"org.fmi-standard.fmi-ls-ref\"\n    fmi-ls:fmi-ls-version=\"1.0.0-alpha.1\"\n    fmi-ls:fmi-ls-description=\"Layered Standard providing information on related files included in an FMU.\">\n    <Related type=\"text/csv\" source=\"{}_ref.csv\" role=\"result\" description=\"{result_description}\"/>\n{input}</fmiReferences>\n",
        scene.name
    )
}

/// The archive bytes, entries in a fixed order with fixed metadata.
fn archive(
    scene: &Scene,
    version: FmiVersion,
    description: &str,
    binary: &[u8],
    reference: Option<&str>,
    input: Option<&str>,
    mesh: &[u8],
) -> zip::result::ZipResult<Vec<u8>> {
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(DateTime::default());
    let scene_json = scene.to_json();
    let mut zip = ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let manifest = reference_manifest(scene, input.is_some());
    let mut entries: Vec<(String, &[u8], u32)> = vec![
        ("modelDescription.xml".into(), description.as_bytes(), 0o644),
        (
            format!("binaries/{}/{}.so", version.platform(), scene.name),
            binary,
            0o755,
        ),
        (
            format!("resources/{SCENE_RESOURCE}"),
            scene_json.as_bytes(),
            0o644,
        ),
        (format!("resources/{MESH_RESOURCE}"), mesh, 0o644),
    ];
    if let Some(csv) = reference {
        entries.push((
            format!("{REFERENCE_FOLDER}/fmi-ls-manifest.xml"),
            manifest.as_bytes(),
            0o644,
        ));
        entries.push((
            format!("{REFERENCE_FOLDER}/{}_ref.csv", scene.name),
            csv.as_bytes(),
            0o644,
        ));
        if let Some(input) = input {
            entries.push((
                format!("{REFERENCE_FOLDER}/{}_in.csv", scene.name),
                input.as_bytes(),
                0o644,
            ));
        }
    }
    for (name, bytes, mode) in entries {
        zip.start_file(name, options.unix_permissions(mode))?;
        zip.write_all(bytes)?;
    }
    Ok(zip.finish()?.into_inner())
}

fn io_error(path: &Path, what: &str, e: std::io::Error) -> Error {
    Error::Io {
        path: path.display().to_string(),
        message: format!("{what}: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_partial_pattern() {
        assert_eq!(partial_pid(&partial_name("A.fmu", 4242)), Some(4242));
        assert_eq!(partial_pid(".x.y.vtu.17.partial"), Some(17));
        for other in [
            "A.fmu",
            ".A.fmu.partial",
            "..17.partial",
            ".A.fmu.-3.partial",
            ".A.fmu.1x.partial",
            "A.fmu.17.partial",
            ".A.fmu.99999999999.partial",
        ] {
            assert_eq!(partial_pid(other), None, "{other}");
        }
    }

    // GOAL: by default the portable library is shipped when it is there and not older than
    //       the native one; otherwise the native one, with a notice naming why and the script
    //       that builds the portable one.
    #[test]
    fn the_default_library_is_the_portable_one_when_it_is_current() {
        let dir = std::env::temp_dir().join(format!("velarium-libchoice-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let native = dir.join("release").join(LIBRARY_FILE);
        let portable = dir.join(PORTABLE_TARGET).join("release").join(LIBRARY_FILE);
        std::fs::create_dir_all(native.parent().unwrap()).unwrap();
        std::fs::write(&native, "native").unwrap();
        assert_eq!(
            portable_library(&native).as_deref(),
            Some(portable.as_path())
        );
        let absent = default_library(&native);
        assert_eq!(absent.path, native);
        let notice = absent.notice.unwrap();
        assert!(
            notice.contains("harness/portable.sh") && notice.contains("not built"),
            "{notice}"
        );
        std::fs::create_dir_all(portable.parent().unwrap()).unwrap();
        std::fs::write(&portable, "portable").unwrap();
        let now = std::time::SystemTime::now();
        let set = |p: &Path, t: std::time::SystemTime| {
            std::fs::File::options()
                .write(true)
                .open(p)
                .unwrap()
                .set_modified(t)
                .unwrap()
        };
        set(&native, now - std::time::Duration::from_secs(60));
        set(&portable, now);
        assert_eq!(
            default_library(&native),
            LibraryChoice {
                path: portable.clone(),
                notice: None
            }
        );
        set(&portable, now - std::time::Duration::from_secs(120));
        let stale = default_library(&native);
        assert_eq!(stale.path, native);
        let notice = stale.notice.unwrap();
        assert!(notice.contains("older than it"), "{notice}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    // GOAL: a write replaces the file whole and leaves nothing else in the directory, whether
    //       the target exists or not; stale partials of a process that no longer runs are
    //       removed, those of a running one (this) and other files are not.
    #[test]
    fn writes_replace_whole_and_stale_partials_go() {
        let dir = std::env::temp_dir().join(format!("velarium-atomic-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("out.csv");
        write_atomically(&target, b"first").unwrap();
        write_atomically(&target, b"second, longer").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"second, longer");
        let names = |d: &Path| {
            let mut v: Vec<String> = std::fs::read_dir(d)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            v.sort();
            v
        };
        assert_eq!(names(&dir), ["out.csv"]);
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale = partial_name("out.csv", dead);
        let live = partial_name("out.csv", std::process::id());
        for name in [&stale, &live, &"keep.txt".to_string()] {
            std::fs::write(dir.join(name), "x").unwrap();
        }
        assert_eq!(remove_stale_partials(&dir), 1);
        let mut want = vec![live, "keep.txt".into(), "out.csv".into()];
        want.sort();
        assert_eq!(names(&dir), want);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
