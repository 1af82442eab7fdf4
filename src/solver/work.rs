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
use super::rows::Row;

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

/// A modal analysis's large buffers, kept in the solver (`Solver::modes_work`; modes.rs) from one
/// analysis to the next: the Lanczos basis Q (n values per vector, grown by blocks), M Q for
/// the last two blocks only (a ring, modes.rs `RING`), the block's vectors, M's nonzero
/// entries and the work spaces. A repeated analysis (the `natural_frequency` output at every
/// committed state) then writes into memory it already has instead of fresh pages (the modes
/// benchmark's first analysis takes about 23 000 minor page faults, a repeated one 2 000-3 500). Their contents do not carry over: every analysis starts
/// from its own start vectors, so its result is the same whether the buffers are new or kept.
#[derive(Default)]
pub(super) struct ModesWork {
    pub(super) q: Vec<f64>,
    pub(super) mq: Vec<f64>,
    /// W, M W and the start block R (n × BLOCK each).
    pub(super) block: Vec<f64>,
    /// The block Cholesky QR's work space (modes.rs).
    pub(super) qr: Vec<f64>,
    /// The symmetric product's row buffer (modes.rs).
    pub(super) rows: Vec<f64>,
    pub(super) mass: (Vec<usize>, Vec<usize>, Vec<f64>),
}
