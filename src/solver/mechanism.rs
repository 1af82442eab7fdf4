//! True mechanisms: parts of a structure that can move as a rigid body because no support
//! stops them. Such a part has no equilibrium under a load that does not balance on it, and no
//! globalisation can find one; the step's failure then says which nodes are free.
//!
//! ```text
//! part        a connected set of nodes (every element connects its nodes: triangles, cable
//!             segments, sleeve ties)
//! rigid modes v(x) = t + ω × (x − c): 6 columns per node, [I, −[(x − c)/L]×] (L: part size)
//! free        rank of the modes over all the part's DOFs > rank over its held DOFs
//!             (a rigid motion that moves the part but no held DOF)
//! loaded      the external load does work on a free motion: g = Σ_nodes f·v(x) ≠ 0
//!             (a free motion the loads balance, e.g. a rotation of a symmetrically loaded
//!             ring about a point no support holds, is harmless and not reported)
//! ```

use crate::model::Model;
use nalgebra::{Matrix3, Matrix6, SMatrix, Vector3};

/// Longest list of node ids a message names.
const NAMED_NODES: usize = 12;

/// A sentence naming a part of the model that can move as a rigid body with no support to
/// stop it while the external forces `f_ext` (per DOF) do work on that motion, or None.
pub fn diagnose(model: &Model, f_ext: &[f64]) -> Option<String> {
    let n = model.reference.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let join = |p: &mut Vec<usize>, a: usize, b: usize| {
        let (ra, rb) = (find(p, a), find(p, b));
        if ra != rb {
            p[ra] = rb;
        }
    };
    let mut used = vec![false; n];
    // Every element joins its nodes into one part, whatever its kind.
    for (kind, e) in model.elements() {
        let nodes = model.element_nodes(kind, e);
        for &i in &nodes[1..] {
            join(&mut parent, nodes[0], i);
        }
        nodes.iter().for_each(|&i| used[i] = true);
    }
    let mut parts: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for i in (0..n).filter(|&i| used[i]) {
        parts.entry(find(&mut parent, i)).or_default().push(i);
    }
    for nodes in parts.values() {
        let count = nodes.len() as f64;
        let c: Vector3<f64> = nodes
            .iter()
            .map(|&i| model.reference[i])
            .sum::<Vector3<f64>>()
            / count;
        let size = nodes
            .iter()
            .map(|&i| (model.reference[i] - c).norm())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let (mut all, mut held) = (Matrix6::<f64>::zeros(), Matrix6::<f64>::zeros());
        // Generalized load (work on each rigid mode) and the size of the loads on the part.
        let (mut work, mut load) = (nalgebra::Vector6::<f64>::zeros(), 0.0f64);
        for &i in nodes {
            let r = (model.reference[i] - c) / size;
            let mut m = SMatrix::<f64, 3, 6>::zeros();
            m.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&Matrix3::identity());
            m.fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&(-r.cross_matrix()));
            for comp in 0..3 {
                let row = m.row(comp).transpose();
                let g = row * row.transpose();
                all += g;
                if model.held[3 * i + comp] {
                    held += g;
                } else {
                    let f = f_ext.get(3 * i + comp).copied().unwrap_or(0.0);
                    work += row * f;
                    load += f.abs();
                }
            }
        }
        let top = all.symmetric_eigenvalues().amax();
        let free = rank(&all, top) - rank(&held, top);
        // The free motions: directions the held DOFs do not see but the part's nodes do.
        let eig = held.symmetric_eigen();
        let loaded = (0..6).any(|k| {
            let v = eig.eigenvectors.column(k);
            let moves = (all * v).norm() > 1e-10 * top;
            eig.eigenvalues[k] <= 1e-10 * top && moves && v.dot(&work).abs() > 1e-9 * load
        });
        if free > 0 && loaded {
            let mut ids: Vec<String> = nodes
                .iter()
                .take(NAMED_NODES)
                .map(|i| i.to_string())
                .collect();
            if nodes.len() > NAMED_NODES {
                ids.push(format!("… ({} nodes)", nodes.len()));
            }
            return Some(format!(
                "the structure is a mechanism: nodes {} form a part with {free} rigid-body motion{} that no support stops and the loads push along (fix more components of its nodes, or connect it to a supported part)",
                ids.join(", "),
                if free == 1 { "" } else { "s" }
            ));
        }
    }
    None
}

/// Numerical rank of a symmetric positive semi-definite 6x6 matrix, eigenvalues counted above
/// 1e-10 of `top`.
fn rank(g: &Matrix6<f64>, top: f64) -> usize {
    g.symmetric_eigenvalues()
        .iter()
        .filter(|&&v| v > 1e-10 * top)
        .count()
}
