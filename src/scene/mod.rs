//! Scene format v1: plain serde data describing one structure, its loads and its probes.
//!
//! A scene is JSON in SI units (m, N, Pa, N/m for membrane forces). It is read with
//! [`Scene::from_json`], which names the JSON path of a type error, and checked with
//! [`validate::validate`], which lists every semantic problem by JSON path. Only a validated
//! scene is turned into a model (`crate::model`). [`plausibility::warnings`] then names what a
//! valid scene has that is most likely a slip (a prestress implying more than 5 % strain, a
//! modulus far outside its material's usual range, a sleeve penalty softer than what it ties).
//!
//! ```text
//! format      always 1
//! name        model name: a C identifier, used as the FMU's modelIdentifier
//! geometry    explicit nodes / triangles / named sets, plus generators (rectangle, disc, annulus,
//!             cushion)
//! membranes   groups of triangles: thickness, material
//! cables      tension-only polylines of nodes: EA, strain law, pretension or unstretched length
//! supports    fixed displacement components on node sets
//! inputs      named loads that become FMU inputs
//! outputs     named probes that become FMU outputs
//! parameters  scene values exposed as FMU parameters (fixed or tunable)
//! solver      tolerances, increments, artificial prestress
//! ```

pub mod coarsen;
pub mod cushion;
pub mod generate;
pub mod limits;
pub mod plausibility;
pub mod read;
pub mod rules;
pub mod shape;
pub mod target;
pub mod validate;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The only scene format version this build reads.
pub const FORMAT_VERSION: u32 = 1;

/// A whole scene (format 1).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Scene format version; must be 1.
    pub format: u32,
    /// Model name: a C identifier (letters, digits, `_`, not starting with a digit). It names the
    /// FMU file, its modelIdentifier and its shared library.
    pub name: String,
    /// Free text carried into the FMU's modelDescription.
    #[serde(default)]
    pub description: String,
    /// Nodes, triangles, named sets and mesh generators.
    #[serde(default)]
    pub geometry: Geometry,
    #[serde(default)]
    pub membranes: Vec<Membrane>,
    #[serde(default)]
    pub cables: Vec<Cable>,
    #[serde(default)]
    pub supports: Vec<Support>,
    /// Unilateral frictionless contacts: nodes against rigid planes, spheres and cylinders,
    /// and a cushion's two sheets against each other (`model::contact`, docs/contact.md).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub contacts: Vec<Contact>,
    #[serde(default)]
    pub inputs: Vec<Input>,
    #[serde(default)]
    pub outputs: Vec<Output>,
    #[serde(default)]
    pub parameters: Vec<Parameter>,
    #[serde(default)]
    pub solver: SolverSettings,
    /// Form finding before the first step: the geometry is replaced by the equilibrium shape of
    /// the membranes' `prestress` and the cables' `pretension` between the supports (Updated
    /// Reference Strategy, `crate::formfind`). Absent: the geometry is taken as given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub form_finding: Option<FormFinding>,
    /// The FMU's DefaultExperiment (pseudo-time: one unit of time is one load history step
    /// as the master chooses it).
    #[serde(default)]
    pub experiment: Experiment,
    /// Debug-only switches that force the FMU's failure paths (a step that does not converge,
    /// an internal panic, an allocation that fails) so that their handling can be tested. Shipped scenes
    /// leave this out; test variants add it (and may expose its fields as parameters).
    #[serde(default, skip_serializing_if = "DebugSettings::is_off")]
    pub debug: DebugSettings,
    /// Mass and damping for the dynamics (docs/dynamics.md): which mass matrix, point masses
    /// on node sets and Rayleigh damping. The membranes' `density` and the cables'
    /// `mass_per_length` give the distributed mass. Absent: the scene is quasi-static and
    /// its results do not depend on any of this (`velarium modes` still uses the distributed
    /// mass, consistent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dynamics: Option<Dynamics>,
}

/// Mass and damping (docs/dynamics.md).
#[derive(Clone, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Dynamics {
    /// The mass matrix: `consistent` (the default: ∫ρ N_a N_b over each element, frequencies
    /// from above) or `lumped` (diagonal, each element's mass shared equally among its nodes).
    #[serde(default)]
    pub mass: MassKind,
    /// Rayleigh damping C = alpha M + beta K0: the mass-proportional factor alpha in 1/s
    /// (>= 0, default 0). Stored for the time integration.
    #[serde(default)]
    pub rayleigh_alpha: f64,
    /// Rayleigh damping's stiffness-proportional factor beta in s (>= 0, default 0). Stored
    /// for the time integration.
    #[serde(default)]
    pub rayleigh_beta: f64,
    /// Point masses: `mass` kg at every node of `nodes` (masts' heads, fittings, ballast).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub point_masses: Vec<PointMass>,
    /// The surrounding air per membrane group: an added mass and a linear damping per unit
    /// area, both acting along the membrane's reference normal (docs/dynamics.md). Used by the
    /// natural frequencies (the added mass) and the time integration (both).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub air: Vec<Air>,
    /// Time integration (docs/dynamics.md): present, a step of the FMU (and a row of
    /// `velarium solve`) advances physical time by its length with generalized-alpha; absent,
    /// the scene is quasi-static whatever else this section holds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_integration: Option<TimeIntegration>,
}

/// Generalized-alpha time integration (Chung & Hulbert 1993): its spectral radius at infinite
/// frequency and the largest sub-step.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TimeIntegration {
    /// High-frequency dissipation: the spectral radius at infinite frequency, 0 to 1
    /// (1: the trapezoidal rule, no numerical dissipation, energy conserved in the linear
    /// regime; 0: the strongest damping of the highest modes). Default 0.9.
    #[serde(default = "default_rho_inf")]
    pub rho_inf: f64,
    /// The largest time sub-step in s: a step of length h is taken in ceil(h / max_time_step)
    /// equal sub-steps (absent: one sub-step per step). A sub-step that does not converge is
    /// cut by 4 and taken again from its start.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_time_step: Option<f64>,
}

fn default_rho_inf() -> f64 {
    0.9
}

impl Default for TimeIntegration {
    fn default() -> Self {
        TimeIntegration {
            rho_inf: default_rho_inf(),
            max_time_step: None,
        }
    }
}

/// Which mass matrix the dynamics uses.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MassKind {
    /// ∫ρ N_a N_b: a membrane triangle ρ t A (1 + δ_ab)/12, a cable segment μ ℓ (1 + δ_ab)/6.
    #[default]
    Consistent,
    /// Diagonal: a membrane triangle ρ t A/3 and a cable segment μ ℓ/2 at each of its nodes.
    Lumped,
}

/// A point mass at every node of a set.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PointMass {
    pub nodes: NodeRef,
    /// Mass in kg at each node (> 0).
    pub mass: f64,
}

/// The air around one membrane group, per unit of its reference area, along the normal.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Air {
    /// The membrane group's name (each group at most once).
    pub membrane: String,
    /// Added (entrained) air mass in kg/m² of reference area (>= 0, default 0), acting on the
    /// motion along the reference normal only: for a panel of span L in air of density ρ_a it
    /// is of the order of ρ_a L (docs/dynamics.md).
    #[serde(default)]
    pub added_mass: f64,
    /// Linear aerodynamic damping in N s/m³ (Pa per m/s of normal velocity, >= 0, default 0):
    /// a pressure −c v·n opposing the normal velocity.
    #[serde(default)]
    pub damping: f64,
}

/// Explicit mesh data plus generators. Generated nodes and triangles are appended after the
/// explicit ones, in generator order.
#[derive(Clone, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Geometry {
    /// Explicit node coordinates [x, y, z] in m; node ids are their positions (0-based).
    #[serde(default)]
    pub nodes: Vec<[f64; 3]>,
    /// Explicit triangles as three nodes, counter-clockwise seen from the membrane's front. A
    /// node is a global node id (explicit nodes first, then every generator's nodes in
    /// generator order, see `node_sets`) or the name of a one-node set such as
    /// `"plate.corner_tr"`.
    #[serde(default)]
    pub triangles: Vec<[OneNode; 3]>,
    /// Named, ordered node sets over node ids of the whole mesh: explicit nodes first, then the
    /// generated ones in generator order (a rectangle's node (i, j) is base + j (nx+1) + i).
    #[serde(default)]
    pub node_sets: BTreeMap<String, Vec<usize>>,
    /// Named triangle sets over triangle ids of the whole mesh (explicit first, then generated).
    #[serde(default)]
    pub triangle_sets: BTreeMap<String, Vec<usize>>,
    /// Mesh generators; each defines the triangle set `<name>` and node sets `<name>.<set>`.
    #[serde(default)]
    pub generators: Vec<Generator>,
}

/// A mesh generator. Generated meshes lie in a plane parallel to x-y (a cushion's sheets with
/// a rise bulge out of it).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Generator {
    /// Rectangle [x0, x0+size_x] x [y0, y0+size_y] at height z0, nx x ny cells, each cell split
    /// into two triangles (alternating diagonals when `pattern` is "crossed").
    /// Node sets: `all`, `edge_bottom` (y = y0, ordered by x), `edge_top`, `edge_left`
    /// (x = x0, ordered by y), `edge_right`, `corner_bl`, `corner_br`, `corner_tl`, `corner_tr`,
    /// `center` (the node nearest the centre), `boundary` (all edge nodes).
    Rectangle {
        name: String,
        /// Lower-left corner [x0, y0, z0] in m.
        origin: [f64; 3],
        /// [size_x, size_y] in m.
        size: [f64; 2],
        /// [nx, ny] cells.
        divisions: [usize; 2],
        #[serde(default)]
        pattern: DiagonalPattern,
    },
    /// Disc of radius `radius` centred at `center`, `rings` rings of nearly equilateral
    /// triangles (ring k has 6k nodes). Node sets: `all`, `center`, `rim` (outer ring,
    /// counter-clockwise), `boundary` (= rim).
    Disc {
        name: String,
        center: [f64; 3],
        radius: f64,
        rings: usize,
    },
    /// Annulus inner_radius < r < outer_radius, `rings` radial divisions (geometric grading by
    /// `grading`, 1 = uniform) and `sectors` nodes per ring. Node sets: `all`, `inner_rim`,
    /// `outer_rim` (counter-clockwise), `boundary` (both rims).
    Annulus {
        name: String,
        center: [f64; 3],
        inner_radius: f64,
        outer_radius: f64,
        rings: usize,
        sectors: usize,
        #[serde(default = "one")]
        grading: f64,
    },
    /// Air cushion: two sheets over one rim (`scene::cushion`): the plan `outline` about
    /// `center` in `rings` rings, the top sheet raised by `rise[0]` and the bottom lowered by
    /// `rise[1]` at the centre (paraboloid of the ring parameter; default flat). Node sets:
    /// `all`, `rim`, `boundary` (= rim), `top`, `bottom` (interior nodes, in matching order),
    /// `top_center`, `bottom_center`; triangle sets `<name>`, `<name>.top`, `<name>.bottom`.
    Cushion {
        name: String,
        center: [f64; 3],
        outline: Outline,
        rings: usize,
        #[serde(default)]
        rise: [f64; 2],
    },
}

/// The plan outline of a cushion, about its centre.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "shape", rename_all = "snake_case", deny_unknown_fields)]
pub enum Outline {
    /// Rectangle of `size` [a, b] in m (x, y), centred.
    Rectangle { size: [f64; 2] },
    /// Circle of `radius` in m.
    Circle { radius: f64 },
    /// Polygon: its corners [x, y] in m relative to the centre, counter-clockwise, each
    /// visible from the centre (every consecutive pair turns counter-clockwise about it).
    Polygon { points: Vec<[f64; 2]> },
}

fn one() -> f64 {
    1.0
}

/// How the rectangle generator splits its cells.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum DiagonalPattern {
    /// All diagonals from lower-left to upper-right.
    Right,
    /// All diagonals from lower-right to upper-left.
    Left,
    /// Alternating diagonals (a symmetric "union jack" on cell pairs).
    #[default]
    Crossed,
}

/// A unilateral frictionless contact (`model::contact`). `penalty` (N/m, optional) defaults to
/// 10 times the neighbouring stiffness and is raised to it when given softer; the answer does
/// not depend on it (augmented Lagrangian).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Contact {
    /// Two sheets, node to node: the i-th node of `top` stays on the side `direction` points
    /// to of the i-th node of `bottom` (the two sets list partners in the same order: a
    /// cushion generator's `top` and `bottom`).
    Sheets {
        name: String,
        top: NodeRef,
        bottom: NodeRef,
        direction: [f64; 3],
        #[serde(default, skip_serializing_if = "Option::is_none")]
        penalty: Option<f64>,
    },
    /// The nodes stay on the side `normal` points to of the plane through `point`.
    Plane {
        name: String,
        nodes: NodeRef,
        point: [f64; 3],
        normal: [f64; 3],
        #[serde(default, skip_serializing_if = "Option::is_none")]
        penalty: Option<f64>,
    },
    /// The nodes stay outside the rigid sphere.
    Sphere {
        name: String,
        nodes: NodeRef,
        center: [f64; 3],
        radius: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        penalty: Option<f64>,
    },
    /// The nodes stay outside the rigid (infinitely long) cylinder through `point` along `axis`.
    Cylinder {
        name: String,
        nodes: NodeRef,
        point: [f64; 3],
        axis: [f64; 3],
        radius: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        penalty: Option<f64>,
    },
}

impl Contact {
    pub fn name(&self) -> &str {
        match self {
            Contact::Sheets { name, .. }
            | Contact::Plane { name, .. }
            | Contact::Sphere { name, .. }
            | Contact::Cylinder { name, .. } => name,
        }
    }

    pub fn penalty(&self) -> Option<f64> {
        match self {
            Contact::Sheets { penalty, .. }
            | Contact::Plane { penalty, .. }
            | Contact::Sphere { penalty, .. }
            | Contact::Cylinder { penalty, .. } => *penalty,
        }
    }
}

/// A reference to nodes: explicit ids or the name of a node set.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(untagged)]
pub enum NodeRef {
    Ids(Vec<usize>),
    Set(String),
}

/// A reference to one node: an id or the name of a one-node set.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(untagged)]
pub enum OneNode {
    Id(usize),
    Set(String),
}

/// A reference to triangles: explicit ids or the name of a triangle set.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(untagged)]
pub enum TriangleRef {
    Ids(Vec<usize>),
    Set(String),
}

/// A membrane group.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Membrane {
    pub name: String,
    pub triangles: TriangleRef,
    /// Thickness in m (> 0).
    pub thickness: f64,
    pub material: Material,
    /// Tension-field law (on by default): where the elastic answer would compress the sheet it
    /// wrinkles instead and carries uniaxial tension, or goes slack. `false`: a plain elastic
    /// sheet that carries compression.
    #[serde(default = "yes")]
    pub wrinkling: bool,
    /// Share ρ of the small-strain elastic stiffness a wrinkled or slack triangle keeps (with
    /// wrinkling on): its stress is (1 − ρ) S_tension-field + ρ D0 E, consistently in the
    /// energy and the tangent. Absent or 0: the pure tension-field law (docs/mechanics.md §1.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual_stiffness: Option<f64>,
    /// Initial stress state of the group in the scene geometry (membrane forces in N/m): part
    /// of the equilibrium (residual and tangent), unlike `solver.artificial_prestress`. The
    /// geometry with no load is in equilibrium only if this prestress balances there (a
    /// form-found shape, a flat sheet with every edge held). Absent: stress-free.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prestress: Option<Prestress>,
    /// Mass density of the sheet in kg/m³ (> 0): its mass, ρ t per unit reference area, is
    /// what a `self_weight` input pulls on. Absent: massless.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<f64>,
}

/// A membrane prestress in N/m (force per unit length of cut = stress × thickness).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Prestress {
    /// The same membrane force `n` (N/m, > 0) in every in-plane direction.
    Isotropic { n: f64 },
    /// Membrane forces `warp` and `fill` (N/m, >= 0, not both 0) along the warp direction and
    /// its in-plane perpendicular. `warp_direction` is a global vector, projected on each
    /// triangle's plane (it must not be normal to any triangle of the group).
    WarpFill {
        warp: f64,
        fill: f64,
        warp_direction: [f64; 3],
    },
    /// One membrane force tensor per triangle of the group (in the group's triangle order), in
    /// global components [n_xx, n_yy, n_zz, n_xy, n_yz, n_xz] (N/m); each triangle takes its
    /// in-plane part. What form finding writes: the stress field that balances the found shape
    /// exactly (within round-off of the prescribed one, see docs/mechanics.md §10).
    Field { n: Vec<[f64; 6]> },
    /// Radial and hoop membrane forces about an axis (a conical tent, a funnel): on each
    /// triangle the warp (radial, `n_r`) runs along the direction away from the axis through
    /// `center` along `axis`, taken at the triangle's centroid and projected on its plane (on
    /// a cone: down the meridian), the fill (hoop, `n_theta`) across it. `n_r` is the radial
    /// force at the distance `radius` from the axis; elsewhere n_r(r) = n_θ + (n_r − n_θ)
    /// radius / r, the one radial field in equilibrium with a uniform hoop force on any surface
    /// of revolution (meridional equilibrium, d(r n_r)/ds = n_θ dr/ds). For warp/fill fabric
    /// give its material the same axis as `warp_axis`, so that its warp runs radially too.
    Cylindrical {
        /// A point on the axis, m.
        center: [f64; 3],
        /// Axis direction (any length but zero; normalised).
        axis: [f64; 3],
        /// Radial membrane force at `radius`, N/m (> 0).
        n_r: f64,
        /// Hoop membrane force, N/m (>= 0).
        n_theta: f64,
        /// Distance from the axis at which `n_r` is given, m (> 0).
        radius: f64,
    },
}

impl Prestress {
    /// (warp, fill, warp direction) on a triangle with centroid `c`: the group's components,
    /// or for a cylindrical prestress the radial and hoop forces at the centroid's distance
    /// from the axis and the radial direction there (None on the axis).
    pub fn at(&self, c: [f64; 3]) -> Option<(f64, f64, [f64; 3])> {
        match self {
            Prestress::Cylindrical {
                center,
                axis,
                n_r,
                n_theta,
                radius,
            } => {
                let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
                let a = axis.map(|v| v / len);
                let v = [0, 1, 2].map(|i| c[i] - center[i]);
                let along = v[0] * a[0] + v[1] * a[1] + v[2] * a[2];
                let radial = [0, 1, 2].map(|i| v[i] - along * a[i]);
                let r = (radial[0].powi(2) + radial[1].powi(2) + radial[2].powi(2)).sqrt();
                (r > 0.0 && r.is_finite()).then(|| {
                    (
                        n_theta + (n_r - n_theta) * radius / r,
                        *n_theta,
                        radial.map(|v| v / r),
                    )
                })
            }
            _ => Some(self.components()),
        }
    }

    /// (warp, fill, warp direction) in N/m; isotropic: (n, n, x); a field: its largest
    /// component as both (a force scale only).
    pub fn components(&self) -> (f64, f64, [f64; 3]) {
        match self {
            Prestress::Isotropic { n } => (*n, *n, [1.0, 0.0, 0.0]),
            Prestress::WarpFill {
                warp,
                fill,
                warp_direction,
            } => (*warp, *fill, *warp_direction),
            Prestress::Cylindrical { n_r, n_theta, .. } => (*n_r, *n_theta, [1.0, 0.0, 0.0]),
            Prestress::Field { n } => {
                let m = n
                    .iter()
                    .flat_map(|t| t.iter())
                    .fold(0.0f64, |m, v| m.max(v.abs()));
                (m, m, [1.0, 0.0, 0.0])
            }
        }
    }
}

/// Membrane material (plane stress, total Lagrangian).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Material {
    /// St Venant-Kirchhoff: S = D E with the isotropic plane-stress D. For films at small
    /// strain (below a few %). `E` in Pa, `nu` in [0, 0.5).
    Svk {
        #[serde(rename = "E")]
        young: f64,
        nu: f64,
    },
    /// Incompressible neo-Hookean plane stress, W = μ/2 (tr C + 1/det C − 3): rubber at large
    /// strain. `mu` is the shear modulus in Pa (small-strain E = 3μ).
    NeoHookean { mu: f64 },
    /// Orthotropic (warp/fill) St Venant-Kirchhoff for coated fabrics: plane-stress compliance
    /// [[1/E_warp, −nu_wf/E_warp, 0], [−nu_wf/E_warp, 1/E_fill, 0], [0, 0, 1/G]] in the warp/fill
    /// axes. Moduli in Pa (> 0); `nu_wf` (fill contraction under warp tension) in
    /// [0, √(E_warp/E_fill)) so the law is positive definite. `warp`: the warp direction as a
    /// vector, projected onto each triangle's plane (it must not be normal to any triangle).
    /// With wrinkling on, the tension-field law solves for the wrinkle direction
    /// (docs/mechanics.md §1.3).
    Orthotropic {
        #[serde(rename = "E_warp")]
        e_warp: f64,
        #[serde(rename = "E_fill")]
        e_fill: f64,
        nu_wf: f64,
        #[serde(rename = "G")]
        g: f64,
        warp: [f64; 3],
        /// Optional: the warp of each triangle runs radially away from this axis, taken at the
        /// triangle's centroid and projected on its plane (a tent's fabric, warp down the
        /// meridians: the direction a `cylindrical` prestress calls radial); `warp` is then
        /// not used. No triangle's centroid may lie on the axis.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        warp_axis: Option<WarpAxis>,
    },
    /// ETFE foil: the SVK sheet (`E`, `nu` as for `svk`) made elastoplastic, von Mises with
    /// isotropic hardening fitted to the uniaxial curve of ETFE design data: elastic up to the
    /// first yield stress `yield_stress` (Pa, at strain yield_stress/E), straight to the second
    /// yield point (`second_yield_strain`, `second_yield_stress`: total uniaxial strain and Pa),
    /// then the tangent modulus `tangent_modulus` (Pa, default 0: no further hardening).
    /// Ranges: 0 < yield_stress < second_yield_stress; second_yield_strain beyond
    /// second_yield_stress/E (the curve between the yield points rises less steeply than E);
    /// 0 <= tangent_modulus < E. Plastic strain is history (saved with the FMU state);
    /// wrinkling acts on the elastoplastic stress (docs/etfe.md). Not with
    /// `residual_stiffness`.
    Etfe {
        #[serde(rename = "E")]
        young: f64,
        nu: f64,
        yield_stress: f64,
        second_yield_stress: f64,
        second_yield_strain: f64,
        #[serde(default)]
        tangent_modulus: f64,
    },
}

/// An axis a warp direction runs radially away from (`Material::Orthotropic::warp_axis`).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WarpAxis {
    /// A point on the axis, m.
    pub center: [f64; 3],
    /// Axis direction (any length but zero; normalised).
    pub axis: [f64; 3],
}

impl WarpAxis {
    /// The unit direction away from the axis at `c` (None on the axis or for a zero axis).
    pub fn radial(&self, c: [f64; 3]) -> Option<[f64; 3]> {
        let len = (self.axis.iter().map(|v| v * v).sum::<f64>()).sqrt();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let a = self.axis.map(|v| v / len);
        let v = [0, 1, 2].map(|i| c[i] - self.center[i]);
        let along = v[0] * a[0] + v[1] * a[1] + v[2] * a[2];
        let radial = [0, 1, 2].map(|i| v[i] - along * a[i]);
        let r = (radial.iter().map(|v| v * v).sum::<f64>()).sqrt();
        (r > 1e-12 * (1.0 + v.iter().map(|x| x.abs()).fold(0.0, f64::max)) && r.is_finite())
            .then(|| radial.map(|v| v / r))
    }
}

/// Strain law of a cable.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StrainLaw {
    /// T = EA (l - L0) / L0.
    #[default]
    Engineering,
    /// T = EA (l² - L0²) l / (2 L0³)  (Green-Lagrange strain, PK2 stress, SVK).
    GreenLagrange,
}

/// A tension-only cable: a chain of 2-node elements along `nodes`.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Cable {
    pub name: String,
    /// At least two distinct nodes, in order along the cable.
    pub nodes: NodeRef,
    /// Axial stiffness E·A in N (> 0).
    #[serde(rename = "EA")]
    pub ea: f64,
    #[serde(default)]
    pub strain: StrainLaw,
    /// Tension in N in the initial (scene) geometry; sets the unstretched length of every
    /// segment. Give at most one of `pretension` and `unstretched_length`; neither = 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pretension: Option<f64>,
    /// Tension in N of each segment in the initial geometry (one per segment, in order): what
    /// form finding writes (the forces that balance the found shape exactly). Give at most one
    /// of `pretension`, `pretensions` and `unstretched_length`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pretensions: Option<Vec<f64>>,
    /// Total unstretched length in m, shared among the segments in proportion to their
    /// initial lengths.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unstretched_length: Option<f64>,
    /// The cable slides through these of its nodes (a sleeve), with friction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sleeve: Option<Sleeve>,
    /// Mass per unit length in kg/m (> 0), per metre of the cable as drawn in the scene
    /// geometry: what a `self_weight` input pulls on. Absent: massless.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass_per_length: Option<f64>,
}

/// A sleeve: interior cable nodes the cable slides through (docs/mechanics.md §2.3 option A). Each
/// sleeve node gets its own cable point, tied to the node by a penalty spring (the seed's contact
/// element), and a slip unknown with the Coulomb law in the bisector frame.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Sleeve {
    /// Interior cable nodes that slide (default: every interior node of the cable).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<NodeRef>,
    /// Friction coefficient (0: frictionless).
    #[serde(default)]
    pub mu: f64,
    /// Tie penalty in N/m (default 100 × max(EA/ℓ_min, E t), model/sleeve.rs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub penalty: Option<f64>,
}

/// Which end of a cable.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CableEnd {
    Start,
    End,
}

/// Stick or slip.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SlipState {
    Stick,
    Slip,
}

/// A displacement component.
#[derive(
    Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Eq, PartialOrd, Ord,
)]
#[serde(rename_all = "snake_case")]
pub enum Component {
    X,
    Y,
    Z,
}

impl Component {
    pub fn index(self) -> usize {
        match self {
            Component::X => 0,
            Component::Y => 1,
            Component::Z => 2,
        }
    }
}

/// Fixed displacement components on a node set.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Support {
    pub nodes: NodeRef,
    /// Components held at zero displacement.
    pub fix: Vec<Component>,
}

/// A named load that becomes an FMU input (causality input, continuous Real).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Input {
    /// Variable name (flat FMI name: letters, digits, `_`, `.`, `[`, `]`).
    pub name: String,
    pub load: Load,
    /// Value the FMU uses until the master sets one; also the value of the initial equilibrium.
    /// In the unit of the load kind (N, Pa, m or N/m; see `load`).
    #[serde(default)]
    pub start: f64,
    /// Smallest value a master may set (the FMU variable's `min`), unit of the load kind.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    /// Largest value a master may set (the FMU variable's `max`), unit of the load kind.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    #[serde(default)]
    pub description: String,
}

/// What an input does. The input's value (and its `start`, `min`, `max`) is in the unit of its
/// kind: N for `point_force`, Pa for `pressure`, m for `displacement` and
/// `polar_displacement`, rad for `rotation`, N/m for `radial_edge_load`, m³ for `volume` and
/// `gas`. Where several displacement-like inputs hold the same component of a node (a rotation
/// and a translation, a radial and a tangential displacement) their displacements add; two
/// inputs of the same kind on the same component are an error.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Load {
    /// Total force in N (the input's value) along `direction` (normalised; a negative value
    /// pushes against it), split equally over the set's nodes. Dead load: the direction does
    /// not follow the structure.
    PointForce {
        nodes: NodeRef,
        /// Direction of a positive force (any length but zero; normalised).
        direction: [f64; 3],
    },
    /// Pressure in Pa (the input's value) on every triangle of a membrane group. Sign: a
    /// positive pressure pushes along the normal of the triangle's node order taken
    /// counter-clockwise, n = (x2 − x1) × (x3 − x1) / |...| (right-hand rule); generated meshes
    /// (`rectangle`, `disc`, `annulus`) are counter-clockwise seen from +z, so positive pushes
    /// towards +z. A negative value pulls (suction). `follower: true` (default): along the
    /// current normal, per current area (wind, inflation; with its load stiffness).
    /// `follower: false`: dead, per reference area along the reference normal.
    Pressure {
        /// Name of the membrane group loaded.
        membrane: String,
        /// Load only the group's triangles in this zone: a named triangle set
        /// (`geometry.triangle_sets` or a generator's set). Absent: the whole group.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        zone: Option<String>,
        /// Follow the deformed surface (true, default) or stay dead (false).
        #[serde(default = "yes")]
        follower: bool,
    },
    /// Pressure in Pa per zone: an array input with one element per zone, element k loading
    /// the group's triangles in `zones[k]` exactly as a `pressure` input with that `zone` would
    /// (same sign convention, same `follower` choice). Zones are named triangle sets; they may
    /// overlap (the pressures then add).
    ZonePressure {
        membrane: String,
        /// Triangle-set names, one per array element (at least one).
        zones: Vec<String>,
        #[serde(default = "yes")]
        follower: bool,
    },
    /// Prescribed displacement in m of every node of the set in x, y and z: an array input of
    /// shape [nodes, 3] (row k = node k of the set, columns x, y, z), for a frame model that
    /// drives the supports. All three components of these nodes become held.
    SupportDisplacement { nodes: NodeRef },
    /// Prescribed displacement in m (the input's value) of one component of every node of the
    /// set, positive along the +axis of `component`. The component becomes held (not an
    /// unknown); a `reaction` probe reads the force it needs.
    Displacement {
        nodes: NodeRef,
        component: Component,
    },
    /// Rotation in rad (the input's value) of every node of the set as one rigid body about the
    /// axis through `point` along `axis` (right-hand rule: positive turns counter-clockwise
    /// seen from the axis tip), exact for any angle: u = R(θ)(X − p) − (X − p). Every component
    /// of every node becomes held; a `reaction_moment` probe reads the torque it needs.
    /// `displacement` inputs on the same nodes add their translation (rotation, then
    /// translation: a general rigid motion).
    Rotation {
        nodes: NodeRef,
        /// A point on the axis, m.
        point: [f64; 3],
        /// Axis direction (any length but zero; normalised).
        axis: [f64; 3],
    },
    /// Displacement in m (the input's value) of every node of the set along its radial
    /// (`component: radial`, away from the axis) or tangential (`tangential`: axis × radial,
    /// counter-clockwise seen from the axis tip) direction about the coordinate axis `axis`
    /// through `center`, both in the reference configuration. The node's two components
    /// perpendicular to the axis become held (the one along the axis stays free unless a
    /// support holds it); a radial and a tangential input on the same nodes add, otherwise the
    /// component the node is not given is zero. No node may lie on the axis.
    PolarDisplacement {
        nodes: NodeRef,
        center: [f64; 3],
        axis: Component,
        component: PolarComponent,
    },
    /// In-plane edge load in N/m (the input's value: force per unit reference length of the
    /// edge polyline through `nodes`, in order), directed radially away from `center`
    /// (positive: outward, negative: towards it). Each edge segment gives half its load to
    /// each end node, along that node's radial direction. Dead load. `closed`: the polyline
    /// returns from the last node to the first (a rim).
    RadialEdgeLoad {
        nodes: NodeRef,
        center: [f64; 3],
        #[serde(default)]
        closed: bool,
    },
    /// Volume control: the volume enclosed by a closed membrane group, prescribed as the change
    /// ΔV in m³ (the input's value) from its reference volume (so `start` 0 is the unloaded
    /// state). The pressure that holds the volume (a follower pressure on the group, sign as for
    /// `pressure`: positive along the triangles' normals, which must face outward) is an
    /// unknown of the solve: read it with an `enclosed_pressure` probe. Unlike a pressure
    /// input, it traces the whole pressure-volume curve of an inflated balloon or cushion,
    /// through and past the pressure's limit point (docs/solver.md, paths past limit points).
    /// The group must be closed (every edge shared by exactly two of its triangles, in
    /// opposite directions); held symmetry planes may cut it only if the group is still closed.
    Volume {
        /// Name of the (closed) membrane group.
        membrane: String,
    },
    /// Gas control: an isothermal ideal gas (p_abs V = const) fills a closed membrane group;
    /// the input's value is the gas added since the reference state, as its volume ΔN in m³ at
    /// the `atmosphere` pressure: (p + p_atm) V = p_atm (V⁰ + ΔN), p the (gauge) pressure on
    /// the membrane, an unknown of the solve as for `volume` (read it with an
    /// `enclosed_pressure` probe). `start` 0 is the reference state (p = 0, V = V⁰). A cushion
    /// inflated by a gas amount; the gas stiffens the path past the membrane's limit pressure.
    /// The group must be closed and outward, as for `volume`.
    Gas {
        /// Name of the (closed) membrane group.
        membrane: String,
        /// Absolute pressure of the atmosphere, Pa (default 101325).
        #[serde(default = "atmosphere")]
        atmosphere: f64,
    },
    /// Snow in Pa (the input's value): a vertical load, along −z, of that many N per m² of
    /// plan area, the area of the current (deformed) surface projected on the x-y plane, on
    /// every triangle of the group (or of its part in `zone`), whichever way its normal
    /// faces. It follows the shape: a triangle that steepens carries less (with its load
    /// stiffness). A negative value lifts.
    Snow {
        /// Name of the membrane group loaded.
        membrane: String,
        /// Load only the group's triangles in this zone (a named triangle set). Absent: the
        /// whole group.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        zone: Option<String>,
    },
    /// Self weight: the gravitational acceleration in m/s² (the input's value; 9.81 on
    /// Earth) along `direction`, on the mass of every membrane group with a `density` (ρ t
    /// per unit reference area) and every cable with a `mass_per_length` (per metre as
    /// drawn). A dead load: mass is conserved, so the total is m g whatever the shape.
    SelfWeight {
        /// Direction of gravity (any length but zero; normalised). Default [0, 0, −1].
        #[serde(default = "down")]
        direction: [f64; 3],
    },
    /// Ponding: the water level h in m (the input's value, a z coordinate). Water of unit
    /// weight `gamma_w` fills the group's triangles (or its part in `zone`) from the side
    /// their normals point to (+z for generated meshes, so from above) up to the level: the
    /// hydrostatic pressure γ_w (h − z) at every point of the current surface below h, along
    /// the current normal, pushing against it (a follower load with its load stiffness);
    /// none above h. Between nodes the pressure is interpolated from the nodes' depths
    /// max(h − z, 0).
    Ponding {
        /// Name of the membrane group loaded.
        membrane: String,
        /// Load only the group's triangles in this zone (a named triangle set).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        zone: Option<String>,
        /// Unit weight of the water, N/m³ (default 9810).
        #[serde(default = "water")]
        gamma_w: f64,
    },
    /// Ponding with the water volume given: the input's value is the volume V_w in m³ of
    /// water on the group's triangles (or its part in `zone`), and the level h is an unknown
    /// of the solve, found so that the water above the current surface up to h, over the
    /// region, is V_w (Σ over its triangles of the plan area times the mean of the nodes'
    /// depths max(h − z, 0): the volume whose weight the `ponding` load puts on the region).
    /// The load is then `ponding`'s at that level. Read the level with a `water_level` probe.
    /// Where the water comes from (rain collected on a roof) is the volume; the level follows
    /// the deflection. `start` 0: no water (the level at the region's lowest point).
    WaterVolume {
        /// Name of the membrane group loaded.
        membrane: String,
        /// Load only the group's triangles in this zone (a named triangle set).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        zone: Option<String>,
        /// Unit weight of the water, N/m³ (default 9810).
        #[serde(default = "water")]
        gamma_w: f64,
    },
}

impl Load {
    /// True for the inputs whose load carries an unknown of the solve (the pressure of a
    /// `volume` or `gas` input, the level of a `water_volume` input), numbered in input order.
    pub fn has_unknown(&self) -> bool {
        matches!(
            self,
            Load::Volume { .. } | Load::Gas { .. } | Load::WaterVolume { .. }
        )
    }
}

fn down() -> [f64; 3] {
    [0.0, 0.0, -1.0]
}

fn water() -> f64 {
    9810.0
}

fn atmosphere() -> f64 {
    101_325.0
}

/// A displacement component about an axis.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PolarComponent {
    Radial,
    Tangential,
}

fn yes() -> bool {
    true
}

/// A named probe that becomes an FMU output.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Output {
    pub name: String,
    pub probe: Probe,
    #[serde(default)]
    pub description: String,
}

/// What an output measures.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Probe {
    /// Displacement component of one node, m.
    Displacement { node: OneNode, component: Component },
    /// Current position component of one node, m.
    Position { node: OneNode, component: Component },
    /// Displacement (m) of one node along its radial (`radial`: away from the axis) or
    /// tangential (`tangential`: axis × radial) direction about the coordinate axis `axis`
    /// through `center`, both in the reference configuration (as the `polar_displacement`
    /// input). The node must not lie on the axis.
    PolarDisplacement {
        node: OneNode,
        center: [f64; 3],
        axis: Component,
        component: PolarComponent,
    },
    /// Current total length of a cable, m.
    /// Current length of a cable, or of its span between two of its nodes.
    CableLength {
        cable: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        from: Option<OneNode>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        to: Option<OneNode>,
    },
    /// Slip (m of unstretched cable, + toward the cable's last node) at a sleeve node.
    CableSlip { cable: String, node: OneNode },
    /// Slip at the first or last sleeve point of a cable (where it leaves the sleeve).
    CableEndSlip { cable: String, end: CableEnd },
    /// Tie (contact) force magnitude at a sleeve node, or the largest over the sleeve.
    ContactForce {
        cable: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        node: Option<OneNode>,
    },
    /// Largest tie gap |x_cable − x_node| over the sleeve, relative to the shorter adjacent
    /// segment (the penetration check: keep below 1e-3).
    ContactGap { cable: String },
    /// Number of sleeve points of a cable in a state (stick or slip) at the last converged
    /// increment.
    SlipCount { cable: String, state: SlipState },
    /// Axial force of a cable, N: of segment `segment` (0-based), or the largest if absent.
    CableTension {
        cable: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        segment: Option<usize>,
    },
    /// Sum of the reaction forces (N) in one component over the constrained nodes of a set:
    /// the force the supports and prescribed displacements exert on the structure.
    Reaction {
        nodes: NodeRef,
        component: Component,
    },
    /// Moment (N·m) about the axis through `point` along `axis` (normalised) of the reaction
    /// forces at the set's constrained nodes, applied at their current positions:
    /// Σ ((x_i − p) × R_i)·a, R_i the force supports and prescribed motions exert there (its
    /// held components). The torque a hub turned by a `rotation` input needs.
    ReactionMoment {
        nodes: NodeRef,
        point: [f64; 3],
        axis: [f64; 3],
    },
    /// Magnitude (N) of the resultant of the reaction forces at the set's constrained nodes,
    /// |Σ R_i| (`reaction` gives one component of the same sum).
    ReactionResultant { nodes: NodeRef },
    /// Component (N) of the resultant force that the pressure loads (every `pressure`,
    /// `zone_pressure`, `volume` and `gas` input) exert on the membrane triangles of a zone (a
    /// triangle set): Σ p A n over the zone's loaded triangles, current area and normal for a
    /// follower pressure, reference ones for a dead pressure. The wind force on a panel.
    ZoneForce { zone: String, component: Component },
    /// Newton iterations used by the last step (all internal increments), Integer.
    NewtonIterations,
    /// Velocity component (m/s) of one node: 0 in a quasi-static scene (docs/dynamics.md).
    Velocity { node: OneNode, component: Component },
    /// Acceleration component (m/s²) of one node: 0 in a quasi-static scene.
    Acceleration { node: OneNode, component: Component },
    /// Kinetic energy ½ vᵀ M v (J) of the whole model, with the scene's mass matrix: 0 in a
    /// quasi-static scene.
    KineticEnergy,
    /// Energy stored in the membranes, cables and ties (J): the strain energy of the
    /// deformation from the reference configuration, the prestress's included.
    StrainEnergy,
    /// The `mode`-th lowest natural frequency (Hz, `mode` 1-based, at most 1000) of small
    /// vibrations about each converged equilibrium (docs/dynamics.md): the scene needs mass
    /// and no sleeves or volume inputs. Each step computes the lowest `mode` frequencies (a
    /// factorization and a Lanczos iteration more per step). No derivative.
    NaturalFrequency { mode: usize },
    /// Fraction (0..1) of the reference area that is wrinkled, of one membrane group or of all.
    WrinkledFraction {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        membrane: Option<String>,
    },
    /// Fraction (0..1) of the reference area that is slack.
    SlackFraction {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        membrane: Option<String>,
    },
    /// Largest major principal Cauchy stress (Pa) over a group or all membranes.
    MaxPrincipalStress {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        membrane: Option<String>,
    },
    /// Smallest minor principal Cauchy stress (Pa) over a group or all membranes.
    MinPrincipalStress {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        membrane: Option<String>,
    },
    /// State of one triangle (mesh triangle id), Integer: 0 taut, 1 wrinkled, 2 slack.
    ElementState { triangle: usize },
    /// Array [nodes, 3]: displacement x, y, z (m) of every node of the set (absent: every
    /// mesh node, in id order).
    DisplacementField {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        nodes: Option<NodeRef>,
    },
    /// Array [nodes, 3]: current position x, y, z (m) of every node of the set (absent: every
    /// mesh node).
    PositionField {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        nodes: Option<NodeRef>,
    },
    /// Array [segments]: axial force (N) of every segment of a cable, in order.
    CableTensions { cable: String },
    /// Array [triangles, 2]: major and minor principal Cauchy stress (Pa) of every triangle of
    /// a group (absent: all groups, in group order).
    PrincipalStresses {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        membrane: Option<String>,
    },
    /// Array [triangles] of UInt8 (Integer scalars in FMI 2): wrinkle state of every triangle
    /// of a group (absent: all groups), 0 taut, 1 wrinkled, 2 slack.
    WrinkleStates {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        membrane: Option<String>,
    },
    /// Array [sleeve points]: slip (m, as `cable_slip`) at every sleeve point of a cable, in
    /// order along it.
    SleeveSlips { cable: String },
    /// Volume (m³) enclosed by a closed membrane group (the signed volume of its triangles
    /// seen from the origin: positive when their normals face outward).
    EnclosedVolume { membrane: String },
    /// Pressure (Pa) that holds the prescribed volume of a `volume` input (the input's name).
    EnclosedPressure { input: String },
    /// Water level h (m, a z coordinate) that holds the water volume of a `water_volume`
    /// input (the input's name).
    WaterLevel { input: String },
    /// Total contact force (N) of a contact (`contacts[].name`): the sum of its nodes' normal
    /// forces, or with `component` that component of the force it puts on the structure (on
    /// the top sheet for `sheets`).
    ContactTotal {
        contact: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<Component>,
    },
    /// Contact area (m²) of a contact: the current tributary area (a third of each adjacent
    /// triangle) of its pressed nodes (the top sheet's for `sheets`).
    ContactArea { contact: String },
}

/// A scene value exposed as an FMU parameter.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Parameter {
    /// Variable name.
    pub name: String,
    /// What it sets: `membranes.<name>.E`, `.nu` (SVK), `.mu` (neo-Hookean), `.E_warp`,
    /// `.E_fill`, `.nu_wf`, `.G` (orthotropic), `.thickness`,
    /// `cables.<name>.EA`, `cables.<name>.pretension`, `solver.artificial_prestress`,
    /// `debug.fail_after_time`, `debug.panic_after_time` (test variants only).
    pub target: String,
    #[serde(default)]
    pub variability: ParameterVariability,
    #[serde(default)]
    pub description: String,
}

/// When a parameter may change.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ParameterVariability {
    /// Set before initialization only.
    #[default]
    Fixed,
    /// May also change at communication points; takes effect from the next step.
    Tunable,
}

/// How a step follows its load path (`solver.path`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PathMethod {
    /// Load increments with growth and cut-back.
    #[default]
    LoadControl,
    /// Arc length (normal plane), the load factor an unknown.
    ArcLength,
}

impl PathMethod {
    fn is_default(&self) -> bool {
        *self == PathMethod::LoadControl
    }
}

/// Internal node numbering of the linear solve (`solver.node_order`, `solver::renumber`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum NodeOrder {
    /// Breadth-first rings outward from a central node, each ring counterclockwise.
    #[default]
    Rings,
    /// Reverse Cuthill-McKee on the node graph.
    Rcm,
    /// A Hilbert curve through the reference coordinates.
    Hilbert,
    /// The scene's own numbering.
    Given,
}

impl NodeOrder {
    fn is_default(&self) -> bool {
        *self == NodeOrder::Rings
    }
}

/// When a Newton direction may come from conjugate gradients preconditioned by an earlier
/// factorization (`solver.inexact_newton`, `solver::linear::Ldlt::pcg`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum InexactNewton {
    /// On for tangents of at least 100 000 equations, off below.
    #[default]
    Auto,
    /// On at every size.
    On,
    /// Off: a fresh factorization for every direction (exact Newton).
    Off,
}

impl InexactNewton {
    fn is_default(&self) -> bool {
        *self == InexactNewton::Auto
    }
}

/// Whether the first step from the undeformed state starts from the answer on a coarser mesh
/// (`solver.coarse_start`, docs/solver.md "The coarse start").
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CoarseStart {
    /// On for models of at least 10 000 free DOF (`engine::coarse::AUTO_DOF`), off below.
    #[default]
    Auto,
    /// On at every size where the scene qualifies.
    On,
    /// Off: every step starts from the committed state.
    Off,
}

impl CoarseStart {
    fn is_default(&self) -> bool {
        *self == CoarseStart::Auto
    }
}

/// Form finding settings (docs/mechanics.md §10). Every membrane group needs a `prestress`
/// and every cable a `pretension`: these are the prescribed stress state whose equilibrium
/// shape is sought. Supported components stay where `place` (or the geometry) puts them.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FormFinding {
    /// Iterations before form finding gives up. Default 50; range 1 to 10 000 (as
    /// `solver.max_iterations`).
    #[serde(default = "form_finding_iterations")]
    pub max_iterations: usize,
    /// Converged when the shape moves at most `tolerance` times the span (bounding-box
    /// diagonal) in one iteration, and so does the distance left estimated from the rate of
    /// the last two moves: membrane nodes along the surface normal, cable nodes wholly.
    /// Default 1e-6; range [1e-12, 0.1): a move of 1e-12 of the span is near the
    /// coordinates' round-off, one of a tenth is no shape yet.
    /// The found scene carries the stress state that balances the found
    /// shape exactly, so its analysis starts in equilibrium whatever the tolerance.
    #[serde(default = "form_finding_tolerance")]
    pub tolerance: f64,
    /// Homotopy factor λ of the Updated Reference Strategy for isotropic prestress, in
    /// [0, 1): each iteration's matrix is the reference-stress stiffness plus λ times the
    /// material part of the true (surface-tension) tangent. 0 is the plain URS (each step the
    /// equilibrium of the prestress as PK2 stress in the last shape); larger λ lets the mesh
    /// settle within the surface faster (1/(1 − λ) per iteration) at the price of a less
    /// stable step. Default 0.5; range [0, 1) (the settling factor 1/(1 − λ) has no
    /// bound at 1).
    #[serde(default = "form_finding_homotopy")]
    pub homotopy: f64,
    /// Start positions of nodes (mast tops, rings): each listed node is moved to `position`
    /// before form finding; with its components supported it stays there.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub place: Vec<Placement>,
    /// Carry the free nodes along with the placed ones (default false): each node neither
    /// placed nor supported moves by the average of its mesh neighbours' moves (a discrete
    /// harmonic extension of `place`), so a raised ring or mast head lifts the fabric around
    /// it into a smooth start shape and the triangles next to it stay well shaped.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub blend: bool,
}

impl Default for FormFinding {
    fn default() -> Self {
        FormFinding {
            max_iterations: form_finding_iterations(),
            tolerance: form_finding_tolerance(),
            homotopy: form_finding_homotopy(),
            place: Vec::new(),
            blend: false,
        }
    }
}

fn form_finding_iterations() -> usize {
    50
}

fn form_finding_homotopy() -> f64 {
    0.5
}

fn form_finding_tolerance() -> f64 {
    1e-6
}

/// Nodes moved before form finding: one node to a position (`node`, `position`), or a node
/// set as one rigid body (`nodes`, turned by `rotate` if given, then moved by `translate`): a
/// ring raised, a mast head set up. Give one of the two forms.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Placement {
    /// The node moved to `position`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<OneNode>,
    /// [x, y, z] in m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f64; 3]>,
    /// The node set moved as one rigid body.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<NodeRef>,
    /// Translation of the set, [dx, dy, dz] in m (after `rotate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub translate: Option<[f64; 3]>,
    /// Rotation of the set about an axis (before `translate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotate: Option<RigidRotation>,
}

/// A rigid rotation by `angle` (rad, right-hand rule) about the axis through `point` along
/// `axis` (any length but zero; normalised).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RigidRotation {
    pub point: [f64; 3],
    pub axis: [f64; 3],
    pub angle: f64,
}

impl RigidRotation {
    /// `x` turned about the axis (Rodrigues' formula).
    pub fn apply(&self, x: [f64; 3]) -> [f64; 3] {
        let n = (self.axis[0].powi(2) + self.axis[1].powi(2) + self.axis[2].powi(2)).sqrt();
        let k = self.axis.map(|a| a / n);
        let v = [0, 1, 2].map(|c| x[c] - self.point[c]);
        let (c, s) = (self.angle.cos(), self.angle.sin());
        let kxv = [
            k[1] * v[2] - k[2] * v[1],
            k[2] * v[0] - k[0] * v[2],
            k[0] * v[1] - k[1] * v[0],
        ];
        let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
        [0, 1, 2].map(|i| self.point[i] + v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c))
    }
}

/// Newton and path-following settings. Every default is chosen for the shipped scenes and
/// explained on its field.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSettings {
    /// Relative residual tolerance: converged when every free DOF's residual is at most
    /// tolerance · F, F the largest of |f_ext|∞, |reactions|∞, the largest nodal force of any
    /// element and the step's load change (applied and carried forces, never a stiffness).
    /// Where round-off keeps a residual above that, its floor 16 ε (Σ|f| + K_dd X) counts only
    /// if the Newton correction is also within tolerance · X at every unknown, X the size of
    /// the coordinates (docs/solver.md). 1e-9 keeps
    /// verification at 1e-8 honest while quadratic convergence makes it cheap.
    /// Range [1e-14, 1e-2] (`validate::TOLERANCE_RANGE`): below 1e-14 (about 45 ε) only the
    /// round-off floor decides, above 1e-2 a converged state keeps over a percent of the forces
    /// unbalanced.
    pub tolerance: f64,
    /// Newton iterations per load increment before it is cut back. 50: quadratic convergence
    /// needs under 10 once the states have settled, but the first increment from a flat,
    /// stress-free sheet (wrinkle states forming, damped steps off the singular start) takes
    /// 30-46 whatever its size (WindSquare 32, the inflated cushion 46), so cutting it back
    /// earlier only repeats that work. Range 1 to 10 000 (`validate::MAX_ITERATIONS`): the
    /// Newton loop keeps one number per iteration and a failing step runs up to 20 increments
    /// of this many, so the bound keeps both finite and small (2^32 asked for a 34 GB history,
    /// 2^64 − 1 overflowed the loop's bound).
    pub max_iterations: usize,
    /// Work one step may spend in all (every increment, cut-back and the prestress
    /// continuation), in Newton iterations, before it gives up, saying so: the step's work
    /// budget. Every further line-search trial, re-check assembly and relaxation round counts
    /// as an iteration of its own, so the budget bounds time, not only iterations. 1000, 1 to
    /// 100000: twenty times an increment's `max_iterations`; 500 cost sliding-cable and capstan
    /// verification cases that converge after many line-search trials (docs/solver.md, fail
    /// fast). `velarium check` prints what it costs on the reference machine.
    #[serde(
        default = "default_step_iterations",
        skip_serializing_if = "is_default_step_iterations"
    )]
    pub max_step_iterations: usize,
    /// First load increment inside a step, as a fraction of the step's load change (1 = try the
    /// whole step at once). Range [min_increment, 1].
    pub initial_increment: f64,
    /// Smallest increment before the step is declared failed (1e-4: ten thousand increments).
    /// Range [1e-12, initial_increment] (`validate::MIN_INCREMENT`): increments are cut by 4,
    /// so a step tries at most 20 before it fails.
    pub min_increment: f64,
    /// Increment growth aims at this many iterations per increment (6). Range 1 to 10 000 (as
    /// `max_iterations`); at or above `max_iterations` every converged increment lets the next
    /// one double.
    pub target_iterations: usize,
    /// Artificial isotropic prestress in Pa for stress-free membranes, flat or curved. It enters
    /// the tangent only (never the residual), out of the current plane and only as far as the
    /// element lacks tension, and fades as the residual falls below 1 % of the force scale, so
    /// it changes the iteration path, not the equilibrium. Absent: 1e-4 · E of each membrane
    /// group (about 1 % of the stress at qa/Eh = 1e-3); 0 switches it off. Range [0, 1e30] Pa
    /// (the bound of every stress in a scene).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub artificial_prestress: Option<f64>,
    /// Starting isotropic pre-strain of the prestress continuation: an increment that fails
    /// from an unstressed membrane (the flat start) is solved again through problems with every
    /// triangle pre-strained by h = this, a quarter of it, ..., down to a thousandth, then 0,
    /// each from the last one's equilibrium, before it is cut back. The last problem is the
    /// scene's own, so it changes the path, not the equilibrium (docs/solver.md). Not with
    /// friction in a sleeve (its history would take in the intermediate slips). 0 switches it
    /// off; range [0, 0.1] (a pre-strain of more than 10 % is no longer a small perturbation of
    /// the problem).
    #[serde(skip_serializing_if = "is_default_continuation")]
    pub prestress_continuation: f64,
    /// First spring of the proximal continuation, relative to the stiffness every DOF would
    /// have with every element taut and unstressed: an increment Newton could not solve is
    /// solved again from its start through problems that tie each point to the last one by a
    /// spring of that stiffness, a pseudo-time step of an overdamped motion, the spring
    /// weakened after each, then the scene's own problem from the last point (docs/solver.md).
    /// It changes the path, not the equilibrium. Not with sleeve points, volume inputs,
    /// elastoplastic groups or in a time step.
    /// 0 switches it off; range [0, 1].
    #[serde(skip_serializing_if = "is_default_proximal")]
    pub proximal_continuation: f64,
    /// Load-to-stiffness ratio of the first problem of the overshoot continuation: an
    /// increment that fails from an unstressed membrane is solved again with its force loads
    /// (point forces, pressures, snow) first raised until Σ|f| / (√A · E t) reaches this ratio
    /// (A the membranes' area, E t their stiffness: strains of a few per cent), then brought
    /// back to the scene's in steps, each from the last equilibrium; the last problem is the
    /// scene's own (docs/solver.md). It changes the path, not the equilibrium. Not with sleeve
    /// points, volume or water inputs, elastoplastic groups or in a time step.
    /// 0 switches it off; range [0, 1].
    #[serde(skip_serializing_if = "is_default_overshoot")]
    pub overshoot_continuation: f64,
    /// Energy (slope) line search on every Newton correction.
    pub line_search: bool,
    /// How a step follows its path: `load_control` (load increments, the default) or
    /// `arc_length` (the load factor an unknown held by the normal-plane arc-length equation;
    /// passes limit points inside a step; load control across wrinkle-state switches, for
    /// sleeves, volume inputs and prescribed displacements; docs/solver.md).
    #[serde(skip_serializing_if = "PathMethod::is_default")]
    pub path: PathMethod,
    /// First arc length of a step under `path: arc_length`: RMS displacement of the free DOFs
    /// in metres, in [1e-30, 1e30] (the bound of every length in a scene). Absent: set by a
    /// first load-controlled increment of `initial_increment`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arc_length: Option<f64>,
    /// Internal numbering of the nodes inside the linear solve (`rings`, the default, `rcm`,
    /// `hilbert` or `given`): the tangent's equations and the element visit order follow it, so the solve
    /// costs the same whatever the mesher's numbering. Every result stays in the scene's node
    /// numbering (docs/performance.md).
    #[serde(default, skip_serializing_if = "NodeOrder::is_default")]
    pub node_order: NodeOrder,
    /// Size limits checked before anything that grows with the scene is allocated
    /// (`limits.rs`): max_nodes, max_triangles, max_unknowns, max_memory_gb.
    #[serde(skip_serializing_if = "Limits::is_default")]
    pub limits: Limits,
    /// Threads of the solver (1 to 64, the solver's pool bound `solver::threads::MAX_THREADS`):
    /// with 2 or more the instance starts that many worker
    /// threads of its own (joined when it is freed) for the element loop of the assembly and
    /// the sparse factorization. 1 (the default, and what an FMU uses unless the scene asks
    /// for more): no thread besides the instance's own. Results agree with 1 thread to
    /// round-off (docs/performance.md).
    #[serde(skip_serializing_if = "is_one")]
    pub threads: usize,
    /// Inexact Newton (`auto`, the default, `on` or `off`): near the solution a Newton
    /// direction by conjugate gradients on the current tangent preconditioned by the last
    /// factorization, a fresh factorization only when they do not converge. `auto`: on for
    /// tangents of at least 100 000 equations. The convergence test is unchanged; answers
    /// agree with `off` within the tolerance (docs/performance.md).
    #[serde(default, skip_serializing_if = "InexactNewton::is_default")]
    pub inexact_newton: InexactNewton,
    /// Coarse start (`auto`, the default, `on` or `off`): the first step from the undeformed
    /// state first solves the same scene on a coarser mesh (generated membranes: half the
    /// divisions; an explicit mesh: edges collapsed to about a quarter of its nodes, outline
    /// and supports kept; itself started the same way), and Newton on this mesh starts from
    /// that answer interpolated; where it does
    /// not converge from there the step goes on from the undeformed state as without it. It
    /// changes the path, not the equilibrium or the convergence test. `auto`: on for models of
    /// at least 10 000 free DOF. Not with sleeves, contacts, volume inputs, prescribed
    /// displacements, elastoplastic groups, arc length, time integration or form finding of
    /// an explicit mesh, nor where a generated node or triangle is named by its id
    /// (docs/solver.md).
    #[serde(default, skip_serializing_if = "CoarseStart::is_default")]
    pub coarse_start: CoarseStart,
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

fn default_step_iterations() -> usize {
    1000
}

fn is_default_step_iterations(n: &usize) -> bool {
    *n == default_step_iterations()
}

fn is_default_continuation(h: &f64) -> bool {
    *h == SolverSettings::default().prestress_continuation
}

fn is_default_proximal(t: &f64) -> bool {
    *t == SolverSettings::default().proximal_continuation
}

fn is_default_overshoot(t: &f64) -> bool {
    *t == SolverSettings::default().overshoot_continuation
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            tolerance: 1e-9,
            max_iterations: 50,
            max_step_iterations: default_step_iterations(),
            initial_increment: 1.0,
            min_increment: 1e-4,
            target_iterations: 6,
            artificial_prestress: None,
            prestress_continuation: 1e-3,
            proximal_continuation: 1e-3,
            overshoot_continuation: 3e-2,
            line_search: true,
            path: PathMethod::LoadControl,
            arc_length: None,
            node_order: NodeOrder::Rings,
            limits: Limits::default(),
            threads: 1,
            inexact_newton: InexactNewton::Auto,
            coarse_start: CoarseStart::Auto,
        }
    }
}

/// Size limits of a scene (`solver.limits`). Every field has a default; a scene above any of
/// them is rejected with the estimate and the limit named.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Limits {
    /// Most mesh nodes (explicit and generated). Default 2,000,000. Range 1 to 4,294,967,295
    /// for this and the next two (`validate::MAX_COUNT_LIMIT`): the solver addresses its
    /// matrix with 32-bit positions, so no larger model can be built.
    pub max_nodes: u64,
    /// Most mesh triangles. Default 4,000,000.
    pub max_triangles: u64,
    /// Most unknowns (3 per node, 4 more per sleeve point). Default 4,000,000.
    pub max_unknowns: u64,
    /// Most estimated peak memory of model and solver, in GB (1e9 bytes). Default 16: what a
    /// 24 GB machine can give a solve while the host keeps the rest. Range [1e-3, 1e6]
    /// (`validate::MEMORY_GB_RANGE`): finite and positive (NaN would switch the check off).
    pub max_memory_gb: f64,
    /// Also compare the estimate with the memory this process can get now (the smaller of the
    /// machine's available memory and the address-space limit). Default true; false leaves
    /// only max_memory_gb (for hosts whose available memory misleads, e.g. with swap). An
    /// allocation that then fails is still an error, never a crash.
    pub check_available_memory: bool,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_nodes: 2_000_000,
            max_triangles: 4_000_000,
            max_unknowns: 4_000_000,
            max_memory_gb: 16.0,
            check_available_memory: true,
        }
    }
}

impl Limits {
    pub fn is_default(&self) -> bool {
        *self == Limits::default()
    }
}

/// Debug-only switches. The two time switches are honoured by the FMU's `fmi2DoStep` (not by
/// `velarium solve`) and may be exposed as parameters (targets `debug.fail_after_time`,
/// `debug.panic_after_time`), which then need a value here as their start value;
/// `skip_memory_probes` is honoured everywhere.
#[derive(Clone, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct DebugSettings {
    /// A step that ends after this time (beyond round-off) does not converge: it returns
    /// `fmi2Discard` exactly as a real non-convergence would (pseudo-time, same unit as the
    /// experiment).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fail_after_time: Option<f64>,
    /// A step that ends after this time panics inside the FMU: the panic boundary turns it into
    /// `fmi2Error` and the instance goes to the Error state.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub panic_after_time: Option<f64>,
    /// Skip the memory probes that run before the model is built and before every step
    /// (`src/memory.rs`), so that a test with a lowered memory limit reaches the fallible
    /// allocations themselves. Honoured everywhere (library, FMU and CLI); not a parameter.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub skip_memory_probes: bool,
}

impl DebugSettings {
    /// No switch set (the section is then left out of the serialized scene).
    pub fn is_off(&self) -> bool {
        self.fail_after_time.is_none()
            && self.panic_after_time.is_none()
            && !self.skip_memory_probes
    }

    /// Set the field a `debug.<field>` parameter targets. False: no such field.
    pub fn set(&mut self, field: &str, value: f64) -> bool {
        match field {
            "fail_after_time" => self.fail_after_time = Some(value),
            "panic_after_time" => self.panic_after_time = Some(value),
            _ => return false,
        }
        true
    }

    /// The value of the field a `debug.<field>` parameter targets (NaN: not set).
    pub fn get(&self, field: &str) -> Option<f64> {
        match field {
            "fail_after_time" => Some(self.fail_after_time.unwrap_or(f64::NAN)),
            "panic_after_time" => Some(self.panic_after_time.unwrap_or(f64::NAN)),
            _ => None,
        }
    }
}

/// The FMU's DefaultExperiment.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Experiment {
    pub start_time: f64,
    pub stop_time: f64,
    pub step_size: f64,
    /// The load history of the default experiment (optional): the FMU's reference results are
    /// computed under it and it is shipped beside them as the reference input
    /// (`<Name>_in.csv`, docs/fmu.md). Absent: the inputs stay at their start values.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub loads: Option<ExperimentLoads>,
}

impl Default for Experiment {
    fn default() -> Self {
        Experiment {
            start_time: 0.0,
            stop_time: 1.0,
            step_size: 0.1,
            loads: None,
        }
    }
}

/// A load history: input values at given times, linear in between and held before the first
/// and after the last time (as fmpy and fmusim apply an input file).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ExperimentLoads {
    /// The times, strictly increasing, in the experiment's pseudo-time.
    pub time: Vec<f64>,
    /// Per input name, one value per time. An array input takes a number (every element) or
    /// the list of its elements in row-major order. Inputs left out keep their start values.
    pub inputs: BTreeMap<String, Vec<LoadValue>>,
}

/// One input's value at one time of a load history.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(untagged)]
pub enum LoadValue {
    /// The value of a scalar input, or of every element of an array input.
    All(f64),
    /// The elements of an array input, row-major.
    Each(Vec<f64>),
}

/// A scene that could not be read: the JSON path and what is wrong there.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// JSON path such as `cables[0].nodes[3]` (empty for the whole document).
    pub path: String,
    pub message: String,
}

impl Scene {
    /// Pretty JSON text of the scene (what is stored in an FMU's resources).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a scene always serializes")
    }
}
