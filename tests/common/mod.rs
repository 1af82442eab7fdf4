//! Helpers shared by the verification tests: drive an Engine by variable names.
#![allow(dead_code)]

use nalgebra::Vector3;
use velarium::variables::VarType;
use velarium::{Engine, Scene};

/// Path of a shipped scene.
pub fn shipped(name: &str) -> String {
    format!(
        "{}/modelDescription/{name}/scene.json",
        env!("CARGO_MANIFEST_DIR")
    )
}

pub fn read_scene(path: &str) -> Scene {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    Scene::from_json(&text).unwrap_or_else(|p| panic!("{path}: {p}"))
}

pub fn engine(scene: Scene) -> Engine {
    Engine::try_new(scene).unwrap_or_else(|e| panic!("{e}"))
}

pub fn vr(engine: &Engine, name: &str) -> u32 {
    engine
        .variables()
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}

pub fn set(engine: &mut Engine, name: &str, value: f64) {
    let r = vr(engine, name);
    engine.set_real(r, value).unwrap();
}

pub fn get(engine: &Engine, name: &str) -> f64 {
    let v = engine.variables().iter().find(|v| v.name == name).unwrap();
    match v.var_type {
        VarType::Real => engine.get_real(v.value_reference).unwrap(),
        VarType::Integer | VarType::UInt8 => engine.get_integer(v.value_reference).unwrap() as f64,
    }
}

/// Solve and insist on convergence.
pub fn solve(engine: &mut Engine) -> velarium::solver::StepReport {
    let report = engine.solve();
    assert!(
        report.converged(),
        "did not converge: {}\n{}",
        report.message,
        report.log.join("\n")
    );
    report
}

pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Small deterministic generator (no rand dependency): xorshift64*.
pub struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545F4914F6CDD1D) >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
    pub fn vec3(&mut self, scale: f64) -> Vector3<f64> {
        Vector3::new(self.next(), self.next(), self.next()) * scale
    }
}

/// Replace every SVK membrane material of `scene` by the orthotropic law with equal warp and
/// fill moduli (E_warp = E_fill = E, nu_wf = ν, G = E/(2(1+ν))) and warp direction `warp`:
/// the same material, described by the orthotropic code path. Parameters that target the SVK
/// constants (`membranes.<name>.E`, `.nu`) go: they have no orthotropic counterpart.
pub fn equal_warp_and_fill(scene: &mut Scene, warp: [f64; 3]) {
    use velarium::scene::Material;
    scene
        .parameters
        .retain(|p| !(p.target.ends_with(".E") || p.target.ends_with(".nu")));
    for m in &mut scene.membranes {
        if let Material::Svk { young, nu } = m.material {
            m.material = Material::Orthotropic {
                e_warp: young,
                e_fill: young,
                nu_wf: nu,
                g: young / (2.0 * (1.0 + nu)),
                warp,
                warp_axis: None,
            };
        }
    }
}

/// Largest |a − b| over two displacement vectors, relative to the largest |a|.
pub fn field_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// An octahedron subdivided `n` times per edge and projected on the sphere of radius `r`:
/// nodes and outward (counter-clockwise seen from outside) triangles. Mirror-symmetric about
/// the three coordinate planes, with nodes on each of them.
pub fn octasphere(n: usize, r: f64) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let axes = [
        Vector3::x(),
        -Vector3::x(),
        Vector3::y(),
        -Vector3::y(),
        Vector3::z(),
        -Vector3::z(),
    ];
    let mut nodes: Vec<Vector3<f64>> = Vec::new();
    let mut index = |p: Vector3<f64>| -> usize {
        let p = p.normalize() * r;
        match nodes.iter().position(|q| (q - p).norm() < 1e-9) {
            Some(k) => k,
            None => {
                nodes.push(p);
                nodes.len() - 1
            }
        }
    };
    let mut triangles = Vec::new();
    for &a in &axes[0..2] {
        for &b in &axes[2..4] {
            for &c in &axes[4..6] {
                let at = |i: usize, j: usize| {
                    a + (b - a) * (i as f64 / n as f64) + (c - a) * (j as f64 / n as f64)
                };
                for i in 0..n {
                    for j in 0..n - i {
                        let mut tris = vec![[at(i, j), at(i + 1, j), at(i, j + 1)]];
                        if i + j + 1 < n {
                            tris.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                        }
                        for [p, q, s] in tris {
                            let (ip, iq, is) = (index(p), index(q), index(s));
                            triangles.push([ip, iq, is]);
                        }
                    }
                }
            }
        }
    }
    let nodes: Vec<[f64; 3]> = nodes.iter().map(|p| [p.x, p.y, p.z]).collect();
    for t in &mut triangles {
        let [p, q, s] = t.map(|k| Vector3::from(nodes[k]));
        if (q - p).cross(&(s - p)).dot(&(p + q + s)) < 0.0 {
            t.swap(1, 2);
        }
    }
    (nodes, triangles)
}

/// The octasphere balloon of radius 1 m (rubber: incompressible neo-Hookean, thickness `h`,
/// shear modulus `mu`) held by its three mirror planes, with one input `dV` of the given load
/// and outputs `p` (the enclosed pressure of `dV`) and `V` (the enclosed volume).
pub fn balloon_scene(divisions: usize, h: f64, mu: f64, load: serde_json::Value) -> Scene {
    let (nodes, triangles) = octasphere(divisions, 1.0);
    let on = |c: usize| -> Vec<usize> {
        (0..nodes.len())
            .filter(|&k| nodes[k][c].abs() < 1e-12)
            .collect()
    };
    let json = serde_json::json!({
        "format": 1, "name": "VolumeBalloon",
        "geometry": {"nodes": nodes, "triangles": triangles,
                     "node_sets": {"px": on(0), "py": on(1), "pz": on(2)},
                     "triangle_sets": {"all": (0..triangles.len()).collect::<Vec<_>>()}},
        "membranes": [{"name": "rubber", "triangles": "all", "thickness": h,
                       "material": {"kind": "neo_hookean", "mu": mu}}],
        "supports": [{"nodes": "px", "fix": ["x"]}, {"nodes": "py", "fix": ["y"]}, {"nodes": "pz", "fix": ["z"]}],
        "inputs": [{"name": "dV", "load": load}],
        "outputs": [
            {"name": "p", "probe": {"kind": "enclosed_pressure", "input": "dV"}},
            {"name": "V", "probe": {"kind": "enclosed_volume", "membrane": "rubber"}}
        ]
    });
    Scene::from_json(&json.to_string()).unwrap_or_else(|p| panic!("{p}"))
}
