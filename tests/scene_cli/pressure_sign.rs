//! GOAL: the sign convention of pressure that the schema and docs/scenes.md state: a positive
//! pressure pushes along n = (x2 − x1) × (x3 − x1) / |...| of each triangle as given
//! (counter-clockwise node order seen from the side it pushes to); generators emit
//! counter-clockwise triangles seen from +z.
//! MESH: the unit square, 4 x 4 cells: once generated (`rectangle`), once as explicit
//! triangles listing the generated nodes clockwise seen from +z (normal −z).
//! BOUNDARY CONDITIONS: the square's boundary clamped; pressure 10 Pa, dead and follower.
//! PARAMETERS: SVK film, E = 1e8 Pa, ν = 0.3, t = 1e-4 m.
//! REFERENCE: the sign of the centre's z displacement (+ for the generated mesh, − for the
//! clockwise one) and, by symmetry of the two problems, equal magnitudes (relative 1e-9).

use crate::common;
use common::*;
use velarium::scene::generate::resolve;

fn scene(follower: bool, explicit: bool) -> velarium::Scene {
    let generated = r#"{"generators": [{"kind": "rectangle", "name": "sheet", "origin": [0, 0, 0], "size": [1, 1], "divisions": [4, 4]}]}"#;
    let geometry = if explicit {
        let g: velarium::scene::Geometry = serde_json::from_str(generated).unwrap();
        let mesh = resolve(&g);
        let cw: Vec<[usize; 3]> = mesh.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect();
        serde_json::json!({
            "nodes": mesh.nodes,
            "triangles": cw,
            "node_sets": {"boundary": mesh.node_sets["sheet.boundary"], "center": mesh.node_sets["sheet.center"]},
            "triangle_sets": {"sheet": (0..cw.len()).collect::<Vec<_>>()}
        })
        .to_string()
    } else {
        generated.to_string()
    };
    let (boundary, center) = if explicit {
        ("boundary", "center")
    } else {
        ("sheet.boundary", "sheet.center")
    };
    let json = format!(
        r#"{{"format": 1, "name": "Sign", "geometry": {geometry},
        "membranes": [{{"name": "film", "triangles": "sheet", "thickness": 1e-4, "material": {{"kind": "svk", "E": 1e8, "nu": 0.3}}}}],
        "supports": [{{"nodes": "{boundary}", "fix": ["x", "y", "z"]}}],
        "inputs": [{{"name": "p", "load": {{"kind": "pressure", "membrane": "film", "follower": {follower}}}, "start": 10}}],
        "outputs": [{{"name": "w", "probe": {{"kind": "displacement", "node": "{center}", "component": "z"}}}}]}}"#
    );
    velarium::Scene::from_json(&json).unwrap_or_else(|e| panic!("{e}\n{json}"))
}

fn centre_deflection(follower: bool, explicit: bool) -> f64 {
    let mut e = engine(scene(follower, explicit));
    solve(&mut e);
    get(&e, "w")
}

#[test]
fn positive_pressure_pushes_along_the_counter_clockwise_normal() {
    for follower in [false, true] {
        let up = centre_deflection(follower, false);
        let down = centre_deflection(follower, true);
        assert!(up > 0.0, "follower {follower}: generated mesh, w = {up}");
        assert!(
            down < 0.0,
            "follower {follower}: clockwise mesh, w = {down}"
        );
        assert!(rel(up, -down) < 1e-9, "follower {follower}: {up} vs {down}");
    }
}
