//! The Newton loop's work buffers: allocated once (at their first use) and reused by every
//! iteration, so that an iteration allocates nothing (issue 15 item 5; docs/performance.md,
//! memory; `tests/guards/alloc_per_iteration.rs` counts it).
//!
//! ```text
//! scratch      an assembly's positions and forces in internal order, the load vector
//! dx, ds       the Newton direction (moved out to the loop and given back after the step)
//! columns      B's columns (slips, volumes) and their solves Y = A⁻¹ B   (m x n)
//! schur        the dense (D − C Y) block, its right-hand side and the pivots   (m x m)
//! trial_rows   the slip rows at a line-search trial point and their residuals
//! patch, nodes nodal relaxation's patch
//! patch_newton the patch Newton's element lists, dense tangent and vectors (relax.rs)
//! ```
//! Buffers only grow (to the largest size asked), never shrink, while the solver lives.

use super::assemble::AssemblyScratch;
use super::slip::Row;

#[derive(Default)]
pub(super) struct Work {
    pub scratch: AssemblyScratch,
    pub dx: Vec<f64>,
    pub ds: Vec<f64>,
    pub columns: Vec<Vec<(usize, f64)>>,
    pub solved: Vec<Vec<f64>>,
    pub schur: Vec<f64>,
    pub schur_rhs: Vec<f64>,
    pub trial_rows: Vec<Row>,
    pub trial_slip: Vec<f64>,
    pub patch: Vec<bool>,
    pub nodes: Vec<usize>,
    pub patch_newton: super::relax::PatchWork,
}

impl Work {
    /// Give the direction's buffers back for the next iteration.
    pub fn recycle(&mut self, dx: Vec<f64>, ds: Vec<f64>) {
        if dx.capacity() >= self.dx.capacity() {
            self.dx = dx;
        }
        if ds.capacity() >= self.ds.capacity() {
            self.ds = ds;
        }
    }
}

/// `m` columns of `n` zeros in `out`, reusing every column's storage.
pub(super) fn zero_columns(out: &mut Vec<Vec<f64>>, m: usize, n: usize) {
    out.truncate(m);
    out.resize_with(m, Vec::new);
    for v in out.iter_mut() {
        v.clear();
        v.resize(n, 0.0);
    }
}

/// Solve the dense m x m system A x = b in place (A row-major in `a`, b in `b`, x returned in
/// `b`) by LU with partial pivoting (Golub & Van Loan 2013, alg. 3.4.1: the largest entry of
/// the column below the diagonal is the pivot); false when a pivot is exactly zero (A
/// singular). No allocation.
pub(super) fn dense_solve(a: &mut [f64], b: &mut [f64]) -> bool {
    let m = b.len();
    debug_assert_eq!(a.len(), m * m);
    for k in 0..m {
        let (mut p, mut big) = (k, a[k * m + k].abs());
        for i in k + 1..m {
            let v = a[i * m + k].abs();
            if v > big {
                (p, big) = (i, v);
            }
        }
        if big == 0.0 || !big.is_finite() {
            return false;
        }
        if p != k {
            for j in 0..m {
                a.swap(k * m + j, p * m + j);
            }
            b.swap(k, p);
        }
        let pivot = a[k * m + k];
        for i in k + 1..m {
            let l = a[i * m + k] / pivot;
            if l != 0.0 {
                a[i * m + k] = l;
                for j in k + 1..m {
                    a[i * m + j] -= l * a[k * m + j];
                }
                b[i] -= l * b[k];
            }
        }
    }
    for k in (0..m).rev() {
        let mut v = b[k];
        for j in k + 1..m {
            v -= a[k * m + j] * b[j];
        }
        b[k] = v / a[k * m + k];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::dense_solve;

    /// A 3 x 3 system that needs a row swap (zero leading entry), against its exact solution
    /// x = (1, −2, 3) (b = A x computed by hand), and a singular one.
    #[test]
    fn dense_solve_pivots_and_reports_singular() {
        let mut a = vec![0.0, 2.0, 1.0, 1.0, 1.0, 1.0, 4.0, -1.0, 2.0];
        let mut b = vec![-1.0, 2.0, 12.0];
        assert!(dense_solve(&mut a, &mut b));
        for (x, want) in b.iter().zip([1.0, -2.0, 3.0]) {
            assert!((x - want).abs() < 1e-14, "{b:?}");
        }
        let mut a = vec![1.0, 2.0, 2.0, 4.0];
        let mut b = vec![1.0, 2.0];
        assert!(!dense_solve(&mut a, &mut b));
    }
}
