//! Unilateral frictionless contact: a node against a rigid plane, sphere or cylinder
//! ([`ContactPoint`]), and a node of one sheet against its partner node of another
//! ([`ContactPair`], node to node on matching meshes: the cushion's two sheets). Penalty with
//! augmented-Lagrangian (Uzawa) updates of a multiplier per contact, as the sleeve ties do
//! (`sleeve.rs`), so that the converged answer does not depend on the penalty.
//!
//! ```text
//! gap g(x) >= 0     plane    g = n·(x − p)                       (n unit: the free side)
//!                   sphere   g = |x − c| − R                     (outside the ball)
//!                   cylinder g = |P (x − p)| − R, P = I − a aᵀ   (outside; a the unit axis)
//!                   pair     g = n·(x_top − x_bottom)            (n unit, the scene's direction)
//! pressure force    p = max(0, λ − k g) >= 0 (N), along ∇g on the structure
//! energy            W = (p² − λ²)/(2 k)
//! internal force    ∂W/∂x = −p ∇g
//! tangent           ∂²W/∂x² = k ∇g ∇gᵀ − p ∇²g while p > 0, else 0
//!                   ∇²g: plane, pair 0; sphere (I − e eᵀ)/r; cylinder (P − e eᵀ)/r
//!                   (e = ∇g the unit normal, r the distance from the centre or axis)
//! Uzawa             after each converged Newton solve (solver::contact):
//!                   λ ← p = max(0, λ − k g) at every contact, while some |p − λ|/k (the gap
//!                   of a pressed contact, the multiplier's push λ/k at an open one) exceeds
//!                   GAP_TOLERANCE × the model's length scale; then the solve again. A contact
//!                   still open after the rounds fails the increment, naming it.
//! converged         λ = p: either g = 0 and p >= 0 (touching) or g >= 0 and p = 0 (apart)
//! ```
//!
//! Penalty: `k = PENALTY_FACTOR × k_n` by default, with `k_n` the neighbouring stiffness (the
//! diagonal stiffness E t A |∇N_a|² the node's membrane triangles, EA/L its cable segments,
//! give it; the larger of the pair's two nodes). A penalty given below `k_n` is raised to it:
//! the rate of the Uzawa rounds, 1/(1 + C k) per round with C the structure's compliance at
//! the node, would only slow (as for the ties).
//!
//! Pairing of two sheets, node to node: the i-th node of the `top` set against the i-th of
//! `bottom`, along one fixed direction n. Exact while the paired nodes stay opposite each
//! other across n; it does not see a node of one sheet that slides past its partner by more
//! than a fraction of a mesh cell, nor an edge or face of the other sheet between two nodes
//! (contact is enforced at the nodes only). The cushion generator (`scene::cushion`) makes the
//! matching meshes; a cushion pressed flat by snow keeps its sheets in plan (measured below in
//! the tests and docs/contact.md).
//!
//! A node held in every component (support, prescribed displacement) gets no contact: nothing
//! the contact does can move it. A contact at a node a prescribed displacement pushes into the
//! body fails its increment with that contact named (its gap cannot close).
//!
//! Outputs: the total contact force (Σ p, or one component of the force on the structure Σ p
//! ∇g at the contacting node, the top node of a pair) and the contact area (the current
//! tributary area of the pressed nodes, a third of each of their triangles).
//!
//! # References
//! Wriggers, *Computational Contact Mechanics*, 2nd ed. 2006, §5.2 (penalty), §6.3 (augmented
//! Lagrangian, Uzawa); Simo & Laursen 1992, Comput. Struct. 42:97–116; Nocedal & Wright 2006,
//! §17.4 (the bound-constrained augmented Lagrangian, max(0, λ − k g)).

use super::element::Element;
use crate::scene::generate::Mesh;
use crate::scene::shape::node_ids;
use crate::scene::{Contact, Scene};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Default penalty as a multiple of the neighbouring stiffness (module docs).
pub const PENALTY_FACTOR: f64 = 10.0;

/// Largest |p − λ|/k after the Uzawa rounds, relative to the model's length scale.
pub const GAP_TOLERANCE: f64 = 1e-10;

/// A rigid surface a node stays outside of (on the free side of).
#[derive(Clone, Debug, PartialEq)]
pub enum Surface {
    Plane {
        point: Vector3<f64>,
        normal: Vector3<f64>,
    },
    Sphere {
        center: Vector3<f64>,
        radius: f64,
    },
    Cylinder {
        point: Vector3<f64>,
        axis: Vector3<f64>,
        radius: f64,
    },
}

impl Surface {
    /// Gap g, its gradient and Hessian at `x` (module docs; normal and axis unit).
    pub fn gap(&self, x: &Vector3<f64>) -> (f64, Vector3<f64>, Matrix3<f64>) {
        match self {
            Surface::Plane { point, normal } => {
                (normal.dot(&(x - point)), *normal, Matrix3::zeros())
            }
            Surface::Sphere { center, radius } => {
                let d = x - center;
                let r = d.norm();
                if r == 0.0 {
                    // At the centre every direction is as far from the surface: push up.
                    return (-radius, Vector3::z(), Matrix3::zeros());
                }
                let e = d / r;
                (r - radius, e, (Matrix3::identity() - e * e.transpose()) / r)
            }
            Surface::Cylinder {
                point,
                axis,
                radius,
            } => {
                let d = x - point;
                let p = Matrix3::identity() - axis * axis.transpose();
                let q = p * d;
                let r = q.norm();
                if r == 0.0 {
                    let any = if axis.z.abs() < 0.9 {
                        Vector3::z()
                    } else {
                        Vector3::x()
                    };
                    return (-radius, (p * any).normalize(), Matrix3::zeros());
                }
                let e = q / r;
                (r - radius, e, (p - e * e.transpose()) / r)
            }
        }
    }
}

/// One node against a rigid surface.
#[derive(Clone, Debug)]
pub struct ContactPoint {
    pub nodes: [usize; 1],
    pub surface: Surface,
    /// Penalty (N/m), at least the neighbouring stiffness.
    pub k: f64,
    /// Index into `Model::contacts`.
    pub set: usize,
}

/// A node of the top sheet against its partner on the bottom sheet, along `direction`.
#[derive(Clone, Debug)]
pub struct ContactPair {
    /// (top, bottom)
    pub nodes: [usize; 2],
    /// Unit direction from the bottom sheet to the top one.
    pub direction: Vector3<f64>,
    pub k: f64,
    pub set: usize,
}

/// One scene contact: its name and its elements.
#[derive(Clone, Debug)]
pub struct ContactSet {
    pub name: String,
    /// Indices into `Model::contact_pairs` (sheets) and `Model::contact_points` (rigid).
    pub pairs: std::ops::Range<usize>,
    pub points: std::ops::Range<usize>,
}

impl Element for ContactPoint {
    fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    /// The penalty k (the stiffness a pressed contact adds along its normal).
    fn reference_stiffness(&self, _a: usize) -> f64 {
        self.k
    }
}

impl Element for ContactPair {
    fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    fn reference_stiffness(&self, _a: usize) -> f64 {
        self.k
    }
}

/// The contact pressure force p = max(0, λ − k g) (N).
pub fn pressure(lambda: f64, k: f64, g: f64) -> f64 {
    (lambda - k * g).max(0.0)
}

/// Internal force, tangent and energy of one contact with gap `g`, gradient `grad` and Hessian
/// `hess` over its N DOFs, multiplier `lambda` and penalty `k` (module docs).
pub fn augmented<const N: usize>(
    lambda: f64,
    k: f64,
    g: f64,
    grad: &SVector<f64, N>,
    hess: &SMatrix<f64, N, N>,
) -> (SVector<f64, N>, SMatrix<f64, N, N>, f64) {
    let p = pressure(lambda, k, g);
    let w = (p * p - lambda * lambda) / (2.0 * k);
    if p > 0.0 {
        (-grad * p, grad * grad.transpose() * k - hess * p, w)
    } else {
        (SVector::zeros(), SMatrix::zeros(), w)
    }
}

/// Gap, gradient and Hessian of a point contact at its node's position `x`.
pub fn point_gap(c: &ContactPoint, x: &Vector3<f64>) -> (f64, SVector<f64, 3>, SMatrix<f64, 3, 3>) {
    c.surface.gap(x)
}

/// Gap, gradient (top, bottom) and Hessian (zero) of a pair at positions `top`, `bottom`.
pub fn pair_gap(
    c: &ContactPair,
    top: &Vector3<f64>,
    bottom: &Vector3<f64>,
) -> (f64, SVector<f64, 6>, SMatrix<f64, 6, 6>) {
    let n = c.direction;
    let grad = SVector::<f64, 6>::from_column_slice(&[n.x, n.y, n.z, -n.x, -n.y, -n.z]);
    (n.dot(&(top - bottom)), grad, SMatrix::zeros())
}

/// The scene's contacts as the model holds them (built by `Model::try_build`).
/// Index of the contact named `name` in the scene (validated to exist).
pub fn position(scene: &Scene, name: &str) -> usize {
    scene
        .contacts
        .iter()
        .position(|c| c.name() == name)
        .expect("validated: a contact of that name")
}

/// The penalty of a contact at nodes whose neighbouring stiffness is `near`: the scene's
/// (raised to `near`) or `PENALTY_FACTOR × near`. A node with no stiffness at all (held
/// everywhere) keeps a unit penalty so that its element stays well formed.
fn penalty(given: Option<f64>, near: f64) -> f64 {
    let near = if near > 0.0 { near } else { 1.0 };
    match given {
        Some(k) => k.max(near),
        None => PENALTY_FACTOR * near,
    }
}

fn unit(v: &[f64; 3]) -> Vector3<f64> {
    Vector3::from(*v).normalize()
}

/// Pairs, points and sets of the scene's contacts.
pub fn build(
    scene: &Scene,
    mesh: &Mesh,
    near: &[f64],
    held: &[bool],
) -> (Vec<ContactPair>, Vec<ContactPoint>, Vec<ContactSet>) {
    // A node held in every component (a support, a prescribed displacement) cannot be moved
    // by a contact: it gets none (a pair none when both its nodes are so held).
    let fixed = |i: usize| held[3 * i..3 * i + 3].iter().all(|&h| h);
    let (mut pairs, mut points, mut sets) = (Vec::new(), Vec::new(), Vec::new());
    if scene.contacts.is_empty() {
        return (pairs, points, sets);
    }
    for (set, c) in scene.contacts.iter().enumerate() {
        let (p0, q0) = (pairs.len(), points.len());
        let given = c.penalty();
        let mut rigid = |nodes: &crate::scene::NodeRef, surface: Surface| {
            for i in node_ids(mesh, nodes).into_iter().filter(|&i| !fixed(i)) {
                points.push(ContactPoint {
                    nodes: [i],
                    surface: surface.clone(),
                    k: penalty(given, near[i]),
                    set,
                });
            }
        };
        match c {
            Contact::Sheets {
                top,
                bottom,
                direction,
                ..
            } => {
                let direction = unit(direction);
                for (t, b) in node_ids(mesh, top).into_iter().zip(node_ids(mesh, bottom)) {
                    if fixed(t) && fixed(b) {
                        continue;
                    }
                    pairs.push(ContactPair {
                        nodes: [t, b],
                        direction,
                        k: penalty(given, near[t].max(near[b])),
                        set,
                    });
                }
            }
            Contact::Plane {
                nodes,
                point,
                normal,
                ..
            } => rigid(
                nodes,
                Surface::Plane {
                    point: Vector3::from(*point),
                    normal: unit(normal),
                },
            ),
            Contact::Sphere {
                nodes,
                center,
                radius,
                ..
            } => rigid(
                nodes,
                Surface::Sphere {
                    center: Vector3::from(*center),
                    radius: *radius,
                },
            ),
            Contact::Cylinder {
                nodes,
                point,
                axis,
                radius,
                ..
            } => rigid(
                nodes,
                Surface::Cylinder {
                    point: Vector3::from(*point),
                    axis: unit(axis),
                    radius: *radius,
                },
            ),
        }
        sets.push(ContactSet {
            name: c.name().to_string(),
            pairs: p0..pairs.len(),
            points: q0..points.len(),
        });
    }
    (pairs, points, sets)
}

/// One contact's state at `u`, for the multiplier updates and the outputs.
#[derive(Clone, Copy, Debug)]
pub struct ContactState {
    /// Index of its multiplier in the unknown vector.
    pub index: usize,
    pub lambda: f64,
    pub k: f64,
    pub gap: f64,
    /// Its nodes (a rigid point's second entry repeats the first) and ∇g at each (a rigid
    /// point's second is zero).
    pub nodes: [usize; 2],
    pub grad: [Vector3<f64>; 2],
    /// Index into `Model::contacts`.
    pub set: usize,
}

impl ContactState {
    /// p = max(0, λ − k g).
    pub fn pressure(&self) -> f64 {
        pressure(self.lambda, self.k, self.gap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The internal force is the energy's gradient and the tangent the force's Jacobian, by
    /// central differences (step 1e-6 m, tolerance 1e-6 relative to the largest entry: the
    /// difference's truncation error h² |W'''| and round-off ε|W|/h are both below 1e-8 here)
    /// on every surface, pressed and apart, and on a pair.
    #[test]
    fn forces_and_tangents_match_finite_differences() {
        let surfaces = [
            Surface::Plane {
                point: Vector3::new(0.1, 0.2, 0.3),
                normal: Vector3::new(1.0, 2.0, 2.0) / 3.0,
            },
            Surface::Sphere {
                center: Vector3::new(0.0, 0.1, -1.0),
                radius: 1.2,
            },
            Surface::Cylinder {
                point: Vector3::new(0.0, 0.0, -0.9),
                axis: Vector3::new(1.0, 0.5, 0.2).normalize(),
                radius: 1.0,
            },
        ];
        let (k, h) = (3.0e4, 1e-6);
        for surface in surfaces {
            let c = ContactPoint {
                nodes: [0],
                surface,
                k,
                set: 0,
            };
            for (x, lambda) in [
                (Vector3::new(0.05, 0.1, 0.2), 50.0),
                (Vector3::new(0.3, -0.2, 0.15), 0.0),
                (Vector3::new(0.3, -0.2, 0.15), 5000.0),
            ] {
                let eval = |x: &Vector3<f64>| {
                    let (g, grad, hess) = point_gap(&c, x);
                    augmented(lambda, k, g, &grad, &hess)
                };
                let (f, kt, _) = eval(&x);
                let scale = f.abs().max() + kt.abs().max() * h + 1e-12;
                for j in 0..3 {
                    let mut xp = x;
                    let mut xm = x;
                    xp[j] += h;
                    xm[j] -= h;
                    let (fp, _, wp) = eval(&xp);
                    let (fm, _, wm) = eval(&xm);
                    let fd = (wp - wm) / (2.0 * h);
                    assert!(
                        (fd - f[j]).abs() <= 1e-6 * scale,
                        "{:?}: dW/dx{j} {fd} against {}",
                        c.surface,
                        f[j]
                    );
                    let col = (fp - fm) / (2.0 * h);
                    let kscale = kt.abs().max() + 1e-12;
                    for i in 0..3 {
                        assert!(
                            (col[i] - kt[(i, j)]).abs() <= 1e-6 * kscale.max(f.abs().max()),
                            "{:?}: K[{i},{j}] {} against {}",
                            c.surface,
                            kt[(i, j)],
                            col[i]
                        );
                    }
                }
            }
        }
        // A pair: the force on the top node pushes it along n, its opposite on the bottom one.
        let pair = ContactPair {
            nodes: [0, 1],
            direction: Vector3::new(0.0, 0.6, 0.8),
            k,
            set: 0,
        };
        let (top, bottom) = (Vector3::new(0.0, 0.0, 0.01), Vector3::new(0.0, 0.0, 0.02));
        let (g, grad, hess) = pair_gap(&pair, &top, &bottom);
        assert!((g + 0.008).abs() < 1e-15);
        let (f, kt, _) = augmented(10.0, k, g, &grad, &hess);
        let p = 10.0 + k * 0.008;
        assert!((f[2] + p * 0.8).abs() < 1e-9 && (f[5] - p * 0.8).abs() < 1e-9);
        assert!((kt[(2, 5)] + k * 0.64).abs() < 1e-9);
    }
}
