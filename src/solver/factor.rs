//! The two calls into faer's sparse LDLT that the whole tangent (`linear.rs`) and each half of
//! the two-domain factorization (`split.rs`) share: symbolic analysis and numeric
//! factorization with dynamic regularization of tiny pivots.

use crate::error::{Breakdown, Error};
use crate::memory::OutOfMemory;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::SparseColMat;
use faer::{Par, Side};

/// faer's numeric LDLT of the upper triangle of `matrix` on the calling thread, in the
/// matrix's precision (f64; f32 for the mixed-precision factor of `linear.rs`), tiny pivots
/// replaced as (delta, epsilon) say (`PIVOT_DELTA`, `PIVOT_EPSILON` times the largest diagonal
/// entry); the whole tangent here, one half in `split.rs`. A failure is a
/// [`Breakdown::Factorization`] of `of` (the matrix, as the message names it).
pub fn numeric_ldlt<T: faer::traits::RealField>(
    symbolic: &SymbolicCholesky<usize>,
    l_values: &mut [T],
    matrix: faer::sparse::SparseColMatRef<'_, usize, T>,
    (delta, epsilon): (f64, f64),
    mem: &mut MemBuffer,
    of: &'static str,
) -> Result<(), Error> {
    let reg = LdltRegularization {
        dynamic_regularization_signs: None,
        dynamic_regularization_delta: faer::traits::math_utils::from_f64::<T>(delta),
        dynamic_regularization_epsilon: faer::traits::math_utils::from_f64::<T>(epsilon),
    };
    symbolic
        .factorize_numeric_ldlt(
            l_values,
            matrix,
            Side::Upper,
            reg,
            Par::Seq,
            MemStack::new(mem),
            Default::default(),
        )
        .map_err(|e| Breakdown::Factorization {
            of,
            detail: format!("{e:?}"),
        })?;
    Ok(())
}

/// faer's supernodal symbolic factorization of the upper triangle of `matrix` in `ordering`.
/// A square pattern with sorted, in-range indices always has one; faer's only other failure is
/// its own allocation (or an index overflow, which the size limits rule out), reported as
/// `what` running out of memory.
pub fn symbolic_ldlt(
    matrix: &SparseColMat<usize, f64>,
    ordering: SymmetricOrdering<'_, usize>,
    what: &'static str,
) -> Result<SymbolicCholesky<usize>, OutOfMemory> {
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    factorize_symbolic_cholesky(matrix.symbolic(), Side::Upper, ordering, params).map_err(|_| {
        OutOfMemory {
            what,
            bytes: (matrix.val().len() as u64).saturating_mul(8 * 4),
        }
    })
}

/// Flops of one numeric factorization: Σ c² over the columns of L, c the column's entries
/// below the diagonal (multiply-adds of the updates it sends); the size check's count
/// (`scene::limits`), one function for both.
pub fn flops(symbolic: &SymbolicCholesky<usize>) -> f64 {
    crate::scene::limits::factor_flops(symbolic)
}
