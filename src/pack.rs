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
//! results (the layered standard "References", 1.0.0-alpha.1, as the Reference FMUs ship them):
//!
//! ```text
//!   extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml   one <Related role="result">
//!   extra/org.fmi-standard.fmi-ls-ref/<Name>_ref.csv        "time" and at most 10 Real
//!                                                           outputs (table order), quoted
//!                                                           names, no units, one row per
//!                                                           stepSize from startTime to stopTime
//! ```
//! The rows are what `simulate_fmu(fmu)` with no arguments records: inputs at their start
//! values, the initial equilibrium at startTime, then one step per row (harness/test_reference.py
//! compares them with a fresh run). A scene whose default experiment does not converge ships no
//! reference result.
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
    let reference = reference_result(scene)?;
    let mesh = crate::vtu::Grid::mesh(&engine).binary();
    let mut archives = Vec::with_capacity(versions.len());
    for &version in versions {
        let description = match version {
            FmiVersion::Fmi2 => model_description(engine.scene(), engine.variables()),
            FmiVersion::Fmi3 => model_description_fmi3(engine.scene(), engine.arrays()),
        };
        let bytes = archive(
            scene,
            version,
            &description,
            &binary,
            reference.as_deref(),
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

/// The environment variable naming the library to ship when `--lib` is not given (e.g. the
/// glibc 2.17 build of `.ci/glibc217`, docs/fmu.md).
pub const LIBRARY_ENV: &str = "VELARIUM_LIB";

/// The library to ship: `explicit` if given (it must exist), else the file named by the
/// environment variable `VELARIUM_LIB` if set and not empty (it must exist), else
/// `libvelarium.so` next to the running executable (cargo puts both in `target/release` or
/// `target/debug`).
pub fn find_library(explicit: Option<&Path>) -> Result<PathBuf, Error> {
    let from_env = std::env::var_os(LIBRARY_ENV).filter(|v| !v.is_empty());
    let given = match (explicit, &from_env) {
        (Some(path), _) => Some((path.to_path_buf(), "given with --lib".to_string())),
        (None, Some(path)) => Some((PathBuf::from(path), format!("given by {LIBRARY_ENV}"))),
        (None, None) => None,
    };
    if let Some((path, source)) = given {
        return if path.is_file() {
            Ok(path)
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
    if beside.is_file() {
        Ok(beside)
    } else {
        Err(Error::Io {
            path: beside.display().to_string(),
            message: format!(
                "{LIBRARY_FILE} not found next to the velarium executable; run `cargo build --release` \
                 (it builds both) or pass --lib PATH"
            ),
        })
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

/// The default experiment's result as CSV (see the module docs); None when it does not
/// converge.
pub fn reference_result(scene: &Scene) -> Result<Option<String>, Error> {
    let mut engine = Engine::try_new(scene.clone())?;
    let outputs: Vec<(String, u32)> = engine
        .variables()
        .iter()
        .filter(|v| {
            v.causality == crate::variables::Causality::Output
                && v.var_type == crate::variables::VarType::Real
        })
        .take(REFERENCE_OUTPUTS)
        .map(|v| (v.name.clone(), v.value_reference))
        .collect();
    let e = &scene.experiment;
    let steps = ((e.stop_time - e.start_time) / e.step_size)
        .round()
        .max(0.0) as usize;
    let quoted: Vec<String> = std::iter::once("time".to_string())
        .chain(outputs.iter().map(|(n, _)| n.clone()))
        .map(|n| csv_quoted(&n))
        .collect();
    let mut csv = quoted.join(",");
    csv.push('\n');
    for k in 0..=steps {
        if !engine.solve().converged() {
            return Ok(None);
        }
        let t = if k == steps {
            e.stop_time
        } else {
            e.start_time + k as f64 * e.step_size
        };
        csv.push_str(&xs_double(t));
        for (_, vr) in &outputs {
            let value = engine.get_real(*vr)?;
            csv.push(',');
            csv.push_str(&xs_double(value));
        }
        csv.push('\n');
    }
    Ok(Some(csv))
}

/// The FMI-LS-REF manifest naming the reference result.
fn reference_manifest(scene: &Scene) -> String {
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiReferences\n    xmlns:fmi-ls=\"http://fmi-standard.org/fmi-ls-manifest\"\n    fmi-ls:fmi-ls-name=\"org.fmi-standard.fmi-ls-ref\"\n    fmi-ls:fmi-ls-version=\"1.0.0-alpha.1\"\n    fmi-ls:fmi-ls-description=\"Layered Standard providing information on related files included in an FMU.\">\n    <Related type=\"text/csv\" source=\"{}_ref.csv\" role=\"result\" description=\"Outputs of the default experiment (inputs at their start values)\"/>\n</fmiReferences>\n",
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
    mesh: &[u8],
) -> zip::result::ZipResult<Vec<u8>> {
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(DateTime::default());
    let scene_json = scene.to_json();
    let mut zip = ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let manifest = reference_manifest(scene);
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
