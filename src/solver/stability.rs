//! Whether an equilibrium under ponding water is stable: the tangent positive definite.
//!
//! ```text
//! ponding_unstable(model, u, loads)   the first ponding input (by load channel) whose water
//!                                     finds the tangent K(u) at u not positive definite
//! water_volume_stable(model, u, loads) with the water given as a volume: the tangent with
//!                                     the level eliminated (K + b bᵀ/d) positive definite
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
//!
//! A water volume held (`water_volume`) stiffens the sheet: the level rises with the mean
//! sag, so only motions that keep the volume count, and the threshold of a flat rectangle
//! becomes that of its first mode moving no water, N π² (4/a² + 1/b²) for a ≥ b.
//! [`water_volume_stable`] tests that; the engine calls it after every converged step of a
//! scene with a water volume (src/engine/stepping.rs) and refuses an unstable equilibrium.

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
    match free_tangent(model, u, loads)? {
        FreeTangent::Decided(answer) => Some(answer),
        FreeTangent::Matrix(_, matrix) => Some(matrix.sp_cholesky(Side::Upper).is_ok()),
    }
}

/// The free-free tangent at `u` under `loads`, or the answer without it.
enum FreeTangent {
    /// No free DOF (trivially positive definite: true) or a non-finite entry (false).
    Decided(bool),
    Matrix(Box<Pattern>, SparseColMat<usize, f64>),
}

/// [`FreeTangent`] at `u` under `loads` (None: out of memory).
fn free_tangent(model: &Model, u: &[f64], loads: &[f64]) -> Option<FreeTangent> {
    let pattern = Pattern::try_new(model).ok()?;
    if pattern.n == 0 {
        return Some(FreeTangent::Decided(true));
    }
    let mut r = vec![0.0; model.dof_count()];
    let mut k = vec![0.0; pattern.row_idx.len()];
    assemble(model, &pattern, u, loads, &mut r, Some(&mut k));
    if !k.iter().all(|v| v.is_finite()) {
        return Some(FreeTangent::Decided(false));
    }
    let sym = SymbolicSparseColMat::new_checked(
        pattern.n,
        pattern.n,
        pattern.col_ptr.clone(),
        None,
        pattern.row_idx.clone(),
    );
    Some(FreeTangent::Matrix(
        Box::new(pattern),
        SparseColMat::new(sym, k),
    ))
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

/// Whether an equilibrium whose water is given as a volume (`water_volume` inputs) is stable:
/// the tangent on the motions that keep every water volume positive definite (None: no water
/// volume input, or the check could not be made: out of memory, a breakdown of the
/// factorization).
///
/// ```text
/// bordered system   [K  c] [Δu]      c = ∂R/∂h (the level's column), r = ∂g/∂u (the row's),
///                   [rᵀ d] [Δh]      d = ∂g/∂h = γ_w A_wet > 0   (solver/volume.rs)
/// level eliminated  K_V = K − c rᵀ/d;  with b = (c − r)/2, its symmetric part
///                   K_V = K + b bᵀ/d   (exactly: on a flat wet sheet r = −c)
/// ```
/// K_V is K plus a positive rank-one term per water input, so the volume stiffens what the
/// level alone would not: a flat a × b sheet under isotropic N keeps positive definite past
/// N π² (1/a² + 1/b²) up to the first mode whose water volume is 0 (docs/mechanics.md §3.2).
/// The test: K positive definite (a sparse Cholesky) is enough; otherwise the inertia of the
/// bordered matrix [K b; bᵀ −d] = inertia(K_V) plus one negative pivot, from the pivots of an
/// LDLᵀ of K (Sylvester's law of inertia: the count of negative pivots) and, per input, the
/// sign of −d − bᵀ K⁻¹ b (one water input; with several, one at a time on the matrix updated
/// by the others is not done: two or more inputs with K indefinite give None).
pub fn water_volume_stable(model: &Model, u: &[f64], loads: &[f64]) -> Option<bool> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, supernodal::SupernodalLdltRef, CholeskySymbolicParams,
        LdltRef, SymbolicCholeskyRaw, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::{Conj, MatMut, Par};

    let water: Vec<usize> = model
        .loads
        .iter()
        .filter(|l| matches!(l, LoadModel::Volume { .. } | LoadModel::Water { .. }))
        .enumerate()
        .filter(|(_, l)| matches!(l, LoadModel::Water { .. }))
        .map(|(k, _)| k)
        .collect();
    if water.is_empty() {
        return None;
    }
    let (pattern, matrix) = match free_tangent(model, u, loads)? {
        FreeTangent::Decided(answer) => return Some(answer),
        FreeTangent::Matrix(pattern, matrix) => (pattern, matrix),
    };
    let n = pattern.n;
    // The symmetric border b and d of each water input.
    let rows = super::volume::rows(model, &pattern.eq, u, loads);
    let columns = super::volume::columns(model, &pattern.eq, u);
    let mut borders = Vec::with_capacity(water.len());
    for &w in &water {
        let (row, column) = (rows.get(w)?, columns.get(w)?);
        let d = row.ds.first()?.1;
        if !(d > 0.0) {
            return None;
        }
        let mut b = vec![0.0; n];
        for &(q, v) in column.iter() {
            b[q] += 0.5 * v;
        }
        for &(q, v) in &row.dx {
            b[q] -= 0.5 * v;
        }
        borders.push((b, d));
    }
    if matrix.sp_cholesky(Side::Upper).is_ok() {
        return Some(true);
    }
    if borders.len() > 1 {
        return None;
    }
    let (b, d) = &borders[0];
    // LDLᵀ of K without pivoting or regularization: its negative pivots count K's negative
    // eigenvalues.
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let symbolic = factorize_symbolic_cholesky(
        matrix.symbolic(),
        Side::Upper,
        SymmetricOrdering::Amd,
        params,
    )
    .ok()?;
    let mut l_values = vec![0.0; symbolic.len_val()];
    let req = symbolic
        .factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Default::default())
        .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
    let mut mem = MemBuffer::try_new(req).ok()?;
    symbolic
        .factorize_numeric_ldlt(
            &mut l_values,
            matrix.as_ref(),
            Side::Upper,
            LdltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .ok()?;
    let SymbolicCholeskyRaw::Supernodal(supernodal) = symbolic.raw() else {
        return None;
    };
    let factor = SupernodalLdltRef::new(supernodal, &l_values);
    let mut negative = 0usize;
    for s in 0..supernodal.n_supernodes() {
        let block = factor.supernode(s).val();
        for j in 0..block.ncols() {
            let pivot = block[(j, j)];
            if !pivot.is_finite() || pivot == 0.0 {
                return None;
            }
            negative += usize::from(pivot < 0.0);
        }
    }
    match negative {
        0 => Some(true),
        1 => {
            let mut x = b.clone();
            LdltRef::new(&symbolic, &l_values).solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut x, n, 1),
                Par::Seq,
                MemStack::new(&mut mem),
            );
            let btkb: f64 = b.iter().zip(&x).map(|(p, q)| p * q).sum();
            Some(-d - btkb > 0.0)
        }
        _ => Some(false),
    }
}
