//! A dense solve of the small blocks the sparse tangent cannot hold (the Schur block of slip
//! and volume rows, the patch Newton's tangent): no solver state, no allocation.

/// Solve the dense m x m system A x = b in place (A row-major in `a`, b in `b`, x returned in
/// `b`) by LU with partial pivoting (Golub & Van Loan 2013, alg. 3.4.1: the largest entry of
/// the column below the diagonal is the pivot); false when a pivot is exactly zero (A
/// singular). No allocation.
pub fn dense_solve(a: &mut [f64], b: &mut [f64]) -> bool {
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
