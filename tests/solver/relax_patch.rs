//! Nodal relaxation's patch Newton (`src/solver/relax.rs`, docs/solver.md "Nodal relaxation")
//! against Gauss-Seidel on a pair of nodes whose joint motion is soft, with a closed-form
//! equilibrium.

use velarium::model::Model;
use velarium::scene::Scene;
use velarium::solver::relax::{relax_nodes, relax_patch, Adjacency, Frozen, PatchWork};

/// Two free nodes joined by a stiff cable (EA 1e6 N) and each held by a soft one (EA 1e2 N)
/// to an anchor, all 1 m long, collinear along x, pretensioned to T0 = 10 N, engineering
/// strain, only x free; P = 1 N along x on the first node. Tension is linear in length
/// (T = T0 + k Δl, k = EA/L0, L0 = 1/(1 + T0/EA)), so the equilibrium is the 2 x 2 system
///     (k_a + k_s) u1 − k_s u2 = P,   −k_s u1 + (k_s + k_b) u2 = 0
/// (closed form, solved below by Cramer's rule). Node by node, each node is held by the
/// stiff cable, while the pair moving together is held only by the soft ones: Gauss-Seidel
/// contracts the error by k_s²/((k_a + k_s)(k_s + k_b)) ≈ 1 − 2e-4 per sweep and three
/// sweeps leave nearly all of P unbalanced; Newton on the pair solves the (linear) system
/// at once. Tolerances: |r| within 1e-9 P and u within 1e-9 of the closed form (round-off
/// of forces of size T0 = 10 N against a stiffness of 1e6 N/m: about 1e-15 · 10 / 110 m).
/// The patch Newton is run with the pair given in both orders.
#[test]
fn the_patch_newton_moves_a_pair_that_gauss_seidel_only_drifts() {
    let scene = Scene::parse(
        br#"{"format": 1, "name": "Pair",
            "geometry": {"nodes": [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]],
                         "node_sets": {"ends": [0, 3], "pair": [1, 2], "first": [1]}},
            "cables": [
                {"name": "a", "nodes": [0, 1], "EA": 1e2, "strain": "engineering", "pretension": 10},
                {"name": "s", "nodes": [1, 2], "EA": 1e6, "strain": "engineering", "pretension": 10},
                {"name": "b", "nodes": [2, 3], "EA": 1e2, "strain": "engineering", "pretension": 10}],
            "supports": [{"nodes": "ends", "fix": ["x", "y", "z"]}, {"nodes": "pair", "fix": ["y", "z"]}],
            "inputs": [{"name": "P", "load": {"kind": "point_force", "nodes": "first", "direction": [1, 0, 0]}}],
            "outputs": []}"#,
    )
    .expect("scene");
    let model = Model::build(&scene);
    let adj = Adjacency::try_new(&model).expect("adjacency");
    let p = 1.0;
    let loads = [p];
    let k = |ea: f64| ea * (1.0 + 10.0 / ea);
    let (ka, ks, kb) = (k(1e2), k(1e6), k(1e2));
    let det = (ka + ks) * (ks + kb) - ks * ks;
    let exact = [p * (ks + kb) / det, p * ks / det];
    let error = |u: &[f64]| (u[3] - exact[0]).abs().max((u[6] - exact[1]).abs());

    let mut u = vec![0.0; model.unknown_count()];
    for _ in 0..3 {
        relax_nodes(
            &model,
            &adj,
            &mut u,
            &loads,
            &[1, 2],
            Frozen::default(),
            1e-9 * p,
            &mut 0,
        );
    }
    let drift = error(&u);
    assert!(
        drift > 0.9 * exact[0],
        "Gauss-Seidel error {drift:e} of {:e}",
        exact[0]
    );

    let mut u = vec![0.0; model.unknown_count()];
    let mut work = PatchWork::default();
    let out = relax_patch(
        &model,
        &adj,
        &mut u,
        &loads,
        &[1, 2],
        Frozen::default(),
        1e-9 * p,
        10,
        1e-8,
        &mut work,
    );
    assert!(out.residual <= 1e-9 * p && out.iterations <= 2, "{out:?}");
    assert!(
        error(&u) <= 1e-9 * exact[0],
        "error {:e} of {:e}",
        error(&u),
        exact[0]
    );

    // The same patch given in another order (relaxation passes its patch in the sweep order
    // of the geometry, `Pattern::sweep_order`, not by node number): the same equilibrium, to
    // the same tolerance. Before, the patch was looked up by binary search in the list as
    // given, which only works sorted: node 2 was not found and its rows were lost.
    let mut u = vec![0.0; model.unknown_count()];
    let out = relax_patch(
        &model,
        &adj,
        &mut u,
        &loads,
        &[2, 1],
        Frozen::default(),
        1e-9 * p,
        10,
        1e-8,
        &mut work,
    );
    assert!(out.residual <= 1e-9 * p && out.iterations <= 2, "{out:?}");
    assert!(
        error(&u) <= 1e-9 * exact[0],
        "in another order: error {:e} of {:e}",
        error(&u),
        exact[0]
    );
}
