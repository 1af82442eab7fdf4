//! The data form finding's phases share (formfind.rs, equations.rs, measure.rs): its
//! constants, the report, the fixed set-up and the state one iteration hands the next. A leaf
//! of the module: it imports none of the phases.

use crate::model::membrane;
use crate::scene::generate::Mesh;
use crate::scene::Scene;
use crate::solver::assemble::Pattern;
use crate::solver::linear::Ldlt;
use nalgebra::{Matrix2, Vector3};

/// A triangle whose area falls below this fraction of its start area has collapsed: the
/// prestress has no equilibrium between the supports.
pub const COLLAPSE: f64 = 1e-3;

/// A shape move ratio between iterations above this marks the mesh creeping within the surface
/// (the shape itself converges at about 0.4 per iteration): the mesh control switches on.
pub const CREEP_RATE: f64 = 0.7;

/// Stiffness of the mesh-control springs relative to a node's own stiffness.
pub const MESH_SPRING: f64 = 100.0;

/// Share of the membrane's in-surface stiffness across an edge cable kept in the matrix while
/// the mesh control is on (the rest is a linear-model artefact that slows the cable arcs; a
/// tenth is kept so that the matrix stays positive definite with margin: the neighbouring
/// membrane nodes' springs leave about 1 % of it coupled).
pub const ACROSS_CABLE_KEPT: f64 = 0.1;

/// Share of a cable-net segment's force-density stiffness along the segment kept in the
/// matrix, between nodes that cannot slide (the true stiffness of a constant-force cable has
/// none along it; with none kept each iteration is a Newton step on Σ T L, a hundredth is kept
/// as a margin for the pivots of odd nets). A 7 x 7 hypar net with forces 1 and 3 kN: 10
/// iterations (0.1 kept: 29; all kept: no convergence in 200).
pub const AXIAL_KEPT: f64 = 0.01;

/// Largest relative deviation of the found stress state from the prescribed one (the report's
/// `deviation`) that form finding accepts: above it the found shape is the equilibrium of
/// another stress state than the one asked for (an anisotropic prestress that has no
/// equilibrium on the surface, a mesh still creeping), and form finding fails saying so.
pub const MAX_DEVIATION: f64 = 1e-2;

/// A found triangle has degenerated when its smallest angle is below this (degrees) and below
/// half its smallest angle in the start shape (so a start mesh's own slivers are not blamed on
/// form finding). 5°: an aspect ratio of about 11; see [`crate::formfind`] for the values it
/// separates.
pub const MIN_ANGLE_DEGREES: f64 = 5.0;

/// Iterative refinement solves of the last step.
pub(super) const REFINEMENTS: usize = 3;

/// What form finding did.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The scene with the found geometry (explicit nodes, triangles and sets; no generators,
    /// no `form_finding` section). Present when converged.
    pub scene: Option<Scene>,
    /// Iterations (linear solves) done.
    pub iterations: usize,
    /// Largest shape move of the last iteration (normal to the surface at membrane nodes, the
    /// whole move at cable nodes), relative to the span. For a found shape: the move of the
    /// finishing step (the plain equations, no homotopy or mesh control), which may exceed the
    /// tolerance; what it does to the stress is `deviation`.
    pub last_move: f64,
    /// The shape move of the iteration that met the tolerance (relative to the span; infinite
    /// while none has): the convergence of the shape iteration that the summary reports.
    pub shape_move: f64,
    /// Smallest angle of a triangle of the last iterate in degrees (60 without triangles), and
    /// that triangle's smallest angle in the start shape (see [`MIN_ANGLE_DEGREES`]).
    pub min_angle: (f64, f64),
    /// Largest relative deviation of the stress state that balances the found shape from the
    /// prescribed one (membrane force components over the group's largest prescribed force;
    /// cable forces over their prescribed force).
    pub deviation: f64,
    /// Wall time, s.
    pub seconds: f64,
    /// One line per iteration.
    pub log: Vec<String>,
    /// Why it failed (empty when converged).
    pub message: String,
}

impl Report {
    pub fn converged(&self) -> bool {
        self.scene.is_some()
    }
}

/// Prescribed stress of one triangle: group prestress (warp, fill in N/m, warp direction) and
/// thickness.
pub(super) struct TriangleStress {
    pub(super) nodes: [usize; 3],
    pub(super) warp: f64,
    pub(super) fill: f64,
    pub(super) direction: Vector3<f64>,
    pub(super) thickness: f64,
    pub(super) group: usize,
    /// Its id in the scene's mesh (explicit triangles first, then each generator's).
    pub(super) id: usize,
    /// A cylindrical prestress, evaluated where the triangle is now ([`Self::prescribed`]):
    /// its radial and hoop forces belong to the place, not to the material triangle, so a
    /// triangle that slides within the surface takes the forces of where it goes.
    pub(super) about: Option<crate::scene::Prestress>,
}

impl TriangleStress {
    /// (warp, fill, warp direction) prescribed on the triangle at positions `x`.
    pub(super) fn prescribed(&self, x: &[Vector3<f64>]) -> (f64, f64, Vector3<f64>) {
        let fixed = (self.warp, self.fill, self.direction);
        match &self.about {
            Some(p) => {
                let c = self.nodes.iter().map(|&i| x[i]).sum::<Vector3<f64>>() / 3.0;
                p.at(c.into())
                    .map_or(fixed, |(w, f, d)| (w, f, Vector3::from(d)))
            }
            None => fixed,
        }
    }

    /// The triangle in the scene's words: its mesh id, its group and its nodes.
    pub(super) fn describe(&self) -> String {
        format!(
            "triangle {} of membranes[{}] (nodes {:?})",
            self.id, self.group, self.nodes
        )
    }
}

/// Why the iterations stopped without a found shape.
pub(super) enum Halt {
    /// No shape (a collapse, a zero-length segment, a failed solve, divergence, the iteration
    /// budget): the report's message.
    Failed(String),
    /// A scene problem found on the way (a warp direction normal to an iterate's triangle).
    Invalid(crate::Error),
}

/// What stays fixed through the iterations: the resolved mesh, the equation numbering and
/// matrix pattern of the scene's model, the prescribed stress of every triangle and force of
/// every cable segment, which nodes the membranes and cables use, the start areas and the span.
pub(super) struct Setup {
    /// The scene's geometry resolved (generators expanded); the found scene is written on it.
    pub(super) mesh: Mesh,
    /// Equation numbers of the DOFs (NONE: held) and the free-free matrix's upper pattern.
    pub(super) pattern: Pattern,
    /// Prescribed stress of every triangle, membrane group by group.
    pub(super) tris: Vec<TriangleStress>,
    /// Cable segments: end nodes and prescribed force T (N).
    pub(super) segments: Vec<(usize, usize, f64)>,
    /// The cable of each segment.
    pub(super) seg_cable: Vec<usize>,
    /// Per node: a triangle uses it.
    pub(super) on_membrane: Vec<bool>,
    /// Per node: a cable segment uses it.
    pub(super) on_cable: Vec<bool>,
    /// Area of each triangle in X_0.
    pub(super) start_area: Vec<f64>,
    /// Smallest angle (degrees) of each triangle in X_0.
    pub(super) start_angle: Vec<f64>,
    /// Bounding-box diagonal of the nodes the elements use in X_0.
    pub(super) span: f64,
}

/// What one iteration hands the next.
pub(super) struct State {
    /// Positions: X_k at the start of iteration k, X_{k+1} after its step.
    pub(super) x: Vec<Vector3<f64>>,
    /// The free-free matrix of the iteration and its factorization.
    pub(super) linear: Ldlt,
    /// The residual L_k X_k at every DOF.
    pub(super) r: Vec<f64>,
    /// Right-hand side, then solution, at the free DOFs.
    pub(super) rhs: Vec<f64>,
    /// Per triangle: its reference data in X_k and its prescribed PK2 stress S0 there.
    pub(super) stage: Vec<(membrane::TriangleRef, Matrix2<f64>)>,
    /// Per cable segment: its length L_k.
    pub(super) lengths: Vec<f64>,
    /// Shape move of the last iteration (0 before the first).
    pub(super) previous_move: f64,
    /// The shape has converged: this iteration solves the plain equations (no homotopy, no
    /// mesh control, no relief) and refines them, and the found scene follows.
    pub(super) finishing: bool,
    /// The mesh creeps: the mesh control is on (until `finishing`).
    pub(super) projecting: bool,
}
