//! The mass matrix M on the tangent's pattern (held DOFs out), for the natural frequencies
//! (`modes.rs`) and the time integration to come.
//!
//! ```text
//! membrane triangle  consistent  M_ab = ρ t A₀ (1 + δ_ab)/12 · I₃   lumped  ρ t A₀/3 · I₃ at each node
//! cable segment      consistent  M_ab = μ ℓ (1 + δ_ab)/6 · I₃       lumped  μ ℓ/2 · I₃ at each node
//! sleeve tie         massless
//! point mass         m · I₃ on its node's diagonal
//! air (added mass)   consistent  m_a A₀ (1 + δ_ab)/12 · n nᵀ       lumped  m_a A₀/3 · n nᵀ at each node
//! ```
//! The air's added mass (`dynamics.air`, per membrane group) acts along the triangle's
//! reference unit normal n only; its linear damping c is distributed the same way
//! ([`Solver::air_damping`], into the time integration's C).
//! (`Element::consistent_mass` / `Element::lumped_mass` per kind, `model/mod.rs`; ρ the group's
//! `density`, μ the cable's `mass_per_length`, A₀ and ℓ the reference area and drawn length,
//! so M is constant: the mass of a material point does not change as it moves.) The values sit
//! at the same positions as the tangent's ([`Pattern::element_maps`], the diagonal positions),
//! so a Newton loop on K + c M adds `c` times [`Mass::values`] to the tangent's values entry
//! by entry ([`Mass::add_to`]), with no new pattern or symbolic factorization.

use super::assemble::{Pattern, NONE, UNMAPPED};
use super::core::Solver;
pub use super::inertia::symmetric_product;
use crate::memory::{self, OutOfMemory};
use crate::model::{ElementKind, Model};
use crate::scene::MassKind;

/// M on a solver's tangent pattern: one value per stored entry of the upper triangle.
#[derive(Clone, Debug)]
pub struct Mass {
    values: Vec<f64>,
    /// Consistent or lumped.
    pub kind: MassKind,
}

impl Mass {
    /// The values, at the tangent's positions.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The values' memory, for reuse as a work buffer (`modes.rs`).
    pub fn into_values(self) -> Vec<f64> {
        self.values
    }

    /// Whether every entry is zero (a massless model).
    pub fn is_zero(&self) -> bool {
        self.values.iter().all(|&v| v == 0.0)
    }

    /// `values[p] += c · M_p` for every stored entry: K + c M on the tangent's values.
    pub fn add_to(&self, c: f64, values: &mut [f64]) {
        for (k, m) in values.iter_mut().zip(&self.values) {
            *k += c * m;
        }
    }
}

/// M's values on `pattern` (`diagonal`: the position of each equation's diagonal entry) into
/// `values` (overwritten; the length of the tangent's values).
pub fn assemble_mass(
    model: &Model,
    pattern: &Pattern,
    diagonal: &[usize],
    kind: MassKind,
    values: &mut [f64],
) {
    values.fill(0.0);
    for element_kind in ElementKind::ALL {
        let dofs = 3 * element_kind.node_count();
        for (e, map) in pattern.element_maps(element_kind) {
            let element = model.element(element_kind, e);
            let nodes = element_kind.node_count();
            for a in 0..nodes {
                for b in 0..nodes {
                    let m = match kind {
                        MassKind::Consistent => element.consistent_mass(a, b),
                        MassKind::Lumped if a == b => element.lumped_mass(a),
                        MassKind::Lumped => 0.0,
                    };
                    if m == 0.0 {
                        continue;
                    }
                    for c in 0..3 {
                        let p = map[(3 * a + c) * dofs + 3 * b + c];
                        if p != UNMAPPED {
                            values[p as usize] += m;
                        }
                    }
                }
            }
        }
    }
    add_air(model, pattern, kind, 0, values);
    for &(node, m) in &model.point_masses {
        for c in 0..3 {
            let e = pattern.eq[3 * node + c];
            if e != NONE {
                values[diagonal[e]] += m;
            }
        }
    }
}

/// The air's matrix (`which` 0: the added mass, 1: the damping) added to `values` on
/// `pattern`: per triangle with air [m_a A₀, c A₀] = x (`Model::air`) and reference unit
/// normal n, the block of nodes a, b is x (1 + δ_ab)/12 · n nᵀ (consistent) or x/3 · n nᵀ at
/// each node (lumped): ∫ N_a N_b over the triangle, along the normal only.
fn add_air(model: &Model, pattern: &Pattern, kind: MassKind, which: usize, values: &mut [f64]) {
    if model.air.is_empty() {
        return;
    }
    let dofs = 9;
    for (e, map) in pattern.element_maps(ElementKind::Membrane) {
        let x = model.air[e][which];
        if x == 0.0 {
            continue;
        }
        let n = model.triangles[e].reference.normal;
        for a in 0..3 {
            for b in 0..3 {
                let m = match kind {
                    MassKind::Consistent => x * if a == b { 2.0 } else { 1.0 } / 12.0,
                    MassKind::Lumped if a == b => x / 3.0,
                    MassKind::Lumped => continue,
                };
                for i in 0..3 {
                    for j in 0..3 {
                        let p = map[(3 * a + i) * dofs + 3 * b + j];
                        if p != UNMAPPED {
                            values[p as usize] += m * n[i] * n[j];
                        }
                    }
                }
            }
        }
    }
}

/// Total mass of the model in kg: every element's and every point mass (the air's added mass,
/// which moves with the normal motion only, is not counted).
pub fn total_mass(model: &Model) -> f64 {
    let mut total = 0.0;
    for kind in ElementKind::ALL {
        for e in 0..model.element_count(kind) {
            let element = model.element(kind, e);
            total += (0..kind.node_count())
                .map(|a| element.lumped_mass(a))
                .sum::<f64>();
        }
    }
    total + model.point_masses.iter().map(|&(_, m)| m).sum::<f64>()
}

impl Solver {
    /// The model's mass matrix on this solver's pattern, of `kind`.
    pub fn mass(&self, model: &Model, kind: MassKind) -> Result<Mass, OutOfMemory> {
        let mut values = memory::zeros(self.linear.values().len(), "the mass matrix")?;
        assemble_mass(
            model,
            &self.pattern,
            &self.diagonal_positions,
            kind,
            &mut values,
        );
        Ok(Mass { values, kind })
    }

    /// The air's damping matrix (`dynamics.air`'s `damping`, along the reference normals) on
    /// this solver's pattern, distributed as the mass of `kind`; None without air damping.
    pub fn air_damping(&self, model: &Model, kind: MassKind) -> Option<Vec<f64>> {
        if !model.air.iter().any(|x| x[1] > 0.0) {
            return None;
        }
        let mut values = vec![0.0; self.linear.values().len()];
        add_air(model, &self.pattern, kind, 1, &mut values);
        Some(values)
    }

    /// y = M x over the equations (`mass` from [`Solver::mass`]).
    pub fn mass_product(&self, mass: &Mass, x: &[f64], y: &mut [f64]) {
        let a = self.linear.matrix();
        let s = a.symbolic();
        symmetric_product(s.col_ptr(), s.row_idx(), &mass.values, x, y);
    }

    /// Equation of every DOF (NONE: held).
    pub fn equation_numbers(&self) -> &[usize] {
        &self.pattern.eq
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Settings;

    /// A 2 m x 1 m sheet (ρ t = 800 kg/m³ · 1 mm) with a cable of 0.5 kg/m along its 2 m
    /// bottom edge, a point mass of 3 kg at one corner; nothing held, so every DOF is an
    /// equation.
    const SCENE: &str = r#"{
      "format": 1, "name": "Massive",
      "geometry": {"generators": [{"kind": "rectangle", "name": "s", "origin": [1, 0.5, 0],
                                   "size": [2, 1], "divisions": [4, 3]}]},
      "membranes": [{"name": "m", "triangles": "s", "thickness": 0.001, "density": 800,
                     "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}],
      "cables": [{"name": "c", "nodes": "s.edge_bottom", "EA": 1e5, "mass_per_length": 0.5}],
      "dynamics": {"point_masses": [{"nodes": "s.corner_tr", "mass": 3}]}
    }"#;

    /// Total mass ρ t A + μ L + m = 0.8·2 + 0.5·2 + 3 = 5.6 kg, and the kinetic energy of a
    /// rigid translation v, ½ vᵀ M v, is ½ · 5.6 · |v|² with either mass matrix (both conserve
    /// the mass: the rows of the consistent element matrices sum to the lumped masses).
    #[test]
    fn total_mass_and_rigid_translation_kinetic_energy() {
        let mut scene = crate::Scene::from_json(SCENE).unwrap();
        let total = 0.8 * 2.0 + 0.5 * 2.0 + 3.0;
        for kind in [MassKind::Consistent, MassKind::Lumped] {
            scene.dynamics.as_mut().unwrap().mass = kind;
            let model = Model::build(&scene);
            assert!((total_mass(&model) - total).abs() <= 1e-12 * total);
            let solver = Solver::try_new(&model, Settings::default()).unwrap();
            let n = solver.free_dofs();
            assert_eq!(n, model.dof_count());
            let mass = solver.mass(&model, kind).unwrap();
            let velocity = [0.3, -1.2, 0.7];
            let mut v = vec![0.0; n];
            for (d, &e) in solver.equation_numbers().iter().enumerate() {
                v[e] = velocity[d % 3];
            }
            let mut mv = vec![0.0; n];
            solver.mass_product(&mass, &v, &mut mv);
            let energy = 0.5 * v.iter().zip(&mv).map(|(a, b)| a * b).sum::<f64>();
            let speed2: f64 = velocity.iter().map(|x| x * x).sum();
            let want = 0.5 * total * speed2;
            assert!(
                (energy - want).abs() <= 1e-12 * want,
                "{kind:?}: {energy} against {want}"
            );
            // Lumped: diagonal only; consistent: coupled, and M positive definite on this
            // mesh (a node's row: 2/12 of its triangles' mass on the diagonal).
            let off_diagonal = {
                let a = solver.linear.matrix();
                let s = a.symbolic();
                (0..n)
                    .flat_map(|j| (s.col_ptr()[j]..s.col_ptr()[j + 1]).map(move |p| (p, j)))
                    .filter(|&(p, j)| s.row_idx()[p] != j)
                    .map(|(p, _)| mass.values()[p].abs())
                    .fold(0.0, f64::max)
            };
            match kind {
                MassKind::Lumped => assert_eq!(off_diagonal, 0.0),
                MassKind::Consistent => assert!(off_diagonal > 0.0),
            }
        }
    }

    /// No density, no mass per length, no point masses: M = 0.
    #[test]
    fn a_scene_without_mass_data_is_massless() {
        let mut scene = crate::Scene::from_json(SCENE).unwrap();
        scene.membranes[0].density = None;
        scene.cables[0].mass_per_length = None;
        scene.dynamics = None;
        let model = Model::build(&scene);
        let solver = Solver::try_new(&model, Settings::default()).unwrap();
        assert!(solver.mass(&model, MassKind::Consistent).unwrap().is_zero());
        assert_eq!(total_mass(&model), 0.0);
    }
}
