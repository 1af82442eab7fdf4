//! Plausibility warnings: numbers a valid scene may have but that are most likely a slip (N/m
//! for kN/m, Pa for MPa, a penalty typed without its exponent). They never stop a scene:
//! `velarium check` prints them after its summary and an FMU logs them at instantiation on
//! `logStatusWarning`. Each names the JSON path and the numbers.
//!
//! ```text
//! prestrain   the strain a membrane prestress or a cable pretension implies in the material
//!             the scene declares, above MAX_PRESTRAIN (5 %):
//!               membrane, principal forces n1, n2 (N/m) on thickness t, small-strain compliance
//!               svk           ε1 = (n1 − ν n2) / (E t)
//!               neo_hookean   the same with E = 3μ, ν = 1/2 (its small-strain limit)
//!               orthotropic   ε_w = (n_w − ν_wf n_f) / (E_w t), ε_f = n_f / (E_f t) − ν_wf n_w / (E_w t)
//!               a `field` prestress: per triangle, its two largest principal forces; on an
//!               orthotropic group the larger over t min(E_w, E_f) (its axes are not known)
//!               cable: T / EA (`pretension`, the largest of `pretensions`), or l / L0 − 1
//!               (`unstretched_length` against the cable's length in the scene geometry)
//! modulus     a membrane modulus more than MODULUS_MARGIN (100x) outside the usual range of
//!             its material kind (USUAL_SHEET_MODULUS, USUAL_RUBBER_SHEAR_MODULUS). Cables give
//!             EA only (no area), so only their strain is checked.
//! penalty     a sleeve's `penalty` (N/m) below the stiffness of the members it ties: the
//!             larger of EA/ℓ_min (ℓ_min the cable's shortest segment in the scene geometry)
//!             and E t of the membranes at its sleeve nodes (E = 3μ for neo-Hookean, the larger
//!             of E_warp, E_fill): the tie would then stretch more than the cable and the
//!             membrane it holds together. The default is 100 times that (`PENALTY_FACTOR` of
//!             model/sleeve.rs, which this layer does not import).
//! ```
//!
//! The 5 % bound: St Venant-Kirchhoff is a small-strain law (its doc: films below a few %),
//! and coated fabrics and foils are prestressed to well under 1 % (the shipped scenes imply at
//! most 1 %, the SlidingCable's 100 N on EA = 1e4 N; the FourPointSail's membrane 0.23 %:
//! `tests/scene_cli/plausibility.rs` prints each margin), so a prestress that needs more is a
//! unit slip far more often than a design.
//!
//! # References
//! Usual ranges of Young's modulus: M. F. Ashby, *Materials Selection in Mechanical Design*,
//! 4th ed. 2011, ch. 4 (the modulus-density chart: elastomers 1e-3 to 1e-1 GPa, polymers 0.2 to
//! 4 GPa); coated fabrics (PVC-polyester, PTFE-glass), taken as an equivalent isotropic sheet of
//! about 1 mm, fall in the same polymer band (B. Forster, M. Mollaert (eds.), *European Design
//! Guide for Tensile Surface Structures*, TensiNet 2004).

use super::generate::{resolve, Mesh};
use super::{Material, NodeRef, Prestress, Scene, TriangleRef};
use nalgebra::{Matrix3, SymmetricEigen};

/// Largest strain a prestress or pretension may imply before it is flagged.
pub const MAX_PRESTRAIN: f64 = 0.05;

/// Usual Young's modulus (Pa) of a membrane sheet, `svk` E and `orthotropic` E_warp, E_fill
/// and G: from elastomers used at small strain (1 MPa) to polymer films, foils and coated
/// fabrics (ETFE about 1 GPa, PET 2 to 4 GPa): 1 MPa to 5 GPa (Ashby's chart; see the module
/// docs).
pub const USUAL_SHEET_MODULUS: (f64, f64) = (1e6, 5e9);

/// Usual shear modulus μ (Pa) of a `neo_hookean` rubber: E = 3μ from 0.3 MPa (soft silicone)
/// to 90 MPa (hard elastomers): Ashby's elastomer band (1 to 100 MPa), extended down to soft
/// silicones.
pub const USUAL_RUBBER_SHEAR_MODULUS: (f64, f64) = (1e5, 3e7);

/// How far outside its usual range a modulus may lie before it is flagged (a factor).
pub const MODULUS_MARGIN: f64 = 100.0;

/// What a plausibility check looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Check {
    /// The strain a membrane prestress or a cable pretension implies.
    Prestrain,
    /// A membrane modulus against the usual range of its material kind.
    Modulus,
    /// A sleeve penalty against the stiffness of what it ties.
    Penalty,
}

/// One checked number: where, how close to its warning threshold (`ratio` above 1 warns) and
/// what the warning says.
#[derive(Clone, Debug, PartialEq)]
pub struct Measure {
    pub check: Check,
    pub path: String,
    /// Prestrain: strain / [`MAX_PRESTRAIN`]; modulus: its factor outside the usual range /
    /// [`MODULUS_MARGIN`] (at most 1/100 inside the range); penalty: the members' stiffness /
    /// the penalty.
    pub ratio: f64,
    pub message: String,
}

/// A plausibility warning: the JSON path and what is odd there, with the numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Warning {
    pub path: String,
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}",
            super::read::clip(&format!("{}: {}", self.path, self.message))
        )
    }
}

/// Every plausibility warning of a validated scene (empty: nothing odd).
pub fn warnings(scene: &Scene) -> Vec<Warning> {
    measures(scene)
        .into_iter()
        .filter(|m| m.ratio > 1.0)
        .map(|m| Warning {
            path: m.path,
            message: m.message,
        })
        .collect()
}

/// Every checked number of a validated scene with its distance to the warning threshold.
pub fn measures(scene: &Scene) -> Vec<Measure> {
    let mut out = Vec::new();
    // The mesh only where a cable's geometry is needed (an unstretched length, a penalty).
    let needs_mesh = scene.cables.iter().any(|c| {
        c.unstretched_length.is_some() || c.sleeve.as_ref().is_some_and(|s| s.penalty.is_some())
    });
    let mesh = needs_mesh.then(|| resolve(&scene.geometry));
    for (i, m) in scene.membranes.iter().enumerate() {
        modulus(&m.material, &format!("membranes[{i}].material"), &mut out);
        if let Some(p) = &m.prestress {
            prestress(p, &m.material, m.thickness, i, &mut out);
        }
    }
    for (i, c) in scene.cables.iter().enumerate() {
        let p = format!("cables[{i}]");
        let largest = c
            .pretension
            .into_iter()
            .map(|t| (t, "pretension"))
            .chain(c.pretensions.iter().flatten().map(|&t| (t, "pretensions")))
            .fold(None, |m: Option<(f64, &str)>, (t, f)| match m {
                Some((b, _)) if b >= t => m,
                _ => Some((t, f)),
            });
        if let Some((t, field)) = largest {
            let strain = t / c.ea;
            out.push(Measure {
                check: Check::Prestrain,
                path: format!("{p}.{field}"),
                ratio: strain / MAX_PRESTRAIN,
                message: format!(
                    "a tension of {} N on EA = {} N implies a strain of {}, more than {:.0} %: check the units of both",
                    num(t),
                    num(c.ea),
                    percent(strain),
                    100.0 * MAX_PRESTRAIN
                ),
            });
        }
        if let (Some(l0), Some(mesh)) = (c.unstretched_length, &mesh) {
            let l = polyline_length(mesh, &cable_nodes(mesh, &c.nodes));
            let strain = l / l0 - 1.0;
            out.push(Measure {
                check: Check::Prestrain,
                path: format!("{p}.unstretched_length"),
                ratio: strain / MAX_PRESTRAIN,
                message: format!(
                    "{} m against the cable's length {} m in the scene geometry implies a strain of {}, more than {:.0} %",
                    num(l0),
                    num(l),
                    percent(strain),
                    100.0 * MAX_PRESTRAIN
                ),
            });
        }
        if let (Some(k), Some(mesh)) = (c.sleeve.as_ref().and_then(|s| s.penalty), &mesh) {
            penalty(scene, mesh, i, k, &mut out);
        }
    }
    out
}

/// `x` with 4 significant digits, trailing zeros dropped: 2e4, 1.667e3, 6e-1.
fn num(x: f64) -> String {
    let text = format!("{x:.3e}");
    match text.split_once('e') {
        Some((mantissa, exponent)) if mantissa.contains('.') => {
            let m = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{exponent}")
        }
        _ => text,
    }
}

/// A strain as a percentage with 3 significant digits.
fn percent(strain: f64) -> String {
    let p = 100.0 * strain;
    let digits = (2.0 - p.abs().log10().floor()).clamp(0.0, 6.0) as usize;
    format!("{p:.digits$} %")
}

/// A modulus far outside the usual range of its material kind.
fn modulus(material: &Material, path: &str, out: &mut Vec<Measure>) {
    let (fields, (lo, hi), what): (Vec<(&str, f64)>, _, _) = match material {
        Material::Svk { young, .. } | Material::Etfe { young, .. } => {
            (vec![("E", *young)], USUAL_SHEET_MODULUS, "a sheet")
        }
        Material::Orthotropic {
            e_warp, e_fill, g, ..
        } => (
            vec![("E_warp", *e_warp), ("E_fill", *e_fill), ("G", *g)],
            USUAL_SHEET_MODULUS,
            "a coated fabric",
        ),
        Material::NeoHookean { mu } => (
            vec![("mu", *mu)],
            USUAL_RUBBER_SHEAR_MODULUS,
            "a rubber's shear modulus",
        ),
    };
    for (field, value) in fields {
        let factor = (lo / value).max(value / hi);
        out.push(Measure {
            check: Check::Modulus,
            path: format!("{path}.{field}"),
            ratio: factor / MODULUS_MARGIN,
            message: format!(
                "{} Pa is {factor:.0}x {} the usual range of {what} ({} to {} Pa), more than {MODULUS_MARGIN:.0}x: check the unit (Pa, not kPa, MPa or GPa)",
                num(value),
                if value < lo { "below" } else { "above" },
                num(lo),
                num(hi)
            ),
        });
    }
}

/// The largest strain a membrane prestress implies in its material (module docs), with a
/// warning above [`MAX_PRESTRAIN`].
fn prestress(p: &Prestress, material: &Material, t: f64, group: usize, out: &mut Vec<Measure>) {
    let (strain, what) = match p {
        Prestress::Isotropic { n } => (
            strain(material, t, *n, *n, true),
            format!("an isotropic prestress of {} N/m", num(*n)),
        ),
        Prestress::WarpFill { warp, fill, .. } => (
            strain(material, t, *warp, *fill, true),
            format!(
                "a prestress of {} (warp) and {} (fill) N/m",
                num(*warp),
                num(*fill)
            ),
        ),
        Prestress::Cylindrical { n_r, n_theta, .. } => (
            strain(material, t, *n_r, *n_theta, true),
            format!(
                "a prestress of {} (radial, at its radius) and {} (hoop) N/m",
                num(*n_r),
                num(*n_theta)
            ),
        ),
        Prestress::Field { n } => {
            let (worst, k) = n
                .iter()
                .enumerate()
                .map(|(k, c)| {
                    let (n1, n2) = principal(c);
                    (strain(material, t, n1, n2, false), k)
                })
                .fold((0.0f64, 0), |a, b| if b.0 > a.0 { b } else { a });
            (
                worst,
                format!("the prestress field (triangle {k} of the group)"),
            )
        }
    };
    out.push(Measure {
        check: Check::Prestrain,
        path: format!("membranes[{group}].prestress"),
        ratio: strain / MAX_PRESTRAIN,
        message: format!(
            "{what} on thickness {} m implies a strain of {} in the group's material ({}), more than {:.0} %: check the units (N/m is stress times thickness)",
            num(t),
            percent(strain),
            stiffness(material, t),
            100.0 * MAX_PRESTRAIN
        ),
    });
}

/// "E t = 6e5 N/m" and the like, for the message.
fn stiffness(material: &Material, t: f64) -> String {
    match material {
        Material::Svk { young, nu } | Material::Etfe { young, nu, .. } => {
            format!("E t = {} N/m, nu {nu}", num(young * t))
        }
        Material::NeoHookean { mu } => format!("3 mu t = {} N/m", num(3.0 * mu * t)),
        Material::Orthotropic { e_warp, e_fill, .. } => format!(
            "E_warp t = {}, E_fill t = {} N/m",
            num(e_warp * t),
            num(e_fill * t)
        ),
    }
}

/// The largest small-strain normal strain of principal membrane forces n1, n2 (N/m) in
/// `material` of thickness `t`; `aligned`: n1, n2 are along warp and fill.
fn strain(material: &Material, t: f64, n1: f64, n2: f64, aligned: bool) -> f64 {
    let isotropic = |e: f64, nu: f64| ((n1 - nu * n2) / (e * t)).max((n2 - nu * n1) / (e * t));
    match material {
        Material::Svk { young, nu } | Material::Etfe { young, nu, .. } => isotropic(*young, *nu),
        Material::NeoHookean { mu } => isotropic(3.0 * mu, 0.5),
        Material::Orthotropic {
            e_warp,
            e_fill,
            nu_wf,
            ..
        } => {
            if aligned {
                let warp = (n1 - nu_wf * n2) / (e_warp * t);
                let fill = n2 / (e_fill * t) - nu_wf * n1 / (e_warp * t);
                warp.max(fill)
            } else {
                n1.abs().max(n2.abs()) / (e_warp.min(*e_fill) * t)
            }
        }
    }
}

/// The two principal values of largest magnitude of a membrane force tensor in global
/// components [xx, yy, zz, xy, yz, xz] (its in-plane pair; the third is about 0).
fn principal(c: &[f64; 6]) -> (f64, f64) {
    let m = Matrix3::new(c[0], c[3], c[5], c[3], c[1], c[4], c[5], c[4], c[2]);
    let mut v: Vec<f64> = SymmetricEigen::new(m).eigenvalues.iter().copied().collect();
    v.sort_by(|a, b| b.abs().total_cmp(&a.abs()));
    (v[0], v[1])
}

/// Node ids of a validated cable.
fn cable_nodes(mesh: &Mesh, r: &NodeRef) -> Vec<usize> {
    match r {
        NodeRef::Ids(ids) => ids.clone(),
        NodeRef::Set(name) => mesh.node_sets.get(name).cloned().unwrap_or_default(),
    }
}

fn distance(mesh: &Mesh, a: usize, b: usize) -> f64 {
    let (p, q) = (mesh.nodes[a], mesh.nodes[b]);
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
}

fn polyline_length(mesh: &Mesh, ids: &[usize]) -> f64 {
    ids.windows(2).map(|w| distance(mesh, w[0], w[1])).sum()
}

/// A sleeve penalty `k` below the stiffness of the members it ties (module docs).
fn penalty(scene: &Scene, mesh: &Mesh, i: usize, k: f64, out: &mut Vec<Measure>) {
    let c = &scene.cables[i];
    let ids = cable_nodes(mesh, &c.nodes);
    let shortest = ids
        .windows(2)
        .map(|w| distance(mesh, w[0], w[1]))
        .fold(f64::INFINITY, f64::min);
    let mut sleeved = vec![false; mesh.nodes.len()];
    let sleeve_nodes = match c.sleeve.as_ref().and_then(|s| s.nodes.as_ref()) {
        Some(r) => cable_nodes(mesh, r),
        None => ids[1..ids.len().saturating_sub(1)].to_vec(),
    };
    sleeve_nodes.iter().for_each(|&n| sleeved[n] = true);
    let mut et = 0.0f64;
    for m in &scene.membranes {
        let e = match &m.material {
            Material::Svk { young, .. } | Material::Etfe { young, .. } => *young,
            Material::NeoHookean { mu } => 3.0 * mu,
            Material::Orthotropic { e_warp, e_fill, .. } => e_warp.max(*e_fill),
        };
        let tris: &[usize] = match &m.triangles {
            TriangleRef::Ids(ids) => ids,
            TriangleRef::Set(name) => mesh.triangle_sets.get(name).map_or(&[], |v| v),
        };
        if tris
            .iter()
            .any(|&t| mesh.triangles[t].iter().any(|&n| sleeved[n]))
        {
            et = et.max(e * m.thickness);
        }
    }
    let axial = c.ea / shortest;
    let members = axial.max(et);
    out.push(Measure {
        check: Check::Penalty,
        path: format!("cables[{i}].sleeve.penalty"),
        ratio: members / k,
        message: format!(
            "{} N/m is softer than the members it ties (EA/l_min = {} N/m over the shortest segment {} m, E t = {} N/m of the membrane at its nodes): the tie would stretch more than they do; leave it out for the default, 100 times the stiffer",
            num(k),
            num(axial),
            num(shortest),
            num(et)
        ),
    });
}
