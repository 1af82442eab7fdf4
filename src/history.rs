//! Quasi-static load histories without an FMI master: `velarium solve SCENE.json --loads F.csv`.
//!
//! ```text
//! loads CSV   header  time,<input names...>   (any subset of the scene's inputs, any order)
//!             rows    time and one value per named input; blank lines and everything after
//!                     a `#` are ignored; a UTF-8 byte-order mark is skipped
//! result CSV  header  time,<output names...>  (every output, table order)
//!             row k   the equilibrium under row k's inputs, reached from row k-1's
//! ```
//!
//! Row 0 is the initial equilibrium under the first row's inputs (inputs not in the table keep
//! their start values): what an FMU gives right after initialization with those inputs. Row k
//! is what the FMU gives after the `fmi2DoStep` that follows setting row k's inputs, i.e. the
//! row fmpy records at t_{k+1} (docs/fmu.md, "The one-step lag"). Numbers are written in Rust's
//! shortest round-trip form, so a reader gets the exact f64 back.

use crate::engine::Engine;
use crate::error::Error;
use crate::format::{csv_quoted, xs_double};
use crate::solver::StepReport;
use crate::variables::{Causality, VarType};
use std::fmt::Write;

/// A parsed load table whose columns are inputs of one engine or combinations of them.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadTable {
    /// The file it was read from (named in errors).
    pub file: String,
    /// The value columns, in header order.
    pub columns: Vec<Column>,
    pub rows: Vec<LoadRow>,
}

/// One value column: an input (one term, factor 1) or a named load combination.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    pub name: String,
    /// (input name, value reference, factor): the column's value v sets factor × v.
    pub terms: Vec<(String, u32, f64)>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct LoadRow {
    /// 1-based line of the row in the file (for messages).
    pub line: usize,
    pub time: f64,
    pub values: Vec<f64>,
}

/// The outputs computed for a load table, possibly cut short by a step that did not converge.
#[derive(Clone, Debug, PartialEq)]
pub struct History {
    /// `time` and the output names.
    pub header: Vec<String>,
    /// One row per converged load row: time, then the outputs.
    pub rows: Vec<Vec<f64>>,
    pub failure: Option<Failure>,
    /// Per-element CSV (header and one line per triangle per row), when asked for.
    pub elements: String,
}

/// Where a history stopped.
#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    pub time: f64,
    pub line: usize,
    pub message: String,
}

impl LoadTable {
    /// Parse CSV `text` (from file `file`, named in errors) against the engine's inputs. Every
    /// value is checked by the engine (finite, within [min, max]) before any solve; the engine's
    /// inputs are left at the first row's values.
    pub fn parse(text: &str, file: &str, engine: &mut Engine) -> Result<LoadTable, Error> {
        let whole = |message: &str| Error::LoadTable {
            path: file.to_string(),
            line: None,
            cell: None,
            message: message.to_string(),
        };
        // A byte-order mark is skipped; `#` starts a comment (whole line or after the cells).
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").trim()))
            .filter(|(_, l)| !l.is_empty());
        let mut combinations: Vec<Column> = Vec::new();
        let (header_line, header) = loop {
            let (line, text) = lines
                .next()
                .ok_or_else(|| whole("no header line; expected `time,<input names>`"))?;
            if text.split(',').next().map(str::trim) != Some("combination") {
                break (line, text);
            }
            combinations.push(parse_combination(
                At { file, line },
                text,
                engine,
                &combinations,
            )?);
        };
        let at = At {
            file,
            line: header_line,
        };
        let columns = parse_header(at, header, engine, &combinations)?;
        let mut rows: Vec<LoadRow> = Vec::new();
        for (line, text) in lines {
            let at = At { file, line };
            let row = parse_row(at, text, &columns)?;
            if let Some(previous) = rows.last() {
                if row.time < previous.time {
                    return Err(at.cell(
                        "column 1 (time)".into(),
                        format!(
                            "{} is earlier than the previous row's {}",
                            row.time, previous.time
                        ),
                    ));
                }
            }
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(whole("no data rows after the header"));
        }
        let table = LoadTable {
            file: file.to_string(),
            columns,
            rows,
        };
        for row in table.rows.iter().rev() {
            table.apply(engine, row)?;
        }
        Ok(table)
    }

    /// Set a row's inputs on the engine: each input named by a column gets the sum of
    /// factor × value over the columns that name it.
    fn apply(&self, engine: &mut Engine, row: &LoadRow) -> Result<(), Error> {
        let at = At {
            file: &self.file,
            line: row.line,
        };
        // (input, value reference, value, the columns that set it)
        let mut inputs: Vec<(&str, u32, f64, Vec<usize>)> = Vec::new();
        for (c, (column, value)) in self.columns.iter().zip(&row.values).enumerate() {
            for (name, vr, factor) in &column.terms {
                match inputs.iter_mut().find(|i| i.1 == *vr) {
                    Some(i) => {
                        i.2 += factor * value;
                        i.3.push(c);
                    }
                    None => inputs.push((name, *vr, factor * value, vec![c])),
                }
            }
        }
        for (name, vr, value, from) in inputs {
            engine.set_real(vr, value).map_err(|e| {
                let columns: Vec<String> = from
                    .iter()
                    .map(|&c| format!("{} ({})", c + 2, self.columns[c].name))
                    .collect();
                let cell = if from.len() == 1 && self.columns[from[0]].name == name {
                    format!("column {}", columns[0])
                } else {
                    format!(
                        "input {name} = {value} (from column {})",
                        columns.join(" and ")
                    )
                };
                at.cell(cell, e.to_string())
            })?;
        }
        Ok(())
    }
}

/// A line of the load table being read, named by its errors.
#[derive(Clone, Copy)]
struct At<'a> {
    file: &'a str,
    line: usize,
}

impl At<'_> {
    /// What is wrong on the line.
    fn bad(self, message: String) -> Error {
        Error::LoadTable {
            path: self.file.to_string(),
            line: Some(self.line),
            cell: None,
            message,
        }
    }

    /// What is wrong in a cell (a column, or an input set from columns) of the line.
    fn cell(self, cell: String, message: String) -> Error {
        Error::LoadTable {
            path: self.file.to_string(),
            line: Some(self.line),
            cell: Some(cell),
            message,
        }
    }
}

/// The value reference of the Real input `name` (None: [`not_an_input`] says why).
fn real_input(engine: &Engine, name: &str) -> Option<u32> {
    engine
        .variables()
        .iter()
        .find(|v| v.name == name)
        .filter(|v| v.causality == Causality::Input && v.var_type == VarType::Real)
        .map(|v| v.value_reference)
}

/// Why `name` is not a Real input: `({name}) is not an input ...` (the name in quotes when no
/// variable has it).
fn not_an_input(engine: &Engine, name: &str) -> String {
    if engine.variables().iter().any(|v| v.name == name) {
        format!("({name}) is not an input (loads can only set inputs)")
    } else {
        let inputs: Vec<&str> = input_names(engine).collect();
        format!(
            "({name:?}) is not an input of this scene; its inputs are: {}",
            inputs.join(", ")
        )
    }
}

/// `combination,<name>,<input>,<factor>[,<input>,<factor>...]`.
fn parse_combination(
    at: At,
    text: &str,
    engine: &Engine,
    known: &[Column],
) -> Result<Column, Error> {
    let cells = header_cells(text);
    let cells: Vec<&str> = cells.iter().map(String::as_str).collect();
    let usage = "expected `combination,<name>,<input>,<factor>[,<input>,<factor>...]`";
    if cells.len() < 4 || !cells.len().is_multiple_of(2) {
        return Err(at.bad(format!("{usage}; got {} cells", cells.len())));
    }
    let name = cells[1];
    if name.is_empty() || name == "time" {
        return Err(at.bad(format!("combination name {name:?}: {usage}")));
    }
    if engine.variables().iter().any(|v| v.name == name) {
        return Err(at.bad(format!(
            "combination {name} has the name of a variable of this scene; choose another"
        )));
    }
    if known.iter().any(|c| c.name == name) {
        return Err(at.bad(format!("combination {name} is defined twice")));
    }
    let mut terms: Vec<(String, u32, f64)> = Vec::new();
    for pair in cells[2..].chunks(2) {
        let vr = real_input(engine, pair[0]).ok_or_else(|| {
            at.bad(format!(
                "combination {name}: input {}",
                not_an_input(engine, pair[0])
            ))
        })?;
        let factor = match pair[1].parse::<f64>() {
            Ok(f) if f.is_finite() => f,
            _ => {
                return Err(at.bad(format!(
                    "combination {name}: factor {:?} of {} is not a finite number",
                    pair[1], pair[0]
                )))
            }
        };
        if terms.iter().any(|t| t.1 == vr) {
            return Err(at.bad(format!("combination {name} names {} twice", pair[0])));
        }
        terms.push((pair[0].to_string(), vr, factor));
    }
    Ok(Column {
        name: name.to_string(),
        terms,
    })
}

fn parse_header(
    at: At,
    header: &str,
    engine: &Engine,
    combinations: &[Column],
) -> Result<Vec<Column>, Error> {
    let cells = header_cells(header);
    let mut cells = cells.iter().map(|c| c.as_str());
    if cells.next() != Some("time") {
        return Err(at.bad("the first column must be `time`".into()));
    }
    let mut columns: Vec<Column> = Vec::new();
    for (c, name) in cells.enumerate() {
        let column = match combinations.iter().find(|k| k.name == name) {
            Some(k) => k.clone(),
            None => {
                let vr = real_input(engine, name).ok_or_else(|| {
                    let m = not_an_input(engine, name);
                    let m = if combinations.is_empty() {
                        m
                    } else {
                        let names: Vec<&str> =
                            combinations.iter().map(|k| k.name.as_str()).collect();
                        format!("{m}; combinations: {}", names.join(", "))
                    };
                    at.bad(format!("column {} {m}", c + 2))
                })?;
                Column {
                    name: name.to_string(),
                    terms: vec![(name.to_string(), vr, 1.0)],
                }
            }
        };
        if columns.iter().any(|k| k.name == name) {
            return Err(at.bad(format!("column {} ({name}) appears twice", c + 2)));
        }
        columns.push(column);
    }
    Ok(columns)
}

/// The cells of a header line: separated by commas, a cell in double quotes may hold commas
/// (the FMI 2 names of 2-D array elements, `"corners[1,3]"`), `""` inside quotes is a quote.
fn header_cells(line: &str) -> Vec<String> {
    let mut cells = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                chars.next();
                cells.last_mut().unwrap().push('"');
            }
            '"' => quoted = !quoted,
            ',' if !quoted => cells.push(String::new()),
            c => cells.last_mut().unwrap().push(c),
        }
    }
    cells.iter().map(|c| c.trim().to_string()).collect()
}

/// A header cell: quoted when the name holds a comma or a quote.
pub fn csv_name(name: &str) -> String {
    if name.contains([',', '"']) {
        csv_quoted(name)
    } else {
        name.to_string()
    }
}

fn input_names(engine: &Engine) -> impl Iterator<Item = &str> {
    engine
        .variables()
        .iter()
        .filter(|v| v.causality == Causality::Input)
        .map(|v| v.name.as_str())
}

fn parse_row(at: At, text: &str, columns: &[Column]) -> Result<LoadRow, Error> {
    let cells: Vec<&str> = text.split(',').map(str::trim).collect();
    if cells.len() != columns.len() + 1 {
        return Err(at.bad(format!(
            "{} cells, but the header has {}",
            cells.len(),
            columns.len() + 1
        )));
    }
    let names = std::iter::once("time").chain(columns.iter().map(|k| k.name.as_str()));
    let mut numbers = Vec::with_capacity(cells.len());
    for (c, (cell, name)) in cells.iter().zip(names).enumerate() {
        match cell.parse::<f64>() {
            Ok(x) if x.is_finite() => numbers.push(x),
            _ => {
                return Err(at.cell(
                    format!("column {} ({name})", c + 1),
                    format!("{cell:?} is not a finite number"),
                ))
            }
        }
    }
    Ok(LoadRow {
        line: at.line,
        time: numbers[0],
        values: numbers[1..].to_vec(),
    })
}

/// Run the table: for each row set its inputs, solve, record time and every output. Stops at
/// the first row that does not converge (the engine keeps the last converged equilibrium).
pub fn run(engine: &mut Engine, table: &LoadTable) -> Result<History, Error> {
    run_with(engine, table, false)
}

/// [`run`], also recording every membrane triangle's state, tension direction and principal
/// stresses after each row when `elements` is true (`History::elements`).
pub fn run_with(engine: &mut Engine, table: &LoadTable, elements: bool) -> Result<History, Error> {
    run_observed(engine, table, elements, &mut |_, _| Ok(()))
}

/// What [`run_observed`] tells its observer.
pub enum Event<'a> {
    /// Row `index` (of `total`) is about to be solved.
    Start {
        index: usize,
        total: usize,
        row: &'a LoadRow,
    },
    /// Row `index` was solved: converged (the engine holds its equilibrium) or not (the engine
    /// kept the last converged one).
    Done {
        index: usize,
        total: usize,
        row: &'a LoadRow,
        report: &'a StepReport,
    },
}

/// [`run_with`], calling `observer` before and after every row (progress, ParaView output).
/// An error of the observer stops the run and is returned.
pub fn run_observed(
    engine: &mut Engine,
    table: &LoadTable,
    elements: bool,
    observer: &mut dyn FnMut(&Engine, Event) -> Result<(), Error>,
) -> Result<History, Error> {
    let header = std::iter::once("time".to_string())
        .chain(engine.outputs().into_iter().map(|(name, _)| name))
        .collect();
    let mut history = History {
        header,
        rows: Vec::with_capacity(table.rows.len()),
        failure: None,
        elements: String::new(),
    };
    if elements {
        history.elements.push_str(ELEMENT_HEADER);
    }
    let total = table.rows.len();
    for (index, row) in table.rows.iter().enumerate() {
        // With time integration row k is reached from row k-1 in t_k - t_{k-1} seconds (the
        // loads linear in between); row 0 is the static equilibrium at rest.
        let duration = match index {
            0 => 0.0,
            _ => row.time - table.rows[index - 1].time,
        };
        if engine.is_dynamic() && index > 0 && !(duration > 0.0 && duration.is_finite()) {
            return Err(Error::LoadTable {
                path: table.file.clone(),
                line: Some(row.line),
                cell: Some("time".into()),
                message: format!(
                    "time {} does not follow the previous row's {}: a scene with dynamics.time_integration needs increasing times (a row's time is when its loads are reached)",
                    row.time,
                    table.rows[index - 1].time
                ),
            });
        }
        engine.set_step_duration(duration);
        table.apply(engine, row)?;
        observer(engine, Event::Start { index, total, row })?;
        let report = engine.solve();
        observer(
            engine,
            Event::Done {
                index,
                total,
                row,
                report: &report,
            },
        )?;
        if !report.converged() {
            history.failure = Some(Failure {
                time: row.time,
                line: row.line,
                message: report.message.to_string(),
            });
            break;
        }
        if elements {
            element_rows(engine, row.time, &mut history.elements);
        }
        let outputs = engine.outputs().into_iter().map(|(_, value)| value);
        history
            .rows
            .push(std::iter::once(row.time).chain(outputs).collect());
    }
    Ok(history)
}

const ELEMENT_HEADER: &str =
    "time,triangle,state,tension_x,tension_y,tension_z,centroid_x,centroid_y,centroid_z,sigma_max,sigma_min,x1,y1,z1,x2,y2,z2,x3,y3,z3\n";

/// One CSV line per membrane triangle: mesh id, state (0 taut, 1 wrinkled, 2 slack), the unit
/// tension direction (major principal direction) in the current configuration, the current
/// centroid, the principal Cauchy stresses and the three current vertices.
fn element_rows(engine: &Engine, time: f64, out: &mut String) {
    let model = engine.model();
    let u = &engine.state().displacement;
    for (t, m) in model.triangles.iter().zip(engine.membranes()) {
        let x = t.nodes.map(|i| model.position(u, i));
        let centroid = (x[0] + x[1] + x[2]) / 3.0;
        let d = crate::results::tension_direction(model, u, t, m);
        let state = crate::results::state_code(m.state);
        // Columns after the state: see ELEMENT_HEADER.
        let v = [
            d.x, d.y, d.z, centroid.x, centroid.y, centroid.z, m.cauchy.0, m.cauchy.1,
        ];
        let _ = write!(out, "{},{},{state}", xs_double(time), t.id);
        for value in v.iter().chain(x.iter().flat_map(|p| p.iter())) {
            let _ = write!(out, ",{}", xs_double(*value));
        }
        out.push('\n');
    }
}

impl History {
    /// CSV text: the header, then one line per row, numbers in shortest round-trip form.
    pub fn to_csv(&self) -> String {
        let mut out = self
            .header
            .iter()
            .map(|n| csv_name(n))
            .collect::<Vec<_>>()
            .join(",");
        out.push('\n');
        for row in &self.rows {
            for (i, x) in row.iter().enumerate() {
                let sep = if i == 0 { "" } else { "," };
                let _ = write!(out, "{sep}{}", xs_double(*x));
            }
            out.push('\n');
        }
        out
    }
}
