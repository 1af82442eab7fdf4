//! The `velarium` command: pack scenes into FMUs, run load histories, check scenes.
//!
//! Exit codes: 0 success, 1 failure (bad scene, unreadable file, a step that did not
//! converge), 2 usage error.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use velarium::description::model_description;
use velarium::history::{self, LoadTable};
use velarium::pack::{find_library, pack_versions, write_atomically, FmiVersion};
use velarium::scene::generate::resolve;
use velarium::scene::validate::validate;
use velarium::{Engine, Scene};

const USAGE: &str = "\
usage:
  velarium pack SCENE.json --out DIR [--lib PATH] [--fmi 2|3]
        write DIR/<name>.fmu (FMI 2.0 co-simulation) and DIR/<name>_fmi3.fmu (FMI 3.0),
        or only the one --fmi names; the library is PATH, else libvelarium.so next to
        this executable (built by `cargo build --release`)
  velarium solve SCENE.json --loads LOADS.csv [--out OUT.csv] [--elements ELEMENTS.csv]
        run a quasi-static load history (CSV header: time,<input names>) and write
        time and every output per row as CSV (to stdout without --out)
  velarium check SCENE.json
        list every problem of a scene by JSON path; exit 1 if there is any
  velarium describe SCENE.json
        print the scene's modelDescription.xml
  velarium schema
        print the JSON Schema of the scene format
  velarium --version";

/// Why the command stopped.
enum Stop {
    /// Wrong arguments: exit 2 with the usage text.
    Usage(String),
    /// The command could not do its job: exit 1.
    Failed(String),
}

fn main() -> ExitCode {
    let args: Result<Vec<String>, _> = std::env::args_os()
        .skip(1)
        .map(|a| a.into_string())
        .collect();
    let result = match args {
        Ok(args) => run(&args),
        Err(bad) => Err(Stop::Usage(format!("argument {bad:?} is not valid UTF-8"))),
    };
    match result {
        Ok(code) => code,
        Err(Stop::Usage(message)) => {
            eprintln!("velarium: {message}\n\n{USAGE}");
            ExitCode::from(2)
        }
        Err(Stop::Failed(message)) => {
            eprintln!("velarium: {message}");
            ExitCode::from(1)
        }
    }
}

fn run(args: &[String]) -> Result<ExitCode, Stop> {
    let Some((command, rest)) = args.split_first() else {
        return Err(Stop::Usage("no command given".into()));
    };
    match command.as_str() {
        "pack" => cmd_pack(&Args::parse(rest, 1, &["--out", "--lib", "--fmi"])?),
        "solve" => cmd_solve(&Args::parse(rest, 1, &["--loads", "--out", "--elements"])?),
        "check" => cmd_check(&Args::parse(rest, 1, &[])?),
        "describe" => cmd_describe(&Args::parse(rest, 1, &[])?),
        "schema" => {
            Args::parse(rest, 0, &[])?;
            println!("{}", Scene::json_schema());
            Ok(ExitCode::SUCCESS)
        }
        "--version" | "-V" | "version" => {
            println!("velarium {}", env!("CARGO_PKG_VERSION"));
            Ok(ExitCode::SUCCESS)
        }
        "--help" | "-h" | "help" => {
            println!("{USAGE}");
            Ok(ExitCode::SUCCESS)
        }
        other => Err(Stop::Usage(format!("unknown command {other:?}"))),
    }
}

/// Positional arguments and `--name VALUE` (or `--name=VALUE`) options of one command.
struct Args {
    positional: Vec<String>,
    options: Vec<(String, String)>,
}

impl Args {
    fn parse(args: &[String], positional: usize, allowed: &[&str]) -> Result<Args, Stop> {
        let mut parsed = Args {
            positional: Vec::new(),
            options: Vec::new(),
        };
        let mut iter = args.iter();
        while let Some(arg) = iter.next() {
            if !arg.starts_with("--") {
                parsed.positional.push(arg.clone());
                continue;
            }
            let (name, inline) = match arg.split_once('=') {
                Some((n, v)) => (n, Some(v.to_string())),
                None => (arg.as_str(), None),
            };
            if !allowed.contains(&name) {
                return Err(Stop::Usage(format!("unknown option {name}")));
            }
            if parsed.options.iter().any(|(n, _)| n == name) {
                return Err(Stop::Usage(format!("option {name} given twice")));
            }
            let value = match inline {
                Some(v) => v,
                None => iter
                    .next()
                    .cloned()
                    .ok_or_else(|| Stop::Usage(format!("option {name} needs a value")))?,
            };
            parsed.options.push((name.to_string(), value));
        }
        if parsed.positional.len() != positional {
            return Err(Stop::Usage(match positional {
                0 => format!("unexpected argument {:?}", parsed.positional[0]),
                _ if parsed.positional.is_empty() => "missing SCENE.json".into(),
                _ => format!("unexpected argument {:?}", parsed.positional[positional]),
            }));
        }
        Ok(parsed)
    }

    fn option(&self, name: &str) -> Option<&str> {
        self.options
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    fn required(&self, name: &str) -> Result<&str, Stop> {
        self.option(name)
            .ok_or_else(|| Stop::Usage(format!("option {name} is required")))
    }

    fn scene_path(&self) -> &str {
        &self.positional[0]
    }
}

fn read_text(path: &str) -> Result<String, Stop> {
    std::fs::read_to_string(path).map_err(|e| Stop::Failed(format!("{path}: cannot read: {e}")))
}

/// Read and parse a scene; a syntax or type error names the file and the JSON path.
fn read_scene(path: &str) -> Result<Scene, Stop> {
    Scene::from_json(&read_text(path)?).map_err(|p| Stop::Failed(format!("{path}: {p}")))
}

/// Validate a scene and build its engine; problems name the file and every JSON path.
fn engine_for(path: &str) -> Result<Engine, Stop> {
    Engine::try_new(read_scene(path)?).map_err(|e| Stop::Failed(format!("{path}: {e}")))
}

fn failed(e: velarium::Error) -> Stop {
    Stop::Failed(e.to_string())
}

fn cmd_pack(args: &Args) -> Result<ExitCode, Stop> {
    let out = PathBuf::from(args.required("--out")?);
    let versions = match args.option("--fmi") {
        None => vec![FmiVersion::Fmi2, FmiVersion::Fmi3],
        Some("2") => vec![FmiVersion::Fmi2],
        Some("3") => vec![FmiVersion::Fmi3],
        Some(other) => {
            return Err(Stop::Usage(format!(
                "--fmi {other:?}: the FMI version is 2 or 3"
            )))
        }
    };
    let scene = read_scene(args.scene_path())?;
    let problems = validate(&scene);
    if !problems.is_empty() {
        return Err(Stop::Failed(format!(
            "{}: {}",
            args.scene_path(),
            velarium::Error::Scene(problems)
        )));
    }
    let library = find_library(args.option("--lib").map(Path::new)).map_err(failed)?;
    let fmus = pack_versions(&scene, &out, &library, &versions)
        .map_err(|e| Stop::Failed(format!("{}: {e}", args.scene_path())))?;
    for fmu in fmus {
        println!("{}", fmu.display());
    }
    Ok(ExitCode::SUCCESS)
}

fn cmd_solve(args: &Args) -> Result<ExitCode, Stop> {
    let loads = args.required("--loads")?;
    let mut engine = engine_for(args.scene_path())?;
    let table = LoadTable::parse(&read_text(loads)?, loads, &mut engine).map_err(failed)?;
    let elements = args.option("--elements");
    let history = history::run_with(&mut engine, &table, elements.is_some()).map_err(failed)?;
    if let Some(path) = elements {
        write_atomically(Path::new(path), history.elements.as_bytes()).map_err(failed)?;
    }
    let csv = history.to_csv();
    match args.option("--out") {
        Some(out) => write_atomically(Path::new(out), csv.as_bytes()).map_err(failed)?,
        None => print!("{csv}"),
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

fn cmd_check(args: &Args) -> Result<ExitCode, Stop> {
    let path = args.scene_path();
    let scene = match Scene::from_json(&read_text(path)?) {
        Ok(scene) => scene,
        Err(problem) => return Ok(report_problems(path, &[problem])),
    };
    let problems = validate(&scene);
    if !problems.is_empty() {
        return Ok(report_problems(path, &problems));
    }
    let mesh = resolve(&scene.geometry);
    let counts = [
        (scene.membranes.len(), "membrane group"),
        (scene.cables.len(), "cable"),
        (scene.inputs.len(), "input"),
        (scene.outputs.len(), "output"),
        (scene.parameters.len(), "parameter"),
    ];
    let engine =
        Engine::try_new(scene.clone()).map_err(|e| Stop::Failed(format!("{path}: {e}")))?;
    let model = engine.model();
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
    println!("{line}, {} unknowns", free);
    Ok(ExitCode::SUCCESS)
}

/// Print each problem as `path: message` on stdout and a summary naming the file on stderr.
fn report_problems(path: &str, problems: &[velarium::scene::Problem]) -> ExitCode {
    for p in problems {
        println!("{p}");
    }
    eprintln!("velarium: {path}: {}", count(problems.len(), "problem"));
    ExitCode::FAILURE
}

fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

fn cmd_describe(args: &Args) -> Result<ExitCode, Stop> {
    print!("{}", model_description(&engine_for(args.scene_path())?));
    Ok(ExitCode::SUCCESS)
}
