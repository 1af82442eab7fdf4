//! The flat start's tangent split into its in-plane and out-of-plane blocks (issue 30): when
//! is the first Newton direction from a flat sheet the solve of the out-of-plane block alone?
//!
//! ```text
//! K = [K_pp K_pn]   p: the two in-plane DOFs of every node, n: the one along the plane's normal
//!     [K_np K_nn]   R_p = 0 at a flat start in equilibrium (no in-plane load)
//! ```
//! If K_pn = 0 and R_p = 0 the Newton direction is Δ_p = 0, K_nn Δ_n = −R_n: a solve with a
//! third of the unknowns and about 1/27 of a full factorization's flops. At a flat state the
//! membrane's own tangent has K_pn = 0 exactly (its material stiffness couples the normal DOFs
//! only through the normal slopes, which are zero; the stresses' geometric stiffness and the
//! artificial prestress are the same 3 x 3 block diagonal per node pair), and so have cables in
//! the plane and dead pressure (a force that does not depend on the displacements). A follower
//! pressure does not: its load stiffness `model::pressure::follower_stiffness` has the blocks
//! p/6 · skew(edge), whose in-plane edges put entries ±p·e/6 into K_pn (the pressed area grows
//! with the in-plane motion, the normal turns with the out-of-plane one). The Hencky disc and
//! the benchmark scenes are loaded by follower pressure: [`decoupled`] says no there, and the
//! measurement in this module's tests says how far the out-of-plane step is from the Newton
//! step (docs/performance.md, "The flat start's out-of-plane block").
//!
//! [`decoupled`] is the strict test (every node in one coordinate plane to round-off, no
//! sleeves, contacts or volume rows, no load but dead pressure and point forces along the
//! normal); [`blocks`] measures the blocks of an assembled tangent and residual.

use super::assemble::{Pattern, NONE};
use crate::model::{LoadModel, Model};

/// The coordinate axis normal to the plane every node lies in at displacement `u` (None: the
/// nodes are not in one coordinate plane to round-off: 8 ulp of the model's size).
pub fn flat_axis(model: &Model, u: &[f64]) -> Option<usize> {
    if model.reference.is_empty() {
        return None;
    }
    let first = model.position(u, 0);
    let size = (0..model.reference.len())
        .map(|i| (model.position(u, i) - first).amax())
        .fold(0.0, f64::max);
    let tolerance = 8.0 * f64::EPSILON * size.max(first.amax());
    (0..3).find(|&axis| {
        (0..model.reference.len())
            .all(|i| (model.position(u, i)[axis] - first[axis]).abs() <= tolerance)
    })
}

/// The normal axis when the tangent at `u` under `loads` has no in-plane/out-of-plane coupling
/// by construction ([`flat_axis`], and nothing that couples: no sleeve, tie, contact, volume
/// or water row, no prescribed displacement, no follower pressure or surface law with a
/// non-zero value, no point force with an in-plane component). None: the normal path.
pub fn decoupled(model: &Model, u: &[f64], loads: &[f64]) -> Option<usize> {
    let axis = flat_axis(model, u)?;
    let plain = model.slips.is_empty()
        && model.ties.is_empty()
        && model.contact_pairs.is_empty()
        && model.contact_points.is_empty()
        && model.volumes == 0;
    let loads_decouple = model
        .loads
        .iter()
        .zip(loads)
        .all(|(load, &value)| match load {
            LoadModel::Pressure { follower, .. } => !*follower || value == 0.0,
            LoadModel::PointForce(forces) => {
                value == 0.0 || forces.iter().all(|&(dof, f)| dof % 3 == axis || f == 0.0)
            }
            LoadModel::Surface { .. } => value == 0.0,
            _ => false,
        });
    (plain && loads_decouple).then_some(axis)
}

/// The blocks of an assembled tangent and residual at a flat state with normal `axis`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Blocks {
    /// Largest |K| entry coupling an in-plane DOF with a normal one.
    pub coupling: f64,
    /// Largest |K| entry of the in-plane block.
    pub in_plane: f64,
    /// Largest |K| entry of the out-of-plane block.
    pub normal: f64,
    /// Largest |R| over the free in-plane DOFs.
    pub in_plane_residual: f64,
    /// Largest |R| over the free normal DOFs.
    pub normal_residual: f64,
}

/// [`Blocks`] of the free-free upper tangent `k` (on `pattern`) and residual `r` (all DOFs).
pub fn blocks(pattern: &Pattern, k: &[f64], r: &[f64], axis: usize) -> Blocks {
    // The component of every equation: its DOF modulo 3.
    let mut component = vec![0u8; pattern.n];
    for (dof, &e) in pattern.eq.iter().enumerate() {
        if e != NONE {
            component[e] = (dof % 3) as u8;
        }
    }
    let normal = |e: usize| component[e] as usize == axis;
    let mut b = Blocks::default();
    for col in 0..pattern.n {
        let range = pattern.col_ptr[col]..pattern.col_ptr[col + 1];
        for (&row, &value) in pattern.row_idx[range.clone()].iter().zip(&k[range]) {
            let v = value.abs();
            let slot = match (normal(row), normal(col)) {
                (true, true) => &mut b.normal,
                (false, false) => &mut b.in_plane,
                _ => &mut b.coupling,
            };
            *slot = slot.max(v);
        }
    }
    for (dof, &e) in pattern.eq.iter().enumerate() {
        if e != NONE {
            let slot = match dof % 3 == axis {
                true => &mut b.normal_residual,
                false => &mut b.in_plane_residual,
            };
            *slot = slot.max(r[dof].abs());
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::assemble::assemble;
    use nalgebra::{DMatrix, DVector};

    /// The shipped Hencky disc at `rings` rings, its pressure follower or dead.
    fn disc(rings: usize, follower: bool) -> Model {
        let path = format!(
            "{}/modelDescription/HenckyDisc/scene.json",
            env!("CARGO_MANIFEST_DIR")
        );
        let mut value: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        value["geometry"]["generators"][0]["rings"] = rings.into();
        value["inputs"][0]["load"]["follower"] = follower.into();
        let scene = crate::scene::Scene::from_json(&value.to_string()).unwrap();
        Model::try_build(&scene).unwrap()
    }

    /// K (symmetric, dense) and R (free DOFs, equation order) at `u` under `loads`.
    fn tangent(model: &Model, u: &[f64], loads: &[f64]) -> (Pattern, DMatrix<f64>, Vec<f64>) {
        let pattern = Pattern::try_new(model).unwrap();
        let mut r = vec![0.0; model.dof_count()];
        let mut k = vec![0.0; pattern.row_idx.len()];
        assemble(model, &pattern, u, loads, &mut r, Some(&mut k));
        let n = pattern.n;
        let mut dense = DMatrix::zeros(n, n);
        for col in 0..n {
            let range = pattern.col_ptr[col]..pattern.col_ptr[col + 1];
            for (&row, &value) in pattern.row_idx[range.clone()].iter().zip(&k[range]) {
                dense[(row, col)] = value;
                dense[(col, row)] = value;
            }
        }
        let mut free = vec![0.0; n];
        for (dof, &e) in pattern.eq.iter().enumerate() {
            if e != NONE {
                free[e] = r[dof];
            }
        }
        (pattern, dense, free)
    }

    /// The full Newton direction and the out-of-plane block's alone (in-plane parts 0), the
    /// largest |difference| relative to the largest |full direction| component, and the blocks.
    fn directions(model: &Model, loads: &[f64]) -> (f64, Blocks) {
        let u = vec![0.0; model.dof_count()];
        let (pattern, k, r) = tangent(model, &u, loads);
        let rhs = -DVector::from_vec(r.clone());
        let full = k.clone().cholesky().expect("positive definite").solve(&rhs);
        let mut normal_eq = Vec::new();
        for (dof, &e) in pattern.eq.iter().enumerate() {
            if e != NONE && dof % 3 == 2 {
                normal_eq.push(e);
            }
        }
        let m = normal_eq.len();
        let knn = DMatrix::from_fn(m, m, |i, j| k[(normal_eq[i], normal_eq[j])]);
        let rn = DVector::from_fn(m, |i, _| -r[normal_eq[i]]);
        let dn = knn.cholesky().expect("positive definite").solve(&rn);
        let mut split = DVector::zeros(pattern.n);
        for (i, &e) in normal_eq.iter().enumerate() {
            split[e] = dn[i];
        }
        let mut residual = vec![0.0; model.dof_count()];
        let mut kv = vec![0.0; pattern.row_idx.len()];
        assemble(model, &pattern, &u, loads, &mut residual, Some(&mut kv));
        let b = blocks(&pattern, &kv, &residual, 2);
        assert!(b.normal > 0.0 && b.in_plane > 0.0, "{b:?}");
        ((&full - &split).amax() / full.amax(), b)
    }

    /// Dead pressure on the flat disc: the coupling block is exactly zero, the in-plane residual
    /// is exactly zero, and the out-of-plane block's solve is the Newton direction to round-off.
    #[test]
    fn the_out_of_plane_solve_is_the_newton_step_of_a_flat_disc_under_dead_pressure() {
        for rings in [4, 12] {
            let model = disc(rings, false);
            let loads = [40.0];
            assert_eq!(
                decoupled(&model, &vec![0.0; model.dof_count()], &loads),
                Some(2)
            );
            let (difference, b) = directions(&model, &loads);
            println!("dead pressure, {rings} rings: {b:?}, direction difference {difference:.2e}");
            assert_eq!(b.coupling, 0.0, "{b:?}");
            // The membrane's forces at zero strain are zero to round-off, far below the
            // convergence tolerance (1e-9 of the force scale).
            assert!(b.in_plane_residual <= 1e-12 * model.force_scale, "{b:?}");
            assert!(difference <= 1e-12, "{difference:e}");
        }
    }

    /// Follower pressure (the Hencky disc as shipped and benchmarked): the load stiffness
    /// couples the blocks, the out-of-plane solve is not the Newton direction, and the test
    /// says so.
    #[test]
    fn a_follower_pressure_couples_the_flat_start_and_is_not_decoupled() {
        for rings in [4, 12] {
            let model = disc(rings, true);
            let loads = [40.0];
            assert_eq!(
                decoupled(&model, &vec![0.0; model.dof_count()], &loads),
                None
            );
            let (difference, b) = directions(&model, &loads);
            println!(
                "follower pressure, {rings} rings: {b:?}, direction difference {difference:.2e}"
            );
            assert!(b.coupling > 0.0, "{b:?}");
            assert!(b.in_plane_residual <= 1e-12 * model.force_scale, "{b:?}");
            assert!(difference > 1e-9, "{difference:e}");
        }
        // At zero pressure nothing couples.
        let model = disc(4, true);
        assert_eq!(
            decoupled(&model, &vec![0.0; model.dof_count()], &[0.0]),
            Some(2)
        );
    }

    /// Not flat (one node moved out of the plane by more than round-off), or an in-plane
    /// point force: the normal path.
    #[test]
    fn a_model_off_the_plane_or_loaded_in_plane_is_not_decoupled() {
        let model = disc(4, false);
        let mut u = vec![0.0; model.dof_count()];
        assert_eq!(decoupled(&model, &u, &[40.0]), Some(2));
        u[3 * 5 + 2] = 1e-9;
        assert_eq!(decoupled(&model, &u, &[40.0]), None);
        let mut loaded = model.clone();
        loaded.loads.push(LoadModel::PointForce(vec![(3 * 5, 1.0)]));
        let u = vec![0.0; model.dof_count()];
        assert_eq!(decoupled(&loaded, &u, &[40.0, 1.0]), None);
        assert_eq!(decoupled(&loaded, &u, &[40.0, 0.0]), Some(2));
        loaded.loads[1] = LoadModel::PointForce(vec![(3 * 5 + 2, 1.0)]);
        assert_eq!(decoupled(&loaded, &u, &[40.0, 1.0]), Some(2));
    }
}
