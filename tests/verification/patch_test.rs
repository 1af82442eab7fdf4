//! GOAL: constant-strain patch test at finite strain: a distorted mesh stretched uniaxially
//!       reproduces the homogeneous solution exactly (to round-off) at every node.
//! MESH: explicit 4 x 3 grid of a 2 m x 1 m sheet, interior nodes moved off the grid, so no
//!       element is a right triangle and element sizes differ.
//! BOUNDARY CONDITIONS: left edge x = 0 held in x, its lowest node also in y; every node held in
//!       z (an in-plane problem); right edge prescribed u_x = δ.
//! PARAMETERS: E = 1 MPa, ν = 0.3, t = 1 mm, δ = 0.2 m (stretch λ1 = 1.1).
//! REFERENCE: homogeneous uniaxial SVK plane stress: E11 = (λ1² − 1)/2, S22 = 0 ⇒
//!            E22 = −ν E11, λ2 = sqrt(1 + 2 E22); S11 = E E11; edge force = λ1 S11 t H
//!            (first Piola-Kirchhoff times reference area). Tolerance 1e-9 relative.

use crate::common;
use common::*;
use velarium::scene::*;

fn distorted_scene() -> Scene {
    let (nx, ny) = (4usize, 3usize);
    let mut nodes = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let (mut x, mut y) = (2.0 * i as f64 / nx as f64, j as f64 / ny as f64);
            if i > 0 && i < nx && j > 0 && j < ny {
                x += 0.11 * ((i * 7 + j * 3) % 5) as f64 / 5.0 - 0.05;
                y += 0.09 * ((i * 3 + j * 5) % 4) as f64 / 4.0 - 0.04;
            }
            nodes.push([x, y, 0.0]);
        }
    }
    let id = |i: usize, j: usize| j * (nx + 1) + i;
    let mut triangles = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let scene = format!(
        r#"{{
        "format": 1, "name": "Patch",
        "geometry": {{"nodes": {nodes:?}, "triangles": {triangles:?},
            "node_sets": {{"left": {left:?}, "right": {right:?}, "pin": [0], "all": {all:?}}},
            "triangle_sets": {{"sheet": {tris:?}}}}},
        "membranes": [{{"name": "sheet", "triangles": "sheet", "thickness": 1e-3, "material": {{"kind": "svk", "E": 1e6, "nu": 0.3}}}}],
        "supports": [{{"nodes": "left", "fix": ["x"]}}, {{"nodes": "pin", "fix": ["y"]}}, {{"nodes": "all", "fix": ["z"]}}],
        "inputs": [{{"name": "stretch", "load": {{"kind": "displacement", "nodes": "right", "component": "x"}}, "start": 0}}],
        "outputs": [{{"name": "force", "probe": {{"kind": "reaction", "nodes": "right", "component": "x"}}}}]
        }}"#,
        left = (0..=ny).map(|j| id(0, j)).collect::<Vec<_>>(),
        right = (0..=ny).map(|j| id(nx, j)).collect::<Vec<_>>(),
        all = (0..nodes.len()).collect::<Vec<_>>(),
        tris = (0..triangles.len()).collect::<Vec<_>>(),
    );
    Scene::from_json(&scene).unwrap()
}

#[test]
fn uniaxial_stretch_is_exact_on_a_distorted_mesh() {
    let scene = distorted_scene();
    let reference: Vec<[f64; 3]> = scene.geometry.nodes.clone();
    let mut e = engine(scene);
    solve(&mut e);
    set(&mut e, "stretch", 0.2);
    solve(&mut e);
    let (young, nu, t, h) = (1e6, 0.3, 1e-3, 1.0);
    let l1 = 1.1f64;
    let e11 = 0.5 * (l1 * l1 - 1.0);
    let l2 = (1.0 - 2.0 * nu * e11).sqrt();
    let u = &e.state().displacement;
    for (n, x) in reference.iter().enumerate() {
        let (ux, uy) = ((l1 - 1.0) * x[0], (l2 - 1.0) * x[1]);
        assert!(
            (u[3 * n] - ux).abs() < 1e-9 * 0.2,
            "node {n} u_x {} vs {ux}",
            u[3 * n]
        );
        assert!(
            (u[3 * n + 1] - uy).abs() < 1e-9 * 0.2,
            "node {n} u_y {} vs {uy}",
            u[3 * n + 1]
        );
    }
    let force = l1 * young * e11 * t * h;
    assert!(
        rel(get(&e, "force"), force) < 1e-9,
        "edge force {} vs {force}",
        get(&e, "force")
    );
}
