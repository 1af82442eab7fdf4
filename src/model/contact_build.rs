//! The model's contacts from the scene's `contacts` (validated): elements, penalties and sets
//! (`contact.rs`).

use super::contact::{ContactPair, ContactPoint, ContactSet, Surface, PENALTY_FACTOR};
use super::{node_ids, Element, Segment, Triangle};
use crate::scene::generate::Mesh;
use crate::scene::{Contact, Scene};
use nalgebra::Vector3;

/// Index of the contact named `name` in the scene (validated to exist).
pub(super) fn position(scene: &Scene, name: &str) -> usize {
    scene
        .contacts
        .iter()
        .position(|c| c.name() == name)
        .expect("validated: a contact of that name")
}

/// The neighbouring stiffness of every node (N/m): the diagonal stiffness its membrane
/// triangles and cable segments give it if taut (`Element::reference_stiffness`).
pub(super) fn neighbouring(n: usize, triangles: &[Triangle], segments: &[Segment]) -> Vec<f64> {
    let mut k = vec![0.0; n];
    for t in triangles {
        for (a, &i) in t.nodes.iter().enumerate() {
            k[i] += t.reference_stiffness(a);
        }
    }
    for s in segments {
        for (a, &i) in s.nodes.iter().enumerate() {
            k[i] += s.reference_stiffness(a);
        }
    }
    k
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
pub(super) fn build(
    scene: &Scene,
    mesh: &Mesh,
    reference: &[Vector3<f64>],
    triangles: &[Triangle],
    segments: &[Segment],
    held: &[bool],
) -> (Vec<ContactPair>, Vec<ContactPoint>, Vec<ContactSet>) {
    // A node held in every component (a support, a prescribed displacement) cannot be moved
    // by a contact: it gets none (a pair none when both its nodes are so held).
    let fixed = |i: usize| held[3 * i..3 * i + 3].iter().all(|&h| h);
    let (mut pairs, mut points, mut sets) = (Vec::new(), Vec::new(), Vec::new());
    if scene.contacts.is_empty() {
        return (pairs, points, sets);
    }
    let near = neighbouring(reference.len(), triangles, segments);
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
        super::contact::pressure(self.lambda, self.k, self.gap)
    }
}

type Vec6 = nalgebra::SVector<f64, 6>;
type Mat6 = nalgebra::SMatrix<f64, 6, 6>;

impl super::Model {
    /// Index in the unknown vector of contact pair `e`'s multiplier.
    pub fn pair_multiplier_index(&self, e: usize) -> usize {
        self.contact_base() + e
    }

    /// Index in the unknown vector of rigid contact point `e`'s multiplier.
    pub fn point_multiplier_index(&self, e: usize) -> usize {
        self.contact_base() + self.contact_pairs.len() + e
    }

    /// Contact pair `e`'s internal force (top, bottom), tangent and energy at `u`.
    pub fn pair_contribution(&self, e: usize, u: &[f64]) -> (Vec6, Mat6, f64) {
        let c = &self.contact_pairs[e];
        let [t, b] = c.nodes;
        let (g, grad, hess) =
            super::contact::pair_gap(c, &self.position(u, t), &self.position(u, b));
        let lambda = u[self.pair_multiplier_index(e)];
        super::contact::augmented(lambda, c.k, g, &grad, &hess)
    }

    /// Rigid contact point `e`'s internal force, tangent and energy at `u`.
    pub fn point_contribution(
        &self,
        e: usize,
        u: &[f64],
    ) -> (nalgebra::SVector<f64, 3>, nalgebra::SMatrix<f64, 3, 3>, f64) {
        let c = &self.contact_points[e];
        let (g, grad, hess) = c.surface.gap(&self.position(u, c.nodes[0]));
        let lambda = u[self.point_multiplier_index(e)];
        super::contact::augmented(lambda, c.k, g, &grad, &hess)
    }

    /// Every contact's state at `u`: the pairs, then the rigid points.
    pub fn contact_states<'a>(&'a self, u: &'a [f64]) -> impl Iterator<Item = ContactState> + 'a {
        let pairs = self.contact_pairs.iter().enumerate().map(move |(e, c)| {
            let [t, b] = c.nodes;
            let index = self.pair_multiplier_index(e);
            ContactState {
                index,
                lambda: u[index],
                k: c.k,
                gap: c
                    .direction
                    .dot(&(self.position(u, t) - self.position(u, b))),
                nodes: [t, b],
                grad: [c.direction, -c.direction],
                set: c.set,
            }
        });
        let points = self.contact_points.iter().enumerate().map(move |(e, c)| {
            let i = c.nodes[0];
            let index = self.point_multiplier_index(e);
            let (gap, grad, _) = c.surface.gap(&self.position(u, i));
            ContactState {
                index,
                lambda: u[index],
                k: c.k,
                gap,
                nodes: [i, i],
                grad: [grad, Vector3::zeros()],
                set: c.set,
            }
        });
        pairs.chain(points)
    }

    /// Total force (N) of contact `set` at `u`: Σ p, or component `component` of the force on
    /// the structure at the contacting nodes, Σ p ∇g (the top sheet's for a pair).
    pub fn contact_total(&self, u: &[f64], set: usize, component: Option<usize>) -> f64 {
        self.contact_states(u)
            .filter(|c| c.set == set)
            .map(|c| match component {
                None => c.pressure(),
                Some(k) => c.pressure() * c.grad[0][k],
            })
            .sum()
    }

    /// Contact area (m²) of contact `set` at `u`: a third of the current area of every
    /// triangle at each pressed node (the top node of a pair).
    pub fn contact_area(&self, u: &[f64], set: usize) -> f64 {
        let mut pressed = vec![false; self.reference.len()];
        let mut any = false;
        for c in self.contact_states(u).filter(|c| c.set == set) {
            if c.pressure() > 0.0 {
                pressed[c.nodes[0]] = true;
                any = true;
            }
        }
        if !any {
            return 0.0;
        }
        let mut area = 0.0;
        for t in &self.triangles {
            let x = t.nodes.map(|i| self.position(u, i));
            let a = 0.5 * (x[1] - x[0]).cross(&(x[2] - x[0])).norm();
            area += t.nodes.iter().filter(|&&i| pressed[i]).count() as f64 * a / 3.0;
        }
        area
    }
}
