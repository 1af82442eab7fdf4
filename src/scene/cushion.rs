//! The cushion generator: two membrane sheets over one rim, as one closed surface.
//!
//! ```text
//! outline    rectangle [a, b], circle R, or a polygon (corners counter-clockwise about the
//!            centre, every corner seen from the centre: a star-shaped outline)
//! plan mesh  the outline's m corners (circle: m = 6, pushed onto the circle as the disc
//!            generator does); ring k (1..=n) is the outline scaled by k/n with k nodes per
//!            side: 1 + m n(n+1)/2 nodes and m n² triangles per sheet
//! sheets     top at z0 + rise_top (1 − ρ²), bottom at z0 − rise_bottom (1 − ρ²), ρ = k/n the
//!            ring parameter (a paraboloid cap on a circle); the rim (ring n) is shared
//! totals     2 + m n² nodes, 2 m n² triangles
//! normals    top counter-clockwise from +z (normal up), bottom reversed (normal down): both
//!            outward, so the generator's triangle set is a closed surface facing outward,
//!            the form the `volume` and `gas` inputs need
//! pairs      the bottom's interior node k lies under the top's interior node k (the node
//!            sets `top` and `bottom` list them in the same order): the node-to-node pairs of
//!            the `sheets` contact (`model::contact`)
//! ```
//!
//! Node sets `<name>.all`, `.rim` (counter-clockwise), `.boundary` (= rim), `.top`, `.bottom`
//! (interior nodes of each sheet, in matching order), `.top_center`, `.bottom_center`;
//! triangle sets `<name>` (both sheets), `<name>.top`, `<name>.bottom`.

use super::Outline;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Where a generator writes: the mesh's node and triangle lists and its named sets.
pub struct Target<'a> {
    pub nodes: &'a mut Vec<[f64; 3]>,
    pub triangles: &'a mut Vec<[usize; 3]>,
    pub node_sets: &'a mut BTreeMap<String, Vec<usize>>,
    pub triangle_sets: &'a mut BTreeMap<String, Vec<usize>>,
}

impl Outline {
    /// Corners per ring (m).
    pub fn sides(&self) -> usize {
        match self {
            Outline::Rectangle { .. } => 4,
            Outline::Circle { .. } => 6,
            Outline::Polygon { points } => points.len(),
        }
    }

    /// The corners relative to the centre (the circle's hexagon).
    fn corners(&self) -> Vec<[f64; 2]> {
        match self {
            Outline::Rectangle { size: [a, b] } => {
                let (a, b) = (a / 2.0, b / 2.0);
                vec![[a, -b], [a, b], [-a, b], [-a, -b]]
            }
            Outline::Circle { radius } => (0..6)
                .map(|s| {
                    let phi = PI * s as f64 / 3.0;
                    [radius * phi.cos(), radius * phi.sin()]
                })
                .collect(),
            Outline::Polygon { points } => points.clone(),
        }
    }

    /// What is wrong with the outline (field, message), if anything.
    pub fn problem(&self) -> Option<(&'static str, String)> {
        let finite = |x: f64| x.is_finite() && x.abs() <= 1e30;
        match self {
            Outline::Rectangle { size } => {
                (!size.iter().all(|&s| finite(s) && s > 0.0)).then(|| {
                    (
                        "size",
                        "both sizes must be positive lengths in m".to_string(),
                    )
                })
            }
            Outline::Circle { radius } => (!(finite(*radius) && *radius > 0.0))
                .then(|| ("radius", "must be a positive length in m".to_string())),
            Outline::Polygon { points } => {
                if points.len() < 3 {
                    return Some(("points", "needs at least 3 corners".to_string()));
                }
                if points.iter().flatten().any(|&x| !finite(x)) {
                    return Some(("points", "coordinates must be finite, |x| <= 1e30 m".into()));
                }
                let scale = points.iter().map(|p| p[0].hypot(p[1])).fold(0.0, f64::max);
                for s in 0..points.len() {
                    let (p, q) = (points[s], points[(s + 1) % points.len()]);
                    if p[0] * q[1] - p[1] * q[0] <= 1e-9 * scale * scale {
                        return Some((
                            "points",
                            format!(
                                "corners {s} and {} do not turn counter-clockwise about the centre: the outline must be star-shaped about it, corners listed counter-clockwise",
                                (s + 1) % points.len()
                            ),
                        ));
                    }
                }
                None
            }
        }
    }
}

/// Nodes and triangles of a cushion with `sides` corners and `rings` rings (saturating).
pub fn counts(sides: usize, rings: usize) -> (u64, u64) {
    let (m, n) = (sides as u64, rings as u64);
    let mn2 = m.saturating_mul(n).saturating_mul(n);
    (mn2.saturating_add(2), mn2.saturating_mul(2))
}

/// Append the cushion to `mesh` (module docs).
pub fn cushion(
    mesh: Target,
    name: &str,
    center: [f64; 3],
    outline: &Outline,
    rings: usize,
    rise: [f64; 2],
) {
    let m = outline.sides();
    let n = rings;
    let corners = outline.corners();
    let base = mesh.nodes.len();
    // Local node id of ring k's first node (k >= 1) on one sheet: 1 + m k (k − 1)/2.
    let ring_start = |k: usize| 1 + m * k * (k - 1) / 2;
    let local = |k: usize, j: usize| {
        if k == 0 {
            0
        } else {
            ring_start(k) + j % (m * k)
        }
    };
    let per_sheet = ring_start(n + 1);
    let interior = ring_start(n);
    let top = |l: usize| base + l;
    let bottom = |l: usize| {
        if l >= interior {
            base + l
        } else {
            base + per_sheet + l
        }
    };
    // Plan positions of one sheet, in local order, with their ring parameter.
    let mut plan = Vec::with_capacity(per_sheet);
    plan.push(([0.0, 0.0], 0.0));
    for k in 1..=n {
        let rho = k as f64 / n as f64;
        for j in 0..m * k {
            let (s, i) = (j / k, j % k);
            let xy = match outline {
                Outline::Circle { radius } => {
                    let phi = 2.0 * PI * j as f64 / (m * k) as f64;
                    [radius * rho * phi.cos(), radius * rho * phi.sin()]
                }
                Outline::Rectangle { .. } | Outline::Polygon { .. } => {
                    let (p, q) = (corners[s], corners[(s + 1) % m]);
                    let t = i as f64 / k as f64;
                    [
                        rho * (p[0] + t * (q[0] - p[0])),
                        rho * (p[1] + t * (q[1] - p[1])),
                    ]
                }
            };
            plan.push((xy, rho));
        }
    }
    let at = |xy: [f64; 2], z: f64| [center[0] + xy[0], center[1] + xy[1], center[2] + z];
    for &(xy, rho) in &plan {
        mesh.nodes.push(at(xy, rise[0] * (1.0 - rho * rho)));
    }
    for &(xy, rho) in &plan[..interior] {
        mesh.nodes.push(at(xy, -rise[1] * (1.0 - rho * rho)));
    }
    // The plan triangles (local ids), counter-clockwise from +z.
    let mut plan_tris = Vec::with_capacity(m * n * n);
    for k in 1..=n {
        for s in 0..m {
            for i in 0..k {
                let outer_a = local(k, s * k + i);
                let outer_b = local(k, s * k + i + 1);
                let inner_a = local(k - 1, s * (k - 1) + i);
                plan_tris.push([inner_a, outer_a, outer_b]);
                if i + 1 < k {
                    plan_tris.push([inner_a, outer_b, local(k - 1, s * (k - 1) + i + 1)]);
                }
            }
        }
    }
    let t0 = mesh.triangles.len();
    for t in &plan_tris {
        mesh.triangles.push(t.map(top));
    }
    let t1 = mesh.triangles.len();
    for t in &plan_tris {
        let [a, b, c] = t.map(bottom);
        mesh.triangles.push([a, c, b]);
    }
    let rim: Vec<usize> = (interior..per_sheet).map(top).collect();
    let sets = vec![
        ("all", (base..mesh.nodes.len()).collect()),
        ("rim", rim.clone()),
        ("boundary", rim),
        ("top", (0..interior).map(top).collect()),
        ("bottom", (0..interior).map(bottom).collect()),
        ("top_center", vec![top(0)]),
        ("bottom_center", vec![bottom(0)]),
    ];
    for (k, v) in sets {
        mesh.node_sets.insert(format!("{name}.{k}"), v);
    }
    mesh.triangle_sets
        .insert(name.to_string(), (t0..mesh.triangles.len()).collect());
    mesh.triangle_sets
        .insert(format!("{name}.top"), (t0..t1).collect());
    mesh.triangle_sets.insert(
        format!("{name}.bottom"),
        (t1..mesh.triangles.len()).collect(),
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::pressure::enclosed_volume;
    use crate::scene::generate::Mesh;
    use nalgebra::Vector3;

    fn build(outline: Outline, rings: usize, rise: [f64; 2]) -> Mesh {
        let mut mesh = Mesh::default();
        let target = Target {
            nodes: &mut mesh.nodes,
            triangles: &mut mesh.triangles,
            node_sets: &mut mesh.node_sets,
            triangle_sets: &mut mesh.triangle_sets,
        };
        cushion(target, "c", [1.0, -2.0, 0.5], &outline, rings, rise);
        mesh
    }

    fn volume(mesh: &Mesh) -> f64 {
        mesh.triangles
            .iter()
            .map(|t| enclosed_volume(&t.map(|i| Vector3::from(mesh.nodes[i]))))
            .sum()
    }

    /// Every edge is shared by exactly two triangles in opposite directions (a closed,
    /// consistently oriented surface), and the counts are the module docs'.
    fn closed(mesh: &Mesh, sides: usize, rings: usize) {
        let (n, t) = counts(sides, rings);
        assert_eq!(mesh.nodes.len() as u64, n);
        assert_eq!(mesh.triangles.len() as u64, t);
        let mut edges = std::collections::BTreeMap::new();
        for tri in &mesh.triangles {
            for k in 0..3 {
                *edges.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &c) in &edges {
            assert_eq!(c, 1, "edge {a}-{b} used {c} times in one direction");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no partner");
        }
    }

    /// A circular cushion with paraboloid caps encloses the two caps' volume, π R² (f_t +
    /// f_b)/2 (a paraboloid cap holds half its cylinder), to the inscribed mesh's error: the
    /// volume of the piecewise-linear interpolant converges as h², measured 0.6 % at 16 rings;
    /// tolerance 1 %.
    #[test]
    fn circle_caps_enclose_the_paraboloid_volume() {
        let (r, ft, fb) = (2.0, 0.3, 0.1);
        let mesh = build(Outline::Circle { radius: r }, 16, [ft, fb]);
        closed(&mesh, 6, 16);
        let exact = PI * r * r * (ft + fb) / 2.0;
        let v = volume(&mesh);
        assert!((v - exact).abs() < 1e-2 * exact, "{v} against {exact}");
        // Rim shared, pairs stacked: each bottom interior node lies under its top node.
        let (top, bottom) = (&mesh.node_sets["c.top"], &mesh.node_sets["c.bottom"]);
        assert_eq!(top.len(), bottom.len());
        for (&a, &b) in top.iter().zip(bottom) {
            let (p, q) = (mesh.nodes[a], mesh.nodes[b]);
            assert_eq!([p[0], p[1]], [q[0], q[1]]);
            assert!(p[2] > q[2]);
        }
        assert_eq!(mesh.node_sets["c.rim"].len(), 6 * 16);
        for &i in &mesh.node_sets["c.rim"] {
            let p = mesh.nodes[i];
            assert!(((p[0] - 1.0).hypot(p[1] + 2.0) - r).abs() < 1e-12);
            assert_eq!(p[2], 0.5);
        }
    }

    /// A flat rectangle's sheets coincide (zero volume); a pre-shaped one's top faces up.
    /// The plan area of the top sheet is the rectangle's exactly (its edges are straight).
    #[test]
    fn rectangle_and_polygon_are_closed_and_face_outward() {
        let flat = build(Outline::Rectangle { size: [3.0, 2.0] }, 5, [0.0, 0.0]);
        closed(&flat, 4, 5);
        assert!(volume(&flat).abs() < 1e-12);
        let shaped = build(Outline::Rectangle { size: [3.0, 2.0] }, 5, [0.2, 0.2]);
        assert!(volume(&shaped) > 0.0);
        let plan: f64 = shaped.triangle_sets["c.top"]
            .iter()
            .map(|&e| {
                let [a, b, c] = shaped.triangles[e].map(|i| shaped.nodes[i]);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            })
            .sum();
        assert!((plan - 6.0).abs() < 1e-12, "{plan}");
        let pentagon = Outline::Polygon {
            points: (0..5)
                .map(|s| {
                    let phi = 2.0 * PI * s as f64 / 5.0;
                    [phi.cos(), 0.8 * phi.sin()]
                })
                .collect(),
        };
        assert!(pentagon.problem().is_none());
        let p = build(pentagon, 4, [0.1, 0.05]);
        closed(&p, 5, 4);
        assert!(volume(&p) > 0.0);
        let clockwise = Outline::Polygon {
            points: vec![[1.0, 0.0], [0.0, -1.0], [-1.0, 0.0], [0.0, 1.0]],
        };
        assert!(clockwise.problem().unwrap().1.contains("counter-clockwise"));
    }
}
