//! Semantic checks of a parsed scene. Every problem is reported (not only the first), each with
//! the JSON path of the field and a sentence a user can act on.

use super::generate::{generator_counts, try_resolve, Mesh};
use super::limits;
use super::target::parameter_value;
use super::{
    Generator, Load, Material, NodeRef, OneNode, Probe, Problem, Scene, TriangleRef, FORMAT_VERSION,
};
use std::collections::{BTreeMap, BTreeSet};

/// All problems of a scene; empty means valid.
pub fn validate(scene: &Scene) -> Vec<Problem> {
    validate_sized(scene).0
}

/// [`validate`], and the size estimate of `limits.rs` (as far as it got: the memory estimate
/// is 0 when the counts or the mesh already failed).
pub fn validate_sized(scene: &Scene) -> (Vec<Problem>, limits::Size) {
    let mut size = limits::Size::default();
    let problems = validate_into(scene, &mut size);
    (problems, size)
}

fn validate_into(scene: &Scene, size: &mut limits::Size) -> Vec<Problem> {
    let mut v = Validator {
        problems: Vec::new(),
    };
    v.header(scene);
    v.solver(scene);
    let before = v.problems.len();
    v.generators(scene);
    if v.problems.len() > before {
        // Without a sound mesh the references below cannot be checked meaningfully.
        return v.problems;
    }
    if v.problems
        .iter()
        .any(|p| p.path.starts_with("solver.limits."))
    {
        // No size check against a limit out of its range, and so no mesh either.
        return v.problems;
    }
    // Size limits from the numbers alone, before the mesh is built.
    let limits = &scene.solver.limits;
    *size = limits::count(scene);
    let mut too_big = limits::check_counts(size, limits);
    if !too_big.is_empty() {
        // Name the generator that makes the most nodes, and its size field.
        let biggest = scene
            .geometry
            .generators
            .iter()
            .enumerate()
            .max_by_key(|(_, g)| generator_counts(g).0);
        if let Some((k, g)) = biggest {
            if generator_counts(g).0 * 2 > size.nodes {
                let field = match g {
                    Generator::Rectangle { .. } => "divisions",
                    _ => "rings",
                };
                too_big[0].path = format!("geometry.generators[{k}].{field}");
            }
        }
        v.problems.extend(too_big);
        return v.problems;
    }
    let mesh = match try_resolve(&scene.geometry) {
        Ok(mesh) => mesh,
        Err(e) => {
            v.problems.push(Problem {
                path: "geometry".into(),
                message: e.to_string(),
            });
            return v.problems;
        }
    };
    v.explicit_geometry(scene, &mesh);
    v.generated_triangles(scene, &mesh);
    if v.problems.len() == before {
        let cables: Vec<Vec<usize>> = scene
            .cables
            .iter()
            .filter_map(|c| cable_ids(&mesh, &c.nodes))
            .collect();
        let sleeve_points: usize = scene
            .cables
            .iter()
            .filter(|c| c.sleeve.is_some())
            .filter_map(|c| cable_ids(&mesh, &c.nodes))
            .map(|ids| ids.len())
            .sum();
        size.unknowns = 3 * mesh.nodes.len() as u64 + 4 * sleeve_points as u64;
        size.sleeve_points = sleeve_points as u64;
        size.threads = scene.solver.threads as u64;
        let mut too_big = limits::check_counts(size, limits);
        if too_big.is_empty() {
            too_big = limits::check_memory(size, &mesh, &cables, limits);
        }
        if !too_big.is_empty() {
            v.problems.extend(too_big);
            return v.problems;
        }
    }
    v.membranes(scene, &mesh);
    v.cables(scene, &mesh);
    let held = v.supports(scene, &mesh);
    v.inputs(scene, &mesh, &held);
    v.outputs(scene, &mesh, &held);
    v.parameters(scene);
    v.names(scene);
    v.form_finding(scene, &mesh);
    v.dynamics(scene, &mesh);
    v.contacts(scene, &mesh, &held);
    v.problems
}

mod contacts;

struct Validator {
    problems: Vec<Problem>,
}

/// Largest magnitude of a coordinate, length, modulus, stiffness or force in a scene, and the
/// smallest positive one: products of a few such numbers (squares of lengths, E·t·area,
/// EA·strain, residual norms) stay far from overflow and underflow.
pub const MAX_MAGNITUDE: f64 = 1e30;
pub const MIN_MAGNITUDE: f64 = 1e-30;
/// Smallest initial strain T/EA a pretension may give: below it the unstretched length rounds
/// to the stretched one (10^4 ulps of 1).
pub const PRESTRAIN_FLOOR: f64 = 1e-12;
const RANGE: &str =
    "(between 1e-30 and 1e30, so that squares and products in the mechanics cannot overflow)";

/// `solver.tolerance` range. Below 1e-14 (about 45 ε) the residual test is met only through its
/// round-off floor 16 ε (Σ|f| + K X) (docs/solver.md), so a smaller tolerance asks for nothing
/// more; above 1e-2 a converged state would keep a residual of over a percent of the forces.
pub const TOLERANCE_RANGE: (f64, f64) = (1e-14, 1e-2);
/// Most `solver.max_iterations` (and `form_finding.max_iterations`). A flat start takes 30-46
/// Newton iterations and steady linear convergence is allowed 200 (`max_iterations_progressing`);
/// the Newton loop keeps one number per iteration, and a step whose first increment fails
/// spends up to (cut-backs + 1) × max_iterations iterations, so 10 000 bounds both (80 kB, and
/// at most 200 000 iterations with [`MIN_INCREMENT`]: 20 increments). 4294967296 made that history ask for
/// 34 GB (an abort), 2^64 − 1 overflowed the loop's bound (a step that never ended).
pub const MAX_ITERATIONS: usize = 10_000;
/// Smallest `solver.min_increment` (and `initial_increment`), a fraction of a step's load
/// change: increments are cut by 4 on failure, so a step tries at most floor(log4(1e12)) + 1 = 20
/// increments before it fails.
pub const MIN_INCREMENT: f64 = 1e-12;
/// Largest `solver.limits.max_nodes`, `max_triangles`, `max_unknowns`: u32::MAX, the most
/// matrix entries the solver's 32-bit position maps address (`limits::MAX_MATRIX_ENTRIES`; the
/// size estimate's node graph stores node ids in 32 bits too), so no larger model can be built.
pub const MAX_COUNT_LIMIT: u64 = u32::MAX as u64;
/// `solver.limits.max_memory_gb` range in GB: positive and finite (NaN would switch the memory
/// check off), from 1 MB (what the smallest scenes are estimated to need) to 1e6 GB (a
/// petabyte, beyond any machine this runs on).
pub const MEMORY_GB_RANGE: (f64, f64) = (1e-3, 1e6);
/// Largest membrane prestress force in N/m (an isotropic `n`, `warp`, `fill`, and every
/// component of a `field` tensor).
pub const MAX_MEMBRANE_FORCE: f64 = 1e12;
/// `membranes[].residual_stiffness` range: a share of the elastic stiffness.
pub const RESIDUAL_STIFFNESS_RANGE: (f64, f64) = (0.0, 1e-2);
/// Poisson's ratio of the SVK membrane: in [0, this).
pub const SVK_NU_BOUND: f64 = 0.5;
/// Fewest `sectors` of an annulus generator.
pub const MIN_SECTORS: usize = 3;
/// Most `solver.max_step_iterations`.
pub const MAX_STEP_ITERATIONS: usize = 100_000;
/// Largest `solver.prestress_continuation` (a pre-strain).
pub const MAX_PRESTRESS_CONTINUATION: f64 = 0.1;
/// `form_finding.tolerance` range, [low, high).
pub const FORM_FINDING_TOLERANCE_RANGE: (f64, f64) = (1e-12, 0.1);
/// `form_finding.homotopy` range, [0, this).
pub const HOMOTOPY_BOUND: f64 = 1.0;
/// Most `solver.threads`: the solver's pool bound (`solver::threads::MAX_THREADS`, which the
/// scene layer does not import; tests/scene_cli/settings_bounds.rs holds the two equal).
pub const MAX_SOLVER_THREADS: usize = 64;

/// Cut-backs by 4 from a whole step down to [`MIN_INCREMENT`]: floor(log4(1e12)) = 19, so
/// 20 tries in all.
fn max_cutbacks() -> usize {
    (1.0 / MIN_INCREMENT).log(4.0).floor() as usize
}

/// A positive number within [MIN_MAGNITUDE, MAX_MAGNITUDE].
fn positive(x: f64) -> bool {
    x.is_finite() && (MIN_MAGNITUDE..=MAX_MAGNITUDE).contains(&x)
}

/// A coordinate: finite with |x| <= MAX_MAGNITUDE.
fn coordinate(x: f64) -> bool {
    x.is_finite() && x.abs() <= MAX_MAGNITUDE
}

/// Node ids of a cable's node reference, if it resolves.
fn cable_ids(mesh: &Mesh, r: &NodeRef) -> Option<Vec<usize>> {
    match r {
        NodeRef::Ids(ids) => ids
            .iter()
            .all(|&i| i < mesh.nodes.len())
            .then(|| ids.clone()),
        NodeRef::Set(name) => mesh.node_sets.get(name).cloned(),
    }
}

/// A C identifier: what an FMU modelIdentifier and a shared-library name must be.
pub fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A flat FMI variable name we accept: identifier characters plus `.`, `[`, `]`.
fn is_variable_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "_.[]".contains(c))
        && !s.starts_with(|c: char| c.is_ascii_digit() || c == '.')
}

impl Validator {
    fn push(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.problems.push(Problem {
            path: path.into(),
            message: message.into(),
        });
    }

    fn header(&mut self, s: &Scene) {
        if s.format != FORMAT_VERSION {
            self.push(
                "format",
                format!(
                    "format {} is not supported; this build reads format {FORMAT_VERSION}",
                    s.format
                ),
            );
        }
        if !is_identifier(&s.name) {
            self.push("name", format!("\"{}\" is not a C identifier (letters, digits and _, not starting with a digit); it names the FMU and its library", s.name));
        }
        let e = &s.experiment;
        if !(e.start_time.is_finite() && e.stop_time.is_finite() && e.stop_time > e.start_time) {
            self.push(
                "experiment.stop_time",
                "must be finite and greater than start_time",
            );
        }
        if !positive(e.step_size) {
            self.push("experiment.step_size", "must be a positive number");
        }
        if let Some(loads) = &e.loads {
            self.experiment_loads(s, loads);
        }
    }

    /// The default experiment's load history: increasing finite times, known inputs, one
    /// finite value per time within the input's `min`/`max` (an array's list length is checked
    /// against its shape when the model is built: `crate::pack::reference_loads`).
    fn experiment_loads(&mut self, s: &Scene, loads: &super::ExperimentLoads) {
        let at = "experiment.loads";
        if loads.time.is_empty() {
            self.push(format!("{at}.time"), "needs at least one time");
        }
        for (k, t) in loads.time.iter().enumerate() {
            if !t.is_finite() {
                self.push(format!("{at}.time[{k}]"), "must be a finite number");
            } else if k > 0 && loads.time[k - 1].is_finite() && *t <= loads.time[k - 1] {
                self.push(
                    format!("{at}.time[{k}]"),
                    format!(
                        "{t} does not follow {}: the times must increase strictly",
                        loads.time[k - 1]
                    ),
                );
            }
        }
        for (name, values) in &loads.inputs {
            let path = format!("{at}.inputs.{name}");
            let Some(input) = s.inputs.iter().find(|i| &i.name == name) else {
                let known: Vec<&str> = s.inputs.iter().map(|i| i.name.as_str()).collect();
                self.push(
                    path,
                    format!(
                        "no input is named \"{name}\" (the scene's inputs: {})",
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                );
                continue;
            };
            if values.len() != loads.time.len() {
                self.push(
                    path.clone(),
                    format!(
                        "has {} values for {} times: give one value per time",
                        values.len(),
                        loads.time.len()
                    ),
                );
            }
            for (k, value) in values.iter().enumerate() {
                let elements = match value {
                    super::LoadValue::All(v) => std::slice::from_ref(v),
                    super::LoadValue::Each(list) => list.as_slice(),
                };
                for (j, v) in elements.iter().enumerate() {
                    let cell = match value {
                        super::LoadValue::All(_) => format!("{path}[{k}]"),
                        super::LoadValue::Each(_) => format!("{path}[{k}][{j}]"),
                    };
                    if !v.is_finite() {
                        self.push(cell, format!("{v} is not a finite number"));
                    } else if input.min.is_some_and(|m| *v < m) || input.max.is_some_and(|m| *v > m)
                    {
                        self.push(
                            cell,
                            format!(
                                "{v} is outside the input's range [{}, {}]",
                                input.min.map_or("-inf".into(), |m| m.to_string()),
                                input.max.map_or("inf".into(), |m| m.to_string())
                            ),
                        );
                    }
                }
            }
        }
    }

    fn generators(&mut self, s: &Scene) {
        for (i, node) in s.geometry.nodes.iter().enumerate() {
            if node.iter().any(|x| !coordinate(*x)) {
                self.push(
                    format!("geometry.nodes[{i}]"),
                    "coordinates must be finite numbers with |x| <= 1e30 m (their squares are used in the mechanics)",
                );
            }
        }
        let mut seen = BTreeSet::new();
        for (i, g) in s.geometry.generators.iter().enumerate() {
            let p = format!("geometry.generators[{i}]");
            let name = match g {
                Generator::Rectangle { name, .. }
                | Generator::Disc { name, .. }
                | Generator::Annulus { name, .. }
                | Generator::Cushion { name, .. } => name,
            };
            if !is_identifier(name) {
                self.push(
                    format!("{p}.name"),
                    format!("\"{name}\" must be an identifier (letters, digits, _)"),
                );
            }
            if !seen.insert(name.clone()) || s.geometry.triangle_sets.contains_key(name) {
                self.push(
                    format!("{p}.name"),
                    format!(
                        "\"{name}\" is used twice; generator and triangle-set names must be unique"
                    ),
                );
            }
            match g {
                Generator::Rectangle {
                    origin,
                    size,
                    divisions,
                    ..
                } => {
                    if origin.iter().any(|x| !coordinate(*x)) {
                        self.push(format!("{p}.origin"), "must be finite with |x| <= 1e30 m");
                    }
                    if !positive(size[0]) || !positive(size[1]) {
                        self.push(
                            format!("{p}.size"),
                            format!("both sizes must be positive lengths in m {RANGE}"),
                        );
                    }
                    if divisions[0] == 0 || divisions[1] == 0 {
                        self.push(
                            format!("{p}.divisions"),
                            "needs at least one cell in each direction",
                        );
                    }
                }
                Generator::Disc {
                    center,
                    radius,
                    rings,
                    ..
                } => {
                    if center.iter().any(|x| !coordinate(*x)) {
                        self.push(format!("{p}.center"), "must be finite with |x| <= 1e30 m");
                    }
                    if !positive(*radius) {
                        self.push(
                            format!("{p}.radius"),
                            format!("must be a positive length in m {RANGE}"),
                        );
                    }
                    if *rings == 0 {
                        self.push(format!("{p}.rings"), "needs at least one ring");
                    }
                }
                Generator::Annulus {
                    center,
                    inner_radius,
                    outer_radius,
                    rings,
                    sectors,
                    grading,
                    ..
                } => {
                    if center.iter().any(|x| !coordinate(*x)) {
                        self.push(format!("{p}.center"), "must be finite with |x| <= 1e30 m");
                    }
                    if !positive(*inner_radius)
                        || !(outer_radius > inner_radius)
                        || !positive(*outer_radius)
                    {
                        self.push(
                            format!("{p}.inner_radius"),
                            format!("needs 0 < inner_radius < outer_radius, both {RANGE}"),
                        );
                    }
                    if *rings == 0 {
                        self.push(format!("{p}.rings"), "needs at least one ring");
                    }
                    if *sectors < MIN_SECTORS {
                        self.push(
                            format!("{p}.sectors"),
                            format!("needs at least {MIN_SECTORS} sectors"),
                        );
                    }
                    if !positive(*grading) {
                        self.push(format!("{p}.grading"), "must be positive (1 = uniform)");
                    }
                }
                Generator::Cushion {
                    center,
                    outline,
                    rings,
                    rise,
                    ..
                } => {
                    if center.iter().any(|x| !coordinate(*x)) {
                        self.push(format!("{p}.center"), "must be finite with |x| <= 1e30 m");
                    }
                    if let Some((field, why)) = outline.problem() {
                        self.push(format!("{p}.outline.{field}"), why);
                    }
                    if *rings == 0 {
                        self.push(format!("{p}.rings"), "needs at least one ring");
                    }
                    if rise
                        .iter()
                        .any(|x| !(x.is_finite() && *x >= 0.0 && *x <= 1e30))
                    {
                        self.push(
                            format!("{p}.rise"),
                            "both rises (top up, bottom down, m) must be finite and >= 0",
                        );
                    }
                }
            }
        }
    }

    /// Generated triangles are checked like explicit ones: a triangle whose nodes coincide or
    /// are collinear in floating point (cells too small for the coordinates' magnitude) is
    /// reported once per generator, with the first such triangle.
    fn generated_triangles(&mut self, s: &Scene, mesh: &Mesh) {
        for (g, gen) in s.geometry.generators.iter().enumerate() {
            let name = generator_name(gen);
            let Some(ids) = mesh.triangle_sets.get(name) else {
                continue;
            };
            let bad: Vec<usize> = ids
                .iter()
                .copied()
                .filter(|&t| degenerate(mesh, &mesh.triangles[t]))
                .collect();
            if let Some(&first) = bad.first() {
                let t = mesh.triangles[first];
                let scale = t
                    .iter()
                    .flat_map(|&i| mesh.nodes[i])
                    .fold(0.0f64, |m, x| m.max(x.abs()));
                self.push(
                    format!("geometry.generators[{g}]"),
                    format!(
                        "{} generated triangle(s) have zero area in floating point (first: triangle {first}, nodes {:?}, longest edge {:e} m at coordinates of magnitude {scale:e} m): the cells are too small for the coordinates' round-off; move the mesh nearer the origin or use larger cells",
                        bad.len(),
                        t,
                        longest_edge2(mesh, &t).sqrt()
                    ),
                );
            }
        }
    }

    fn explicit_geometry(&mut self, s: &Scene, mesh: &Mesh) {
        let n = mesh.nodes.len();
        for (i, (given, t)) in s.geometry.triangles.iter().zip(&mesh.triangles).enumerate() {
            let mut ok = true;
            for (k, &id) in t.iter().enumerate() {
                if id >= n {
                    let path = format!("geometry.triangles[{i}][{k}]");
                    match &given[k] {
                        OneNode::Id(id) => self.push(
                            path,
                            format!(
                                "unknown node {id}: the mesh has {n} nodes (ids 0 to {}: geometry.nodes first, then each generator's nodes in order)",
                                n.saturating_sub(1)
                            ),
                        ),
                        OneNode::Set(_) => {
                            self.one_node(mesh, &given[k], &path);
                        }
                    }
                    ok = false;
                }
            }
            if ok && degenerate(mesh, t) {
                self.push(
                    format!("geometry.triangles[{i}]"),
                    format!("zero-area triangle {i} (its three nodes are collinear or repeated)"),
                );
            }
        }
        for (name, ids) in &s.geometry.node_sets {
            for (k, &id) in ids.iter().enumerate() {
                if id >= mesh.nodes.len() {
                    self.push(
                        format!("geometry.node_sets.{name}[{k}]"),
                        format!("unknown node {id}: the mesh has {} nodes", mesh.nodes.len()),
                    );
                }
            }
            if mesh.node_sets.get(name) != Some(ids) {
                self.push(
                    format!("geometry.node_sets.{name}"),
                    "clashes with a generated node set of the same name",
                );
            }
        }
        let nt = mesh.triangles.len();
        for (name, ids) in &s.geometry.triangle_sets {
            for (k, &id) in ids.iter().enumerate() {
                if id >= nt {
                    self.push(
                        format!("geometry.triangle_sets.{name}[{k}]"),
                        format!("unknown triangle {id}: the mesh has {nt}"),
                    );
                }
            }
        }
    }

    /// Resolve a node reference, reporting unknown ids or sets. Returns None on a problem.
    fn nodes(&mut self, mesh: &Mesh, r: &NodeRef, path: &str) -> Option<Vec<usize>> {
        match r {
            NodeRef::Set(name) => match mesh.node_sets.get(name) {
                Some(ids) if !ids.is_empty() => Some(ids.clone()),
                Some(_) => {
                    self.push(path, format!("node set \"{name}\" is empty"));
                    None
                }
                None => {
                    self.push(
                        path,
                        format!(
                            "no node set is named \"{name}\"{}",
                            suggest(name, mesh.node_sets.keys())
                        ),
                    );
                    None
                }
            },
            NodeRef::Ids(ids) => {
                let mut ok = !ids.is_empty();
                if ids.is_empty() {
                    self.push(path, "lists no nodes");
                }
                for (k, &id) in ids.iter().enumerate() {
                    if id >= mesh.nodes.len() {
                        self.push(
                            format!("{path}[{k}]"),
                            format!("unknown node {id}: the mesh has {} nodes", mesh.nodes.len()),
                        );
                        ok = false;
                    }
                }
                ok.then(|| ids.clone())
            }
        }
    }

    /// A finite point and a non-zero finite axis at `{path}.point`, `{path}.axis`.
    fn point_and_axis(&mut self, point: &[f64; 3], axis: &[f64; 3], path: &str) {
        if point.iter().any(|x| !coordinate(*x)) {
            self.push(format!("{path}.point"), "must be finite with |x| <= 1e30 m");
        }
        let n = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !positive(n) {
            self.push(format!("{path}.axis"), "must be a non-zero finite vector");
        }
    }

    /// A node set of which at least one node is held in some component.
    fn reaction_nodes(
        &mut self,
        mesh: &Mesh,
        nodes: &NodeRef,
        held: &BTreeSet<(usize, usize)>,
        path: &str,
    ) {
        if let Some(ids) = self.nodes(mesh, nodes, &format!("{path}.nodes")) {
            if !ids
                .iter()
                .any(|&id| (0..3).any(|c| held.contains(&(id, c))))
            {
                self.push(
                    format!("{path}.nodes"),
                    "no node of this set is held, so there is no reaction to report",
                );
            }
        }
    }

    fn one_node(&mut self, mesh: &Mesh, r: &OneNode, path: &str) -> Option<usize> {
        let ids = match r {
            OneNode::Id(id) if *id >= mesh.nodes.len() => {
                self.push(
                    path,
                    format!("unknown node {id}: the mesh has {} nodes", mesh.nodes.len()),
                );
                return None;
            }
            OneNode::Id(id) => vec![*id],
            OneNode::Set(name) => self.nodes(mesh, &NodeRef::Set(name.clone()), path)?,
        };
        if ids.len() != 1 {
            self.push(
                path,
                format!("names {} nodes; a probe needs exactly one", ids.len()),
            );
            return None;
        }
        Some(ids[0])
    }

    /// A membrane group that encloses a volume: it exists, it is closed (every edge shared by
    /// exactly two of its triangles, in opposite directions) and its triangles face outward
    /// (positive enclosed volume).
    fn closed_group(&mut self, s: &Scene, mesh: &Mesh, membrane: &str, path: &str) {
        let Some(group) = s.membranes.iter().find(|m| m.name == membrane) else {
            let names: Vec<&String> = s.membranes.iter().map(|m| &m.name).collect();
            self.push(
                path,
                format!(
                    "no membrane group is named \"{membrane}\"{}",
                    suggest(membrane, names.into_iter())
                ),
            );
            return;
        };
        let ids: Vec<usize> = match &group.triangles {
            TriangleRef::Set(name) => match mesh.triangle_sets.get(name) {
                Some(ids) => ids.clone(),
                None => return, // reported with the membrane group
            },
            TriangleRef::Ids(ids) => ids.clone(),
        };
        if ids.iter().any(|&t| t >= mesh.triangles.len()) {
            return; // reported with the membrane group
        }
        let mut edges: BTreeMap<(usize, usize), usize> = BTreeMap::new();
        for &t in &ids {
            let [a, b, c] = mesh.triangles[t];
            for e in [(a, b), (b, c), (c, a)] {
                *edges.entry(e).or_default() += 1;
            }
        }
        if let Some((&(a, b), _)) = edges
            .iter()
            .find(|(&(a, b), &n)| n != 1 || edges.get(&(b, a)) != Some(&1))
        {
            self.push(
                path,
                format!("membrane group \"{membrane}\" is not closed: its edge between nodes {a} and {b} is not shared by exactly two of its triangles in opposite directions (a volume needs a closed, consistently oriented surface)"),
            );
            return;
        }
        let x = |i: usize| mesh.nodes[i];
        let (volume, magnitude) = ids
            .iter()
            .map(|&t| {
                let [a, b, c] = mesh.triangles[t].map(x);
                let cross = [
                    b[1] * c[2] - b[2] * c[1],
                    b[2] * c[0] - b[0] * c[2],
                    b[0] * c[1] - b[1] * c[0],
                ];
                (a[0] * cross[0] + a[1] * cross[1] + a[2] * cross[2]) / 6.0
            })
            .fold((0.0, 0.0), |(v, m), t: f64| (v + t, m + t.abs()));
        // A flat closed group (a deflated cushion: two sheets on top of each other, sharing
        // their rim, every node in one plane) encloses no volume whichever way it faces: it
        // inflates along its triangles' normals, as a pressure input does, so that the volume
        // it then encloses is positive. Zero within the round-off of the sum is accepted
        // there and only there (a closed group facing both ways, as an outward and an inward
        // sphere, sums to zero too); a negative volume is a group facing inward.
        let zero = volume.abs() <= 1e-12 * magnitude;
        if !(if zero {
            coplanar(mesh, &ids)
        } else {
            volume > 0.0
        }) {
            self.push(
                path,
                format!("membrane group \"{membrane}\" encloses the volume {volume:e} m³: its triangles must face outward (counter-clockwise seen from outside) and enclose a positive volume (or none, a flat cushion inflating along its normals)"),
            );
        }
    }

    fn membranes(&mut self, s: &Scene, mesh: &Mesh) {
        for (i, m) in s.membranes.iter().enumerate() {
            let p = format!("membranes[{i}]");
            match &m.triangles {
                TriangleRef::Set(name) => {
                    if !mesh.triangle_sets.contains_key(name) {
                        self.push(
                            format!("{p}.triangles"),
                            format!(
                                "no triangle set is named \"{name}\"{}",
                                suggest(name, mesh.triangle_sets.keys())
                            ),
                        );
                    } else if mesh.triangle_sets[name].is_empty() {
                        self.push(
                            format!("{p}.triangles"),
                            format!("triangle set \"{name}\" is empty"),
                        );
                    }
                }
                TriangleRef::Ids(ids) => {
                    if ids.is_empty() {
                        self.push(format!("{p}.triangles"), "lists no triangles");
                    }
                    for (k, &id) in ids.iter().enumerate() {
                        if id >= mesh.triangles.len() {
                            self.push(
                                format!("{p}.triangles[{k}]"),
                                format!(
                                    "unknown triangle {id}: the mesh has {}",
                                    mesh.triangles.len()
                                ),
                            );
                        }
                    }
                }
            }
            if let Some(rho) = m.residual_stiffness {
                let (lo, hi) = RESIDUAL_STIFFNESS_RANGE;
                if !(rho.is_finite() && (lo..=hi).contains(&rho)) {
                    self.push(
                        format!("{p}.residual_stiffness"),
                        format!("{rho} is not a share of the elastic stiffness in [0, 0.01]"),
                    );
                } else if rho > 0.0 && !m.wrinkling {
                    self.push(
                        format!("{p}.residual_stiffness"),
                        "applies to the tension-field law only: this group has wrinkling off"
                            .to_string(),
                    );
                }
            }
            if !positive(m.thickness) {
                self.push(
                    format!("{p}.thickness"),
                    format!("{} is not a positive thickness in m {RANGE}", m.thickness),
                );
            }
            if let Some(rho) = m.density {
                if !positive(rho) {
                    self.push(
                        format!("{p}.density"),
                        format!("{rho} is not a positive mass density in kg/m3 {RANGE}"),
                    );
                }
            }
            match m.material {
                Material::Svk { young, nu } => {
                    if !positive(young) {
                        self.push(
                            format!("{p}.material.E"),
                            format!("{young} is not a positive Young's modulus in Pa {RANGE}"),
                        );
                    }
                    if !(nu.is_finite() && (0.0..SVK_NU_BOUND).contains(&nu)) {
                        self.push(
                            format!("{p}.material.nu"),
                            format!(
                                "{nu}: Poisson's ratio must be in [0, 0.5) for the SVK membrane"
                            ),
                        );
                    }
                }
                Material::Etfe {
                    young,
                    nu,
                    yield_stress,
                    second_yield_stress,
                    second_yield_strain,
                    tangent_modulus,
                } => self.etfe(
                    &p,
                    m,
                    [
                        young,
                        nu,
                        yield_stress,
                        second_yield_stress,
                        second_yield_strain,
                        tangent_modulus,
                    ],
                ),
                Material::NeoHookean { mu } => {
                    if !positive(mu) {
                        self.push(
                            format!("{p}.material.mu"),
                            format!("{mu} is not a positive shear modulus in Pa {RANGE}"),
                        );
                    }
                }
                Material::Orthotropic {
                    e_warp,
                    e_fill,
                    nu_wf,
                    g,
                    warp,
                    ref warp_axis,
                } => {
                    for (name, v, what) in [
                        ("E_warp", e_warp, "Young's modulus"),
                        ("E_fill", e_fill, "Young's modulus"),
                        ("G", g, "shear modulus"),
                    ] {
                        if !positive(v) {
                            self.push(
                                format!("{p}.material.{name}"),
                                format!("{v} is not a positive {what} in Pa {RANGE}"),
                            );
                        }
                    }
                    if positive(e_warp) && positive(e_fill) {
                        let bound = (e_warp / e_fill).sqrt();
                        if !(nu_wf.is_finite() && nu_wf >= 0.0 && nu_wf < bound) {
                            self.push(
                                format!("{p}.material.nu_wf"),
                                format!("{nu_wf}: nu_wf must be in [0, sqrt(E_warp/E_fill)) = [0, {bound:.6}) for a positive-definite orthotropic law"),
                            );
                        }
                    }
                    let length = warp.iter().map(|x| x * x).sum::<f64>().sqrt();
                    if let Some(axis) = warp_axis {
                        self.warp_axis(&p, mesh, m, axis);
                    } else if !positive(length) || warp.iter().any(|x| !coordinate(*x)) {
                        self.push(
                            format!("{p}.material.warp"),
                            "must be a non-zero finite vector (the warp direction)",
                        );
                    } else if let Some(ids) = group_triangles(mesh, &m.triangles) {
                        let w = warp.map(|x| x / length);
                        for t in ids {
                            let Some(n) = unit_normal(mesh, &mesh.triangles[t]) else {
                                continue;
                            };
                            let along = (w[0] * n[0] + w[1] * n[1] + w[2] * n[2]).abs();
                            if (1.0 - along * along).max(0.0).sqrt() < WARP_IN_PLANE {
                                self.push(
                                    format!("{p}.material.warp"),
                                    format!("{warp:?} is (nearly) normal to triangle {t}: its projection onto the triangle gives no warp direction"),
                                );
                                break;
                            }
                        }
                    }
                }
            }
            if let Some(pre) = &m.prestress {
                self.prestress(m, pre, &format!("{p}.prestress"), mesh);
            }
        }
    }

    fn prestress(&mut self, m: &super::Membrane, pre: &super::Prestress, p: &str, mesh: &Mesh) {
        let (warp, fill, dir) = pre.components();
        let force = |x: f64| x.is_finite() && (0.0..=MAX_MEMBRANE_FORCE).contains(&x);
        match pre {
            super::Prestress::Isotropic { n } => {
                if !(force(*n) && *n > 0.0) {
                    self.push(
                        format!("{p}.n"),
                        format!("{n} is not a positive membrane force in N/m (at most {MAX_MEMBRANE_FORCE:e})"),
                    );
                }
            }
            super::Prestress::WarpFill { .. } => {
                for (name, v) in [("warp", warp), ("fill", fill)] {
                    if !force(v) {
                        self.push(
                            format!("{p}.{name}"),
                            format!("{v} is not a membrane force in N/m >= 0 (at most {MAX_MEMBRANE_FORCE:e})"),
                        );
                    }
                }
                if warp == 0.0 && fill == 0.0 {
                    self.push(
                        format!("{p}.warp"),
                        "warp and fill are both 0: leave the prestress out for a stress-free sheet",
                    );
                }
                let len = dir.iter().map(|c| c * c).sum::<f64>().sqrt();
                if !(len.is_finite() && len > 0.0) {
                    self.push(
                        format!("{p}.warp_direction"),
                        format!("{dir:?} is not a direction (finite, not zero)"),
                    );
                }
            }
            super::Prestress::Cylindrical {
                center,
                axis,
                n_r,
                n_theta,
                radius,
            } => {
                if !(force(*n_r) && *n_r > 0.0) {
                    self.push(
                        format!("{p}.n_r"),
                        format!("{n_r} is not a positive membrane force in N/m (at most {MAX_MEMBRANE_FORCE:e})"),
                    );
                }
                if !force(*n_theta) {
                    self.push(
                        format!("{p}.n_theta"),
                        format!("{n_theta} is not a membrane force in N/m >= 0 (at most {MAX_MEMBRANE_FORCE:e})"),
                    );
                }
                if !positive(*radius) {
                    self.push(
                        format!("{p}.radius"),
                        format!("{radius} is not a positive distance from the axis in m {RANGE}"),
                    );
                }
                if center.iter().any(|x| !coordinate(*x)) {
                    self.push(format!("{p}.center"), "must be finite with |x| <= 1e30 m");
                }
                let n = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
                if !positive(n) {
                    self.push(format!("{p}.axis"), "must be a non-zero finite vector");
                }
            }
            super::Prestress::Field { n } => {
                let count = match &m.triangles {
                    TriangleRef::Ids(ids) => ids.len(),
                    TriangleRef::Set(name) => mesh.triangle_sets.get(name).map_or(0, |t| t.len()),
                };
                if n.len() != count {
                    self.push(
                        format!("{p}.n"),
                        format!(
                            "lists {} tensors for the group's {count} triangles",
                            n.len()
                        ),
                    );
                }
                if let Some(k) = n.iter().position(|t| {
                    !t.iter()
                        .all(|v| v.is_finite() && v.abs() <= MAX_MEMBRANE_FORCE)
                }) {
                    self.push(
                        format!("{p}.n[{k}]"),
                        format!(
                            "{:?} is not a membrane force tensor in N/m (components at most {MAX_MEMBRANE_FORCE:e} in magnitude)",
                            n[k]
                        ),
                    );
                }
            }
        }
        // The neo-Hookean sheet carries a principal PK2 stress below μ only (S_i = μ (1 −
        // 1/(λ_i det C)) < μ); beyond half of it the equivalent stretch exceeds 26 %.
        if let Material::NeoHookean { mu } = m.material {
            let s = warp.max(fill) / m.thickness;
            if positive(mu) && positive(m.thickness) && s.is_finite() && s >= 0.5 * mu {
                self.push(
                    p.to_string(),
                    format!(
                        "{s:e} Pa (the largest prestress / thickness) is at least half the neo-Hookean shear modulus {mu:e} Pa: the sheet cannot carry it at moderate stretch"
                    ),
                );
            }
        }
    }

    fn cables(&mut self, s: &Scene, mesh: &Mesh) {
        for (i, c) in s.cables.iter().enumerate() {
            let p = format!("cables[{i}]");
            if let Some(ids) = self.nodes(mesh, &c.nodes, &format!("{p}.nodes")) {
                if ids.len() < 2 {
                    self.push(
                        format!("{p}.nodes"),
                        format!(
                            "a cable needs at least two nodes, this one has {}",
                            ids.len()
                        ),
                    );
                }
                for k in 1..ids.len() {
                    let (a, b) = (mesh.nodes[ids[k - 1]], mesh.nodes[ids[k]]);
                    if dist(a, b) <= 0.0 {
                        self.push(
                            format!("{p}.nodes[{k}]"),
                            format!(
                                "segment {} has zero length (nodes {} and {} coincide)",
                                k - 1,
                                ids[k - 1],
                                ids[k]
                            ),
                        );
                    }
                }
            }
            if let Some(mu) = c.mass_per_length {
                if !positive(mu) {
                    self.push(
                        format!("{p}.mass_per_length"),
                        format!("{mu} is not a positive mass per length in kg/m {RANGE}"),
                    );
                }
            }
            if !positive(c.ea) {
                self.push(
                    format!("{p}.EA"),
                    format!("{} is not a positive axial stiffness in N {RANGE}", c.ea),
                );
            }
            if c.pretension.is_some() && c.unstretched_length.is_some() {
                self.push(
                    format!("{p}.pretension"),
                    "give either pretension or unstretched_length, not both",
                );
            }
            if let Some(t) = c.pretension {
                if !(t.is_finite() && (0.0..=MAX_MAGNITUDE).contains(&t)) {
                    self.push(
                        format!("{p}.pretension"),
                        format!("{t} is not a tension in N (>= 0 and <= 1e30)"),
                    );
                } else if t > 0.0 && positive(c.ea) && t / c.ea < PRESTRAIN_FLOOR {
                    // L0 = L / (1 + T/EA) would round to L: the pretension would vanish.
                    self.push(
                        format!("{p}.EA"),
                        format!(
                            "{} N is too stiff for the pretension {t} N: the initial strain {:e} is below round-off ({PRESTRAIN_FLOOR:e}), so the pretension would be lost; EA must be below {:e} N",
                            c.ea,
                            t / c.ea,
                            t / PRESTRAIN_FLOOR
                        ),
                    );
                }
            }
            if let Some(ts) = &c.pretensions {
                if c.pretension.is_some() || c.unstretched_length.is_some() {
                    self.push(
                        format!("{p}.pretensions"),
                        "give one of pretension, pretensions and unstretched_length",
                    );
                }
                let segments =
                    cable_ids(mesh, &c.nodes).map_or(0, |ids| ids.len().saturating_sub(1));
                if ts.len() != segments {
                    self.push(
                        format!("{p}.pretensions"),
                        format!("lists {} tensions for {segments} segments", ts.len()),
                    );
                }
                for (k, &t) in ts.iter().enumerate() {
                    if !(t.is_finite() && (0.0..=MAX_MAGNITUDE).contains(&t)) {
                        self.push(
                            format!("{p}.pretensions[{k}]"),
                            format!("{t} is not a tension in N (>= 0 and <= 1e30)"),
                        );
                    } else if t > 0.0 && positive(c.ea) && t / c.ea < PRESTRAIN_FLOOR {
                        self.push(
                            format!("{p}.pretensions[{k}]"),
                            format!("{t} N is below round-off for EA = {} N (initial strain below {PRESTRAIN_FLOOR:e})", c.ea),
                        );
                    }
                }
            }
            if let Some(l) = c.unstretched_length {
                if !positive(l) {
                    self.push(
                        format!("{p}.unstretched_length"),
                        format!("{l} is not a positive length in m {RANGE}"),
                    );
                }
            }
            if let Some(sleeve) = &c.sleeve {
                self.sleeve(mesh, c, sleeve, &format!("{p}.sleeve"));
            }
        }
    }

    fn sleeve(&mut self, mesh: &Mesh, c: &super::Cable, sleeve: &super::Sleeve, p: &str) {
        if !(sleeve.mu.is_finite() && sleeve.mu >= 0.0) {
            self.push(
                format!("{p}.mu"),
                format!("{} is not a friction coefficient >= 0", sleeve.mu),
            );
        }
        if let Some(k) = sleeve.penalty {
            if !positive(k) {
                self.push(
                    format!("{p}.penalty"),
                    format!("{k} is not a positive penalty stiffness in N/m {RANGE}"),
                );
            }
        }
        let Some(ids) = cable_ids(mesh, &c.nodes) else {
            return;
        };
        if ids.len() < 3 {
            self.push(
                p.to_string(),
                "a sleeve needs a cable with at least one interior node to slide through",
            );
            return;
        }
        if let Some(r) = &sleeve.nodes {
            if let Some(nodes) = self.nodes(mesh, r, &format!("{p}.nodes")) {
                let interior = &ids[1..ids.len() - 1];
                for (k, id) in nodes.iter().enumerate() {
                    if !interior.contains(id) {
                        self.push(
                            format!("{p}.nodes[{k}]"),
                            format!("node {id} is not an interior node of cable \"{}\"", c.name),
                        );
                    } else if nodes[..k].contains(id) {
                        self.push(
                            format!("{p}.nodes[{k}]"),
                            format!("node {id} is listed twice"),
                        );
                    }
                }
            }
        }
        for (k, id) in ids.iter().enumerate() {
            if ids[..k].contains(id) {
                self.push(
                    p.to_string(),
                    format!(
                        "cable \"{}\" passes node {id} twice; a sleeved cable may not",
                        c.name
                    ),
                );
            }
        }
    }

    /// The sleeve node ids of a cable (None: no sleeve or unresolved).
    fn sleeve_ids(s: &Scene, mesh: &Mesh, cable: &str) -> Option<Vec<usize>> {
        let c = s.cables.iter().find(|c| c.name == cable)?;
        let ids = cable_ids(mesh, &c.nodes)?;
        super::shape::sleeve_nodes(&ids, c.sleeve.as_ref()?, mesh)
    }

    /// Probe checks of a sleeve: the cable has one, and `node` (if any) is one of its nodes.
    fn sleeve_probe(
        &mut self,
        s: &Scene,
        mesh: &Mesh,
        cable: &str,
        node: Option<&OneNode>,
        p: &str,
    ) {
        self.cable_name(s, cable, &format!("{p}.cable"));
        let Some(c) = s.cables.iter().find(|c| c.name == cable) else {
            return;
        };
        if c.sleeve.is_none() {
            self.push(
                format!("{p}.cable"),
                format!("cable \"{cable}\" has no sleeve"),
            );
            return;
        }
        if let Some(node) = node {
            if let (Some(id), Some(ids)) = (
                self.one_node(mesh, node, &format!("{p}.node")),
                Self::sleeve_ids(s, mesh, cable),
            ) {
                if !ids.contains(&id) {
                    self.push(
                        format!("{p}.node"),
                        format!("node {id} is not a sleeve node of cable \"{cable}\""),
                    );
                }
            }
        }
    }

    /// Supports; returns the held (node, component) pairs.
    fn supports(&mut self, s: &Scene, mesh: &Mesh) -> BTreeSet<(usize, usize)> {
        let mut held = BTreeSet::new();
        for (i, sup) in s.supports.iter().enumerate() {
            let p = format!("supports[{i}]");
            if sup.fix.is_empty() {
                self.push(
                    format!("{p}.fix"),
                    "names no component; use [\"x\", \"y\", \"z\"] to clamp",
                );
            }
            if let Some(ids) = self.nodes(mesh, &sup.nodes, &format!("{p}.nodes")) {
                for id in ids {
                    for c in &sup.fix {
                        held.insert((id, c.index()));
                    }
                }
            }
        }
        // Inputs that hold components; two of the same kind on one component are an error,
        // different kinds add (a rotation and a translation, radial and tangential).
        let mut prescribed: BTreeMap<(usize, usize), Vec<String>> = BTreeMap::new();
        const AXES: [&str; 3] = ["x", "y", "z"];
        for (i, input) in s.inputs.iter().enumerate() {
            let (nodes, components, kind): (&NodeRef, Vec<usize>, String) = match &input.load {
                Load::Displacement { nodes, component } => {
                    (nodes, vec![component.index()], "displacement".to_string())
                }
                Load::Rotation { nodes, .. } => (nodes, vec![0, 1, 2], "rotation".to_string()),
                Load::PolarDisplacement {
                    nodes,
                    axis,
                    component,
                    ..
                } => (
                    nodes,
                    (0..3).filter(|&c| c != axis.index()).collect(),
                    format!("{component:?}").to_lowercase() + " displacement",
                ),
                Load::SupportDisplacement { nodes } => {
                    (nodes, vec![0, 1, 2], "support displacement".to_string())
                }
                _ => continue,
            };
            let p = format!("inputs[{i}].load.nodes");
            if let Some(ids) = self.nodes(mesh, nodes, &p) {
                for id in ids {
                    for &c in &components {
                        let key = (id, c);
                        let axis = AXES[c];
                        if held.contains(&key) && !prescribed.contains_key(&key) {
                            self.push(&p, format!("node {id} is already fixed in {axis} by a support; a prescribed {kind} cannot move it"));
                        } else {
                            let kinds = prescribed.entry(key).or_default();
                            if kinds.contains(&kind) {
                                self.push(
                                    &p,
                                    format!("node {id} component {axis} is prescribed by two {kind} inputs"),
                                );
                            } else {
                                kinds.push(kind.clone());
                            }
                        }
                        held.insert(key);
                    }
                }
            }
        }
        if held.is_empty() && (!s.membranes.is_empty() || !s.cables.is_empty()) {
            self.push("supports", "nothing is held: add a support or a prescribed displacement, or the structure floats freely");
        }
        held
    }

    fn inputs(&mut self, s: &Scene, mesh: &Mesh, _held: &BTreeSet<(usize, usize)>) {
        for (i, input) in s.inputs.iter().enumerate() {
            let p = format!("inputs[{i}]");
            match &input.load {
                Load::PointForce { nodes, direction } => {
                    self.nodes(mesh, nodes, &format!("{p}.load.nodes"));
                    let n = direction.iter().map(|x| x * x).sum::<f64>().sqrt();
                    if !positive(n) {
                        self.push(
                            format!("{p}.load.direction"),
                            "must be a non-zero finite vector",
                        );
                    }
                }
                Load::Pressure { membrane, zone, .. } => {
                    if self.membrane_name(s, membrane, &format!("{p}.load.membrane")) {
                        if let Some(zone) = zone {
                            self.zone(s, mesh, membrane, zone, &format!("{p}.load.zone"));
                        }
                    }
                }
                Load::Volume { membrane } => {
                    self.closed_group(s, mesh, membrane, &format!("{p}.load.membrane"));
                }
                Load::Snow { membrane, zone }
                | Load::Ponding { membrane, zone, .. }
                | Load::WaterVolume { membrane, zone, .. } => {
                    if self.membrane_name(s, membrane, &format!("{p}.load.membrane")) {
                        if let Some(zone) = zone {
                            self.zone(s, mesh, membrane, zone, &format!("{p}.load.zone"));
                        }
                    }
                    if let Load::Ponding { gamma_w, .. } | Load::WaterVolume { gamma_w, .. } =
                        &input.load
                    {
                        if !positive(*gamma_w) {
                            self.push(
                                format!("{p}.load.gamma_w"),
                                format!("{gamma_w} is not a positive unit weight of water in N/m3 {RANGE}"),
                            );
                        }
                    }
                }
                Load::SelfWeight { direction } => {
                    let n = direction.iter().map(|x| x * x).sum::<f64>().sqrt();
                    if !positive(n) {
                        self.push(
                            format!("{p}.load.direction"),
                            "must be a non-zero finite vector",
                        );
                    }
                    let massive = s.membranes.iter().any(|m| m.density.is_some())
                        || s.cables.iter().any(|c| c.mass_per_length.is_some());
                    if !massive {
                        self.push(
                            format!("{p}.load"),
                            "a self_weight input needs mass: give a membrane group a density (kg/m3) or a cable a mass_per_length (kg/m)",
                        );
                    }
                }
                Load::Gas {
                    membrane,
                    atmosphere,
                } => {
                    self.closed_group(s, mesh, membrane, &format!("{p}.load.membrane"));
                    if !positive(*atmosphere) {
                        self.push(
                            format!("{p}.load.atmosphere"),
                            format!(
                                "{atmosphere} is not a positive absolute pressure in Pa {RANGE}"
                            ),
                        );
                    }
                }
                Load::ZonePressure {
                    membrane, zones, ..
                } => {
                    if zones.is_empty() {
                        self.push(format!("{p}.load.zones"), "lists no zone");
                    }
                    if self.membrane_name(s, membrane, &format!("{p}.load.membrane")) {
                        for (k, zone) in zones.iter().enumerate() {
                            self.zone(s, mesh, membrane, zone, &format!("{p}.load.zones[{k}]"));
                        }
                    }
                }
                // Checked with the supports.
                Load::SupportDisplacement { .. } => {}
                Load::Displacement { .. } => {} // checked with the supports
                Load::Rotation { point, axis, .. } => {
                    self.point_and_axis(point, axis, &format!("{p}.load"));
                }
                Load::PolarDisplacement {
                    nodes,
                    center,
                    axis,
                    ..
                } => {
                    if center.iter().any(|x| !coordinate(*x)) {
                        self.push(
                            format!("{p}.load.center"),
                            "must be finite with |x| <= 1e30 m",
                        );
                    } else if let Some(ids) = self.nodes(mesh, nodes, &format!("{p}.load.nodes")) {
                        let k = axis.index();
                        for id in ids {
                            if on_axis(mesh.nodes[id], center, k) {
                                self.push(
                                    format!("{p}.load.nodes"),
                                    format!("node {id} lies on the axis: it has no radial or tangential direction"),
                                );
                                break;
                            }
                        }
                    }
                }
                Load::RadialEdgeLoad { nodes, center, .. } => {
                    if let Some(ids) = self.nodes(mesh, nodes, &format!("{p}.load.nodes")) {
                        if ids.len() < 2 {
                            self.push(
                                format!("{p}.load.nodes"),
                                "an edge load needs at least two nodes (one edge)",
                            );
                        }
                    }
                    if center.iter().any(|x| !coordinate(*x)) {
                        self.push(
                            format!("{p}.load.center"),
                            "must be finite with |x| <= 1e30 m",
                        );
                    }
                }
            }
            if !input.start.is_finite() {
                self.push(format!("{p}.start"), "must be a finite number");
            }
            if let (Some(lo), Some(hi)) = (input.min, input.max) {
                if lo > hi {
                    self.push(format!("{p}.min"), format!("min {lo} is above max {hi}"));
                }
            }
            if input.min.is_some_and(|lo| input.start < lo)
                || input.max.is_some_and(|hi| input.start > hi)
            {
                self.push(
                    format!("{p}.start"),
                    format!("start {} is outside [min, max]", input.start),
                );
            }
        }
    }

    fn outputs(&mut self, s: &Scene, mesh: &Mesh, held: &BTreeSet<(usize, usize)>) {
        for (i, out) in s.outputs.iter().enumerate() {
            let p = format!("outputs[{i}].probe");
            match &out.probe {
                Probe::Displacement { node, .. }
                | Probe::Position { node, .. }
                | Probe::Velocity { node, .. }
                | Probe::Acceleration { node, .. } => {
                    self.one_node(mesh, node, &format!("{p}.node"));
                }
                Probe::KineticEnergy | Probe::StrainEnergy => {}
                Probe::PolarDisplacement {
                    node, center, axis, ..
                } => {
                    if center.iter().any(|x| !coordinate(*x)) {
                        self.push(format!("{p}.center"), "must be finite with |x| <= 1e30 m");
                    } else if let Some(id) = self.one_node(mesh, node, &format!("{p}.node")) {
                        let k = axis.index();
                        if on_axis(mesh.nodes[id], center, k) {
                            self.push(
                                format!("{p}.node"),
                                format!("node {id} lies on the axis: it has no radial or tangential direction"),
                            );
                        }
                    }
                }
                Probe::CableLength { cable, from, to } => {
                    self.cable_name(s, cable, &format!("{p}.cable"));
                    let ids = s
                        .cables
                        .iter()
                        .find(|c| &c.name == cable)
                        .and_then(|c| cable_ids(mesh, &c.nodes));
                    let mut at = |r: &Option<OneNode>, field: &str| -> Option<usize> {
                        let id = self.one_node(mesh, r.as_ref()?, &format!("{p}.{field}"))?;
                        let k = ids.as_ref()?.iter().position(|&i| i == id);
                        if k.is_none() {
                            self.push(
                                format!("{p}.{field}"),
                                format!("node {id} is not a node of cable \"{cable}\""),
                            );
                        }
                        k
                    };
                    if let (Some(a), Some(b)) = (at(from, "from"), at(to, "to")) {
                        if a >= b {
                            self.push(format!("{p}.to"), "must come after `from` along the cable");
                        }
                    }
                }
                Probe::CableSlip { cable, node } => {
                    self.sleeve_probe(s, mesh, cable, Some(node), &p);
                }
                Probe::ContactForce { cable, node } => {
                    self.sleeve_probe(s, mesh, cable, node.as_ref(), &p);
                }
                Probe::CableEndSlip { cable, .. }
                | Probe::ContactGap { cable }
                | Probe::SlipCount { cable, .. } => {
                    self.sleeve_probe(s, mesh, cable, None, &p);
                }
                Probe::CableTension { cable, segment } => {
                    self.cable_name(s, cable, &format!("{p}.cable"));
                    if let (Some(seg), Some(c)) =
                        (segment, s.cables.iter().find(|c| &c.name == cable))
                    {
                        let n = match &c.nodes {
                            NodeRef::Ids(ids) => ids.len(),
                            NodeRef::Set(name) => mesh.node_sets.get(name).map_or(0, Vec::len),
                        };
                        if *seg + 1 >= n.max(1) {
                            self.push(
                                format!("{p}.segment"),
                                format!(
                                    "cable \"{cable}\" has {} segments (0 to {})",
                                    n.saturating_sub(1),
                                    n.saturating_sub(2)
                                ),
                            );
                        }
                    }
                }
                Probe::Reaction { nodes, component } => {
                    if let Some(ids) = self.nodes(mesh, nodes, &format!("{p}.nodes")) {
                        if !ids
                            .iter()
                            .any(|&id| held.contains(&(id, component.index())))
                        {
                            self.push(format!("{p}.nodes"), format!("no node of this set is held in {component:?}, so there is no reaction to report"));
                        }
                    }
                }
                Probe::ReactionMoment { nodes, point, axis } => {
                    self.point_and_axis(point, axis, &p);
                    self.reaction_nodes(mesh, nodes, held, &p);
                }
                Probe::ReactionResultant { nodes } => {
                    self.reaction_nodes(mesh, nodes, held, &p);
                }
                Probe::ZoneForce { zone, .. } => {
                    let path = format!("{p}.zone");
                    if !mesh.triangle_sets.contains_key(zone) {
                        self.push(
                            path,
                            format!(
                                "no triangle set is named \"{zone}\"{}",
                                suggest(zone, mesh.triangle_sets.keys())
                            ),
                        );
                    } else if !s.membranes.iter().any(|m| {
                        !super::shape::zone_positions(s, mesh, &m.name, Some(zone)).is_empty()
                    }) {
                        self.push(
                            path,
                            format!("zone \"{zone}\" has no triangle of any membrane group"),
                        );
                    }
                }
                Probe::NewtonIterations => {}
                Probe::NaturalFrequency { mode } => {
                    if !(1..=1000).contains(mode) {
                        self.push(
                            format!("{p}.mode"),
                            format!("{mode} is not a mode number in 1..=1000"),
                        );
                    }
                    let massive = s.membranes.iter().any(|m| m.density.is_some())
                        || s.cables.iter().any(|c| c.mass_per_length.is_some())
                        || s.dynamics.iter().any(|d| !d.point_masses.is_empty());
                    if !massive {
                        self.push(
                            p.clone(),
                            "a natural_frequency output needs mass: give a membrane group a density (kg/m3), a cable a mass_per_length (kg/m) or dynamics.point_masses",
                        );
                    }
                    let sleeves = s.cables.iter().any(|c| c.sleeve.is_some());
                    let volumes = s.inputs.iter().any(|i| i.load.has_unknown());
                    if !s.contacts.is_empty() {
                        self.push(
                            p.clone(),
                            "a natural_frequency output is not available with contacts (their multipliers are not in the eigenproblem)",
                        );
                    }
                    if sleeves || volumes {
                        self.push(
                            p.clone(),
                            "a natural_frequency output is not available with sleeves or volume, gas or water_volume inputs (their unknowns are not in the eigenproblem yet)",
                        );
                    }
                }
                Probe::EnclosedVolume { membrane } => {
                    self.closed_group(s, mesh, membrane, &format!("{p}.membrane"));
                }
                Probe::ContactTotal { contact, .. } | Probe::ContactArea { contact } => {
                    self.contact_name(s, contact, &format!("{p}.contact"));
                }
                Probe::EnclosedPressure { input } => {
                    let volume = s.inputs.iter().any(|i| {
                        &i.name == input && matches!(i.load, Load::Volume { .. } | Load::Gas { .. })
                    });
                    if !volume {
                        let names: Vec<&String> = s
                            .inputs
                            .iter()
                            .filter(|i| matches!(i.load, Load::Volume { .. } | Load::Gas { .. }))
                            .map(|i| &i.name)
                            .collect();
                        self.push(
                            format!("{p}.input"),
                            format!(
                                "no input of kind volume or gas is named \"{input}\"{}",
                                suggest(input, names.into_iter())
                            ),
                        );
                    }
                }
                Probe::WaterLevel { input } => {
                    let water = |i: &&super::Input| matches!(i.load, Load::WaterVolume { .. });
                    if !s.inputs.iter().filter(water).any(|i| &i.name == input) {
                        let names = s.inputs.iter().filter(water).map(|i| &i.name);
                        self.push(
                            format!("{p}.input"),
                            format!(
                                "no input of kind water_volume is named \"{input}\"{}",
                                suggest(input, names)
                            ),
                        );
                    }
                }
                Probe::WrinkledFraction { membrane }
                | Probe::SlackFraction { membrane }
                | Probe::MaxPrincipalStress { membrane }
                | Probe::MinPrincipalStress { membrane } => {
                    if s.membranes.is_empty() {
                        self.push(format!("{p}.kind"), "the scene has no membrane to measure");
                    }
                    if let Some(name) = membrane {
                        if !s.membranes.iter().any(|m| &m.name == name) {
                            let names: Vec<&String> = s.membranes.iter().map(|m| &m.name).collect();
                            self.push(
                                format!("{p}.membrane"),
                                format!(
                                    "no membrane group is named \"{name}\"{}",
                                    suggest(name, names.into_iter())
                                ),
                            );
                        }
                    }
                }
                Probe::DisplacementField { nodes } | Probe::PositionField { nodes } => {
                    if let Some(nodes) = nodes {
                        self.nodes(mesh, nodes, &format!("{p}.nodes"));
                    }
                }
                Probe::CableTensions { cable } => {
                    self.cable_name(s, cable, &format!("{p}.cable"));
                }
                Probe::SleeveSlips { cable } => {
                    self.sleeve_probe(s, mesh, cable, None, &p);
                }
                Probe::PrincipalStresses { membrane } | Probe::WrinkleStates { membrane } => {
                    if s.membranes.is_empty() {
                        self.push(format!("{p}.kind"), "the scene has no membrane to measure");
                    }
                    if let Some(name) = membrane {
                        self.membrane_name(s, name, &format!("{p}.membrane"));
                    }
                }
                Probe::ElementState { triangle } => {
                    let in_group = s.membranes.iter().any(|m| match &m.triangles {
                        TriangleRef::Ids(ids) => ids.contains(triangle),
                        TriangleRef::Set(name) => mesh
                            .triangle_sets
                            .get(name)
                            .is_some_and(|t| t.contains(triangle)),
                    });
                    if !in_group {
                        self.push(
                            format!("{p}.triangle"),
                            format!("triangle {triangle} belongs to no membrane group"),
                        );
                    }
                }
            }
        }
    }

    /// Whether a membrane group of that name exists (reported when not).
    fn membrane_name(&mut self, s: &Scene, membrane: &str, path: &str) -> bool {
        if s.membranes.iter().any(|m| m.name == membrane) {
            return true;
        }
        let names: Vec<&String> = s.membranes.iter().map(|m| &m.name).collect();
        self.push(
            path,
            format!(
                "no membrane group is named \"{membrane}\"{}",
                suggest(membrane, names.into_iter())
            ),
        );
        false
    }

    /// A pressure zone: a triangle set that shares at least one triangle with the group.
    fn zone(&mut self, s: &Scene, mesh: &Mesh, membrane: &str, zone: &str, path: &str) {
        if !mesh.triangle_sets.contains_key(zone) {
            self.push(
                path,
                format!(
                    "no triangle set is named \"{zone}\"{}",
                    suggest(zone, mesh.triangle_sets.keys())
                ),
            );
        } else if super::shape::zone_positions(s, mesh, membrane, Some(zone)).is_empty() {
            self.push(
                path,
                format!("zone \"{zone}\" has no triangle of membrane group \"{membrane}\""),
            );
        }
    }

    fn cable_name(&mut self, s: &Scene, cable: &str, path: &str) {
        if !s.cables.iter().any(|c| c.name == cable) {
            let names: Vec<&String> = s.cables.iter().map(|c| &c.name).collect();
            self.push(
                path,
                format!(
                    "no cable is named \"{cable}\"{}",
                    suggest(cable, names.into_iter())
                ),
            );
        }
    }

    fn parameters(&mut self, s: &Scene) {
        for (i, p) in s.parameters.iter().enumerate() {
            let path = format!("parameters[{i}].target");
            match parameter_value(s, &p.target) {
                None => self.push(path, format!("\"{}\" is not a parameter target; use membranes.<name>.E|nu|mu|E_warp|E_fill|nu_wf|G|thickness, cables.<name>.EA|pretension or solver.artificial_prestress (test variants: debug.fail_after_time|panic_after_time)", p.target)),
                Some(v) if !v.is_finite() => self.push(path, format!("{} must be given a value in the scene to be exposed as a parameter", p.target)),
                Some(_) => {}
            }
            if p.target.ends_with(".pretension") {
                if let Some(c) = s
                    .cables
                    .iter()
                    .find(|c| p.target == format!("cables.{}.pretension", c.name))
                {
                    if c.unstretched_length.is_some() {
                        self.push(format!("parameters[{i}].target"), format!("cable \"{}\" is given by unstretched_length; expose that or give it a pretension", c.name));
                    }
                }
            }
        }
    }

    /// Variable names: valid and unique over parameters, inputs and outputs; names unique
    /// within membranes and cables.
    fn names(&mut self, s: &Scene) {
        let mut seen: BTreeMap<&str, String> = BTreeMap::new();
        let all = s
            .parameters
            .iter()
            .map(|p| (&p.name, "parameters"))
            .chain(s.inputs.iter().map(|p| (&p.name, "inputs")))
            .chain(s.outputs.iter().map(|p| (&p.name, "outputs")));
        let mut counters: BTreeMap<&str, usize> = BTreeMap::new();
        for (name, list) in all {
            let k = counters.entry(list).or_insert(0);
            let path = format!("{list}[{k}].name");
            *k += 1;
            if !is_variable_name(name) || name == "time" {
                self.push(&path, format!("\"{name}\" is not a usable variable name (letters, digits, _ . [ ], not \"time\")"));
            }
            if let Some(first) = seen.get(name.as_str()) {
                self.push(&path, format!("\"{name}\" is already used by {first}"));
            } else {
                seen.insert(name, path);
            }
        }
        // An array's FMI 2 scalars are `name[i]`: its name has no brackets, and no other
        // variable is named like one of its elements. (Only a scene with arrays builds the
        // mesh here, fallibly: without the memory the shapes are not checked.)
        self.array_names(s, &seen);
        self.group_names(s);
    }

    /// Array inputs and outputs: no brackets in their names, no clash with another variable's
    /// name of the form `name[...]`.
    fn array_names(&mut self, s: &Scene, seen: &BTreeMap<&str, String>) {
        if !super::shape::has_arrays(s) {
            return;
        }
        let Ok(mesh) = super::generate::try_resolve(&s.geometry) else {
            return;
        };
        let arrays: Vec<(&String, String)> = s
            .inputs
            .iter()
            .enumerate()
            .filter(|(_, i)| !super::shape::input_shape(&mesh, &i.load).is_empty())
            .map(|(k, i)| (&i.name, format!("inputs[{k}].name")))
            .chain(
                s.outputs
                    .iter()
                    .enumerate()
                    .filter(|(_, o)| !super::shape::output_shape(s, &mesh, &o.probe).is_empty())
                    .map(|(k, o)| (&o.name, format!("outputs[{k}].name"))),
            )
            .collect();
        for (name, path) in &arrays {
            if name.contains(['[', ']']) {
                self.push(path, format!("\"{name}\" names an array: no [ ] in it (FMI 2 names its elements {name}[1], {name}[2], ...)"));
            }
            let prefix = format!("{name}[");
            for (other, first) in seen {
                if other.starts_with(&prefix) {
                    self.push(path, format!("the elements of array \"{name}\" would clash with {first} (\"{other}\")"));
                }
            }
        }
    }

    /// Membrane and cable names: identifiers, unique within their list.
    fn group_names(&mut self, s: &Scene) {
        for (list, names) in [
            (
                "membranes",
                s.membranes.iter().map(|m| &m.name).collect::<Vec<_>>(),
            ),
            ("cables", s.cables.iter().map(|c| &c.name).collect()),
        ] {
            let mut set = BTreeSet::new();
            for (i, n) in names.iter().enumerate() {
                if !is_identifier(n) {
                    self.push(
                        format!("{list}[{i}].name"),
                        format!("\"{n}\" must be an identifier (letters, digits, _)"),
                    );
                }
                if !set.insert(*n) {
                    self.push(
                        format!("{list}[{i}].name"),
                        format!("\"{n}\" is used twice"),
                    );
                }
            }
        }
    }

    /// The `dynamics` section: damping factors non-negative and finite, point masses
    /// positive on node sets that resolve, air on existing membrane groups (once each) with
    /// non-negative added mass and damping.
    fn dynamics(&mut self, s: &Scene, mesh: &Mesh) {
        let Some(d) = &s.dynamics else {
            return;
        };
        for (field, value, unit) in [
            ("rayleigh_alpha", d.rayleigh_alpha, "1/s"),
            ("rayleigh_beta", d.rayleigh_beta, "s"),
        ] {
            if !(value.is_finite() && (0.0..=MAX_MAGNITUDE).contains(&value)) {
                self.push(
                    format!("dynamics.{field}"),
                    format!("{value} is not a damping factor in {unit} (0 or more, at most 1e30)"),
                );
            }
        }
        for (k, pm) in d.point_masses.iter().enumerate() {
            let p = format!("dynamics.point_masses[{k}]");
            if !positive(pm.mass) {
                self.push(
                    format!("{p}.mass"),
                    format!("{} is not a positive mass in kg {RANGE}", pm.mass),
                );
            }
            self.nodes(mesh, &pm.nodes, &format!("{p}.nodes"));
        }
        let mut seen = std::collections::BTreeSet::new();
        for (k, air) in d.air.iter().enumerate() {
            let p = format!("dynamics.air[{k}]");
            if self.membrane_name(s, &air.membrane, &format!("{p}.membrane"))
                && !seen.insert(air.membrane.as_str())
            {
                self.push(
                    format!("{p}.membrane"),
                    format!(
                        "membrane group \"{}\" has air given twice (one entry per group)",
                        air.membrane
                    ),
                );
            }
            for (field, value, what) in [
                ("added_mass", air.added_mass, "an added mass in kg/m2"),
                ("damping", air.damping, "a damping per unit area in N s/m3"),
            ] {
                if !(value.is_finite() && (0.0..=MAX_MAGNITUDE).contains(&value)) {
                    self.push(
                        format!("{p}.{field}"),
                        format!("{value} is not {what} (0 or more, at most 1e30)"),
                    );
                }
            }
        }
        if let Some(t) = &d.time_integration {
            if !(t.rho_inf.is_finite() && (0.0..=1.0).contains(&t.rho_inf)) {
                self.push(
                    "dynamics.time_integration.rho_inf",
                    format!(
                        "{} is not a spectral radius in [0, 1] (1: no numerical dissipation)",
                        t.rho_inf
                    ),
                );
            }
            if let Some(dt) = t.max_time_step {
                if !positive(dt) {
                    self.push(
                        "dynamics.time_integration.max_time_step",
                        format!("{dt} is not a positive time step in s {RANGE}"),
                    );
                }
            }
            let massive = s.membranes.iter().any(|m| m.density.is_some())
                || s.cables.iter().any(|c| c.mass_per_length.is_some())
                || !d.point_masses.is_empty();
            if !massive {
                self.push(
                    "dynamics.time_integration",
                    "time integration needs mass: give a membrane group a density (kg/m3), a cable a mass_per_length (kg/m) or dynamics.point_masses",
                );
            }
        }
    }

    fn form_finding(&mut self, s: &Scene, mesh: &Mesh) {
        let Some(ff) = &s.form_finding else {
            return;
        };
        if !(1..=MAX_ITERATIONS).contains(&ff.max_iterations) {
            self.push(
                "form_finding.max_iterations",
                format!("{} is not in 1..={MAX_ITERATIONS}", ff.max_iterations),
            );
        }
        let (lo, hi) = FORM_FINDING_TOLERANCE_RANGE;
        if !(ff.tolerance.is_finite() && ff.tolerance >= lo && ff.tolerance < hi) {
            self.push(
                "form_finding.tolerance",
                format!(
                    "{} is not a relative tolerance in [{lo:e}, {hi})",
                    ff.tolerance
                ),
            );
        }
        if !(ff.homotopy.is_finite() && (0.0..HOMOTOPY_BOUND).contains(&ff.homotopy)) {
            self.push(
                "form_finding.homotopy",
                format!(
                    "{} is not a homotopy factor in [0, {HOMOTOPY_BOUND})",
                    ff.homotopy
                ),
            );
        }
        for (k, pl) in ff.place.iter().enumerate() {
            let p = format!("form_finding.place[{k}]");
            let single = pl.node.is_some() || pl.position.is_some();
            let rigid = pl.nodes.is_some() || pl.translate.is_some() || pl.rotate.is_some();
            if single == rigid {
                self.push(
                    &p,
                    "give either \"node\" and \"position\" (one node moved) or \"nodes\" with \"translate\" and/or \"rotate\" (a node set moved as one rigid body)",
                );
                continue;
            }
            if single {
                match &pl.node {
                    Some(node) => {
                        self.one_node(mesh, node, &format!("{p}.node"));
                    }
                    None => self.push(
                        format!("{p}.node"),
                        "missing: the node to move to \"position\"",
                    ),
                }
                match pl.position {
                    Some(position) if !position.iter().all(|&c| coordinate(c)) => self.push(
                        format!("{p}.position"),
                        format!("{position:?} is not a position in m {RANGE}"),
                    ),
                    Some(_) => {}
                    None => self.push(
                        format!("{p}.position"),
                        "missing: where \"node\" goes, [x, y, z] in m",
                    ),
                }
                continue;
            }
            match &pl.nodes {
                Some(nodes) => {
                    self.nodes(mesh, nodes, &format!("{p}.nodes"));
                }
                None => self.push(
                    format!("{p}.nodes"),
                    "missing: the node set moved by \"translate\"/\"rotate\"",
                ),
            }
            if let Some(t) = pl.translate {
                if !t.iter().all(|&c| coordinate(c)) {
                    self.push(
                        format!("{p}.translate"),
                        format!("{t:?} is not a translation in m {RANGE}"),
                    );
                }
            }
            if let Some(r) = &pl.rotate {
                self.point_and_axis(&r.point, &r.axis, &format!("{p}.rotate"));
                if !(r.angle.is_finite() && r.angle.abs() <= 1e3) {
                    self.push(
                        format!("{p}.rotate.angle"),
                        format!("{} is not an angle in rad in [-1000, 1000]", r.angle),
                    );
                }
            }
        }
        if s.membranes.is_empty() && s.cables.is_empty() {
            self.push(
                "form_finding",
                "there is nothing to form-find: give membranes with a prestress or cables with a pretension",
            );
        }
        for (i, m) in s.membranes.iter().enumerate() {
            if matches!(m.prestress, Some(super::Prestress::Field { .. })) {
                self.push(
                    format!("membranes[{i}].prestress"),
                    "form finding takes an isotropic or warp_fill prestress (the stress prescribed on the unknown shape), not a field",
                );
            }
            if m.prestress.is_none() {
                self.push(
                    format!("membranes[{i}].prestress"),
                    "form finding needs a prestress on every membrane group (the stress whose equilibrium shape is sought)",
                );
            }
        }
        for (i, c) in s.cables.iter().enumerate() {
            if !c.pretension.is_some_and(|t| t > 0.0) {
                self.push(
                    format!("cables[{i}].pretension"),
                    "form finding needs a positive pretension on every cable (its prescribed force)",
                );
            }
            if c.sleeve.is_some() {
                self.push(
                    format!("cables[{i}].sleeve"),
                    "form finding does not take sleeved cables; form-find without the sleeve, then add it to the found scene",
                );
            }
        }
    }

    /// Every numeric solver setting within its documented range ([`MAX_ITERATIONS`] and the
    /// constants beside it; `SolverSettings` and `Limits` say why each range is what the solver
    /// can use). Checked before the mesh, so that a bad setting is named whatever else is wrong.
    fn solver(&mut self, s: &Scene) {
        let st = &s.solver;
        let (lo, hi) = TOLERANCE_RANGE;
        if !(st.tolerance.is_finite() && (lo..=hi).contains(&st.tolerance)) {
            self.push(
                "solver.tolerance",
                format!("{} is not in [{lo:e}, {hi:e}]: below it only the round-off floor of the residual test decides, above it a converged state keeps a residual of over a percent of the forces", st.tolerance),
            );
        }
        if !(1..=MAX_ITERATIONS).contains(&st.max_iterations) {
            self.push(
                "solver.max_iterations",
                format!("{} is not in 1..={MAX_ITERATIONS} (Newton iterations per load increment; a flat start takes 30 to 46)", st.max_iterations),
            );
        }
        if !(1..=MAX_STEP_ITERATIONS).contains(&st.max_step_iterations) {
            self.push(
                "solver.max_step_iterations",
                format!(
                    "{} is not in 1..={MAX_STEP_ITERATIONS} (Newton iterations of a whole step before it gives up)",
                    st.max_step_iterations
                ),
            );
        }
        if !(1..=MAX_ITERATIONS).contains(&st.target_iterations) {
            self.push(
                "solver.target_iterations",
                format!(
                    "{} is not in 1..={MAX_ITERATIONS} (iterations per increment that let the next one grow)",
                    st.target_iterations
                ),
            );
        }
        if !(st.initial_increment.is_finite()
            && (MIN_INCREMENT..=1.0).contains(&st.initial_increment))
        {
            self.push(
                "solver.initial_increment",
                format!(
                    "{} is not in [{MIN_INCREMENT:e}, 1] (a fraction of the step's load change)",
                    st.initial_increment
                ),
            );
        }
        let top = if st.initial_increment.is_finite() {
            st.initial_increment.clamp(MIN_INCREMENT, 1.0)
        } else {
            1.0
        };
        if !(st.min_increment.is_finite() && (MIN_INCREMENT..=top).contains(&st.min_increment)) {
            self.push(
                "solver.min_increment",
                format!(
                    "{} is not in [{MIN_INCREMENT:e}, initial_increment = {top}] (at most {} cut-backs by 4 from a whole step)",
                    st.min_increment,
                    max_cutbacks()
                ),
            );
        }
        let most = MAX_SOLVER_THREADS;
        if !(1..=most).contains(&st.threads) {
            self.push(
                "solver.threads",
                format!("{} must be an integer from 1 to {most}", st.threads),
            );
        }
        if let Some(a) = st.arc_length {
            if !positive(a) {
                self.push(
                    "solver.arc_length",
                    format!("{a} is not a length in m in [1e-30, 1e30]"),
                );
            }
        }
        let h = st.prestress_continuation;
        if !(h.is_finite() && (0.0..=MAX_PRESTRESS_CONTINUATION).contains(&h)) {
            self.push(
                "solver.prestress_continuation",
                format!("{h} must be a strain from 0 (off) to {MAX_PRESTRESS_CONTINUATION}"),
            );
        }
        let t = st.proximal_continuation;
        if !(t.is_finite() && (0.0..=1.0).contains(&t)) {
            self.push(
                "solver.proximal_continuation",
                format!("{t} must be a relative stiffness from 0 (off) to 1"),
            );
        }
        let o = st.overshoot_continuation;
        if !(o.is_finite() && (0.0..=1.0).contains(&o)) {
            self.push(
                "solver.overshoot_continuation",
                format!("{o} must be a load-to-stiffness ratio from 0 (off) to 1"),
            );
        }
        if let Some(p) = st.artificial_prestress {
            if !(p.is_finite() && (0.0..=MAX_MAGNITUDE).contains(&p)) {
                self.push(
                    "solver.artificial_prestress",
                    format!("{p} must be a stress >= 0 in Pa (at most 1e30)"),
                );
            }
        }
        let l = &st.limits;
        for (field, value) in [
            ("max_nodes", l.max_nodes),
            ("max_triangles", l.max_triangles),
            ("max_unknowns", l.max_unknowns),
        ] {
            if !(1..=MAX_COUNT_LIMIT).contains(&value) {
                self.push(
                    format!("solver.limits.{field}"),
                    format!("{value} is not in 1..={MAX_COUNT_LIMIT} (the solver addresses its matrix with 32-bit positions: no larger model can be built)"),
                );
            }
        }
        let (lo, hi) = MEMORY_GB_RANGE;
        if !(l.max_memory_gb.is_finite() && (lo..=hi).contains(&l.max_memory_gb)) {
            self.push(
                "solver.limits.max_memory_gb",
                format!("{} is not in [{lo}, {hi:e}] GB", l.max_memory_gb),
            );
        }
    }
}

fn generator_name(g: &Generator) -> &str {
    match g {
        Generator::Rectangle { name, .. }
        | Generator::Disc { name, .. }
        | Generator::Annulus { name, .. }
        | Generator::Cushion { name, .. } => name,
    }
}

/// Zero area in floating point: relative to the longest edge (collinear or repeated nodes), or
/// below what the model's reference frame can be formed from (twice the area <= 1e-300).
/// Smallest in-plane part (sine of the angle to the normal) of an orthotropic group's warp
/// vector on any of its triangles: below this the projected direction is round-off.
const WARP_IN_PLANE: f64 = 1e-3;

/// Triangle ids of a group's reference, if it resolves.
fn group_triangles(mesh: &Mesh, r: &TriangleRef) -> Option<Vec<usize>> {
    match r {
        TriangleRef::Set(name) => mesh.triangle_sets.get(name).cloned(),
        TriangleRef::Ids(ids) => ids
            .iter()
            .all(|&i| i < mesh.triangles.len())
            .then(|| ids.clone()),
    }
}

/// Unit normal of a mesh triangle (None if degenerate or a node id is out of range).
fn unit_normal(mesh: &Mesh, t: &[usize; 3]) -> Option<[f64; 3]> {
    let p = |i: usize| mesh.nodes.get(t[i]).copied();
    let (a, b, c) = (p(0)?, p(1)?, p(2)?);
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    (l > 0.0 && l.is_finite()).then(|| n.map(|x| x / l))
}

fn degenerate(mesh: &Mesh, t: &[usize; 3]) -> bool {
    let area = triangle_area(mesh, t);
    !(area.is_finite() && 2.0 * area > 1e-300 && area > 1e-14 * longest_edge2(mesh, t))
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn triangle_area(mesh: &Mesh, t: &[usize; 3]) -> f64 {
    let [a, b, c] = t.map(|i| mesh.nodes[i]);
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let w = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    0.5 * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt()
}

fn longest_edge2(mesh: &Mesh, t: &[usize; 3]) -> f64 {
    let [a, b, c] = t.map(|i| mesh.nodes[i]);
    dist(a, b).max(dist(b, c)).max(dist(c, a)).powi(2)
}

/// ", did you mean \"x\"?" for the closest known name sharing a prefix or suffix, else a list.
fn suggest<'a>(name: &str, known: impl Iterator<Item = &'a String>) -> String {
    let known: Vec<&String> = known.collect();
    if known.is_empty() {
        return String::new();
    }
    let tail = name.rsplit('.').next().unwrap_or(name);
    if let Some(k) = known
        .iter()
        .find(|k| k.ends_with(tail) || k.starts_with(name))
    {
        return format!("; did you mean \"{k}\"?");
    }
    let shown: Vec<&str> = known.iter().take(8).map(|s| s.as_str()).collect();
    format!("; known: {}", shown.join(", "))
}

/// Whether a node at `x` lies on the axis through `center` along coordinate `k` (to round-off of
/// the coordinates): it then has no radial or tangential direction.
fn on_axis(x: [f64; 3], center: &[f64; 3], k: usize) -> bool {
    let (mut off, mut size) = (0.0f64, 0.0f64);
    for c in (0..3).filter(|&c| c != k) {
        off += (x[c] - center[c]).powi(2);
        size = size.max(x[c].abs()).max(center[c].abs());
    }
    off.sqrt() <= 1e-12 * size.max(1e-300)
}

impl Validator {
    /// An `etfe` material (`Material::Etfe`): the elastic constants as for `svk`, the two yield
    /// points in order and below the elastic line, the last tangent modulus below E, no
    /// residual stiffness, and a prestress below the first yield stress.
    fn etfe(&mut self, p: &str, m: &crate::scene::Membrane, values: [f64; 6]) {
        let [young, nu, s1, s2, e2, et3] = values;
        let at = |field: &str| format!("{p}.material.{field}");
        if !positive(young) {
            self.push(
                at("E"),
                format!("{young} is not a positive Young's modulus in Pa {RANGE}"),
            );
        }
        if !(nu.is_finite() && (0.0..SVK_NU_BOUND).contains(&nu)) {
            self.push(
                at("nu"),
                format!("{nu}: Poisson's ratio must be in [0, 0.5) for the ETFE membrane"),
            );
        }
        if !positive(s1) {
            self.push(
                at("yield_stress"),
                format!("{s1} is not a positive first yield stress in Pa {RANGE}"),
            );
        }
        if !(s2.is_finite() && s2 > s1) {
            self.push(
                at("second_yield_stress"),
                format!("{s2} must be a stress in Pa above yield_stress {s1}"),
            );
        }
        if positive(young) && s2.is_finite() && !(e2.is_finite() && e2 > s2 / young) {
            self.push(
                at("second_yield_strain"),
                format!(
                    "{e2} must be a total uniaxial strain beyond second_yield_stress / E = {:.6} (the curve between the yield points rises less steeply than E)",
                    s2 / young
                ),
            );
        }
        if !(et3.is_finite() && et3 >= 0.0 && (!positive(young) || et3 < young)) {
            self.push(
                at("tangent_modulus"),
                format!("{et3} must be a tangent modulus in Pa in [0, E) (beyond the second yield point)"),
            );
        }
        if m.residual_stiffness.is_some_and(|r| r != 0.0) {
            self.push(
                format!("{p}.residual_stiffness"),
                "is not offered with the etfe material (wrinkled states carry the tension-field stress only)",
            );
        }
        if let Some(pre) = &m.prestress {
            let (warp, fill, _) = pre.components();
            let s = warp.max(fill) / m.thickness;
            if positive(m.thickness) && s.is_finite() && positive(s1) && s >= s1 {
                self.push(
                    format!("{p}.prestress"),
                    format!("{s:e} Pa (the largest prestress / thickness) is not below the first yield stress {s1:e} Pa: an ETFE prestress must be elastic"),
                );
            }
        }
    }
}

impl Validator {
    /// An orthotropic group's `warp_axis`: finite, a non-zero axis, and on every triangle a
    /// radial direction at its centroid that is off the axis and not normal to the triangle.
    fn warp_axis(
        &mut self,
        p: &str,
        mesh: &Mesh,
        m: &crate::scene::Membrane,
        axis: &super::WarpAxis,
    ) {
        let at = format!("{p}.material.warp_axis");
        if axis
            .center
            .iter()
            .chain(&axis.axis)
            .any(|x| !coordinate(*x))
        {
            self.push(at, "must be finite with |x| <= 1e30 m");
            return;
        }
        let n = axis.axis.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !positive(n) {
            self.push(format!("{at}.axis"), "must be a non-zero finite vector");
            return;
        }
        let Some(ids) = group_triangles(mesh, &m.triangles) else {
            return;
        };
        for t in ids {
            let tri = mesh.triangles[t];
            let Some(normal) = unit_normal(mesh, &tri) else {
                continue;
            };
            let c = [0, 1, 2].map(|k| tri.iter().map(|&i| mesh.nodes[i][k]).sum::<f64>() / 3.0);
            let Some(w) = axis.radial(c) else {
                self.push(
                    at,
                    format!(
                        "triangle {t}'s centroid lies on the axis: no radial warp direction there"
                    ),
                );
                return;
            };
            let along = (w[0] * normal[0] + w[1] * normal[1] + w[2] * normal[2]).abs();
            if (1.0 - along * along).max(0.0).sqrt() < WARP_IN_PLANE {
                self.push(at, format!("the radial direction is (nearly) normal to triangle {t}: its projection onto the triangle gives no warp direction"));
                return;
            }
        }
    }
}

/// Whether the nodes of the triangles `ids` lie in one plane, within 1e-9 of their extent: the
/// plane of the largest triangle (a flat cushion's two sheets on top of each other).
fn coplanar(mesh: &Mesh, ids: &[usize]) -> bool {
    let p = |i: usize| {
        let [x, y, z] = mesh.nodes[i];
        [x, y, z]
    };
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let mut best = (0.0, [0.0; 3], [0.0; 3]);
    for &t in ids {
        let [a, b, c] = mesh.triangles[t].map(p);
        let n = cross(sub(b, a), sub(c, a));
        let area = dot(n, n).sqrt();
        if area > best.0 {
            best = (area, n.map(|v| v / area), a);
        }
    }
    if !(best.0 > 0.0) {
        return false;
    }
    let (lo, hi) = ids.iter().flat_map(|&t| mesh.triangles[t]).fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), i| {
            let x = p(i);
            (
                [lo[0].min(x[0]), lo[1].min(x[1]), lo[2].min(x[2])],
                [hi[0].max(x[0]), hi[1].max(x[1]), hi[2].max(x[2])],
            )
        },
    );
    let extent = dot(sub(hi, lo), sub(hi, lo)).sqrt();
    ids.iter()
        .flat_map(|&t| mesh.triangles[t])
        .all(|i| dot(best.1, sub(p(i), best.2)).abs() <= 1e-9 * extent)
}
