//! GOAL: every tangent equals the central finite difference of its force vector.
//! MESH: single elements in random deformed states; the assembled LiftedMembrane model.
//! REFERENCE: docs/mechanics.md §5 (verify every tangent against central differences, relative
//!            error < 1e-6). Step h = 1e-6 times the element size; central differences are
//!            O(h²) accurate, so 1e-6 relative leaves room for round-off only.

use crate::common;
use common::Rng;
use nalgebra::{SMatrix, Vector3};
use velarium::model::wrinkling::Law;
use velarium::model::{cable, membrane, pressure};

/// Force and tangent of one triangle.
fn tri(
    r: &membrane::TriangleRef,
    mat: &membrane::Material,
    x: &[Vector3<f64>],
) -> (Vec<f64>, membrane::Mat9, f64) {
    tri_pre(r, mat, x, 0.0)
}

/// [`tri`] with the prestress continuation's isotropic pre-strain `pre`.
fn tri_pre(
    r: &membrane::TriangleRef,
    mat: &membrane::Material,
    x: &[Vector3<f64>],
    pre: f64,
) -> (Vec<f64>, membrane::Mat9, f64) {
    let mut k = membrane::Mat9::zeros();
    let (f, eval) = membrane::triangle_with(
        r,
        mat,
        0.0,
        &[x[0], x[1], x[2]],
        None,
        Some(&mut k),
        velarium::model::wrinkling::REGULARIZATION,
        pre,
    );
    (f.as_slice().to_vec(), k, eval.energy)
}

/// Central-difference matrix of `force` (a force function of N/3 nodes) at `x`, step `h`.
fn fd_matrix<const N: usize>(
    x: &[Vector3<f64>],
    force: impl Fn(&[Vector3<f64>]) -> Vec<f64>,
    h: f64,
) -> SMatrix<f64, N, N> {
    let mut fd = SMatrix::<f64, N, N>::zeros();
    for j in 0..N {
        let (node, c) = (j / 3, j % 3);
        let mut xp = x.to_vec();
        let mut xm = x.to_vec();
        xp[node][c] += h;
        xm[node][c] -= h;
        let (fp, fm) = (force(&xp), force(&xm));
        for i in 0..N {
            fd[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    fd
}

/// Max |K − K_fd| / max |K| for a force function of N/3 nodes.
fn fd_error<const N: usize>(
    x: &[Vector3<f64>],
    k: &SMatrix<f64, N, N>,
    force: impl Fn(&[Vector3<f64>]) -> Vec<f64>,
    h: f64,
) -> f64 {
    (k - fd_matrix::<N>(x, force, h)).abs().max() / k.abs().max()
}

#[test]
fn membrane_tangent_matches_finite_differences() {
    let mut rng = Rng(0x9E3779B97F4A7C15);
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let reference = [
            Vector3::zeros(),
            Vector3::new(1.0, 0.1, 0.0),
            Vector3::new(0.3, 0.9, 0.2),
        ]
        .map(|p| p + rng.vec3(0.1));
        let r = membrane::triangle_ref(reference).unwrap();
        let law = Law::Svk {
            young: 2e8 * (1.0 + 0.5 * rng.next()),
            nu: 0.3 + 0.15 * rng.next(),
        };
        let mat = membrane::Material {
            law,
            thickness: 1e-4,
            wrinkling: false,
            residual: 0.0,
            plastic: None,
        };
        // Large displacements and rotations, strains up to ~20 %.
        let x: Vec<Vector3<f64>> = reference
            .iter()
            .map(|p| p * 1.05 + rng.vec3(0.15))
            .collect();
        let (_, k, _) = tri(&r, &mat, &x);
        // Entry by entry, with entries below 1e-3 of the elastic scale held to 1e-9 of it.
        let k0 = tri(&r, &mat, &reference).1.abs().max();
        let err = fd_error_entrywise(&x, &k, |y| tri(&r, &mat, y).0, 1e-6, 1e-3 * k0);
        worst = worst.max(err);
        // Measured worst 2.1e-8 over the 200 samples; tolerance 1e-7.
        assert!(err < 1e-7, "membrane tangent error {err:e}");
        let (f_only, _) = membrane::triangle(&r, &mat, 0.0, &[x[0], x[1], x[2]], None, None);
        assert_eq!(
            f_only.as_slice(),
            tri(&r, &mat, &x).0.as_slice(),
            "residual-only path must agree bit for bit"
        );
    }
    println!("plain SVK membrane: worst entry-wise error {worst:e}");
}

#[test]
fn membrane_force_is_the_gradient_of_its_energy() {
    let mut rng = Rng(7);
    let reference = [
        Vector3::zeros(),
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.4, 0.8, 0.0),
    ];
    let r = membrane::triangle_ref(reference).unwrap();
    let mat = membrane::Material {
        law: Law::Svk {
            young: 1e6,
            nu: 0.3,
        },
        thickness: 1e-3,
        wrinkling: false,
        residual: 0.0,
        plastic: None,
    };
    let x: Vec<Vector3<f64>> = reference.iter().map(|p| p + rng.vec3(0.1)).collect();
    let (f, _, _) = tri(&r, &mat, &x);
    let h = 1e-6;
    for j in 0..9 {
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[j / 3][j % 3] += h;
        xm[j / 3][j % 3] -= h;
        let wp = tri(&r, &mat, &xp).2;
        let wm = tri(&r, &mat, &xm).2;
        let fd = (wp - wm) / (2.0 * h);
        assert!(
            (f[j] - fd).abs() < 1e-6 * f.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            "dof {j}: {} vs {fd}",
            f[j]
        );
    }
}

#[test]
fn cable_tangent_matches_finite_differences_for_both_laws() {
    let mut rng = Rng(42);
    for law in [cable::Law::Engineering, cable::Law::GreenLagrange] {
        for _ in 0..200 {
            let xa = rng.vec3(1.0);
            let xb = xa + Vector3::new(1.0, 0.0, 0.0) + rng.vec3(0.3);
            let l = (xb - xa).norm();
            // Taut states only: l0 below l (slack tangent is a regulariser, checked apart).
            let l0 = l / (1.0 + 0.2 * (rng.next() + 1.0) + 1e-3);
            let (_, k, _) = cable::segment(law, 1e5, l0, &xa, &xb);
            let force = |y: &[Vector3<f64>]| {
                cable::segment(law, 1e5, l0, &y[0], &y[1])
                    .0
                    .as_slice()
                    .to_vec()
            };
            let err = fd_error(&[xa, xb], &k, force, 1e-6);
            assert!(err < 1e-6, "{law:?} tangent error {err:e}");
        }
    }
}

#[test]
fn slack_cable_has_zero_force_and_zero_tangent() {
    let (xa, xb) = (Vector3::zeros(), Vector3::new(0.9, 0.0, 0.0));
    let (f, k, w) = cable::segment(cable::Law::Engineering, 1e5, 1.0, &xa, &xb);
    assert_eq!(f.abs().max(), 0.0);
    assert_eq!(w, 0.0);
    assert_eq!(k.abs().max(), 0.0);
}

#[test]
fn follower_pressure_stiffness_matches_finite_differences() {
    let mut rng = Rng(3);
    for _ in 0..100 {
        let x: Vec<Vector3<f64>> = [
            Vector3::zeros(),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.2, 1.0, 0.0),
        ]
        .iter()
        .map(|p| p + rng.vec3(0.3))
        .collect();
        let p = 1e3 * rng.next();
        let k = pressure::follower_stiffness(p, &[x[0], x[1], x[2]]);
        // The load stiffness is −∂f_ext/∂x.
        let force = |y: &[Vector3<f64>]| {
            let f = pressure::follower_force(p, &[y[0], y[1], y[2]]);
            (0..9).map(|i| -f[i % 3]).collect()
        };
        let err = fd_error(&x, &k, force, 1e-6);
        assert!(err < 1e-6, "pressure stiffness error {err:e}");
    }
}

/// Snow per current plan area and ponding (hydrostatic, follower, partly wet triangles
/// included): the load stiffness −∂f/∂x of `pressure::SurfaceLaw` against central differences
/// of its nodal forces, and ∂f/∂value (`SurfaceLaw::rate`, what the derivatives use) against a
/// central difference in the value. Nodes are kept 1e-3 m or more from the water level, where
/// the depth max(h − z, 0) has its kink.
#[test]
fn snow_and_ponding_stiffness_match_finite_differences() {
    use pressure::SurfaceLaw;
    let mut rng = Rng(29);
    let (mut worst_k, mut worst_rate, mut partly_wet) = (0.0f64, 0.0f64, 0);
    for trial in 0..300 {
        let x: Vec<Vector3<f64>> = [
            Vector3::zeros(),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.2, 1.0, 0.0),
        ]
        .iter()
        .map(|p| p + rng.vec3(0.3))
        .collect();
        let (law, value) = if trial % 2 == 0 {
            (SurfaceLaw::Snow, 1e3 * rng.next())
        } else {
            (SurfaceLaw::Ponding { gamma_w: 9810.0 }, 0.3 * rng.next())
        };
        if matches!(law, SurfaceLaw::Ponding { .. }) {
            if x.iter().any(|p| (p.z - value).abs() < 1e-3) {
                continue;
            }
            let wet = x.iter().filter(|p| p.z < value).count();
            if wet == 0 {
                continue;
            }
            partly_wet += (wet < 3) as usize;
        }
        let xa = [x[0], x[1], x[2]];
        let k = law.stiffness(value, &xa);
        let force = |y: &[Vector3<f64>]| {
            let f = law.forces(value, &[y[0], y[1], y[2]]);
            (0..9).map(|i| -f[i / 3][i % 3]).collect()
        };
        let err = fd_error(&x, &k, force, 1e-6);
        worst_k = worst_k.max(err);
        let h = 1e-6;
        let (fp, fm, rate) = (
            law.forces(value + h, &xa),
            law.forces(value - h, &xa),
            law.rate(value, &xa),
        );
        let scale = rate.iter().map(|v| v.abs().max()).fold(0.0, f64::max);
        for a in 0..3 {
            let fd = (fp[a] - fm[a]) / (2.0 * h);
            worst_rate = worst_rate.max((fd - rate[a]).abs().max() / scale);
        }
    }
    assert!(
        partly_wet > 20,
        "only {partly_wet} partly wet triangles tried"
    );
    assert!(worst_k < 1e-8, "snow/ponding stiffness error {worst_k:e}");
    assert!(worst_rate < 1e-6, "snow/ponding rate error {worst_rate:e}");
    eprintln!("snow/ponding: stiffness error {worst_k:.1e}, rate error {worst_rate:.1e}");
}

/// The water volume of a `water_volume` input's row (`pressure::ponding_volume`): its
/// gradients ∂V/∂x and ∂V/∂h against central differences (partly wet triangles included,
/// nodes 1e-3 m or more from the level as above), and γ_w V against the vertical resultant of
/// the ponding forces it stands for (−Σ f_z = γ_w V, an identity: to round-off). Tolerances:
/// 1e-9 of the largest gradient entry (step 1e-6: truncation 1e-12, round-off about 1e-10,
/// measured 1.0e-10) and 1e-14 for the identity (measured 4.4e-16).
#[test]
fn ponding_volume_gradients_match_finite_differences() {
    use pressure::{ponding_volume, SurfaceLaw};
    let mut rng = Rng(292);
    let (mut worst, mut worst_total, mut partly_wet, mut tried) = (0.0f64, 0.0f64, 0, 0);
    for _ in 0..300 {
        let x: Vec<Vector3<f64>> = [
            Vector3::zeros(),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.2, 1.0, 0.0),
        ]
        .iter()
        .map(|p| p + rng.vec3(0.3))
        .collect();
        let h = 0.3 * rng.next();
        let wet = x.iter().filter(|p| p.z < h).count();
        if wet == 0 || x.iter().any(|p| (p.z - h).abs() < 1e-3) {
            continue;
        }
        tried += 1;
        partly_wet += (wet < 3) as usize;
        let xa = [x[0], x[1], x[2]];
        let (v, grad, dh) = ponding_volume(h, &xa);
        let step = 1e-6;
        let mut scale = dh.abs();
        let mut err = 0.0f64;
        for a in 0..3 {
            for c in 0..3 {
                let (mut plus, mut minus) = (xa, xa);
                plus[a][c] += step;
                minus[a][c] -= step;
                let fd = (ponding_volume(h, &plus).0 - ponding_volume(h, &minus).0) / (2.0 * step);
                err = err.max((fd - grad[a][c]).abs());
                scale = scale.max(grad[a][c].abs());
            }
        }
        let fd_h =
            (ponding_volume(h + step, &xa).0 - ponding_volume(h - step, &xa).0) / (2.0 * step);
        err = err.max((fd_h - dh).abs());
        worst = worst.max(err / scale);
        let f = SurfaceLaw::Ponding { gamma_w: 9810.0 }.forces(h, &xa);
        let fz: f64 = f.iter().map(|v| v.z).sum();
        worst_total = worst_total.max((9810.0 * v + fz).abs() / (9810.0 * v.abs()).max(1e-300));
    }
    eprintln!("ponding volume: {tried} triangles ({partly_wet} partly wet), gradient error {worst:.1e}, γV vs −Σf_z {worst_total:.1e}");
    assert!(
        partly_wet > 20,
        "only {partly_wet} partly wet triangles tried"
    );
    assert!(worst < 1e-9, "ponding volume gradient error {worst:e}");
    assert!(
        worst_total < 1e-14,
        "γ V against the ponding forces {worst_total:e}"
    );
}

/// The snow load's nodal forces total s times the current plan area, downwards, whichever way
/// the triangle faces, and a flat triangle under water of depth d carries the water column's
/// weight γ_w d A (closed forms, to round-off).
#[test]
fn snow_and_ponding_totals_are_the_closed_forms() {
    use pressure::SurfaceLaw;
    let x = [
        Vector3::new(0.0, 0.0, 0.3),
        Vector3::new(2.0, 0.0, -0.1),
        Vector3::new(0.5, 1.5, 0.7),
    ];
    let plan = 0.5 * 2.0 * 1.5;
    for order in [[0, 1, 2], [0, 2, 1]] {
        let y = order.map(|i| x[i]);
        let f = SurfaceLaw::Snow.forces(800.0, &y);
        let total: Vector3<f64> = f.iter().sum();
        assert!((total - Vector3::new(0.0, 0.0, -800.0 * plan)).norm() < 1e-12 * 800.0 * plan);
    }
    let flat = [
        Vector3::new(0.0, 0.0, -0.2),
        Vector3::new(2.0, 0.0, -0.2),
        Vector3::new(0.5, 1.5, -0.2),
    ];
    let f = SurfaceLaw::Ponding { gamma_w: 9810.0 }.forces(0.1, &flat);
    let total: Vector3<f64> = f.iter().sum();
    let weight = 9810.0 * 0.3 * plan;
    assert!((total - Vector3::new(0.0, 0.0, -weight)).norm() < 1e-12 * weight);
    // Above the level: dry.
    let dry = SurfaceLaw::Ponding { gamma_w: 9810.0 }.forces(-0.3, &flat);
    assert_eq!(dry.iter().map(|v| v.norm()).sum::<f64>(), 0.0);
}

/// The assembled tangent of a whole model (membrane, cables, follower pressure on a clamped
/// disc) against central differences of the assembled residual, in a deformed state.
#[test]
fn assembled_tangent_matches_finite_differences() {
    use velarium::solver::assemble::{assemble, Pattern, NONE};
    for name in ["LiftedMembrane", "HenckyDisc"] {
        let mut scene = common::read_scene(&common::shipped(name));
        scene.solver.artificial_prestress = Some(0.0); // the exact tangent, no regulariser
        if let velarium::scene::Generator::Rectangle { divisions, .. } =
            &mut scene.geometry.generators[0]
        {
            *divisions = [4, 3];
        }
        if let velarium::scene::Generator::Disc { rings, .. } = &mut scene.geometry.generators[0] {
            *rings = 3;
        }
        let model = velarium::model::Model::build(&scene);
        let pattern = Pattern::try_new(&model).unwrap();
        let mut rng = Rng(11);
        let mut u: Vec<f64> = (0..model.dof_count())
            .map(|d| {
                if model.held[d] {
                    0.0
                } else {
                    0.02 * rng.next()
                }
            })
            .collect();
        for d in (2..u.len()).step_by(3) {
            if !model.held[d] {
                u[d] += 0.05; // lift out of plane so membrane and pressure terms are all active
            }
        }
        let loads = vec![30.0; model.loads.len()];
        let mut r = vec![0.0; model.dof_count()];
        let nnz = pattern.row_idx.len();
        let mut k = vec![0.0; nnz];
        assemble(&model, &pattern, &u, &loads, &mut r, Some(&mut k));
        // Dense upper-triangular tangent for lookup.
        let n = pattern.n;
        let mut dense = vec![0.0; n * n];
        for j in 0..n {
            let column = pattern.col_ptr[j]..pattern.col_ptr[j + 1];
            for (p, &i) in column.clone().zip(&pattern.row_idx[column]) {
                dense[i * n + j] = k[p];
                dense[j * n + i] = k[p];
            }
        }
        let scale = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let h = 1e-7;
        let mut worst = 0.0f64;
        for (dj, &j) in pattern.eq.iter().enumerate() {
            if j == NONE {
                continue;
            }
            let (mut up, mut um) = (u.clone(), u.clone());
            up[dj] += h;
            um[dj] -= h;
            let (mut rp, mut rm) = (vec![0.0; r.len()], vec![0.0; r.len()]);
            assemble(&model, &pattern, &up, &loads, &mut rp, None);
            assemble(&model, &pattern, &um, &loads, &mut rm, None);
            for (di, &i) in pattern.eq.iter().enumerate() {
                if i != NONE {
                    let fd = (rp[di] - rm[di]) / (2.0 * h);
                    worst = worst.max((dense[i * n + j] - fd).abs() / scale);
                }
            }
        }
        assert!(worst < 1e-6, "{name}: assembled tangent error {worst:e}");
    }
}

/// Worst entry-wise error of K against the central difference of `force`:
/// max over (i, j) of |K_ij − FD_ij| / (|K_ij| + floor), each entry against its own size, with
/// an absolute `floor` (N/m) for entries that vanish.
fn fd_error_entrywise<const N: usize>(
    x: &[Vector3<f64>],
    k: &SMatrix<f64, N, N>,
    force: impl Fn(&[Vector3<f64>]) -> Vec<f64>,
    h: f64,
    floor: f64,
) -> f64 {
    let fd = fd_matrix::<N>(x, force, h);
    k.iter()
        .zip(fd.iter())
        .fold(0.0f64, |m, (k, d)| m.max((k - d).abs() / (k.abs() + floor)))
}

/// The wrinkling law's tangent (taut, wrinkled and slack states, SVK and neo-Hookean), entry by
/// entry, at states away from the switch: a sample counts only when the state is the same at
/// every point of a ±1e-4 box around it (a hundred times the difference step), so the central
/// difference never straddles a state border. Step h = 1e-6 of the element size: the O(h²)
/// truncation is ~1e-12 relative, round-off ~1e-10 of the entry; tolerance per entry 1e-7
/// (taut; measured 3.3e-8) and 1e-6 (wrinkled, slack; measured 3.6e-7: the rotating tension
/// direction makes the difference quotient noisier) plus an absolute floor in units of the element's elastic scale k0 (the largest entry of its
/// tangent in the unstressed reference state): 1e-3 k0 for taut elements (entries below it
/// are held to 1e-9 k0), and 3 k0 for wrinkled and slack ones, whose tangent carries the
/// tangent-only regularisation ε·D0 (ε = wrinkling::REGULARIZATION = 1e-6, not in the
/// forces): an entry may differ from the difference quotient by up to ε k0, held to 3e-6 k0.
#[test]
fn wrinkling_tangent_matches_finite_differences_entry_by_entry() {
    let laws = [
        Law::Svk {
            young: 2e8,
            nu: 0.3,
        },
        Law::NeoHookean { mu: 1e5 },
    ];
    let (counts, worst) = wrinkling_fd_samples(&laws, 0x2545F4914F6CDD1D, 600, 0.0, 0.0);
    println!("samples taut/wrinkled/slack {counts:?}, worst entry-wise error {worst:?}");
}

/// The same entry-wise check for the orthotropic fabric law (E_warp = 4 E_fill, nu_wf = 0.5,
/// G = E_fill/5, warp at two angles to the element frame), whose wrinkle direction is solved
/// for rather than read off the principal strains; same tolerances (measured worst: taut
/// 3.3e-8, wrinkled 3.4e-7, slack 3.4e-7).
#[test]
fn orthotropic_wrinkling_tangent_matches_finite_differences_entry_by_entry() {
    use velarium::model::orthotropic::Orthotropic;
    let laws = [
        Law::Orthotropic(Orthotropic::new(4e8, 1e8, 0.5, 2e7, 0.5)),
        Law::Orthotropic(Orthotropic::new(4e8, 1e8, 0.5, 2e7, -1.1)),
    ];
    let (counts, worst) = wrinkling_fd_samples(&laws, 0x9E3779B97F4A7C15, 600, 0.0, 0.0);
    println!(
        "orthotropic: samples taut/wrinkled/slack {counts:?}, worst entry-wise error {worst:?}"
    );
}

/// The law with a residual stiffness ρ = 1e-4 (`membranes[].residual_stiffness`): stress,
/// energy and tangent all carry ρ·D0 in wrinkled and slack states, so the tangent is consistent
/// there too and every state is held to the taut floor 1e-3 k0 (not 3 ε k0); tolerances as
/// above. SVK, neo-Hookean and orthotropic.
#[test]
fn residual_stiffness_tangent_matches_finite_differences_entry_by_entry() {
    use velarium::model::orthotropic::Orthotropic;
    let laws = [
        Law::Svk {
            young: 2e8,
            nu: 0.3,
        },
        Law::NeoHookean { mu: 1e5 },
        Law::Orthotropic(Orthotropic::new(4e8, 1e8, 0.5, 2e7, 0.5)),
    ];
    let (counts, worst) = wrinkling_fd_samples(&laws, 0xD1B54A32D192ED03, 900, 1e-4, 0.0);
    println!("residual 1e-4: samples taut/wrinkled/slack {counts:?}, worst {worst:?}");
}

/// The prestress continuation's pre-strain (`membrane::triangle_with`, the law at
/// E + h (1, 1, 0), docs/solver.md "Prestress continuation"): h = 1e-3, its starting value,
/// with wrinkling on the total strain, SVK, neo-Hookean and orthotropic; same samples,
/// floors and tolerances as above (the pre-strain shifts which states occur, not the tangent's
/// form); measured worst 4.8e-8 / 3.5e-7 / 3.4e-7 over 99 / 342 / 458 stable samples. Also the
/// closed form at rest (x = X): SVK's stress is then isotropic, S = E h / (1 − ν) (plane
/// stress), to 1e-12 relative (round-off of a few operations).
#[test]
fn pre_strained_tangent_matches_finite_differences_entry_by_entry() {
    use velarium::model::orthotropic::Orthotropic;
    let reference = [
        Vector3::zeros(),
        Vector3::new(1.0, 0.1, 0.0),
        Vector3::new(0.3, 0.9, 0.0),
    ];
    let r = membrane::triangle_ref(reference).unwrap();
    let mat = membrane::Material {
        law: Law::Svk {
            young: 2e8,
            nu: 0.3,
        },
        thickness: 1e-4,
        wrinkling: true,
        residual: 0.0,
        plastic: None,
    };
    let eps = velarium::model::wrinkling::REGULARIZATION;
    let (_, at_rest) = membrane::triangle_with(&r, &mat, 0.0, &reference, None, None, eps, 1e-3);
    let s = 2e8 * 1e-3 / (1.0 - 0.3);
    let off = (at_rest.stress - Vector3::new(s, s, 0.0)).abs().max() / s;
    assert!(off < 1e-12, "stress at rest {:?} vs {s}", at_rest.stress);
    let laws = [
        Law::Svk {
            young: 2e8,
            nu: 0.3,
        },
        Law::NeoHookean { mu: 1e5 },
        Law::Orthotropic(Orthotropic::new(4e8, 1e8, 0.5, 2e7, 0.5)),
    ];
    let (counts, worst) = wrinkling_fd_samples(&laws, 0x8CB92BA72F3D8DD7, 900, 0.0, 1e-3);
    println!("pre-strain 1e-3: samples taut/wrinkled/slack {counts:?}, worst {worst:?}");
}

/// Sample `samples` random deformed triangles, law `laws[sample % laws.len()]`, and check
/// those whose state is stable over the ±1e-4 box (see above); returns the sample counts and
/// the worst errors per state (taut, wrinkled, slack).
fn wrinkling_fd_samples(
    laws: &[Law],
    seed: u64,
    samples: usize,
    residual: f64,
    pre: f64,
) -> ([usize; 3], [f64; 3]) {
    use velarium::model::wrinkling::WrinkleState;
    let mut rng = Rng(seed);
    let mut counts = [0usize; 3];
    let mut worst = [0.0f64; 3];
    for sample in 0..samples {
        let reference = [
            Vector3::zeros(),
            Vector3::new(1.0, 0.1, 0.0),
            Vector3::new(0.3, 0.9, 0.0),
        ]
        .map(|p| p + rng.vec3(0.05).component_mul(&Vector3::new(1.0, 1.0, 0.0)));
        let r = membrane::triangle_ref(reference).unwrap();
        let law = laws[sample % laws.len()];
        let mat = membrane::Material {
            law,
            thickness: 1e-4,
            wrinkling: true,
            residual,
            plastic: None,
        };
        // Stretch in one direction, compress or stretch in the other, rotate out of plane:
        // taut, wrinkled and slack states all occur.
        let (s1, s2) = (
            1.0 + 0.2 * (rng.next() - 0.3),
            1.0 + 0.2 * (rng.next() - 0.6),
        );
        let x: Vec<Vector3<f64>> = reference
            .iter()
            .map(|p| Vector3::new(p.x * s1, p.y * s2, 0.3 * p.x * p.y) + rng.vec3(0.02))
            .collect();
        let state = |y: &[Vector3<f64>]| {
            let x = [y[0], y[1], y[2]];
            let eps = velarium::model::wrinkling::REGULARIZATION;
            membrane::triangle_with(&r, &mat, 0.0, &x, None, None, eps, pre)
                .1
                .state
        };
        let s0 = state(&x);
        let stable = (0..9).all(|j| {
            [-1e-4, 1e-4].iter().all(|&d| {
                let mut y = x.clone();
                y[j / 3][j % 3] += d;
                state(&y) == s0
            })
        });
        if !stable {
            continue;
        }
        let (_, k, _) = tri_pre(&r, &mat, &x, pre);
        let k0 = tri(&r, &mat, &reference).1.abs().max();
        // With a residual stiffness the tangent is consistent in every state.
        let floor = if s0 == WrinkleState::Taut || residual > 0.0 {
            1e-3 * k0
        } else {
            3.0 * velarium::model::wrinkling::REGULARIZATION / 1e-6 * k0
        };
        let err = fd_error_entrywise(&x, &k, |y| tri_pre(&r, &mat, y, pre).0, 1e-6, floor);
        let which = match s0 {
            WrinkleState::Taut => 0,
            WrinkleState::Wrinkled => 1,
            WrinkleState::Slack => 2,
        };
        counts[which] += 1;
        worst[which] = worst[which].max(err);
        // Measured worst: taut 3.3e-8, wrinkled 3.6e-7, slack 3.3e-7.
        let tolerance = if s0 == WrinkleState::Taut { 1e-7 } else { 1e-6 };
        assert!(
            err < tolerance,
            "{s0:?} tangent, entry-wise error {err:e} (sample {sample})"
        );
    }
    assert!(
        counts.iter().all(|&c| c >= 20),
        "every state sampled away from the switch: {counts:?}"
    );
    (counts, worst)
}

/// The tangent with a membrane prestress (an initial PK2 stress S0 as the equivalent initial
/// strain E0 in `TriangleRef::initial_strain`), entry by entry against central differences, with
/// wrinkling off (SVK) and on (SVK and neo-Hookean, taut and wrinkled states from the total
/// stress), at states stable over a ±1e-4 box as above. Random warp/fill prestress up to 1 % of
/// E (SVK) or 0.3 μ (neo-Hookean) along a random direction projected on the element; strains of
/// a few % either way. The force is also the gradient of the energy (the prestress is a
/// state with a potential). Tolerances as in the test above (same step, same floors, 1e-7 taut
/// and 1e-6 wrinkled/slack); measured worst 4.2e-8 / 3.2e-7 / 3.3e-7 over 314 / 178 / 107
/// stable samples.
#[test]
fn prestressed_membrane_tangent_matches_finite_differences() {
    use velarium::model::wrinkling::WrinkleState;
    let mut rng = Rng(0x853C49E6748FEA9B);
    let mut counts = [0usize; 3];
    let mut worst = [0.0f64; 3];
    let mut worst_gradient = 0.0f64;
    for sample in 0..600 {
        let reference = [
            Vector3::zeros(),
            Vector3::new(1.0, 0.1, 0.0),
            Vector3::new(0.3, 0.9, 0.2),
        ]
        .map(|p| p + rng.vec3(0.05));
        let mut r = membrane::triangle_ref(reference).unwrap();
        let (law, scale, wrinkling) = match sample % 3 {
            0 => (
                Law::Svk {
                    young: 2e8,
                    nu: 0.3,
                },
                2e8 * 1e-2,
                false,
            ),
            1 => (
                Law::Svk {
                    young: 2e8,
                    nu: 0.3,
                },
                2e8 * 1e-2,
                true,
            ),
            _ => (Law::NeoHookean { mu: 1e5 }, 0.3e5, true),
        };
        let mat = membrane::Material {
            law,
            thickness: 1e-4,
            wrinkling,
            residual: 0.0,
            plastic: None,
        };
        let u01 = |v: f64| 0.5 + 0.5 * v;
        let (warp, fill) = (
            scale * u01(rng.next()) * mat.thickness,
            scale * u01(rng.next()) * mat.thickness,
        );
        let dir = rng.vec3(1.0) + Vector3::new(0.0, 0.0, 0.0);
        let dir = if dir.norm() > 0.1 { dir } else { Vector3::x() };
        let s0 = membrane::initial_stress(&r, warp, fill, &dir, mat.thickness).unwrap();
        r.initial_strain = membrane::initial_strain(&mat, &s0).unwrap();
        // The equivalent strain reproduces S0 at rest.
        let (_, at_rest) = membrane::triangle(&r, &mat, 0.0, &reference, None, None);
        assert!(
            (at_rest.stress - s0).amax() <= 1e-9 * s0.amax().max(1.0),
            "S(E0) = {:?} vs S0 = {s0:?}",
            at_rest.stress
        );
        let (s1, s2) = (
            1.0 + 0.06 * (rng.next() - 0.5),
            1.0 + 0.06 * (rng.next() - 0.6),
        );
        let x: Vec<Vector3<f64>> = reference
            .iter()
            .map(|p| Vector3::new(p.x * s1, p.y * s2, p.z + 0.3 * p.x * p.y) + rng.vec3(0.005))
            .collect();
        let state = |y: &[Vector3<f64>]| {
            membrane::triangle(&r, &mat, 0.0, &[y[0], y[1], y[2]], None, None)
                .1
                .state
        };
        let st = state(&x);
        let stable = (0..9).all(|j| {
            [-1e-4, 1e-4].iter().all(|&d| {
                let mut y = x.clone();
                y[j / 3][j % 3] += d;
                state(&y) == st
            })
        });
        if !stable {
            continue;
        }
        let (f, k, _) = tri(&r, &mat, &x);
        let mut unstressed = r.clone();
        unstressed.initial_strain = Vector3::zeros();
        let k0 = tri(&unstressed, &mat, &reference).1.abs().max();
        let floor = if st == WrinkleState::Taut {
            1e-3 * k0
        } else {
            3.0 * velarium::model::wrinkling::REGULARIZATION / 1e-6 * k0
        };
        let err = fd_error_entrywise(&x, &k, |y| tri(&r, &mat, y).0, 1e-6, floor);
        let which = st as usize;
        counts[which] += 1;
        worst[which] = worst[which].max(err);
        let tolerance = if st == WrinkleState::Taut { 1e-7 } else { 1e-6 };
        assert!(
            err < tolerance,
            "{st:?} prestressed tangent, entry-wise error {err:e} (sample {sample})"
        );
        // f = ∂W/∂x by central differences of the energy, against the element's largest force.
        // Step 1e-6: the truncation error falls as h² (5.7e-4 at h = 1e-4, 5.7e-6 at 1e-5);
        // at 1e-6 the round-off ε W/h of the stored prestress energy W is left (measured
        // 5.8e-7); tolerance 2e-6.
        let h = 1e-6;
        for j in 0..9 {
            let mut yp = x.clone();
            let mut ym = x.clone();
            yp[j / 3][j % 3] += h;
            ym[j / 3][j % 3] -= h;
            let g = (tri(&r, &mat, &yp).2 - tri(&r, &mat, &ym).2) / (2.0 * h);
            worst_gradient = worst_gradient
                .max((g - f[j]).abs() / f.iter().fold(0.0, |m: f64, v| m.max(v.abs())));
        }
    }
    println!(
        "prestressed: samples taut/wrinkled/slack {counts:?}, worst entry-wise error {worst:?}, force vs energy gradient {worst_gradient:e}"
    );
    assert!(
        worst_gradient < 2e-6,
        "force is not the energy gradient: {worst_gradient:e}"
    );
    assert!(
        counts[0] >= 50 && counts[1] >= 20,
        "taut and wrinkled states sampled away from the switch: {counts:?}"
    );
}

/// The warp/fill law with a membrane prestress: the same check as the test above (entry by
/// entry against central differences, same step, floors and tolerances: 1e-7 taut, 1e-6
/// wrinkled/slack; force = energy gradient within 2e-6) with the orthotropic law E_w = 4e8,
/// E_f = 1e8, ν_wf = 0.5, G = 2e7 Pa, its warp at a random angle, wrinkling off on a third of
/// the samples, random warp/fill prestress up to 1 % of E_f along a random direction. The
/// prestress enters as the equivalent initial strain E0 = D⁻¹ S0 of the warp/fill elasticity,
/// so the mixed criterion, the wrinkle direction and the tangent all see the total stress.
/// Measured worst 1.4e-8 / 3.3e-7 / 3.3e-7 over 260 / 155 / 183 stable taut / wrinkled / slack
/// samples; force vs energy gradient 6.1e-8.
#[test]
fn prestressed_orthotropic_tangent_matches_finite_differences() {
    use velarium::model::orthotropic::Orthotropic;
    use velarium::model::wrinkling::WrinkleState;
    let mut rng = Rng(0x2545F4914F6CDD1D);
    let mut counts = [0usize; 3];
    let mut worst = [0.0f64; 3];
    let mut worst_gradient = 0.0f64;
    for sample in 0..600 {
        let reference = [
            Vector3::zeros(),
            Vector3::new(1.0, 0.1, 0.0),
            Vector3::new(0.3, 0.9, 0.2),
        ]
        .map(|p| p + rng.vec3(0.05));
        let mut r = membrane::triangle_ref(reference).unwrap();
        // Warp/fill law with its warp at a random angle in the element frame; E_w != E_f.
        let angle = std::f64::consts::PI * rng.next();
        let law = Law::Orthotropic(Orthotropic::new(4e8, 1e8, 0.5, 2e7, angle));
        let (scale, wrinkling) = (1e8 * 1e-2, sample % 3 != 0);
        let mat = membrane::Material {
            law,
            thickness: 1e-4,
            wrinkling,
            residual: 0.0,
            plastic: None,
        };
        let u01 = |v: f64| 0.5 + 0.5 * v;
        let (warp, fill) = (
            scale * u01(rng.next()) * mat.thickness,
            scale * u01(rng.next()) * mat.thickness,
        );
        let dir = rng.vec3(1.0) + Vector3::new(0.0, 0.0, 0.0);
        let dir = if dir.norm() > 0.1 { dir } else { Vector3::x() };
        let s0 = membrane::initial_stress(&r, warp, fill, &dir, mat.thickness).unwrap();
        r.initial_strain = membrane::initial_strain(&mat, &s0).unwrap();
        // The equivalent strain reproduces S0 at rest.
        let (_, at_rest) = membrane::triangle(&r, &mat, 0.0, &reference, None, None);
        assert!(
            (at_rest.stress - s0).amax() <= 1e-9 * s0.amax().max(1.0),
            "S(E0) = {:?} vs S0 = {s0:?}",
            at_rest.stress
        );
        let (s1, s2) = (
            1.0 + 0.06 * (rng.next() - 0.5),
            1.0 + 0.06 * (rng.next() - 0.6),
        );
        let x: Vec<Vector3<f64>> = reference
            .iter()
            .map(|p| Vector3::new(p.x * s1, p.y * s2, p.z + 0.3 * p.x * p.y) + rng.vec3(0.005))
            .collect();
        let state = |y: &[Vector3<f64>]| {
            membrane::triangle(&r, &mat, 0.0, &[y[0], y[1], y[2]], None, None)
                .1
                .state
        };
        let st = state(&x);
        let stable = (0..9).all(|j| {
            [-1e-4, 1e-4].iter().all(|&d| {
                let mut y = x.clone();
                y[j / 3][j % 3] += d;
                state(&y) == st
            })
        });
        if !stable {
            continue;
        }
        let (f, k, _) = tri(&r, &mat, &x);
        let mut unstressed = r.clone();
        unstressed.initial_strain = Vector3::zeros();
        let k0 = tri(&unstressed, &mat, &reference).1.abs().max();
        let floor = if st == WrinkleState::Taut {
            1e-3 * k0
        } else {
            3.0 * velarium::model::wrinkling::REGULARIZATION / 1e-6 * k0
        };
        let err = fd_error_entrywise(&x, &k, |y| tri(&r, &mat, y).0, 1e-6, floor);
        let which = st as usize;
        counts[which] += 1;
        worst[which] = worst[which].max(err);
        let tolerance = if st == WrinkleState::Taut { 1e-7 } else { 1e-6 };
        assert!(
            err < tolerance,
            "{st:?} prestressed orthotropic tangent, entry-wise error {err:e} (sample {sample})"
        );
        // f = ∂W/∂x by central differences of the energy, against the element's largest force.
        // Step 1e-6: the truncation error falls as h² (5.7e-4 at h = 1e-4, 5.7e-6 at 1e-5);
        // at 1e-6 the round-off ε W/h of the stored prestress energy W is left (measured
        // 5.8e-7); tolerance 2e-6.
        let h = 1e-6;
        for j in 0..9 {
            let mut yp = x.clone();
            let mut ym = x.clone();
            yp[j / 3][j % 3] += h;
            ym[j / 3][j % 3] -= h;
            let g = (tri(&r, &mat, &yp).2 - tri(&r, &mat, &ym).2) / (2.0 * h);
            worst_gradient = worst_gradient
                .max((g - f[j]).abs() / f.iter().fold(0.0, |m: f64, v| m.max(v.abs())));
        }
    }
    println!(
        "prestressed orthotropic: samples taut/wrinkled/slack {counts:?}, worst entry-wise error {worst:?}, force vs energy gradient {worst_gradient:e}"
    );
    assert!(
        worst_gradient < 2e-6,
        "force is not the energy gradient: {worst_gradient:e}"
    );
    assert!(
        counts.iter().all(|&c| c >= 50),
        "taut and wrinkled states sampled away from the switch: {counts:?}"
    );
}
