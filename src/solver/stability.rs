//! Whether an equilibrium under ponding water is stable: the tangent positive definite.
//!
//! ```text
//! ponding_unstable(model, u, loads)   the first ponding input (by load channel) whose water
//!                                     finds the tangent K(u) at u not positive definite
//! ```
//! Water that fills a deflection deepens with it: the ponding load stiffness of a flat sheet
//! is −γ_w ∫ N_a N_b dA on the z components (`model::pressure`), a softening that grows with
//! γ_w while the membrane's geometric stiffness N ∇² does not. Past γ_w,cr (for a flat
//! rectangle a × b under isotropic N held on its edges, γ_w,cr = N π² (1/a² + 1/b²)) the
//! tangent has a negative eigenvalue: Newton may still converge to an equilibrium there (the
//! water would run off it at the least disturbance), so the engine refuses such a state and
//! names the reason (docs/mechanics.md §3.2). The test is a sparse Cholesky factorization of
//! the assembled free-free tangent (the symmetric part of the load stiffnesses, as the solver
//! factors it), whose failure is the loss of positive definiteness.

use super::assemble::{assemble, Pattern};
use crate::model::pressure::SurfaceLaw;
use crate::model::{LoadModel, Model};
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use faer::Side;

/// True when the model has a ponding input.
pub fn has_ponding(model: &Model) -> bool {
    model.loads.iter().any(|l| {
        matches!(
            l,
            LoadModel::Surface {
                law: SurfaceLaw::Ponding { .. },
                ..
            }
        )
    })
}

/// Whether the free-free tangent at `u` under `loads` is positive definite (None: the tangent
/// could not be built, out of memory; the caller then keeps its answer).
pub fn positive_definite(model: &Model, u: &[f64], loads: &[f64]) -> Option<bool> {
    let pattern = Pattern::try_new(model).ok()?;
    if pattern.n == 0 {
        return Some(true);
    }
    let mut r = vec![0.0; model.dof_count()];
    let mut k = vec![0.0; pattern.row_idx.len()];
    assemble(model, &pattern, u, loads, &mut r, Some(&mut k));
    if !k.iter().all(|v| v.is_finite()) {
        return Some(false);
    }
    let sym = SymbolicSparseColMat::new_checked(
        pattern.n,
        pattern.n,
        pattern.col_ptr.clone(),
        None,
        pattern.row_idx.clone(),
    );
    let matrix = SparseColMat::new(sym, k);
    Some(matrix.sp_cholesky(Side::Upper).is_ok())
}

/// The load channel of the first ponding input when the tangent at `u` under `loads` is not
/// positive definite and some of its water is on the membrane (None: stable, or no ponding).
pub fn ponding_unstable(model: &Model, u: &[f64], loads: &[f64]) -> Option<usize> {
    let channel = model.loads.iter().enumerate().position(|(l, load)| {
        matches!(load, LoadModel::Surface { triangles, law: SurfaceLaw::Ponding { .. } }
        if triangles.iter().any(|&e| {
            model.triangles[e].nodes.iter().any(|&i| model.position(u, i).z < loads[l])
        }))
    })?;
    (positive_definite(model, u, loads) == Some(false)).then_some(channel)
}
