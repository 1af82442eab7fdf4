//! The `velarium` command: pack scenes into FMUs, run load histories, check scenes.
//!
//! Exit codes: 0 success, 1 failure (bad scene, unreadable file, a step that did not
//! converge), 2 usage error (clap's usage errors exit 2).

use clap::{Parser, Subcommand};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use velarium::description::model_description;
use velarium::history::{self, Event, LoadTable};
use velarium::pack::{choose_library, pack_versions, write_atomically, FmiVersion};
use velarium::scene::generate::try_resolve;
use velarium::scene::validate::validate;
use velarium::vtk;
use velarium::{Engine, Scene};

/// Nonlinear cable-reinforced membranes: pack scenes into FMI 2.0 co-simulation FMUs, run load
/// histories, check scenes.
#[derive(Parser)]
#[command(
    name = "velarium",
    version,
    arg_required_else_help = true,
    after_help = "Exit codes: 0 success, 1 failure (a bad scene, an unreadable file, a step that did not converge), 2 wrong arguments.\n\nExamples:\n  velarium check examples/WindSquare.json\n  velarium solve examples/WindSquare.json --loads examples/WindSquare-loads.csv --vtk build/WindSquare\n  velarium pack modelDescription/HenckyDisc/scene.json --out build/fmus\n\n`velarium help COMMAND` or `velarium COMMAND --help` explains one command."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Write DIR/<name>.fmu (FMI 2.0) and DIR/<name>_fmi3.fmu (FMI 3.0 co-simulation).
    ///
    /// The scene is validated first. Each FMU holds its modelDescription.xml, the library
    /// (binaries/linux64/<name>.so for FMI 2, binaries/x86_64-linux/<name>.so for FMI 3; one
    /// binary serves both) and resources/scene.json. The archives are reproducible and written
    /// through temporary files: a failed pack leaves nothing.
    #[command(
        after_help = "Examples:\n  velarium pack modelDescription/HenckyDisc/scene.json --out build/fmus\n  velarium pack examples/WindSquare.json --out build/fmus --fmi 3\n  velarium pack examples/WindSquare.json --out build/fmus --lib target/release/libvelarium.so"
    )]
    Pack {
        /// The scene (JSON).
        #[arg(value_name = "SCENE.json")]
        scene: String,
        /// Directory to write <name>.fmu into (created if missing).
        #[arg(long, value_name = "DIR")]
        out: String,
        /// The FMU library to ship; default: the file named by the environment variable
        /// VELARIUM_LIB if set, else the portable glibc 2.17 build
        /// (../x86_64-unknown-linux-gnu/release/libvelarium.so, built by harness/portable.sh)
        /// when it is not older than the native one, else libvelarium.so next to this
        /// executable (built by `cargo build --release`), with a note on stderr.
        #[arg(long, value_name = "PATH")]
        lib: Option<String>,
        /// Write only this FMI version's archive (2 or 3); default: both.
        #[arg(long, value_name = "2|3", value_parser = ["2", "3"])]
        fmi: Option<String>,
    },
    /// Run a quasi-static load history and write every output per load row as CSV.
    ///
    /// LOADS.csv has the header `time,<input names>` (any subset of the scene's inputs, any
    /// order; the others keep their start values; `#` lines are comments). Lines
    /// `combination,<name>,<input>,<factor>,...` before the header define load combinations
    /// that the header may name like inputs: the column's value times each factor goes to each
    /// input, and an input named by several columns gets the sum. Row 0 of the result
    /// is the equilibrium under the first row's loads, row k the equilibrium under row k's loads
    /// reached from row k-1's. If a step does not converge, the rows before it are written and
    /// the command exits 1 naming the row.
    ///
    /// A progress line (load row, load fraction and iterations of the last row, elapsed time)
    /// is shown on stderr once a run takes longer than a second, only when stderr is a
    /// terminal and --quiet is not given.
    #[command(
        after_help = "Examples:\n  velarium solve modelDescription/PrestressedCable/scene.json --loads examples/PrestressedCable-loads.csv\n  velarium solve examples/WindSquare.json --loads examples/WindSquare-loads.csv --out build/WindSquare.csv --vtk build/WindSquare\n  velarium solve examples/WindSquare.json --loads examples/WindSquare-loads.csv --elements build/WindSquare-elements.csv --quiet\n\nA load table (examples/PrestressedCable-loads.csv):\n  time,P\n  0,0\n  0.5,5000\n  1,10000\n\nWith a load combination (1.35 dead + 1.5 wind):\n  combination,ULS,dead,1.35,wind,1.5\n  time,ULS\n  0,0\n  1,1"
    )]
    Solve {
        /// The scene (JSON).
        #[arg(value_name = "SCENE.json")]
        scene: String,
        /// The load table (CSV, header `time,<input names>`).
        #[arg(long, value_name = "LOADS.csv")]
        loads: String,
        /// Write the result CSV here instead of stdout.
        #[arg(long, value_name = "OUT.csv")]
        out: Option<String>,
        /// Also write, per triangle and row, the wrinkle state, tension direction, centroid,
        /// principal stresses and vertices (plot with harness/plot_elements.py).
        #[arg(long, value_name = "ELEMENTS.csv")]
        elements: Option<String>,
        /// Write a ParaView series into DIR: <name>_NNNN.vtu per converged load row (mesh and
        /// cables at their reference positions with displacement_m, so Warp By Vector shows
        /// the deformed shape; stresses, wrinkle state, tension direction, cable tension, slip;
        /// zlib-compressed binary) and <name>.pvd ordering them in time. DIR is created if
        /// missing.
        #[arg(long, value_name = "DIR")]
        vtk: Option<String>,
        /// No progress line on stderr.
        #[arg(long, short)]
        quiet: bool,
        /// Print the memory line on stderr also when stderr is not a terminal (it is printed
        /// at the end of a run on a terminal unless --quiet): the engine's estimate for model
        /// and solver and the process's peak resident set.
        #[arg(long)]
        memory: bool,
        /// Print on stderr where the run's time went: reading the scene, setting up (mesh,
        /// model, pattern, ordering, symbolic factorization), solving the load rows, writing;
        /// and the thread count (the scale example's `--e2e` reads this line).
        #[arg(long)]
        timings: bool,
        /// Solver threads (1-64), instead of the scene's `solver.threads`; when neither gives
        /// a count, the machine's cores (an FMU uses 1 unless its scene asks). 2 or more
        /// factor and assemble a tangent of 20 000 equations or more in two halves at once
        /// (docs/performance.md); below that size the count changes nothing, and above it
        /// the results agree with 1 thread to round-off (`--threads 1` gives the FMU's bits).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=64))]
        threads: Option<u64>,
    },
    /// Print the lowest natural frequencies about an equilibrium and write the mode shapes.
    ///
    /// The equilibrium is the scene's start (its inputs' start values) or, with --loads, the
    /// load table's row K (rows 0 to K solved as `velarium solve` does). The frequencies are
    /// those of small vibrations about it: the true tangent there (the prestress's geometric
    /// stiffness, wrinkled and slack states as converged, held DOFs removed) and the mass of
    /// the membranes' `density`, the cables' `mass_per_length` and the `dynamics` section's
    /// point masses, consistent or lumped as that section says (consistent without it);
    /// shift-invert Lanczos (docs/dynamics.md). Exits 1 if the scene has no mass, the
    /// equilibrium is not reached or the factorization fails.
    #[command(
        after_help = "Examples:\n  velarium modes examples/VibratingMembrane.json --count 6\n  velarium modes scene.json --loads loads.csv --row 3 --count 10 --vtk build/modes"
    )]
    Modes {
        /// The scene (JSON).
        #[arg(value_name = "SCENE.json")]
        scene: String,
        /// A load table (as `velarium solve`'s) whose row --row is the equilibrium.
        #[arg(long, value_name = "LOADS.csv")]
        loads: Option<String>,
        /// The row of --loads (0-based; default: the last).
        #[arg(long, value_name = "K", requires = "loads")]
        row: Option<usize>,
        /// How many of the lowest frequencies.
        #[arg(long, value_name = "N", default_value_t = 6, value_parser = clap::value_parser!(u64).range(1..=1000))]
        count: u64,
        /// Write the mode shapes as a ParaView series into DIR: <name>_modes_NNNN.vtu per mode
        /// (the equilibrium's arrays plus `mode_shape`, largest amplitude 1, and
        /// `frequency_Hz`; time = the mode's number) and <name>_modes.pvd.
        #[arg(long, value_name = "DIR")]
        vtk: Option<String>,
    },
    /// List every problem of a scene by JSON path; exit 1 if there is any.
    ///
    /// A valid scene gets a summary, a cost line and a `warning: path: message` line for each
    /// number that is valid but most likely a slip: a prestress or pretension implying more
    /// than 5 % strain, a modulus 100x outside its material's usual range, a sleeve penalty
    /// softer than the members it ties. Warnings do not change the exit code.
    #[command(
        after_help = "Examples:\n  velarium check modelDescription/SleeveCable/scene.json\n  (prints `ok: SleeveCable, ... unknowns`, or one `path: message` line per problem)"
    )]
    Check {
        /// The scene (JSON).
        #[arg(value_name = "SCENE.json")]
        scene: String,
    },
    /// Find the equilibrium shape of the scene's prestress and write it as a new scene.
    ///
    /// Every membrane group needs a `prestress` and every cable a `pretension`; supported
    /// components stay where the geometry (or `form_finding.place`) puts them. The iteration is
    /// the Updated Reference Strategy (docs/mechanics.md §10), with the scene's `form_finding`
    /// settings or their defaults. FOUND.json has the found positions as explicit geometry (all
    /// node and triangle sets kept) and the same prestress as its initial stress state, so its
    /// analysis starts in equilibrium. Prints the iterations and the time; exits 1 if the shape
    /// is not found (nothing is written then).
    #[command(
        after_help = "Examples:\n  velarium formfind modelDescription/FourPointSail/scene.json --out build/FourPointSail-found.json\n  velarium formfind modelDescription/ConicalTent/scene.json --out build/ConicalTent-found.json --quiet"
    )]
    Formfind {
        /// The scene (JSON).
        #[arg(value_name = "SCENE.json")]
        scene: String,
        /// Where to write the found scene (JSON).
        #[arg(long, value_name = "FOUND.json")]
        out: String,
        /// Print only the summary line, not one line per iteration.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Print the scene's modelDescription.xml.
    #[command(
        after_help = "Examples:\n  velarium describe modelDescription/HenckyDisc/scene.json > build/modelDescription.xml"
    )]
    Describe {
        /// The scene (JSON).
        #[arg(value_name = "SCENE.json")]
        scene: String,
    },
    /// Print the JSON Schema of the scene format (every field, its unit and default).
    #[command(after_help = "Examples:\n  velarium schema > build/scene.schema.json")]
    Schema,
    /// Print the version (as --version).
    #[command(hide = true)]
    Version,
}

/// The usage line of a subcommand (of the whole command if `name` is none of them).
fn usage_of(name: Option<&str>) -> String {
    use clap::CommandFactory;
    let mut command = Cli::command();
    command.build();
    let usage = match name.and_then(|n| command.find_subcommand_mut(n)) {
        Some(sub) => sub.render_usage(),
        None => command.render_usage(),
    };
    usage.to_string().replacen("Usage:", "usage:", 1)
}

/// Why the command stopped (wrong arguments are clap's: exit 2).
enum Stop {
    /// The command could not do its job: exit 1.
    Failed(String),
}

/// Write to standard output. A reader that closed the pipe (`velarium check x.json | head -1`)
/// ends the command quietly with success, as the usual Unix tools do, instead of a panic.
fn emit(text: &str) {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("velarium: cannot write to standard output: {e}");
        std::process::exit(1);
    }
}

macro_rules! out {
    ($($arg:tt)*) => { emit(&format!($($arg)*)) };
}

macro_rules! outln {
    ($($arg:tt)*) => { emit(&format!("{}\n", format!($($arg)*))) };
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            return match e.kind() {
                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
                    let _ = e.print();
                    ExitCode::SUCCESS
                }
                ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
                    eprint!("{}", e.render().to_string().replacen("Usage:", "usage:", 1));
                    ExitCode::from(2)
                }
                _ => {
                    let text = e.render().to_string();
                    let text = text.strip_prefix("error: ").unwrap_or(&text);
                    let text = text.replacen("Usage:", "usage:", 1);
                    eprint!("velarium: {text}");
                    if !text.contains("usage:") {
                        eprintln!("\n{}", usage_of(std::env::args().nth(1).as_deref()));
                    }
                    ExitCode::from(2)
                }
            };
        }
    };
    let result = match cli.command {
        Command::Pack {
            scene,
            out,
            lib,
            fmi,
        } => cmd_pack(&scene, &out, lib.as_deref(), fmi.as_deref()),
        Command::Solve {
            scene,
            loads,
            out,
            elements,
            vtk,
            quiet,
            memory,
            timings,
            threads,
        } => cmd_solve(&SolveArgs {
            scene,
            loads,
            out,
            elements,
            vtk,
            quiet,
            memory,
            timings,
            threads: threads.map(|n| n as usize),
        }),
        Command::Check { scene } => cmd_check(&scene),
        Command::Modes {
            scene,
            loads,
            row,
            count,
            vtk,
        } => cmd_modes(
            &scene,
            loads.as_deref(),
            row,
            count as usize,
            vtk.as_deref(),
        ),
        Command::Formfind { scene, out, quiet } => cmd_formfind(&scene, &out, quiet),
        Command::Describe { scene } => cmd_describe(&scene),
        Command::Schema => {
            outln!("{}", Scene::json_schema());
            Ok(ExitCode::SUCCESS)
        }
        Command::Version => {
            outln!("velarium {}", env!("CARGO_PKG_VERSION"));
            Ok(ExitCode::SUCCESS)
        }
    };
    match result {
        Ok(code) => code,
        Err(Stop::Failed(message)) => {
            eprintln!("velarium: {message}");
            ExitCode::from(1)
        }
    }
}

fn read_bytes(path: &str) -> Result<Vec<u8>, Stop> {
    std::fs::read(path).map_err(|e| Stop::Failed(format!("{path}: cannot read: {e}")))
}

/// A text file (a load table): a byte-order mark is skipped, invalid UTF-8 named by offset.
fn read_text(path: &str) -> Result<String, Stop> {
    let bytes = read_bytes(path)?;
    velarium::scene::read::decode_text(&bytes)
        .map(str::to_string)
        .map_err(|m| Stop::Failed(format!("{path}: {m}")))
}

fn read_scene(path: &str) -> Result<Scene, Stop> {
    Scene::parse(&read_bytes(path)?)
        .map_err(|p| Stop::Failed(format!("{path}: {}", velarium::Error::Scene(p))))
}

/// Whether a scene's text sets `solver.threads` (a valid scene: it parsed).
fn sets_threads(bytes: &[u8]) -> bool {
    // Most scenes never name it: a search of the bytes spares them a second parse.
    if !bytes.windows(9).any(|w| w == b"\"threads\"") {
        return false;
    }
    serde_json::from_slice::<serde_json::Value>(bytes)
        .ok()
        .and_then(|v| v.get("solver").map(|s| s.get("threads").is_some()))
        .unwrap_or(false)
}

/// `velarium solve`'s thread count when neither `--threads` nor the scene gives one: the cores
/// the process may use (1 where that is unknown), at most the solver's bound.
fn machine_threads() -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, velarium::solver::threads::MAX_THREADS)
}

/// Validate a scene and build its engine; problems name the file and every JSON path.
fn engine_for(path: &str) -> Result<Engine, Stop> {
    Engine::try_new(read_scene(path)?).map_err(|e| Stop::Failed(format!("{path}: {e}")))
}

fn failed(e: velarium::Error) -> Stop {
    Stop::Failed(e.to_string())
}

fn cmd_formfind(path: &str, out: &str, quiet: bool) -> Result<ExitCode, Stop> {
    let scene = read_scene(path)?;
    let report =
        velarium::formfind::run(&scene).map_err(|e| Stop::Failed(format!("{path}: {e}")))?;
    if !quiet {
        for line in &report.log {
            println!("{line}");
        }
    }
    let Some(found) = report.scene else {
        return Err(Stop::Failed(format!(
            "{path}: form finding failed after {} iterations: {}",
            report.iterations, report.message
        )));
    };
    let mut text = found.to_json();
    text.push('\n');
    write_atomically(Path::new(out), text.as_bytes()).map_err(failed)?;
    println!(
        "form finding converged: {} iterations, {:.3} s; the shape moved {:.1e} of the span in the iteration that met the tolerance, the finishing step {:.1e}; stress within {:.1e} of the prescribed, smallest triangle angle {:.1}°; wrote {out}",
        report.iterations,
        report.seconds,
        report.shape_move,
        report.last_move,
        report.deviation,
        report.min_angle.0
    );
    Ok(ExitCode::SUCCESS)
}

fn cmd_pack(
    scene_path: &str,
    out: &str,
    lib: Option<&str>,
    fmi: Option<&str>,
) -> Result<ExitCode, Stop> {
    let versions = match fmi {
        None => vec![FmiVersion::Fmi2, FmiVersion::Fmi3],
        Some("2") => vec![FmiVersion::Fmi2],
        Some("3") => vec![FmiVersion::Fmi3],
        Some(other) => {
            // clap's value parser admits only 2 and 3.
            return Err(Stop::Failed(format!(
                "--fmi {other:?}: the FMI version is 2 or 3"
            )));
        }
    };
    let out = PathBuf::from(out);
    let scene = read_scene(scene_path)?;
    let problems = validate(&scene);
    if !problems.is_empty() {
        return Err(Stop::Failed(format!(
            "{}: {}",
            scene_path,
            velarium::Error::Scene(problems)
        )));
    }
    let choice = choose_library(lib.map(Path::new)).map_err(failed)?;
    if let Some(notice) = &choice.notice {
        eprintln!("velarium pack: {notice}");
    }
    let library = choice.path;
    let fmus = pack_versions(&scene, &out, &library, &versions)
        .map_err(|e| Stop::Failed(format!("{scene_path}: {e}")))?;
    for fmu in fmus {
        outln!("{}", fmu.display());
    }
    Ok(ExitCode::SUCCESS)
}

struct SolveArgs {
    scene: String,
    loads: String,
    out: Option<String>,
    elements: Option<String>,
    vtk: Option<String>,
    quiet: bool,
    memory: bool,
    timings: bool,
    threads: Option<usize>,
}

fn cmd_solve(args: &SolveArgs) -> Result<ExitCode, Stop> {
    let loads = args.loads.as_str();
    let started = Instant::now();
    let bytes = read_bytes(&args.scene)?;
    let mut scene = Scene::parse(&bytes)
        .map_err(|p| Stop::Failed(format!("{}: {}", args.scene, velarium::Error::Scene(p))))?;
    match args.threads {
        Some(n) => scene.solver.threads = n,
        // The user's machine: its cores, unless the scene asks for a count.
        None if !sets_threads(&bytes) => scene.solver.threads = machine_threads(),
        None => {}
    }
    let threads = scene.solver.threads;
    let read = started.elapsed().as_secs_f64();
    let mut engine =
        Engine::try_new(scene).map_err(|e| Stop::Failed(format!("{}: {e}", args.scene)))?;
    let setup = started.elapsed().as_secs_f64() - read;
    let table = LoadTable::parse(&read_text(loads)?, loads, &mut engine).map_err(failed)?;
    let mut series = match &args.vtk {
        Some(dir) => {
            Some(vtk::Series::create(Path::new(dir), &engine.scene().name).map_err(failed)?)
        }
        None => None,
    };
    let progress = Progress::start(!args.quiet && std::io::stderr().is_terminal());
    let result = history::run_observed(
        &mut engine,
        &table,
        args.elements.is_some(),
        &mut |engine, event| {
            progress.update(&event);
            match (&mut series, event) {
                (Some(series), Event::Done { row, report, .. }) if report.converged() => {
                    series.write_row(engine, row.time)
                }
                _ => Ok(()),
            }
        },
    );
    progress.finish();
    let solved = started.elapsed().as_secs_f64();
    if args.memory || (!args.quiet && std::io::stderr().is_terminal()) {
        eprintln!(
            "velarium: {}",
            velarium::memory::report(engine.memory_estimate())
        );
    }
    let history = result.map_err(failed)?;
    if let Some(series) = &series {
        series.finish().map_err(failed)?;
    }
    if let Some(path) = &args.elements {
        write_atomically(Path::new(path), history.elements.as_bytes()).map_err(failed)?;
    }
    let csv = history.to_csv();
    match &args.out {
        Some(out) => write_atomically(Path::new(out), csv.as_bytes()).map_err(failed)?,
        None => out!("{csv}"),
    }
    if args.timings {
        eprintln!(
            "velarium: timings: read {read:.3} s, setup {setup:.3} s, solve {:.3} s, write {:.3} s, {threads} thread(s)",
            solved - read - setup,
            started.elapsed().as_secs_f64() - solved
        );
    }
    match history.failure {
        None => Ok(ExitCode::SUCCESS),
        Some(f) => Err(Stop::Failed(format!(
            "{loads}: line {}: the step to time {} did not converge: {}; the {} row(s) before it were written",
            f.line,
            f.time,
            f.message,
            history.rows.len()
        ))),
    }
}

fn cmd_modes(
    path: &str,
    loads: Option<&str>,
    row: Option<usize>,
    count: usize,
    vtk_dir: Option<&str>,
) -> Result<ExitCode, Stop> {
    let started = Instant::now();
    let mut engine = engine_for(path)?;
    match loads {
        Some(loads) => {
            let mut table =
                LoadTable::parse(&read_text(loads)?, loads, &mut engine).map_err(failed)?;
            let last = table.rows.len().saturating_sub(1);
            let k = row.unwrap_or(last);
            if k > last {
                return Err(Stop::Failed(format!(
                    "--row {k}: {loads} has rows 0 to {last}"
                )));
            }
            table.rows.truncate(k + 1);
            let history = history::run_observed(&mut engine, &table, false, &mut |_, _| Ok(()))
                .map_err(failed)?;
            if let Some(f) = history.failure {
                return Err(Stop::Failed(format!(
                    "{loads}: line {}: the step to time {} did not converge: {}",
                    f.line, f.time, f.message
                )));
            }
        }
        None => {
            let report = engine.solve();
            if !report.converged() {
                return Err(Stop::Failed(format!(
                    "{path}: the equilibrium under the start values was not reached: {}",
                    report.message
                )));
            }
        }
    }
    let solved = started.elapsed().as_secs_f64();
    let modes = engine
        .modes(count)
        .map_err(|e| Stop::Failed(format!("{path}: {e}")))?;
    let seconds = started.elapsed().as_secs_f64() - solved;
    outln!("mode,frequency_Hz");
    for (k, f) in modes.frequencies.iter().enumerate() {
        outln!("{},{}", k + 1, f);
    }
    eprintln!(
        "velarium: {} of {count} frequencies in {seconds:.3} s ({} solves with K - sigma M, sigma = {:.3e} 1/s2); equilibrium {solved:.3} s",
        modes.frequencies.len(),
        modes.solves,
        modes.shift
    );
    if let Some(dir) = vtk_dir {
        let stem = format!("{}_modes", engine.scene().name);
        let mut series = vtk::Series::create(Path::new(dir), &stem).map_err(failed)?;
        for (k, (f, shape)) in modes.frequencies.iter().zip(&modes.shapes).enumerate() {
            series
                .write_mode(&engine, k + 1, *f, shape)
                .map_err(failed)?;
        }
        series.finish().map_err(failed)?;
    }
    if modes.frequencies.len() < count.min(engine.free_dofs()) {
        return Err(Stop::Failed(format!(
            "{path}: only {} of the {count} lowest frequencies converged",
            modes.frequencies.len()
        )));
    }
    Ok(ExitCode::SUCCESS)
}

/// The progress line of `velarium solve` on stderr: redrawn a few times a second by a thread
/// of its own once the run has taken `VELARIUM_PROGRESS_AFTER` seconds (default 1), so that a
/// long load row still shows its elapsed time.
struct Progress {
    /// Seconds before the line appears.
    after: f64,
    shared: Option<Arc<Mutex<ProgressState>>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

struct ProgressState {
    started: Instant,
    row: usize,
    total: usize,
    time: f64,
    row_started: Instant,
    /// Load fraction reached and Newton iterations of the last finished row.
    last: Option<(f64, usize)>,
    iterations: usize,
    shown: bool,
}

impl ProgressState {
    fn line(&self) -> String {
        let now = Instant::now();
        let last = match self.last {
            Some((reached, iterations)) => {
                format!("last row: load fraction {reached:.3}, {iterations} iterations; ")
            }
            None => String::new(),
        };
        format!(
            "velarium: row {}/{} (time {}), {:.1} s on it; {last}{} iterations in all; elapsed {:.1} s",
            self.row + 1,
            self.total,
            self.time,
            (now - self.row_started).as_secs_f64(),
            self.iterations,
            (now - self.started).as_secs_f64()
        )
    }
}

impl Progress {
    fn start(enabled: bool) -> Progress {
        let stop = Arc::new(AtomicBool::new(false));
        if !enabled {
            return Progress {
                after: f64::INFINITY,
                shared: None,
                stop,
                thread: None,
            };
        }
        let after = std::env::var("VELARIUM_PROGRESS_AFTER")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v >= 0.0)
            .unwrap_or(1.0);
        let now = Instant::now();
        let shared = Arc::new(Mutex::new(ProgressState {
            started: now,
            row: 0,
            total: 0,
            time: 0.0,
            row_started: now,
            last: None,
            iterations: 0,
            shown: false,
        }));
        let thread = {
            let shared = Arc::clone(&shared);
            let stop = Arc::clone(&stop);
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(100));
                    let Ok(mut state) = shared.lock() else { return };
                    if stop.load(Ordering::Relaxed) {
                        return;
                    }
                    if state.started.elapsed().as_secs_f64() >= after {
                        eprint!("\r\x1b[2K{}", state.line());
                        state.shown = true;
                    }
                }
            })
        };
        Progress {
            after,
            shared: Some(shared),
            stop,
            thread: Some(thread),
        }
    }

    fn update(&self, event: &Event) {
        let Some(shared) = &self.shared else { return };
        let Ok(mut state) = shared.lock() else { return };
        match event {
            Event::Start { index, total, row } => {
                state.row = *index;
                state.total = *total;
                state.time = row.time;
                state.row_started = Instant::now();
            }
            Event::Done { report, .. } => {
                state.last = Some((report.reached, report.iterations));
                state.iterations += report.iterations;
            }
        }
    }

    /// Stop redrawing; leave the final progress line (for a run that took `after` seconds or
    /// more) ended by a newline, so that what follows starts on a line of its own.
    fn finish(mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        if let Some(shared) = &self.shared {
            if let Ok(state) = shared.lock() {
                if state.shown || state.started.elapsed().as_secs_f64() >= self.after {
                    eprintln!("\r\x1b[2K{}", state.line());
                }
            }
        }
    }
}

fn cmd_check(path: &str) -> Result<ExitCode, Stop> {
    let scene = match velarium::scene::read::parse(&read_bytes(path)?) {
        Ok(scene) => scene,
        Err((mut problems, recovered)) => {
            // Only unknown fields: the rest of the scene is checked in the same run.
            if let Some(scene) = recovered {
                problems.extend(validate(&scene));
            }
            return Ok(report_problems(path, &problems));
        }
    };
    let (problems, size) = velarium::scene::validate::validate_sized(&scene);
    if !problems.is_empty() {
        return Ok(report_problems(path, &problems));
    }
    let mesh = try_resolve(&scene.geometry).map_err(|e| Stop::Failed(format!("{path}: {e}")))?;
    let counts = [
        (scene.membranes.len(), "membrane group"),
        (scene.cables.len(), "cable"),
        (scene.inputs.len(), "input"),
        (scene.outputs.len(), "output"),
        (scene.parameters.len(), "parameter"),
    ];
    // The model only (not the solver's workspace): check stays fast and small.
    let model = velarium::model::Model::try_build(&scene)
        .map_err(|p| Stop::Failed(format!("{path}: {p}")))?;
    // Free displacement DOFs plus one slip per sleeve point.
    let free = model.held.iter().filter(|held| !**held).count() + model.slips.len();
    let mut line = format!(
        "ok: {}, {}, {}",
        scene.name,
        count(mesh.nodes.len(), "node"),
        count(mesh.triangles.len(), "triangle")
    );
    for (n, what) in counts {
        line.push_str(&format!(", {}", count(n, what)));
    }
    outln!(
        "{line}, {free} unknowns; estimated solve memory {:.3} GB (factor {} entries), limit {} GB",
        size.memory_bytes as f64 / 1e9,
        size.factor_entries,
        scene.solver.limits.max_memory_gb
    );
    outln!("{}", cost_line(&scene, &size, model.triangles.len()));
    if velarium::engine::coarse::coarser_scene(&scene, &model, free).is_some() {
        outln!(
            "coarse start: the first step from the undeformed state first solves this scene on a coarser mesh (solver.coarse_start: a generated mesh with half the divisions, an explicit one with edges collapsed), within its own budget, and Newton here starts from its answer; each coarser mesh has about a quarter of the next finer one's unknowns (the coarse meshes together about a third of this one's, or less: a factorization's cost grows faster than the unknowns), and where Newton does not converge from that answer the step goes on from the undeformed state within the budget above"
        );
    }
    // Plausibility warnings: the scene is valid, so they do not change the exit code.
    for w in velarium::scene::plausibility::warnings(&scene) {
        outln!("warning: {w}");
    }
    Ok(ExitCode::SUCCESS)
}

/// What one Newton iteration costs at least (one factorization, one assembly and one trial
/// point), what a step whose increment converges at once takes (up to max_iterations; a step
/// that cuts back or continues takes more, within the budget), and what a
/// step that does not converge spends before it gives up: its work budget of
/// max_step_iterations iterations, in which every further line-search trial, re-check assembly
/// and relaxation round counts as an iteration of its own or half of one (a relaxation round
/// can cost more than the iteration it stands for: the step's whole work, each round counted
/// at the element evaluations it made, is bounded by 20 times the budget; the model:
/// `velarium::scene::limits::cost`).
fn cost_line(
    scene: &velarium::Scene,
    size: &velarium::scene::limits::Size,
    triangles: usize,
) -> String {
    let s = &scene.solver;
    let c = velarium::scene::limits::cost(s, size, triangles as u64);
    format!(
        "cost: a Newton iteration factors {:.3} GFlop and assembles {triangles} membrane elements, at least {:.3} s on the reference machine; a step whose load increment converges at once takes up to about {} iterations (solver.max_iterations, about {:.0} s); cut-backs and continuations can take a converging step further, up to the budget of one that does not converge, which gives up after at most {} iterations' worth of work (solver.max_step_iterations; every further line-search trial or re-check counts as half of one, a round of nodal relaxation as one, though it can cost several, so the whole work with each round counted at its cost may reach 20 times the budget): about {:.0} s, a few times that where nodal relaxation runs long",
        size.factor_flops / 1e9,
        c.iteration,
        s.max_iterations,
        c.converging,
        s.max_step_iterations,
        c.failing
    )
}

/// Print each problem as `path: message` on stdout and a summary naming the file on stderr.
fn report_problems(path: &str, problems: &[velarium::scene::Problem]) -> ExitCode {
    for p in problems {
        outln!("{p}");
    }
    eprintln!("velarium: {path}: {}", count(problems.len(), "problem"));
    ExitCode::FAILURE
}

fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

fn cmd_describe(path: &str) -> Result<ExitCode, Stop> {
    let engine = engine_for(path)?;
    out!("{}", model_description(engine.scene(), engine.variables()));
    Ok(ExitCode::SUCCESS)
}
