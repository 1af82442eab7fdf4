//! Node renumbering for locality (issue 15 item 2, `solver::renumber`, `solver.node_order`).
//!
//! GOAL: (1) the internal node order is a property of the mesh, not of its numbering: the same
//!       disc given with shuffled node and triangle ids gets the same tangent factor (equal
//!       stored entries) and the same answers, mapped to each numbering: every output, the
//!       displacement of every node (the `u` displacement-field array as an FMU reads it), the
//!       stresses and wrinkle states of every triangle (array outputs), and the VTK file's point
//!       and cell data; (2) renumbering changes nothing but round-off: the same scene solved
//!       with `node_order: "given"` (the scene's own numbering, the code path before
//!       renumbering) and with each internal order agrees on every array output and on the VTK
//!       document's numbers (ZonedCushion: cables, zones, supports; HenckyDisc); (3) messages
//!       name the scene's node ids whatever the internal order (the mechanism diagnosis);
//!       (4) the default order fills the factor no more than the generator's own ring order;
//!       (5) on a sensitive path (the scaling benchmark's square with edge cables: wrinkling,
//!       frozen chattering states, nodal relaxation) a shuffled numbering gives the generator's
//!       answers in every place they leave the engine: outputs, the load history CSV, the
//!       per-element CSV, FMU arrays and VTK point and cell data, on the same Newton path
//!       (nodal relaxation sweeps its nodes in an order of the geometry, not of the numbering),
//!       so to round-off.
//! MESH: HenckyDisc at 12 rings (469 nodes, 864 triangles) and 34 rings (fill only), the same
//!       mesh written explicitly with node and triangle ids permuted by a fixed-seed xorshift
//!       generator; the shipped ZonedCushion (8 x 8 cells, edge cables); the 4 m square at 57 x 57
//!       cells (3364 nodes, 6498 triangles, 4 x 57 cable segments) and its shuffle.
//! BOUNDARY CONDITIONS: rim clamped (disc); the cushion's own; the square held at its four
//!                     corners.
//! PARAMETERS: follower pressure 40 Pa on the disc (docs/mechanics.md §4a); the cushion's
//!             pressure zones at their start values, then wind 200 / 80 Pa; the square: 1 mm
//!             SVK film E 600 MPa, nu 0.3, edge cables EA 2e6 N pretensioned to 2 kN, follower
//!             pressure 150 then 300 Pa (a load table run as `velarium solve` runs it).
//! REFERENCE: exact identities (the same equilibrium); only the order of floating-point sums
//!            differs, so the tolerance is round-off: 1e-11 of the largest value of each field
//!            (measured, printed by each test: shuffled vs generated disc, displacements 1.1e-14,
//!            principal stresses 1.2e-12 (array output and VTK cell data alike), centre
//!            deflection 1.1e-15, rim reaction 1.7e-14; internal orders vs given, worst field or
//!            VTK number 1.1e-12 on the disc, 3.3e-13 on the cushion; shuffled vs generated
//!            square, on the same Newton path (26 and 7 iterations in both numberings):
//!            scalar outputs 1.0e-13, displacements 1.6e-14, stresses 3.2e-13, per-element
//!            CSV 4.0e-13, VTK cable tensions 4.8e-12; the tension direction (a line: its sign
//!            is free) as its angle times the principal-stress gap over the largest stress,
//!            because an eigenvector is only as well defined as that gap; at the flat start
//!            both stresses are round-off and the direction is arbitrary). Integer outputs
//!            (iterations, wrinkle states) exactly equal. The square needs nodal relaxation,
//!            whose Gauss-Seidel sweep runs in an order of the mesh's geometry
//!            (`Pattern::sweep_order`); while it swept in the user's numbering the two paths
//!            parted at the first relaxation (27 / 6 against 26 / 7 iterations) and this test
//!            needed 1e-7.
//!            Factor fill (deterministic): the default order's stored entries at most 1.02x the
//!            generator's order at 34 rings (measured 0.971: 896 148 against 923 382).

use crate::common;
use common::*;
use serde_json::{json, Value};
use velarium::scene::generate::resolve;
use velarium::scene::NodeOrder;
use velarium::{Engine, Scene};

const Q: f64 = 40.0;
/// Round-off tolerance relative to a field's largest magnitude.
const ROUND_OFF: f64 = 1e-11;

/// A fixed-seed permutation of 0..n (Fisher-Yates on xorshift64*): old id -> new id.
fn permutation(n: usize, seed: u64) -> Vec<usize> {
    let mut p: Vec<usize> = (0..n).collect();
    let mut s = seed;
    for i in (1..n).rev() {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        let r = s.wrapping_mul(0x2545_F491_4F6C_DD1D);
        p.swap(i, (r % (i as u64 + 1)) as usize);
    }
    p
}

/// The shipped disc at `rings` rings with array outputs of every node's displacement and every
/// triangle's stresses and wrinkle state.
fn disc(rings: usize) -> Value {
    let mut v: Value =
        serde_json::from_str(&std::fs::read_to_string(shipped("HenckyDisc")).unwrap()).unwrap();
    v["geometry"]["generators"][0]["rings"] = json!(rings);
    let outputs = v["outputs"].as_array_mut().unwrap();
    outputs.push(json!({"name": "u", "probe": {"kind": "displacement_field"}}));
    outputs.push(
        json!({"name": "stress", "probe": {"kind": "principal_stresses", "membrane": "film"}}),
    );
    outputs
        .push(json!({"name": "wrinkle", "probe": {"kind": "wrinkle_states", "membrane": "film"}}));
    v
}

/// The same disc as explicit nodes and triangles, node ids permuted by `node_perm` and
/// triangles by `tri_perm` (old -> new), node sets `disc.rim` and `disc.center` carried over.
fn shuffled(generated: &Value, node_perm: &[usize], tri_perm: &[usize]) -> Value {
    let scene: Scene = Scene::from_json(&generated.to_string()).unwrap();
    let mesh = resolve(&scene.geometry);
    let mut nodes = vec![[0.0; 3]; mesh.nodes.len()];
    for (old, x) in mesh.nodes.iter().enumerate() {
        nodes[node_perm[old]] = *x;
    }
    let mut triangles = vec![[0usize; 3]; mesh.triangles.len()];
    for (old, t) in mesh.triangles.iter().enumerate() {
        triangles[tri_perm[old]] = t.map(|i| node_perm[i]);
    }
    let set =
        |name: &str| -> Vec<usize> { mesh.node_sets[name].iter().map(|&i| node_perm[i]).collect() };
    let mut v = generated.clone();
    v["geometry"] = json!({
        "nodes": nodes,
        "triangles": triangles,
        "node_sets": {"disc.rim": set("disc.rim"), "disc.center": set("disc.center")},
        "triangle_sets": {"disc": (0..triangles.len()).collect::<Vec<_>>()},
    });
    v
}

fn with_order(mut v: Value, order: &str) -> Scene {
    v["solver"]["node_order"] = json!(order);
    Scene::from_json(&v.to_string()).unwrap_or_else(|p| panic!("{p}"))
}

fn array(e: &Engine, name: &str) -> Vec<f64> {
    let var = e.arrays().iter().find(|v| v.name == name).unwrap();
    e.values(var).to_vec()
}

/// Largest difference relative to the largest magnitude of `a`.
fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = a
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()))
        .max(f64::MIN_POSITIVE);
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// The numbers of every `DataArray` named `name` in a VTK document.
fn vtk_array(doc: &str, name: &str) -> Vec<f64> {
    let tag = format!("Name=\"{name}\"");
    let start = doc
        .find(&tag)
        .unwrap_or_else(|| panic!("no {name} in the VTK file"));
    let body = &doc[start..];
    let body = &body[body.find('>').unwrap() + 1..body.find("</DataArray>").unwrap()];
    body.split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect()
}

fn solved(scene: Scene) -> Engine {
    let mut e = engine(scene);
    set(&mut e, "pressure", Q);
    solve(&mut e);
    e
}

#[test]
fn a_shuffled_disc_gives_the_generated_answers_in_its_own_numbering() {
    let generated = disc(12);
    let n = resolve(&Scene::from_json(&generated.to_string()).unwrap().geometry)
        .nodes
        .len();
    let e0 = engine(with_order(generated.clone(), "rings"));
    let nt = e0.model().triangles.len();
    let (node_perm, tri_perm) = (permutation(n, 0x9E37_79B9_7F4A_7C15), permutation(nt, 7));
    let shuffled = shuffled(&generated, &node_perm, &tri_perm);
    drop(e0);
    let a = solved(with_order(generated, "rings"));
    let b = solved(with_order(shuffled, "rings"));
    // The internal order is the mesh's: the same factor.
    assert_eq!(a.factor_nonzeros(), b.factor_nonzeros());
    for name in ["center_uz", "rim_reaction_z"] {
        let (x, y) = (get(&a, name), get(&b, name));
        println!("{name}: {x:e} vs {y:e}, relative {:.1e}", rel(y, x));
        assert!(rel(y, x) <= ROUND_OFF, "{name}: {x} vs {y}");
    }
    assert_eq!(get(&a, "newton_iterations"), get(&b, "newton_iterations"));
    // Every node's displacement (the displacement-field array), mapped to the generator's ids.
    let (ua, ub) = (array(&a, "u"), array(&b, "u"));
    let ub_mapped: Vec<f64> = (0..3 * n)
        .map(|d| ub[3 * node_perm[d / 3] + d % 3])
        .collect();
    let du = rel_diff(&ua, &ub_mapped);
    assert_eq!(ua, a.state().displacement[..3 * n].to_vec());
    // Every triangle's principal stresses and wrinkle state.
    let (sa, sb) = (array(&a, "stress"), array(&b, "stress"));
    let sb_mapped: Vec<f64> = (0..2 * nt)
        .map(|k| sb[2 * tri_perm[k / 2] + k % 2])
        .collect();
    let ds = rel_diff(&sa, &sb_mapped);
    let (wa, wb) = (array(&a, "wrinkle"), array(&b, "wrinkle"));
    let wb_mapped: Vec<f64> = (0..nt).map(|k| wb[tri_perm[k]]).collect();
    assert_eq!(wa, wb_mapped, "wrinkle states");
    // The VTK file: point displacements and cell stresses, each in its own numbering.
    let (va, vb) = (
        velarium::vtk::unstructured_grid(&a),
        velarium::vtk::unstructured_grid(&b),
    );
    let (pa, pb) = (
        vtk_array(&va, "displacement_m"),
        vtk_array(&vb, "displacement_m"),
    );
    let pb_mapped: Vec<f64> = (0..3 * n)
        .map(|d| pb[3 * node_perm[d / 3] + d % 3])
        .collect();
    let dv = rel_diff(&pa, &pb_mapped);
    let (ca, cb) = (
        vtk_array(&va, "sigma_max_Pa"),
        vtk_array(&vb, "sigma_max_Pa"),
    );
    let cb_mapped: Vec<f64> = (0..nt).map(|k| cb[tri_perm[k]]).collect();
    let dc = rel_diff(&ca, &cb_mapped);
    println!(
        "shuffled vs generated ({n} nodes, {nt} triangles): u {du:.1e}, stress {ds:.1e}, VTK displacement {dv:.1e}, VTK sigma_max {dc:.1e}"
    );
    for (what, d) in [
        ("u", du),
        ("stress", ds),
        ("VTK displacement", dv),
        ("VTK sigma_max", dc),
    ] {
        assert!(d <= ROUND_OFF, "{what}: {d:e}");
    }
    // A generated number is in the file in the user's numbering: the centre node's
    // deflection sits at its own id in each.
    let centre_a = a
        .model()
        .reference
        .iter()
        .position(|x| x.norm() < 1e-12)
        .unwrap();
    let centre_b = b
        .model()
        .reference
        .iter()
        .position(|x| x.norm() < 1e-12)
        .unwrap();
    assert_eq!(centre_b, node_perm[centre_a]);
    assert_eq!(pa[3 * centre_a + 2], get(&a, "center_uz"));
    assert_eq!(pb[3 * centre_b + 2], get(&b, "center_uz"));
}

/// Every internal order against the scene's own numbering on one scene: every array output
/// and every number of the VTK document within round-off, integer outputs exactly.
fn orders_agree(scene: Value, drive: impl Fn(&mut Engine), label: &str) {
    let run = |order: &str| {
        let mut e = engine(with_order(scene.clone(), order));
        drive(&mut e);
        e
    };
    let given = run("given");
    let doc_given = velarium::vtk::unstructured_grid(&given);
    for order in ["rings", "rcm", "hilbert"] {
        let e = run(order);
        let mut worst = 0.0f64;
        for var in given.arrays() {
            let (x, y) = (array(&given, &var.name), array(&e, &var.name));
            if var.var_type == velarium::variables::VarType::Real {
                let d = rel_diff(&x, &y);
                worst = worst.max(d);
                assert!(
                    d <= ROUND_OFF,
                    "{label} {order}: {} differs by {d:e}",
                    var.name
                );
            } else {
                assert_eq!(x, y, "{label} {order}: {}", var.name);
            }
        }
        let doc = velarium::vtk::unstructured_grid(&e);
        let numbers = |d: &str| -> Vec<f64> {
            d.split(|c: char| c.is_whitespace() || c == '>' || c == '<')
                .filter_map(|s| s.parse::<f64>().ok())
                .collect()
        };
        let d = rel_diff(&numbers(&doc_given), &numbers(&doc));
        worst = worst.max(d);
        assert!(
            d <= ROUND_OFF,
            "{label} {order}: VTK numbers differ by {d:e}"
        );
        println!(
            "{label}: {order} vs given: worst relative difference {worst:.1e}; factor nnz {} vs {}",
            e.factor_nonzeros(),
            given.factor_nonzeros()
        );
    }
}

#[test]
fn every_order_gives_the_given_numberings_answers_on_the_zoned_cushion() {
    let path = format!(
        "{}/modelDescription/ZonedCushion/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let scene: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    orders_agree(
        scene,
        |e| {
            solve(e);
            set(e, "wind[1]", 200.0);
            set(e, "wind[2]", 80.0);
            solve(e);
        },
        "ZonedCushion",
    );
}

#[test]
fn every_order_gives_the_given_numberings_answers_on_the_disc() {
    orders_agree(
        disc(12),
        |e| {
            set(e, "pressure", Q);
            solve(e);
        },
        "HenckyDisc",
    );
}

/// The floating patch of hard case l6 (tests/solver/hard_cases.rs), numbered patch first: whatever
/// the internal order, the failure names the patch's own ids 0, 1, 2, 3.
#[test]
fn a_mechanism_is_named_by_the_scenes_node_ids_in_every_order() {
    let mut nodes: Vec<[f64; 3]> = vec![
        [0.0, 1.0, 0.0],
        [0.2, 1.0, 0.0],
        [0.2, 1.2, 0.0],
        [0.0, 1.2, 0.0],
    ];
    nodes.extend((0..12).map(|k| [k as f64 * 0.1, 0.0, 0.0]));
    let base = json!({
        "format": 1, "name": "Floating",
        "geometry": {"nodes": nodes, "triangles": [[0, 1, 2], [0, 2, 3]],
                     "node_sets": {"ends": [4, 15], "corner": [2]}},
        "membranes": [{"name": "patch", "triangles": [0, 1], "thickness": 1e-4,
                       "material": {"kind": "svk", "E": 2e8, "nu": 0.3}}],
        "cables": [{"name": "c", "nodes": (4..16).collect::<Vec<_>>(), "EA": 1e4, "pretension": 10.0}],
        "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": "corner", "direction": [1.0, 0.0, 0.0]}}]
    });
    let mut messages = Vec::new();
    for order in ["given", "rings", "rcm", "hilbert"] {
        let message = match Engine::try_new(with_order(base.clone(), order)) {
            Err(err) => err.to_string(),
            Ok(mut e) => {
                set(&mut e, "F", 1.0);
                let report = e.solve();
                assert!(
                    !report.converged(),
                    "{order}: a floating patch has no equilibrium"
                );
                report.message
            }
        };
        let tokens: Vec<&str> = message
            .split(|c: char| !c.is_ascii_digit())
            .filter(|s| !s.is_empty())
            .collect();
        for id in ["0", "1", "2", "3"] {
            assert!(
                tokens.contains(&id),
                "{order}: must name node {id}: {message}"
            );
        }
        assert!(message.contains("mechanism"), "{order}: {message}");
        // The diagnosis (after the iteration's last residual, which differs by order).
        let diagnosis = message[message.find("the structure is").unwrap()..].to_string();
        messages.push(diagnosis);
    }
    println!("{}", messages[1]);
    assert!(messages.iter().all(|m| m == &messages[0]), "{messages:#?}");
}

/// Fill: the default order on the shuffled disc against the generator's ring order as given.
#[test]
fn the_default_order_fills_no_more_than_the_generators_order() {
    let generated = disc(34);
    let n = resolve(&Scene::from_json(&generated.to_string()).unwrap().geometry)
        .nodes
        .len();
    let nt = engine(with_order(generated.clone(), "given"))
        .model()
        .triangles
        .len();
    let shuffled = shuffled(&generated, &permutation(n, 3), &permutation(nt, 5));
    let fill = |v: &Value, order: &str| engine(with_order(v.clone(), order)).factor_nonzeros();
    let reference = fill(&generated, "given");
    let shuffled_given = fill(&shuffled, "given");
    let shuffled_rings = fill(&shuffled, "rings");
    let generated_rings = fill(&generated, "rings");
    println!(
        "factor nnz at 34 rings: generated/given {reference}, shuffled/given {shuffled_given}, generated/rings {generated_rings}, shuffled/rings {shuffled_rings} ({:.3}x)",
        shuffled_rings as f64 / reference as f64
    );
    assert_eq!(shuffled_rings, generated_rings);
    assert!(
        (shuffled_rings as f64) <= 1.02 * reference as f64,
        "{shuffled_rings} vs {reference}"
    );
    // The default is `rings`.
    assert_eq!(
        velarium::scene::SolverSettings::default().node_order,
        NodeOrder::Rings
    );
}

/// The scaling benchmark's square (examples/scale.rs, docs/performance.md): 4 m x 4 m, 1 mm
/// SVK film (E 600 MPa, nu 0.3) with four pretensioned edge cables, held at its corners,
/// follower pressure `wind`; `n` x `n` cells. Array outputs of every node's displacement and
/// every triangle's stresses and wrinkle state; the corner's reaction and one cable's tension.
fn square(n: usize) -> Value {
    let cables = ["bottom", "right", "top", "left"].map(|side| {
        json!({"name": format!("edge_{side}"), "nodes": format!("sheet.edge_{side}"), "EA": 2e6,
               "pretension": 2000})
    });
    let supports = ["bl", "br", "tl", "tr"]
        .map(|c| json!({"nodes": format!("sheet.corner_{c}"), "fix": ["x", "y", "z"]}));
    json!({"format": 1, "name": "ScaleSquare",
      "geometry": {"generators": [{"kind": "rectangle", "name": "sheet", "origin": [0, 0, 0],
                                   "size": [4.0, 4.0], "divisions": [n, n]}]},
      "membranes": [{"name": "fabric", "triangles": "sheet", "thickness": 1e-3,
                     "material": {"kind": "svk", "E": 6e8, "nu": 0.3}}],
      "cables": cables,
      "supports": supports,
      "inputs": [{"name": "wind", "load": {"kind": "pressure", "membrane": "fabric", "follower": true},
                  "start": 0, "min": -1000, "max": 300}],
      "outputs": [
        {"name": "center_uz", "probe": {"kind": "displacement", "node": "sheet.center", "component": "z"}},
        {"name": "corner_reaction_z", "probe": {"kind": "reaction", "nodes": "sheet.corner_bl", "component": "z"}},
        {"name": "bottom_tension", "probe": {"kind": "cable_tension", "cable": "edge_bottom"}},
        {"name": "newton_iterations", "probe": {"kind": "newton_iterations"}},
        {"name": "u", "probe": {"kind": "displacement_field"}},
        {"name": "stress", "probe": {"kind": "principal_stresses", "membrane": "fabric"}},
        {"name": "wrinkle", "probe": {"kind": "wrinkle_states", "membrane": "fabric"}}],
      // The same path for both numberings: the coarse start applies to generated meshes
      // only (docs/solver.md), so it is off for the generated one too.
      "solver": {"coarse_start": "off"}})
}

/// `scene`'s mesh written explicitly with node ids permuted by `node_perm` and triangles by
/// `tri_perm` (old -> new), every node set (in its order: a cable's nodes run along it) and
/// triangle set carried over under its name.
fn shuffled_explicit(scene: &Value, node_perm: &[usize], tri_perm: &[usize]) -> Value {
    let mesh = resolve(&Scene::from_json(&scene.to_string()).unwrap().geometry);
    let mut nodes = vec![[0.0; 3]; mesh.nodes.len()];
    for (old, x) in mesh.nodes.iter().enumerate() {
        nodes[node_perm[old]] = *x;
    }
    let mut triangles = vec![[0usize; 3]; mesh.triangles.len()];
    for (old, t) in mesh.triangles.iter().enumerate() {
        triangles[tri_perm[old]] = t.map(|i| node_perm[i]);
    }
    let node_sets: serde_json::Map<String, Value> = mesh
        .node_sets
        .iter()
        .map(|(name, set)| {
            (
                name.clone(),
                json!(set.iter().map(|&i| node_perm[i]).collect::<Vec<_>>()),
            )
        })
        .collect();
    let triangle_sets: serde_json::Map<String, Value> = mesh
        .triangle_sets
        .iter()
        .map(|(name, set)| {
            // In ascending new ids (as a mesher would list them): an array output over a
            // membrane then runs in the shuffled triangle order.
            let mut ids: Vec<usize> = set.iter().map(|&e| tri_perm[e]).collect();
            ids.sort_unstable();
            (name.clone(), json!(ids))
        })
        .collect();
    let mut v = scene.clone();
    v["geometry"] = json!({"nodes": nodes, "triangles": triangles,
                           "node_sets": node_sets, "triangle_sets": triangle_sets});
    v
}

/// The per-element CSV (`velarium solve --elements`) as (triangle id, state, numbers) rows.
fn element_rows(csv: &str) -> Vec<(usize, u8, Vec<f64>)> {
    csv.lines()
        .skip(1)
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            let numbers = f[3..].iter().map(|s| s.parse().unwrap()).collect();
            (f[1].parse().unwrap(), f[2].parse().unwrap(), numbers)
        })
        .collect()
}

/// A sensitive path: the square with edge cables wrinkles, its wrinkle states chatter and are
/// frozen, and nodal relaxation (Gauss-Seidel and Newton over the nodes that carry the
/// residual) rescues stalled iterations, so any difference in the order of a sweep or a sum can
/// grow into a different Newton path. The same mesh in a shuffled numbering must give the
/// generator's answers in every place they leave the engine in the user's numbering: the
/// outputs, the load history's CSV (`velarium solve --out`), the per-element CSV
/// (`--elements`), the FMU arrays and the VTK file, with the same wrinkle state in every
/// triangle and the same Newton iterations in every load row. The triangles are visited by
/// their internal nodes and relaxation sweeps in an order of the mesh's geometry, so both
/// numberings take the same path (26 and 7 iterations, measured) and differ by round-off.
/// TOLERANCE: round-off, 1e-11 of each field's largest value (measured at most 4.8e-12, the
/// VTK cable tensions; 1.0e-13 the outputs). A wrong mapping of ids would show as O(1), a
/// different path as about 1e-8 (measured when the sweep ran in the user's numbering).
#[test]
fn a_shuffled_square_with_edge_cables_gives_the_generators_answers_everywhere() {
    let generated = square(57);
    let mesh = resolve(&Scene::from_json(&generated.to_string()).unwrap().geometry);
    let (n, nt) = (mesh.nodes.len(), mesh.triangles.len());
    let (node_perm, tri_perm) = (permutation(n, 0x9E37_79B9_7F4A_7C15), permutation(nt, 11));
    let shuffled = shuffled_explicit(&generated, &node_perm, &tri_perm);
    let loads = "time,wind\n0,0\n1,150\n2,300\n";
    let run = |v: &Value| {
        let mut e = engine(with_order(v.clone(), "rings"));
        let table = velarium::history::LoadTable::parse(loads, "loads.csv", &mut e).unwrap();
        let history = velarium::history::run_with(&mut e, &table, true).unwrap();
        assert!(history.failure.is_none(), "{:?}", history.failure);
        (e, history)
    };
    let (a, ha) = run(&generated);
    let (b, hb) = run(&shuffled);
    assert_eq!(a.factor_nonzeros(), b.factor_nonzeros());
    // The load history's CSV (one row per load row: time, then the outputs; the array
    // outputs' elements, each in its own numbering, are compared below).
    assert_eq!(ha.header, hb.header);
    let column = |name: &str| ha.header.iter().position(|h| h == name).unwrap();
    let it = column("newton_iterations");
    let scalars = [
        "time",
        "center_uz",
        "corner_reaction_z",
        "bottom_tension",
        "newton_iterations",
    ]
    .map(column);
    let mut worst = 0.0f64;
    assert_eq!(ha.rows.len(), 3);
    for (ra, rb) in ha.rows.iter().zip(&hb.rows) {
        for &k in &scalars {
            let (x, y) = (ra[k], rb[k]);
            let d = if x == y { 0.0 } else { rel(y, x) };
            println!(
                "t = {}: {} {x:e} vs {y:e}, relative {d:.1e}",
                ra[0], ha.header[k]
            );
            worst = worst.max(d);
            assert!(d <= ROUND_OFF, "{}: {x} vs {y}", ha.header[k]);
        }
    }
    // From the flat start to 150 Pa: the path with wrinkling, freezing and relaxation.
    assert!(
        ha.rows[1][it] >= 10.0,
        "a path that needs its relaxation: {:?}",
        ha.rows.iter().map(|r| r[it]).collect::<Vec<_>>()
    );
    // The per-element CSV: each triangle under its own id, every number to round-off.
    let (ea, eb) = (element_rows(&ha.elements), element_rows(&hb.elements));
    assert_eq!(ea.len(), 3 * nt);
    let row_of_b: std::collections::HashMap<(usize, usize), usize> = eb
        .iter()
        .enumerate()
        .map(|(k, r)| ((k / nt, r.0), k))
        .collect();
    let scale = ea
        .iter()
        .flat_map(|r| r.2[6..8].iter())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let mut worst_csv = 0.0f64;
    for (k, (id, state, xa)) in ea.iter().enumerate() {
        let (_, state_b, xb) = &eb[row_of_b[&(k / nt, tri_perm[*id])]];
        assert_eq!(state, state_b, "triangle {id}");
        // The tension direction is a line, not an arrow (its sign is the eigenvector's, which
        // round-off may flip), and an eigenvector's perturbation is the matrix's over the gap
        // between its eigenvalues (undefined at t = 0, where both stresses are round-off,
        // 1e-6 Pa against 5 MPa): the angle times the gap, against the largest stress.
        let gap = (xa[6] - xa[7]).abs() / scale;
        let along = |sign: f64| (0..3).fold(0.0f64, |m, c| m.max((xa[c] - sign * xb[c]).abs()));
        worst_csv = worst_csv.max(along(1.0).min(along(-1.0)) * gap);
        // Centroids and vertices (O(1) m) against 1, stresses against the largest stress.
        for c in 3..xa.len() {
            let s = if c == 6 || c == 7 { scale } else { 1.0 };
            worst_csv = worst_csv.max((xa[c] - xb[c]).abs() / s);
        }
    }
    // The FMU arrays, mapped to the generator's ids.
    let (ua, ub) = (array(&a, "u"), array(&b, "u"));
    let ub_mapped: Vec<f64> = (0..3 * n)
        .map(|d| ub[3 * node_perm[d / 3] + d % 3])
        .collect();
    let du = rel_diff(&ua, &ub_mapped);
    let (sa, sb) = (array(&a, "stress"), array(&b, "stress"));
    let sb_mapped: Vec<f64> = (0..2 * nt)
        .map(|k| sb[2 * tri_perm[k / 2] + k % 2])
        .collect();
    let ds = rel_diff(&sa, &sb_mapped);
    let (wa, wb) = (array(&a, "wrinkle"), array(&b, "wrinkle"));
    let wb_mapped: Vec<f64> = (0..nt).map(|k| wb[tri_perm[k]]).collect();
    assert_eq!(wa, wb_mapped, "wrinkle states");
    // The VTK file's point displacements and cell stresses.
    let (va, vb) = (
        velarium::vtk::unstructured_grid(&a),
        velarium::vtk::unstructured_grid(&b),
    );
    let (pa, pb) = (
        vtk_array(&va, "displacement_m"),
        vtk_array(&vb, "displacement_m"),
    );
    let pb_mapped: Vec<f64> = (0..3 * n)
        .map(|d| pb[3 * node_perm[d / 3] + d % 3])
        .collect();
    let dv = rel_diff(&pa, &pb_mapped);
    // Cells: the triangles (each under its own id), then the cable segments (the same order
    // in both: a cable runs along its node set).
    let (ca, cb) = (
        vtk_array(&va, "sigma_max_Pa"),
        vtk_array(&vb, "sigma_max_Pa"),
    );
    let cb_mapped: Vec<f64> = (0..nt).map(|k| cb[tri_perm[k]]).collect();
    let dc = rel_diff(&ca[..nt], &cb_mapped);
    let (ta, tb) = (
        vtk_array(&va, "cable_tension_N"),
        vtk_array(&vb, "cable_tension_N"),
    );
    assert_eq!(ta.len(), nt + 4 * 57);
    let dt = rel_diff(&ta[nt..], &tb[nt..]);
    println!(
        "shuffled vs generated square ({n} nodes, {nt} triangles, iterations {:?}): outputs {worst:.1e}, element CSV {worst_csv:.1e}, u {du:.1e}, stress {ds:.1e}, VTK displacement {dv:.1e}, VTK sigma_max {dc:.1e}, VTK cable_tension {dt:.1e}",
        ha.rows.iter().map(|r| r[it]).collect::<Vec<_>>()
    );
    for (what, d) in [
        ("element CSV", worst_csv),
        ("u", du),
        ("stress", ds),
        ("VTK displacement", dv),
        ("VTK sigma_max", dc),
        ("VTK cable_tension", dt),
    ] {
        assert!(d <= ROUND_OFF, "{what}: {d:e}");
    }
}
