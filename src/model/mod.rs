//! The model: a validated scene turned into numbers the solver works on. Immutable once built;
//! built again when a parameter changes.
//!
//! ```text
//! DOFs         3 per node (x, y, z displacement), dof = 3 node + component
//! held         a DOF fixed by a support, prescribed by a displacement input, or of a node no
//!              element uses (it has no stiffness)
//! triangles    membrane CST elements with reference data, material, artificial prestress
//! segments     cable segments with unstretched length
//! slips        sleeve points: one slip unknown each, stored after the 3 N displacements
//!              (u[3 N + j]); each sleeve point is its own node, tied to its sleeve node
//! ties         penalty springs between a cable's sleeve point and its sleeve node
//! contacts     unilateral contacts (`contact.rs`): node pairs of two sheets, nodes against
//!              rigid surfaces, each with a multiplier stored after the ties'
//!              (triangles, segments, ties and contacts are the element kinds: `element.rs`)
//! loads        one per input: force per unit value, pressure triangles, prescribed DOFs
//! probes       one per output, with node ids and DOFs resolved
//! ```
//! "Model only what a scene needs": only the element kinds and loads the scene declares exist.

pub mod cable;
pub mod contact;
pub mod element;
pub mod etfe;
pub mod membrane;
pub mod orthotropic;
pub mod plane_stress;
pub mod pressure;
pub mod sleeve;
pub mod state;
pub mod wrinkling;

use crate::error::Error;
use crate::memory;
use crate::scene::generate::{try_resolve, Mesh};
use crate::scene::{
    CableEnd, Load, Material, OneNode, PolarComponent, Probe, Scene, SlipState, StrainLaw,
    TriangleRef as TriSel,
};
use nalgebra::Vector3;

pub use element::{Element, ElementKind, PerKind};

/// Default artificial prestress of a membrane group, as a fraction of its E (3μ for
/// neo-Hookean).
pub const AUTO_PRESTRESS_FRACTION: f64 = 1e-4;

#[derive(Clone, Debug)]
pub struct Triangle {
    /// Mesh triangle id (explicit triangles first, then generated ones).
    pub id: usize,
    pub nodes: [usize; 3],
    pub reference: membrane::TriangleRef,
    pub material: membrane::Material,
    /// Tangent-only artificial prestress, Pa.
    pub prestress: f64,
    /// Mass ρ t A₀ in kg (the group's `density`; 0: massless).
    pub mass: f64,
}

#[derive(Clone, Debug)]
pub struct Segment {
    pub nodes: [usize; 2],
    pub l0: f64,
    pub ea: f64,
    pub law: cable::Law,
    /// Slip unknowns (indices into `Model::slips`) at the start and end point: the unstretched
    /// length is `l0 + s_end − s_start` (material flows through sleeve points).
    pub slip: [Option<usize>; 2],
    /// Mass μ ℓ in kg, ℓ as drawn (the cable's `mass_per_length`; 0: massless).
    pub mass: f64,
}

impl Element for Triangle {
    fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    /// E t A |∇N_a|².
    fn reference_stiffness(&self, a: usize) -> f64 {
        let k = self.material.modulus() * self.material.thickness * self.reference.area;
        k * self.reference.grad[a].norm_squared()
    }

    /// ρ t A₀/3.
    fn lumped_mass(&self, _a: usize) -> f64 {
        self.mass / 3.0
    }

    /// ρ t A₀ (1 + δ_ab)/12 (∫ N_a N_b dA of the linear triangle).
    fn consistent_mass(&self, a: usize, b: usize) -> f64 {
        self.mass * if a == b { 2.0 } else { 1.0 } / 12.0
    }
}

impl Element for Segment {
    fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    /// EA/L0.
    fn reference_stiffness(&self, _a: usize) -> f64 {
        self.ea / self.l0
    }

    /// μ ℓ/2.
    fn lumped_mass(&self, _a: usize) -> f64 {
        self.mass / 2.0
    }

    /// μ ℓ (1 + δ_ab)/6 (∫ N_a N_b ds of the linear segment).
    fn consistent_mass(&self, a: usize, b: usize) -> f64 {
        self.mass * if a == b { 2.0 } else { 1.0 } / 6.0
    }
}

#[derive(Clone, Debug)]
pub struct CableInfo {
    pub name: String,
    /// Indices into `Model::segments`, in order along the cable.
    pub segments: std::ops::Range<usize>,
    /// Mesh node id of every cable point, in order (sleeve points: the sleeve node).
    pub mesh_nodes: Vec<usize>,
    /// Indices into `Model::slips` of this cable's sleeve points, in order.
    pub slips: Vec<usize>,
}

/// What one input does, per unit of its value.
#[derive(Clone, Debug)]
pub enum LoadModel {
    /// (dof, force per unit input value).
    PointForce(Vec<(usize, f64)>),
    /// Triangles (indices into `Model::triangles`) loaded by the pressure.
    Pressure {
        triangles: Vec<usize>,
        follower: bool,
    },
    /// Snow or ponding on triangles (indices into `Model::triangles`): loads that follow the
    /// current shape by a law of their own (`pressure::SurfaceLaw`), at the input's value.
    Surface {
        triangles: Vec<usize>,
        law: pressure::SurfaceLaw,
    },
    /// Prescribed DOFs and how the input's value moves them.
    Displacement(Prescribed),
    /// Prescribed enclosed volume V⁰ + value of a closed group (`Model::triangles` indices):
    /// a follower pressure whose value is the unknown `u[Model::volume_unknown(unknown)]`,
    /// with the constraint row `stiffness · (V(u) − V⁰ − value)` (N: `stiffness` = E t / A of
    /// the group, so the row is a force and meets the same tolerance as the others).
    ///
    /// With `atmosphere` (a gas input) the row is the isothermal gas law instead,
    /// `stiffness · ((p + p_atm) V(u)/p_atm − V⁰ − value)`.
    Volume {
        triangles: Vec<usize>,
        unknown: usize,
        reference: f64,
        stiffness: f64,
        atmosphere: Option<f64>,
    },
    /// Ponding with the water volume given (a `water_volume` input): the ponding load
    /// (`pressure::SurfaceLaw::Ponding`) on `triangles` at the level h = `datum` + the
    /// unknown `u[Model::volume_unknown(unknown)]` (numbered with the volume inputs'
    /// pressures), with the row `gamma_w · (V_w(u, h) − value)` (N: the weight of the water
    /// missing or in excess), V_w the water above the current surface up to h
    /// (`solver/volume.rs`). `datum`: the lowest reference z of the triangles' nodes, so the
    /// unknown 0 is the level of an empty region.
    Water {
        triangles: Vec<usize>,
        gamma_w: f64,
        unknown: usize,
        datum: f64,
    },
}

/// DOFs an input prescribes. Where several inputs prescribe one DOF their displacements add
/// (`Prescribed::add`): a rotation plus a translation, a radial plus a tangential component.
#[derive(Clone, Debug)]
pub struct Prescribed {
    pub dofs: Vec<usize>,
    pub motion: Motion,
}

/// The displacement a prescribing input gives per value.
#[derive(Clone, Debug)]
pub enum Motion {
    /// u[dof] = value (a `displacement` input: one global component).
    Component,
    /// Rigid rotation by the value (rad) about the unit `axis` through `point`.
    Rotation {
        point: Vector3<f64>,
        axis: Vector3<f64>,
    },
    /// value × e (m) with e the node's unit radial or tangential direction (per DOF: its
    /// component of e).
    Along(Vec<f64>),
}

impl Prescribed {
    /// Add this input's displacement at `value` to the prescribed DOFs of `u`.
    pub fn add(&self, reference: &[Vector3<f64>], value: f64, u: &mut [f64]) {
        match &self.motion {
            Motion::Component => {
                for &d in &self.dofs {
                    u[d] += value;
                }
            }
            Motion::Along(unit) => {
                for (&d, e) in self.dofs.iter().zip(unit) {
                    u[d] += value * e;
                }
            }
            Motion::Rotation { point, axis } => {
                let rotation = nalgebra::Rotation3::from_axis_angle(
                    &nalgebra::Unit::new_unchecked(*axis),
                    value,
                );
                for &d in &self.dofs {
                    let r = reference[d / 3] - point;
                    u[d] += (rotation * r - r)[d % 3];
                }
            }
        }
    }
}

/// What one output reads.
#[derive(Clone, Debug)]
pub enum ProbeModel {
    Displacement {
        dof: usize,
    },
    Position {
        dof: usize,
        reference: f64,
    },
    /// Length of the segments `segments` (indices into `Model::segments`).
    CableLength {
        segments: std::ops::Range<usize>,
    },
    /// Slip at a sleeve point (index into `Model::slips`).
    CableSlip {
        slip: usize,
    },
    /// Tie force at a sleeve point, or the largest over a cable's sleeve points.
    ContactForce {
        slips: Vec<usize>,
    },
    ContactGap {
        slips: Vec<usize>,
    },
    SlipCount {
        slips: Vec<usize>,
        slipping: bool,
    },
    CableTension {
        cable: usize,
        segment: Option<usize>,
    },
    Reaction {
        dofs: Vec<usize>,
    },
    /// Moment of the reactions at `nodes` about the unit `axis` through `point`.
    ReactionMoment {
        nodes: Vec<usize>,
        point: Vector3<f64>,
        axis: Vector3<f64>,
    },
    /// Displacement of `node` along the unit vector `unit`.
    Along {
        node: usize,
        unit: Vector3<f64>,
    },
    /// |Σ R| over the held DOFs of `nodes`.
    ReactionResultant {
        nodes: Vec<usize>,
    },
    /// Component `component` of the pressure loads' resultant on triangles `zone` (a mask
    /// over `Model::triangles`).
    ZoneForce {
        zone: Vec<bool>,
        component: usize,
    },
    NewtonIterations,
    /// Velocity and acceleration of one DOF (filled in by the engine from its state: 0 in a
    /// quasi-static scene).
    Velocity {
        dof: usize,
    },
    Acceleration {
        dof: usize,
    },
    /// ½ vᵀ M v (filled in by the engine).
    KineticEnergy,
    /// The elements' stored energy.
    StrainEnergy,
    /// The `mode`-th lowest natural frequency, Hz (filled in by the engine after each
    /// converged step: `Engine::modes`).
    NaturalFrequency {
        mode: usize,
    },
    /// Area fractions and principal-stress extremes over these triangles (`Model::triangles`
    /// indices).
    WrinkledFraction(Vec<usize>),
    SlackFraction(Vec<usize>),
    MaxPrincipalStress(Vec<usize>),
    MinPrincipalStress(Vec<usize>),
    ElementState(usize),
    /// Volume enclosed by these triangles (`Model::triangles` indices).
    EnclosedVolume(Vec<usize>),
    /// The pressure unknown of a volume input, or the level of a water volume (index among the
    /// volume unknowns; the value is `Model::unknown_value`).
    EnclosedPressure(usize),
    /// Σ p over the contact set's elements, or component `component` of Σ p ∇g at their
    /// first node (index into `Model::contacts`).
    ContactTotal {
        set: usize,
        component: Option<usize>,
    },
    /// Tributary area of the contact set's pressed nodes (index into `Model::contacts`).
    ContactArea(usize),
}

#[derive(Clone, Debug)]
pub struct Model {
    pub reference: Vec<Vector3<f64>>,
    pub triangles: Vec<Triangle>,
    pub segments: Vec<Segment>,
    pub cables: Vec<CableInfo>,
    pub slips: Vec<sleeve::SlipPoint>,
    pub ties: Vec<sleeve::Tie>,
    /// Unilateral contacts (`contact.rs`): sheet pairs, rigid points, and the scene's contact
    /// entries they come from.
    pub contact_pairs: Vec<contact::ContactPair>,
    pub contact_points: Vec<contact::ContactPoint>,
    pub contacts: Vec<contact::ContactSet>,
    pub loads: Vec<LoadModel>,
    pub probes: Vec<ProbeModel>,
    /// Per DOF: held (not an unknown of the solver).
    pub held: Vec<bool>,
    /// A force scale (N) for absolute convergence floors: the largest of E t h and EA.
    pub force_scale: f64,
    /// A length scale (m): the bounding-box diagonal of the used nodes.
    pub length_scale: f64,
    /// Pressure unknowns of volume inputs (stored after the slips).
    pub volumes: usize,
    /// Point masses (node, kg) of the scene's `dynamics` section, one entry per node and
    /// point-mass entry.
    pub point_masses: Vec<(usize, f64)>,
    /// The mass matrix the dynamics uses (consistent without a `dynamics` section).
    pub mass_kind: crate::scene::MassKind,
    /// The surrounding air (`dynamics.air`) per triangle of `triangles`: [added mass m_a A₀ in
    /// kg, damping c A₀ in N s/m], both along the triangle's reference normal; empty when the
    /// scene gives no air.
    pub air: Vec<[f64; 2]>,
    /// The committed plastic strains the assembly reads (`state.rs`; empty without an
    /// elastoplastic group).
    pub plastic: etfe::PlasticStore,
    /// The triangles of each membrane group (scene order) as a range of `triangles`.
    pub membrane_groups: Vec<std::ops::Range<usize>>,
}

impl Model {
    /// Build from a scene that passed validation (validation guarantees every reference
    /// resolves; this function does not re-check). For tools and tests: panics where
    /// [`Model::try_build`] errs.
    pub fn build(scene: &Scene) -> Model {
        Model::try_build(scene).unwrap_or_else(|e| panic!("a validated scene builds: {e}"))
    }

    /// Build the model of a validated scene; a triangle whose reference frame cannot be formed
    /// in floating point is a located problem (validation rejects these first), and memory
    /// that cannot be had is [`Error::Memory`]: the mesh and the model's arrays are reserved
    /// fallibly after a probe of the whole build (`crate::memory`).
    pub fn try_build(scene: &Scene) -> Result<Model, Error> {
        let _phase = crate::phases::start("Model::try_build");
        let mesh = try_resolve(&scene.geometry)?;
        let (nodes, triangles) = (mesh.nodes.len() as u64, mesh.triangles.len() as u64);
        // The arrays below, the per-group triangle lists and the loads' and probes' lists: at
        // most a few indices per node and per triangle besides the elements themselves.
        let probe = |bytes, what| match scene.debug.skip_memory_probes {
            true => Ok(()),
            false => memory::probe(bytes, what),
        };
        probe(
            triangles
                .saturating_mul(std::mem::size_of::<Triangle>() as u64 + 64)
                .saturating_add(nodes.saturating_mul(24 + 3 + 1 + 64)),
            "the model",
        )?;
        let mut reference: Vec<Vector3<f64>> = memory::collect(
            mesh.nodes.iter().map(|p| Vector3::from(*p)),
            "the model's nodes",
        )?;
        let mut used = memory::filled(reference.len(), false, "the model's nodes")?;
        let triangles = build_triangles(scene, &mesh, &reference, &mut used)?;
        let mut sleeves = Sleeves::default();
        let (segments, cables) = build_cables(
            scene,
            &mesh,
            &triangles,
            &mut reference,
            &mut used,
            &mut sleeves,
        );
        let n = reference.len();
        let mut held = memory::filled(3 * n, false, "the model's DOFs")?;
        for (node, u) in used.iter().enumerate() {
            if !u {
                held[3 * node..3 * node + 3].fill(true);
            }
        }
        for s in &scene.supports {
            for id in node_ids(&mesh, &s.nodes) {
                for c in &s.fix {
                    held[3 * id + c.index()] = true;
                }
            }
        }
        let mut loads: Vec<LoadModel> = Vec::new();
        for i in &scene.inputs {
            loads.extend(build_loads(scene, &mesh, &triangles, &i.load)?);
        }
        let mut volumes = 0;
        for l in &mut loads {
            if let LoadModel::Volume { unknown, .. } | LoadModel::Water { unknown, .. } = l {
                *unknown = volumes;
                volumes += 1;
            }
        }
        for l in &loads {
            if let LoadModel::Displacement(p) = l {
                for &d in &p.dofs {
                    held[d] = true;
                }
            }
        }
        let built_contacts = contact::build(
            scene,
            &mesh,
            &neighbouring(reference.len(), &triangles, &segments),
            &held,
        );
        let groups = group_ranges(scene, &mesh);
        let probes = scene
            .outputs
            .iter()
            .map(|o| build_probes(scene, &mesh, &cables, &sleeves.slips, &groups, &o.probe))
            .collect::<Result<Vec<Vec<ProbeModel>>, _>>()?
            .into_iter()
            .flatten()
            .collect();
        let force_scale = triangles
            .iter()
            .map(|t| t.material.modulus() * t.material.thickness * t.reference.area.sqrt())
            .chain(segments.iter().map(|s| s.ea))
            .fold(0.0, f64::max);
        let length_scale = bounding_diagonal(&reference, &used);
        let mut point_masses = Vec::new();
        for pm in scene.dynamics.iter().flat_map(|d| &d.point_masses) {
            point_masses.extend(node_ids(&mesh, &pm.nodes).into_iter().map(|i| (i, pm.mass)));
        }
        let air = build_air(scene, &groups, &triangles)?;
        let membrane_groups = groups.iter().map(|g| g.1.clone()).collect();
        Ok(Model {
            reference,
            triangles,
            segments,
            cables,
            slips: sleeves.slips,
            ties: sleeves.ties,
            contact_pairs: built_contacts.0,
            contact_points: built_contacts.1,
            contacts: built_contacts.2,
            loads,
            probes,
            held,
            force_scale,
            length_scale,
            volumes,
            point_masses,
            mass_kind: scene
                .dynamics
                .as_ref()
                .map_or_else(Default::default, |d| d.mass),
            plastic: Default::default(),
            air,
            membrane_groups,
        })
    }

    /// Length of the plastic history (`state::History::plastic`): 4 per triangle when a
    /// membrane group is elastoplastic, 0 otherwise.
    pub fn plastic_len(&self) -> usize {
        if self.triangles.iter().any(|t| t.material.plastic.is_some()) {
            4 * self.triangles.len()
        } else {
            0
        }
    }

    /// True when every load has a potential (no follower pressure).
    pub fn is_conservative(&self) -> bool {
        !self.loads.iter().any(|l| {
            matches!(
                l,
                LoadModel::Pressure { follower: true, .. }
                    | LoadModel::Volume { .. }
                    | LoadModel::Surface { .. }
                    | LoadModel::Water { .. }
            )
        })
    }

    /// Displacement DOFs: 3 per node.
    pub fn dof_count(&self) -> usize {
        3 * self.reference.len()
    }

    /// Length of the unknown vector: the displacements, then one slip per sleeve point, then
    /// one pressure per volume input, then the multiplier (3 components) of every sleeve tie.
    /// The multipliers are no Newton unknowns: they are held within a solve and updated
    /// between solves (`model::sleeve`, augmented Lagrangian), but they are part of the
    /// converged state and travel with it.
    pub fn unknown_count(&self) -> usize {
        self.contact_base() + self.contact_pairs.len() + self.contact_points.len()
    }

    /// Index in the unknown vector of the first contact multiplier (the pairs', then the rigid
    /// points'): after the ties' multipliers. Like those, held within a solve and updated
    /// between solves (`contact.rs`).
    pub fn contact_base(&self) -> usize {
        self.dof_count() + self.slips.len() + self.volumes + 3 * self.ties.len()
    }

    /// Index in the unknown vector of the first component of tie `t`'s multiplier.
    pub fn multiplier_index(&self, t: usize) -> usize {
        self.dof_count() + self.slips.len() + self.volumes + 3 * t
    }

    /// The multiplier λ (N) of tie `t` under `u`.
    pub fn tie_multiplier(&self, u: &[f64], t: usize) -> Vector3<f64> {
        let i = self.multiplier_index(t);
        Vector3::new(u[i], u[i + 1], u[i + 2])
    }

    /// Force (N) of tie `t` on its cable point under `u`: λ + k (x_c − x_m).
    pub fn tie_force(&self, u: &[f64], t: usize) -> Vector3<f64> {
        let tie = &self.ties[t];
        let [c, m] = tie.nodes;
        sleeve::augmented_tie_force(
            tie.k,
            &self.tie_multiplier(u, t),
            &self.position(u, c),
            &self.position(u, m),
        )
        .0
    }

    /// Index in the unknown vector of the pressure of volume input `k` (k-th volume input).
    pub fn volume_unknown(&self, k: usize) -> usize {
        self.dof_count() + self.slips.len() + k
    }

    /// The value load `l` applies under `u` and the input values `loads`: the input's value,
    /// except for a volume input, whose load is the pressure unknown, and a water volume,
    /// whose load is ponding at the level its unknown gives.
    pub fn load_value(&self, l: usize, u: &[f64], loads: &[f64]) -> f64 {
        match &self.loads[l] {
            LoadModel::Volume { unknown, .. } => u[self.volume_unknown(*unknown)],
            LoadModel::Water { unknown, datum, .. } => datum + u[self.volume_unknown(*unknown)],
            _ => loads[l],
        }
    }

    /// The value of the k-th volume unknown as its probe reads it: the pressure of a volume or
    /// gas input, the water level (datum + unknown) of a water volume.
    pub fn unknown_value(&self, u: &[f64], k: usize) -> f64 {
        let datum = self
            .loads
            .iter()
            .find_map(|l| match l {
                LoadModel::Water { unknown, datum, .. } if *unknown == k => Some(*datum),
                _ => None,
            })
            .unwrap_or(0.0);
        datum + u[self.volume_unknown(k)]
    }

    /// Volume enclosed by triangles `tris` (`Model::triangles` indices) under `u`.
    pub fn enclosed_volume(&self, u: &[f64], tris: &[usize]) -> f64 {
        tris.iter()
            .map(|&e| {
                let x = self.triangles[e].nodes.map(|i| self.position(u, i));
                pressure::enclosed_volume(&x)
            })
            .sum()
    }

    /// Current unstretched length of segment `e` (its reference one plus the material that
    /// slipped in through its ends).
    pub fn segment_l0(&self, u: &[f64], e: usize) -> f64 {
        let s = &self.segments[e];
        let slip = |k: Option<usize>| k.map_or(0.0, |j| u[self.dof_count() + j]);
        s.l0 + slip(s.slip[1]) - slip(s.slip[0])
    }

    /// Whether segment `e` is closed: it joins two sleeve points of its cable that touch, and
    /// its unstretched length is held at −`sleeve::CLOSED_OFFSET`·l0 (`solver::order`).
    pub fn segment_closed(&self, u: &[f64], e: usize) -> bool {
        let s = &self.segments[e];
        s.slip[0].is_some() && s.slip[1].is_some() && self.segment_l0(u, e) < 0.0
    }

    /// Stiffness (N/m) of the link that holds the two cable points of a closed segment
    /// together: `sleeve::LINK_FACTOR` times the stiffer of their ties.
    pub fn link_stiffness(&self, e: usize) -> f64 {
        let s = &self.segments[e];
        let k = |j: Option<usize>| j.map_or(0.0, |j| self.ties[self.slips[j].tie].k);
        sleeve::LINK_FACTOR * k(s.slip[0]).max(k(s.slip[1]))
    }

    /// Axial force (N) of segment `e` under `u` (displacements, then slips). A closed segment
    /// (between touching sleeve points) has no length of its own; it reports the tension of the
    /// cable entering its group (the last open segment before it).
    pub fn segment_tension(&self, u: &[f64], e: usize) -> f64 {
        let mut e = e;
        // A closed segment starts at a sleeve point, never at the cable's first point, so
        // e − 1 is a segment of the same cable.
        while e > 0 && self.segment_closed(u, e) {
            e -= 1;
        }
        let s = &self.segments[e];
        let l = (self.position(u, s.nodes[1]) - self.position(u, s.nodes[0])).norm();
        cable::tension(s.law, s.ea, self.segment_l0(u, e), l).0
    }

    /// Current position of a node under displacement `u`.
    pub fn position(&self, u: &[f64], node: usize) -> Vector3<f64> {
        self.reference[node] + Vector3::new(u[3 * node], u[3 * node + 1], u[3 * node + 2])
    }
}

/// The element kinds' storage (`element.rs`).
impl Model {
    /// Number of elements of `kind`.
    pub fn element_count(&self, kind: ElementKind) -> usize {
        match kind {
            ElementKind::Membrane => self.triangles.len(),
            ElementKind::Cable => self.segments.len(),
            ElementKind::Tie => self.ties.len(),
            ElementKind::ContactPair => self.contact_pairs.len(),
            ElementKind::ContactPoint => self.contact_points.len(),
        }
    }

    /// Element `e` of `kind`.
    pub fn element(&self, kind: ElementKind, e: usize) -> &dyn Element {
        match kind {
            ElementKind::Membrane => &self.triangles[e],
            ElementKind::Cable => &self.segments[e],
            ElementKind::Tie => &self.ties[e],
            ElementKind::ContactPair => &self.contact_pairs[e],
            ElementKind::ContactPoint => &self.contact_points[e],
        }
    }

    /// Nodes of element `e` of `kind`.
    pub fn element_nodes(&self, kind: ElementKind, e: usize) -> &[usize] {
        self.element(kind, e).nodes()
    }

    /// Every element of the model with its kind, kind by kind in the order of
    /// [`ElementKind::ALL`], each kind in model order.
    pub fn elements(&self) -> impl Iterator<Item = (ElementKind, usize)> + '_ {
        ElementKind::ALL
            .into_iter()
            .flat_map(move |kind| (0..self.element_count(kind)).map(move |e| (kind, e)))
    }
}

/// The neighbouring stiffness of every node (N/m): the diagonal stiffness its membrane
/// triangles and cable segments give it if taut (`Element::reference_stiffness`): the
/// contacts' penalty scale (`contact.rs`).
fn neighbouring(n: usize, triangles: &[Triangle], segments: &[Segment]) -> Vec<f64> {
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

type Vec6 = nalgebra::SVector<f64, 6>;
type Mat6 = nalgebra::SMatrix<f64, 6, 6>;

/// The contacts' kernels and outputs (`contact.rs`).
impl Model {
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
        let (g, grad, hess) = contact::pair_gap(c, &self.position(u, t), &self.position(u, b));
        let lambda = u[self.pair_multiplier_index(e)];
        contact::augmented(lambda, c.k, g, &grad, &hess)
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
        contact::augmented(lambda, c.k, g, &grad, &hess)
    }

    /// Every contact's state at `u`: the pairs, then the rigid points.
    pub fn contact_states<'a>(
        &'a self,
        u: &'a [f64],
    ) -> impl Iterator<Item = contact::ContactState> + 'a {
        let pairs = self.contact_pairs.iter().enumerate().map(move |(e, c)| {
            let [t, b] = c.nodes;
            let index = self.pair_multiplier_index(e);
            contact::ContactState {
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
            contact::ContactState {
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

pub use crate::scene::shape::node_ids;

fn one_node(mesh: &Mesh, r: &OneNode) -> usize {
    match r {
        OneNode::Id(id) => *id,
        OneNode::Set(name) => mesh.node_sets[name][0],
    }
}

use crate::scene::shape;

pub fn triangle_ids<'a>(mesh: &'a Mesh, r: &'a TriSel) -> &'a [usize] {
    match r {
        TriSel::Ids(ids) => ids,
        TriSel::Set(name) => &mesh.triangle_sets[name],
    }
}

/// Membrane elements, group by group.
fn build_triangles(
    scene: &Scene,
    mesh: &Mesh,
    x: &[Vector3<f64>],
    used: &mut [bool],
) -> Result<Vec<Triangle>, Error> {
    let total = scene
        .membranes
        .iter()
        .map(|m| match &m.triangles {
            TriSel::Ids(ids) => ids.len(),
            TriSel::Set(name) => mesh.triangle_sets.get(name).map_or(0, Vec::len),
        })
        .sum();
    let mut out = memory::with_capacity(total, "the model's membrane elements")?;
    for m in &scene.membranes {
        let law = match m.material {
            Material::Svk { young, nu } => wrinkling::Law::Svk { young, nu },
            Material::NeoHookean { mu } => wrinkling::Law::NeoHookean { mu },
            Material::Etfe { young, nu, .. } => wrinkling::Law::Svk { young, nu },
            // The warp angle is set per triangle below.
            Material::Orthotropic {
                e_warp,
                e_fill,
                nu_wf,
                g,
                ..
            } => wrinkling::Law::Orthotropic(orthotropic::Orthotropic::new(
                e_warp, e_fill, nu_wf, g, 0.0,
            )),
        };
        let material = membrane::Material {
            law,
            thickness: m.thickness,
            wrinkling: m.wrinkling,
            residual: m.residual_stiffness.unwrap_or(0.0),
            plastic: match m.material {
                Material::Etfe {
                    young,
                    yield_stress,
                    second_yield_stress,
                    second_yield_strain,
                    tangent_modulus,
                    ..
                } => Some(etfe::Etfe {
                    hardening: etfe::Hardening::from_curve(
                        young,
                        yield_stress,
                        (second_yield_strain, second_yield_stress),
                        tangent_modulus,
                    ),
                    slot: 0,
                }),
                _ => None,
            },
        };
        let first = out.len();
        for (k, &t) in triangle_ids(mesh, &m.triangles).iter().enumerate() {
            let nodes = mesh.triangles[t];
            let Some(reference) = membrane::triangle_ref(nodes.map(|i| x[i])) else {
                return Err(Error::Scene(vec![crate::scene::Problem {
                    path: format!("membranes[{}].triangles", group_index(scene, m)),
                    message: format!(
                        "triangle {t} (nodes {nodes:?}) has zero area in floating point"
                    ),
                }]));
            };
            for &i in &nodes {
                used[i] = true;
            }
            let mut material = material;
            if let Some(p) = &mut material.plastic {
                // The triangle's place in the plastic history: its model index.
                p.slot = out.len();
            }
            if let (
                wrinkling::Law::Orthotropic(o),
                Material::Orthotropic {
                    warp, warp_axis, ..
                },
            ) = (material.law, &m.material)
            {
                // A radial warp is taken at the centroid (validation: off the axis).
                let c = nodes.map(|i| x[i]).iter().sum::<Vector3<f64>>() / 3.0;
                let radial = warp_axis.as_ref().and_then(|a| a.radial(c.into()));
                let w = Vector3::from(radial.unwrap_or(*warp));
                let angle = w.dot(&reference.frame[1]).atan2(w.dot(&reference.frame[0]));
                material.law = wrinkling::Law::Orthotropic(orthotropic::Orthotropic::new(
                    o.e_warp, o.e_fill, o.nu_wf, o.g, angle,
                ));
            }
            let mut reference = reference;
            if let Some(pre) = &m.prestress {
                let at = (group_index(scene, m), t);
                let c = nodes.map(|i| x[i]).iter().sum::<Vector3<f64>>() / 3.0;
                reference.initial_strain =
                    prestress_strain(at, k, m, &material, pre, &reference, c.into())?;
            }
            let mass = m
                .density
                .map_or(0.0, |rho| rho * m.thickness * reference.area);
            out.push(Triangle {
                id: t,
                nodes,
                reference,
                material,
                prestress: 0.0,
                mass,
            });
        }
        // Every group, flat or curved, gets the same tangent-only artificial prestress: each
        // facet of a curved group (a cylinder of flat facets, a tube's flat cap) has the
        // singular out-of-plane tangent of a flat sheet while it is unstressed.
        let prestress = scene
            .solver
            .artificial_prestress
            .unwrap_or(AUTO_PRESTRESS_FRACTION * material.modulus());
        for t in &mut out[first..] {
            t.prestress = prestress;
        }
    }
    Ok(out)
}

fn group_index(scene: &Scene, m: &crate::scene::Membrane) -> usize {
    scene
        .membranes
        .iter()
        .position(|g| std::ptr::eq(g, m))
        .unwrap_or(0)
}

/// Equivalent initial strain of a group's prestress on its `k`-th triangle
/// (`membrane::initial_strain`). Where there is none, a scene problem at
/// `membranes[group].prestress` naming triangle `t` (its mesh id).
fn prestress_strain(
    (group, t): (usize, usize),
    k: usize,
    m: &crate::scene::Membrane,
    material: &membrane::Material,
    pre: &crate::scene::Prestress,
    r: &membrane::TriangleRef,
    centroid: [f64; 3],
) -> Result<Vector3<f64>, Error> {
    let problem = |message: String| {
        Error::Scene(vec![crate::scene::Problem {
            path: format!("membranes[{group}].prestress"),
            message: format!("triangle {t}: {message}"),
        }])
    };
    let s0 = if let crate::scene::Prestress::Field { n } = pre {
        membrane::field_stress(r, &n[k], m.thickness)
    } else {
        let (warp, fill, dir) = pre
            .at(centroid)
            .ok_or_else(|| problem("its centroid lies on the prestress's axis".to_string()))?;
        membrane::initial_stress(r, warp, fill, &Vector3::from(dir), m.thickness)
            .ok_or_else(|| problem(format!("the warp direction {dir:?} is normal to its plane")))?
    };
    membrane::initial_strain(material, &s0).ok_or_else(|| {
        problem(format!(
            "the material cannot carry the initial stress {s0:?} Pa (PK2, element frame)"
        ))
    })
}

/// Sleeve points and ties collected while the cables are built.
#[derive(Default)]
struct Sleeves {
    slips: Vec<sleeve::SlipPoint>,
    ties: Vec<sleeve::Tie>,
}

fn build_cables(
    scene: &Scene,
    mesh: &Mesh,
    triangles: &[Triangle],
    x: &mut Vec<Vector3<f64>>,
    used: &mut Vec<bool>,
    sleeves: &mut Sleeves,
) -> (Vec<Segment>, Vec<CableInfo>) {
    let mut segments = Vec::new();
    let mut cables = Vec::new();
    for c in &scene.cables {
        let ids = node_ids(mesh, &c.nodes);
        let law = match c.strain {
            StrainLaw::Engineering => cable::Law::Engineering,
            StrainLaw::GreenLagrange => cable::Law::GreenLagrange,
        };
        let lengths: Vec<f64> = ids.windows(2).map(|w| (x[w[1]] - x[w[0]]).norm()).collect();
        let total: f64 = lengths.iter().sum();
        let sleeved = c
            .sleeve
            .as_ref()
            .and_then(|sl| crate::scene::shape::sleeve_nodes(&ids, sl, mesh))
            .unwrap_or_default();
        // Cable points: a sleeve node gets its own point (a new node at the same place).
        let mut points = ids.clone();
        let mut slip_of_point = vec![None; ids.len()];
        let cable_index = cables.len();
        let first_slip = sleeves.slips.len();
        for (k, id) in ids.iter().enumerate() {
            if k == 0 || k + 1 == ids.len() || !sleeved.contains(id) {
                continue;
            }
            let sl = c.sleeve.as_ref().expect("sleeved nodes come from a sleeve");
            let point = x.len();
            x.push(x[*id]);
            used.push(true);
            used[*id] = true;
            points[k] = point;
            let j = sleeves.slips.len();
            slip_of_point[k] = Some(j);
            let shortest = lengths[k - 1].min(lengths[k]);
            // A penalty softer than what it ties only slows the multipliers' closure of the
            // gap (model/sleeve.rs): Newton uses at least the neighbouring stiffness.
            let neighbours = neighbour_stiffness(c.ea, shortest, *id, triangles);
            let k_tie = sl
                .penalty
                .map_or(sleeve::PENALTY_FACTOR * neighbours, |k| k.max(neighbours));
            sleeves.ties.push(sleeve::Tie {
                nodes: [point, *id],
                k: k_tie,
            });
            let seg0 = segments.len() + k - 1;
            sleeves.slips.push(sleeve::SlipPoint {
                node: point,
                membrane: *id,
                prev: 0,
                next: 0,
                segments: [seg0, seg0 + 1],
                mu: sl.mu,
                tie: sleeves.ties.len() - 1,
                cable: cable_index,
            });
        }
        for j in first_slip..sleeves.slips.len() {
            let k = slip_of_point
                .iter()
                .position(|s| *s == Some(j))
                .expect("own point");
            sleeves.slips[j].prev = points[k - 1];
            sleeves.slips[j].next = points[k + 1];
        }
        let start = segments.len();
        for (k, w) in points.windows(2).enumerate() {
            let l = lengths[k];
            let l0 = match (c.pretension, c.unstretched_length, &c.pretensions) {
                (_, Some(l0_total), _) => l0_total * l / total,
                (_, None, Some(t)) => cable::unstretched_length(law, c.ea, l, t[k]),
                (t0, None, None) => cable::unstretched_length(law, c.ea, l, t0.unwrap_or(0.0)),
            };
            used[w[0]] = true;
            used[w[1]] = true;
            segments.push(Segment {
                nodes: [w[0], w[1]],
                l0,
                ea: c.ea,
                law,
                slip: [slip_of_point[k], slip_of_point[k + 1]],
                mass: c.mass_per_length.map_or(0.0, |mu| mu * l),
            });
        }
        cables.push(CableInfo {
            name: c.name.clone(),
            segments: start..segments.len(),
            mesh_nodes: ids,
            slips: (first_slip..sleeves.slips.len()).collect(),
        });
    }
    (segments, cables)
}

/// The stiffness (N/m) of what a tie joins: `max(EA/ℓ, E t)` over the membranes at `node`. The
/// default penalty is `PENALTY_FACTOR` times it, and a penalty given is raised to it.
fn neighbour_stiffness(ea: f64, segment: f64, node: usize, triangles: &[Triangle]) -> f64 {
    let et = triangles
        .iter()
        .filter(|t| t.nodes.contains(&node))
        .map(|t| t.material.modulus() * t.material.thickness)
        .fold(0.0, f64::max);
    (ea / segment).max(et)
}

/// (group name, range of `Model::triangles` indices, mesh triangle ids) per membrane group.
/// Per triangle [m_a A₀, c A₀] of the scene's `dynamics.air` (empty without it).
fn build_air(
    scene: &Scene,
    groups: &[(String, std::ops::Range<usize>, &[usize])],
    triangles: &[Triangle],
) -> Result<Vec<[f64; 2]>, crate::memory::OutOfMemory> {
    let entries = scene.dynamics.iter().flat_map(|d| &d.air);
    let mut air = Vec::new();
    for entry in entries {
        if air.is_empty() {
            air = memory::filled(triangles.len(), [0.0; 2], "the air's added mass")?;
        }
        for (name, range, _) in groups {
            if *name == entry.membrane {
                let slots = air.get_mut(range.clone()).unwrap_or_default();
                for (slot, t) in slots
                    .iter_mut()
                    .zip(triangles.get(range.clone()).unwrap_or_default())
                {
                    let area = t.reference.area;
                    *slot = [entry.added_mass * area, entry.damping * area];
                }
            }
        }
    }
    Ok(air)
}

fn group_ranges<'a>(
    scene: &'a Scene,
    mesh: &'a Mesh,
) -> Vec<(String, std::ops::Range<usize>, &'a [usize])> {
    let mut first = 0;
    scene
        .membranes
        .iter()
        .map(|m| {
            let ids = triangle_ids(mesh, &m.triangles);
            let range = first..first + ids.len();
            first = range.end;
            (m.name.clone(), range, ids)
        })
        .collect()
}

/// The load channels of one input: one for a scalar input, one per element (row-major) for
/// an array input (`scene::shape`).
/// A pressure's triangle list is as long as its group: allocated fallibly (`crate::memory`).
fn build_loads(
    scene: &Scene,
    mesh: &Mesh,
    triangles: &[Triangle],
    load: &Load,
) -> Result<Vec<LoadModel>, crate::memory::OutOfMemory> {
    const WHAT: &str = "a pressure input's triangle list";
    let loaded = |membrane: &str, zone: Option<&str>| {
        let range = group_ranges(scene, mesh)
            .into_iter()
            .find(|g| g.0 == membrane)
            .map(|g| g.1)
            .expect("validated group");
        debug_assert!(range.end <= triangles.len());
        match zone {
            None => crate::memory::collect(range, WHAT),
            Some(_) => crate::memory::collect(
                shape::zone_positions(scene, mesh, membrane, zone)
                    .into_iter()
                    .map(|k| range.start + k),
                WHAT,
            ),
        }
    };
    let pressure = |membrane: &str, zone: Option<&str>, follower: bool| {
        Ok::<_, crate::memory::OutOfMemory>(LoadModel::Pressure {
            triangles: loaded(membrane, zone)?,
            follower,
        })
    };
    Ok(match load {
        Load::Pressure {
            membrane,
            zone,
            follower,
        } => vec![pressure(membrane, zone.as_deref(), *follower)?],
        Load::Snow { membrane, zone } => vec![LoadModel::Surface {
            triangles: loaded(membrane, zone.as_deref())?,
            law: pressure::SurfaceLaw::Snow,
        }],
        Load::Ponding {
            membrane,
            zone,
            gamma_w,
        } => vec![LoadModel::Surface {
            triangles: loaded(membrane, zone.as_deref())?,
            law: pressure::SurfaceLaw::Ponding { gamma_w: *gamma_w },
        }],
        Load::WaterVolume {
            membrane,
            zone,
            gamma_w,
        } => {
            let list = loaded(membrane, zone.as_deref())?;
            let datum = list
                .iter()
                .flat_map(|&e| triangles[e].nodes)
                .map(|i| mesh.nodes[i][2])
                .fold(f64::INFINITY, f64::min);
            vec![LoadModel::Water {
                triangles: list,
                gamma_w: *gamma_w,
                unknown: 0,
                datum: if datum.is_finite() { datum } else { 0.0 },
            }]
        }
        Load::ZonePressure {
            membrane,
            zones,
            follower,
        } => zones
            .iter()
            .map(|z| pressure(membrane, Some(z), *follower))
            .collect::<Result<Vec<_>, _>>()?,
        Load::SupportDisplacement { nodes } => node_ids(mesh, nodes)
            .iter()
            .flat_map(|&i| {
                (0..3).map(move |c| {
                    LoadModel::Displacement(Prescribed {
                        dofs: vec![3 * i + c],
                        motion: Motion::Component,
                    })
                })
            })
            .collect(),
        _ => vec![build_load(scene, mesh, triangles, load)?],
    })
}

/// The one load channel of a scalar input other than a pressure.
fn build_load(
    scene: &Scene,
    mesh: &Mesh,
    triangles: &[Triangle],
    load: &Load,
) -> Result<LoadModel, crate::memory::OutOfMemory> {
    Ok(match load {
        Load::PointForce { nodes, direction } => {
            let ids = node_ids(mesh, nodes);
            let d = Vector3::from(*direction).normalize() / ids.len() as f64;
            LoadModel::PointForce(
                ids.iter()
                    .flat_map(|&i| (0..3).map(move |c| (3 * i + c, d[c])))
                    .filter(|(_, f)| *f != 0.0)
                    .collect(),
            )
        }
        Load::Displacement { nodes, component } => LoadModel::Displacement(Prescribed {
            dofs: node_ids(mesh, nodes)
                .iter()
                .map(|&i| 3 * i + component.index())
                .collect(),
            motion: Motion::Component,
        }),
        Load::Rotation { nodes, point, axis } => LoadModel::Displacement(Prescribed {
            dofs: node_ids(mesh, nodes)
                .iter()
                .flat_map(|&i| (0..3).map(move |c| 3 * i + c))
                .collect(),
            motion: Motion::Rotation {
                point: Vector3::from(*point),
                axis: Vector3::from(*axis).normalize(),
            },
        }),
        Load::PolarDisplacement {
            nodes,
            center,
            axis,
            component,
        } => {
            let k = axis.index();
            let mut a = Vector3::zeros();
            a[k] = 1.0;
            let (mut dofs, mut unit) = (Vec::new(), Vec::new());
            for i in node_ids(mesh, nodes) {
                let r = Vector3::from(mesh.nodes[i]) - Vector3::from(*center);
                let radial = (r - a * r[k]).normalize();
                let e = match component {
                    PolarComponent::Radial => radial,
                    PolarComponent::Tangential => a.cross(&radial),
                };
                for c in (0..3).filter(|&c| c != k) {
                    dofs.push(3 * i + c);
                    unit.push(e[c]);
                }
            }
            LoadModel::Displacement(Prescribed {
                dofs,
                motion: Motion::Along(unit),
            })
        }
        Load::Volume { membrane } | Load::Gas { membrane, .. } => {
            let range = group_ranges(scene, mesh)
                .into_iter()
                .find(|g| &g.0 == membrane)
                .map(|g| g.1)
                .expect("validated group");
            let tris = &triangles[range.clone()];
            let area: f64 = tris.iter().map(|t| t.reference.area).sum();
            let et = tris
                .iter()
                .map(|t| t.material.modulus() * t.material.thickness)
                .fold(0.0, f64::max);
            let reference = tris
                .iter()
                .map(|t| {
                    let x = t.nodes.map(|i| Vector3::from(mesh.nodes[i]));
                    pressure::enclosed_volume(&x)
                })
                .sum();
            LoadModel::Volume {
                triangles: crate::memory::collect(range, "a volume input's triangle list")?,
                unknown: 0,
                reference,
                stiffness: et / area,
                atmosphere: match load {
                    Load::Gas { atmosphere, .. } => Some(*atmosphere),
                    _ => None,
                },
            }
        }
        Load::RadialEdgeLoad {
            nodes,
            center,
            closed,
        } => radial_edge_load(
            mesh,
            &node_ids(mesh, nodes),
            Vector3::from(*center),
            *closed,
        ),
        Load::SelfWeight { direction } => self_weight(scene, mesh, triangles, direction)?,
        Load::Pressure { .. }
        | Load::ZonePressure { .. }
        | Load::SupportDisplacement { .. }
        | Load::Snow { .. }
        | Load::Ponding { .. }
        | Load::WaterVolume { .. } => {
            unreachable!("built by build_loads")
        }
    })
}

/// Nodal forces per unit of gravitational acceleration (m/s²) along `direction`: a third of
/// each massive triangle's mass ρ t A₀ to each of its nodes, half of each massive cable
/// segment's μ ℓ (ℓ as drawn) to each end.
fn self_weight(
    scene: &Scene,
    mesh: &Mesh,
    triangles: &[Triangle],
    direction: &[f64; 3],
) -> Result<LoadModel, crate::memory::OutOfMemory> {
    let d = Vector3::from(*direction).normalize();
    let mut mass: Vec<f64> =
        crate::memory::zeros(mesh.nodes.len(), "the self weight's nodal masses")?;
    for ((_, range, _), m) in group_ranges(scene, mesh).into_iter().zip(&scene.membranes) {
        let Some(rho) = m.density else {
            continue;
        };
        for t in &triangles[range] {
            let share = rho * t.material.thickness * t.reference.area / 3.0;
            for &i in &t.nodes {
                mass[i] += share;
            }
        }
    }
    for cable in &scene.cables {
        let Some(mu) = cable.mass_per_length else {
            continue;
        };
        let ids = node_ids(mesh, &cable.nodes);
        for w in ids.windows(2) {
            let l = (Vector3::from(mesh.nodes[w[1]]) - Vector3::from(mesh.nodes[w[0]])).norm();
            mass[w[0]] += 0.5 * mu * l;
            mass[w[1]] += 0.5 * mu * l;
        }
    }
    let mut forces = Vec::new();
    for (i, &m) in mass.iter().enumerate() {
        for c in 0..3 {
            if m != 0.0 && d[c] != 0.0 {
                forces.push((3 * i + c, m * d[c]));
            }
        }
    }
    Ok(LoadModel::PointForce(forces))
}

/// Nodal forces per unit edge load (N/m): half of each segment's reference length to each end
/// node, along the node's radial direction from `center` (projected on nothing: 3-D radial).
fn radial_edge_load(mesh: &Mesh, ids: &[usize], center: Vector3<f64>, closed: bool) -> LoadModel {
    let x = |i: usize| Vector3::from(mesh.nodes[i]);
    let mut length = vec![0.0; ids.len()];
    let segments = if closed { ids.len() } else { ids.len() - 1 };
    for k in 0..segments {
        let (a, b) = (k, (k + 1) % ids.len());
        let l = (x(ids[b]) - x(ids[a])).norm();
        length[a] += 0.5 * l;
        length[b] += 0.5 * l;
    }
    let mut forces = Vec::new();
    for (k, &i) in ids.iter().enumerate() {
        let radial = x(i) - center;
        let dir = if radial.norm() > 0.0 {
            radial.normalize()
        } else {
            Vector3::zeros()
        };
        for c in 0..3 {
            if dir[c] != 0.0 {
                forces.push((3 * i + c, dir[c] * length[k]));
            }
        }
    }
    LoadModel::PointForce(forces)
}

type Groups<'a> = [(String, std::ops::Range<usize>, &'a [usize])];

/// Model triangle indices of a membrane group, or of every group (None).
fn group_elements(groups: &Groups, name: &Option<String>) -> Vec<usize> {
    groups
        .iter()
        .filter(|g| name.as_ref().is_none_or(|n| n == &g.0))
        .flat_map(|g| g.1.clone())
        .collect()
}

/// Index of a (validated) cable name.
fn cable_position(cables: &[CableInfo], name: &str) -> usize {
    cables
        .iter()
        .position(|c| c.name == name)
        .expect("validated cable name")
}

/// The probes of one output: one for a scalar output, one per element (row-major) for an
/// array output (`scene::shape`).
fn build_probes(
    scene: &Scene,
    mesh: &Mesh,
    cables: &[CableInfo],
    slips: &[sleeve::SlipPoint],
    groups: &Groups,
    probe: &Probe,
) -> Result<Vec<ProbeModel>, crate::memory::OutOfMemory> {
    let elements = |name: &Option<String>| group_elements(groups, name);
    let cable = |name: &str| cable_position(cables, name);
    Ok(match probe {
        Probe::DisplacementField { nodes } => shape::field_nodes(mesh, nodes)
            .into_iter()
            .flat_map(|i| (0..3).map(move |c| ProbeModel::Displacement { dof: 3 * i + c }))
            .collect(),
        Probe::PositionField { nodes } => shape::field_nodes(mesh, nodes)
            .into_iter()
            .flat_map(|i| {
                (0..3).map(move |c| ProbeModel::Position {
                    dof: 3 * i + c,
                    reference: mesh.nodes[i][c],
                })
            })
            .collect(),
        Probe::CableTensions { cable: name } => {
            let k = cable(name);
            (0..cables[k].segments.len())
                .map(|s| ProbeModel::CableTension {
                    cable: k,
                    segment: Some(s),
                })
                .collect()
        }
        Probe::PrincipalStresses { membrane } => elements(membrane)
            .into_iter()
            .flat_map(|e| {
                [
                    ProbeModel::MaxPrincipalStress(vec![e]),
                    ProbeModel::MinPrincipalStress(vec![e]),
                ]
            })
            .collect(),
        Probe::WrinkleStates { membrane } => elements(membrane)
            .into_iter()
            .map(ProbeModel::ElementState)
            .collect(),
        Probe::SleeveSlips { cable: name } => cables[cable(name)]
            .slips
            .iter()
            .map(|&slip| ProbeModel::CableSlip { slip })
            .collect(),
        _ => vec![build_probe(scene, mesh, cables, slips, groups, probe)?],
    })
}

/// The one probe of a scalar output.
fn build_probe(
    scene: &Scene,
    mesh: &Mesh,
    cables: &[CableInfo],
    slips: &[sleeve::SlipPoint],
    groups: &Groups<'_>,
    probe: &Probe,
) -> Result<ProbeModel, crate::memory::OutOfMemory> {
    // A probe over a membrane group lists its triangles: as long as the mesh, so fallible.
    let elements = |name: &Option<String>| -> Result<Vec<usize>, crate::memory::OutOfMemory> {
        let chosen = || {
            groups
                .iter()
                .filter(|g| name.as_ref().is_none_or(|n| n == &g.0))
        };
        let total = chosen().map(|g| g.1.len()).sum();
        let mut list = crate::memory::with_capacity(total, "a probe's triangle list")?;
        list.extend(chosen().flat_map(|g| g.1.clone()));
        Ok(list)
    };
    let cable_index = |name: &str| cable_position(cables, name);
    Ok(match probe {
        Probe::Displacement { node, component } => ProbeModel::Displacement {
            dof: 3 * one_node(mesh, node) + component.index(),
        },
        Probe::PolarDisplacement {
            node,
            center,
            axis,
            component,
        } => {
            let id = one_node(mesh, node);
            let k = axis.index();
            let mut a = Vector3::zeros();
            a[k] = 1.0;
            let r = Vector3::from(mesh.nodes[id]) - Vector3::from(*center);
            let radial = (r - a * r[k]).normalize();
            ProbeModel::Along {
                node: id,
                unit: match component {
                    PolarComponent::Radial => radial,
                    PolarComponent::Tangential => a.cross(&radial),
                },
            }
        }
        Probe::Position { node, component } => {
            let id = one_node(mesh, node);
            ProbeModel::Position {
                dof: 3 * id + component.index(),
                reference: mesh.nodes[id][component.index()],
            }
        }
        Probe::CableLength { cable, from, to } => {
            let c = &cables[cable_index(cable)];
            let point = |r: &Option<OneNode>, default: usize| {
                r.as_ref().map_or(default, |r| {
                    let id = one_node(mesh, r);
                    c.mesh_nodes
                        .iter()
                        .position(|&i| i == id)
                        .expect("validated: a node of the cable")
                })
            };
            let (a, b) = (point(from, 0), point(to, c.mesh_nodes.len() - 1));
            ProbeModel::CableLength {
                segments: c.segments.start + a..c.segments.start + b,
            }
        }
        Probe::CableSlip { cable, node } => {
            let id = one_node(mesh, node);
            let c = &cables[cable_index(cable)];
            ProbeModel::CableSlip {
                slip: *c
                    .slips
                    .iter()
                    .find(|&&j| slips[j].membrane == id)
                    .expect("validated: a sleeve node"),
            }
        }
        Probe::CableEndSlip { cable, end } => {
            let c = &cables[cable_index(cable)];
            let j = match end {
                CableEnd::Start => c.slips.first(),
                CableEnd::End => c.slips.last(),
            };
            ProbeModel::CableSlip {
                slip: *j.expect("validated: the cable has a sleeve point"),
            }
        }
        Probe::ContactForce { cable, node } => {
            let c = &cables[cable_index(cable)];
            let slips = match node {
                Some(r) => {
                    let id = one_node(mesh, r);
                    c.slips
                        .iter()
                        .copied()
                        .filter(|&j| slips[j].membrane == id)
                        .collect()
                }
                None => c.slips.clone(),
            };
            ProbeModel::ContactForce { slips }
        }
        Probe::ContactGap { cable } => ProbeModel::ContactGap {
            slips: cables[cable_index(cable)].slips.clone(),
        },
        Probe::SlipCount { cable, state } => ProbeModel::SlipCount {
            slips: cables[cable_index(cable)].slips.clone(),
            slipping: *state == SlipState::Slip,
        },
        Probe::CableTension { cable, segment } => ProbeModel::CableTension {
            cable: cable_index(cable),
            segment: *segment,
        },
        Probe::Reaction { nodes, component } => ProbeModel::Reaction {
            dofs: node_ids(mesh, nodes)
                .iter()
                .map(|&i| 3 * i + component.index())
                .collect(),
        },
        Probe::ReactionMoment { nodes, point, axis } => ProbeModel::ReactionMoment {
            nodes: node_ids(mesh, nodes),
            point: Vector3::from(*point),
            axis: Vector3::from(*axis).normalize(),
        },
        Probe::ReactionResultant { nodes } => ProbeModel::ReactionResultant {
            nodes: node_ids(mesh, nodes),
        },
        Probe::ZoneForce { zone, component } => {
            let total = groups.iter().map(|g| g.1.end).max().unwrap_or(0);
            let mut mask = crate::memory::with_capacity(total, "a zone's triangle mask")?;
            mask.resize(total, false);
            let set: std::collections::BTreeSet<usize> = mesh
                .triangle_sets
                .get(zone)
                .map(|t| t.iter().copied().collect())
                .unwrap_or_default();
            for (_, range, ids) in groups {
                for (k, id) in ids.iter().enumerate() {
                    if set.contains(id) {
                        mask[range.start + k] = true;
                    }
                }
            }
            ProbeModel::ZoneForce {
                zone: mask,
                component: component.index(),
            }
        }
        Probe::NewtonIterations => ProbeModel::NewtonIterations,
        Probe::Velocity { node, component } => ProbeModel::Velocity {
            dof: 3 * one_node(mesh, node) + component.index(),
        },
        Probe::Acceleration { node, component } => ProbeModel::Acceleration {
            dof: 3 * one_node(mesh, node) + component.index(),
        },
        Probe::KineticEnergy => ProbeModel::KineticEnergy,
        Probe::StrainEnergy => ProbeModel::StrainEnergy,
        Probe::NaturalFrequency { mode } => ProbeModel::NaturalFrequency { mode: *mode },
        Probe::EnclosedVolume { membrane } => {
            ProbeModel::EnclosedVolume(elements(&Some(membrane.clone()))?)
        }
        Probe::ContactTotal { contact, component } => ProbeModel::ContactTotal {
            set: contact::position(scene, contact),
            component: component.map(|c| c.index()),
        },
        Probe::ContactArea { contact } => {
            ProbeModel::ContactArea(contact::position(scene, contact))
        }
        // The level of a water volume is read as its unknown, as a volume's pressure.
        Probe::EnclosedPressure { input } | Probe::WaterLevel { input } => {
            let unknown = scene
                .inputs
                .iter()
                .filter(|i| i.load.has_unknown())
                .position(|i| &i.name == input)
                .expect("validated: a volume, gas or water volume input");
            ProbeModel::EnclosedPressure(unknown)
        }
        Probe::WrinkledFraction { membrane } => ProbeModel::WrinkledFraction(elements(membrane)?),
        Probe::SlackFraction { membrane } => ProbeModel::SlackFraction(elements(membrane)?),
        Probe::MaxPrincipalStress { membrane } => {
            ProbeModel::MaxPrincipalStress(elements(membrane)?)
        }
        Probe::MinPrincipalStress { membrane } => {
            ProbeModel::MinPrincipalStress(elements(membrane)?)
        }
        Probe::ElementState { triangle } => {
            let index = groups
                .iter()
                .find_map(|g| {
                    g.2.iter()
                        .position(|t| t == triangle)
                        .map(|k| g.1.start + k)
                })
                .expect("validated: the triangle belongs to a membrane group");
            ProbeModel::ElementState(index)
        }
        Probe::DisplacementField { .. }
        | Probe::PositionField { .. }
        | Probe::CableTensions { .. }
        | Probe::PrincipalStresses { .. }
        | Probe::WrinkleStates { .. }
        | Probe::SleeveSlips { .. } => unreachable!("built by build_probes"),
    })
}

fn bounding_diagonal(x: &[Vector3<f64>], used: &[bool]) -> f64 {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for (p, _) in x.iter().zip(used).filter(|(_, u)| **u) {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let d = (hi - lo).norm();
    if d.is_finite() && d > 0.0 {
        d
    } else {
        1.0
    }
}

/// The model of a shipped scene (`modelDescription/<name>/scene.json`), for unit tests.
#[cfg(test)]
pub(crate) fn shipped_model(name: &str) -> Model {
    let path = format!(
        "{}/modelDescription/{name}/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let scene = crate::scene::Scene::from_json(&std::fs::read_to_string(path).unwrap()).unwrap();
    Model::try_build(&scene).unwrap()
}
