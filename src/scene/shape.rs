//! Array inputs and outputs: which scene entries are arrays, their shapes, and the mesh
//! entities behind their elements. The variable table (dimensions) and the model (one load
//! channel or probe per element) both read them from here, so they cannot disagree.
//!
//! ```text
//! entry                                 shape             element k (row-major)
//! input  zone_pressure {zones}          [zones]           pressure on zone k's triangles
//! input  support_displacement {nodes}   [nodes, 3]        node k/3 of the set, component k%3
//! output displacement_field {nodes?}    [nodes, 3]        u of node k/3, component k%3
//! output position_field {nodes?}        [nodes, 3]        x of node k/3, component k%3
//! output cable_tensions {cable}         [segments]        tension of segment k
//! output principal_stresses {membrane?} [triangles, 2]    major (k%2 = 0) / minor stress
//! output wrinkle_states {membrane?}     [triangles]       0 taut, 1 wrinkled, 2 slack
//! output sleeve_slips {cable}           [sleeve points]   slip at sleeve point k
//! ```
//!
//! Every other input and output is a scalar (shape `[]`). The functions assume a validated
//! scene: a missing name gives an empty list, never a panic.

use super::generate::Mesh;
use super::{Load, NodeRef, Probe, Scene, Sleeve, TriangleRef};

/// Node ids of a reference (an unknown set: none).
pub fn node_ids(mesh: &Mesh, r: &NodeRef) -> Vec<usize> {
    match r {
        NodeRef::Ids(ids) => ids.clone(),
        NodeRef::Set(name) => mesh.node_sets.get(name).cloned().unwrap_or_default(),
    }
}

/// Mesh triangle ids of a reference (an unknown set: none).
pub fn triangle_ids(mesh: &Mesh, r: &TriangleRef) -> Vec<usize> {
    match r {
        TriangleRef::Ids(ids) => ids.clone(),
        TriangleRef::Set(name) => mesh.triangle_sets.get(name).cloned().unwrap_or_default(),
    }
}

/// Mesh triangle ids of a membrane group, or of every group in scene order (None).
pub fn group_triangles(scene: &Scene, mesh: &Mesh, membrane: Option<&str>) -> Vec<usize> {
    scene
        .membranes
        .iter()
        .filter(|m| membrane.is_none_or(|n| n == m.name))
        .flat_map(|m| triangle_ids(mesh, &m.triangles))
        .collect()
}

/// Positions within a group (0-based, group order) of its triangles that lie in the zone
/// (a triangle set name); every position when `zone` is None.
pub fn zone_positions(
    scene: &Scene,
    mesh: &Mesh,
    membrane: &str,
    zone: Option<&str>,
) -> Vec<usize> {
    let group = group_triangles(scene, mesh, Some(membrane));
    let Some(zone) = zone else {
        return (0..group.len()).collect();
    };
    let set: std::collections::BTreeSet<usize> = mesh
        .triangle_sets
        .get(zone)
        .map(|t| t.iter().copied().collect())
        .unwrap_or_default();
    (0..group.len())
        .filter(|&k| set.contains(&group[k]))
        .collect()
}

/// Node ids of a cable, in order.
pub fn cable_nodes(scene: &Scene, mesh: &Mesh, cable: &str) -> Vec<usize> {
    scene
        .cables
        .iter()
        .find(|c| c.name == cable)
        .map(|c| node_ids(mesh, &c.nodes))
        .unwrap_or_default()
}

/// Sleeve node ids of a cable with node ids `ids` (every interior node unless the sleeve lists
/// them); None when a listed set does not exist.
pub fn sleeve_nodes(ids: &[usize], sleeve: &Sleeve, mesh: &Mesh) -> Option<Vec<usize>> {
    match &sleeve.nodes {
        None if ids.len() < 3 => Some(Vec::new()),
        None => Some(ids[1..ids.len() - 1].to_vec()),
        Some(NodeRef::Ids(list)) => Some(list.clone()),
        Some(NodeRef::Set(name)) => mesh.node_sets.get(name).cloned(),
    }
}

/// Number of sleeve points of a cable (0 without a sleeve).
pub fn sleeve_points(scene: &Scene, mesh: &Mesh, cable: &str) -> usize {
    let Some(c) = scene.cables.iter().find(|c| c.name == cable) else {
        return 0;
    };
    let ids = node_ids(mesh, &c.nodes);
    c.sleeve
        .as_ref()
        .and_then(|s| sleeve_nodes(&ids, s, mesh))
        .map_or(0, |v| v.len())
}

/// The nodes of a field output: the set, or every mesh node.
pub fn field_nodes(mesh: &Mesh, nodes: &Option<NodeRef>) -> Vec<usize> {
    match nodes {
        Some(r) => node_ids(mesh, r),
        None => (0..mesh.nodes.len()).collect(),
    }
}

/// Shape of an input: `[]` for a scalar.
pub fn input_shape(mesh: &Mesh, load: &Load) -> Vec<usize> {
    match load {
        Load::ZonePressure { zones, .. } => vec![zones.len()],
        Load::SupportDisplacement { nodes } => vec![node_ids(mesh, nodes).len(), 3],
        _ => Vec::new(),
    }
}

/// Shape of an output: `[]` for a scalar.
pub fn output_shape(scene: &Scene, mesh: &Mesh, probe: &Probe) -> Vec<usize> {
    match probe {
        Probe::DisplacementField { nodes } | Probe::PositionField { nodes } => {
            vec![field_nodes(mesh, nodes).len(), 3]
        }
        Probe::CableTensions { cable } => {
            vec![cable_nodes(scene, mesh, cable).len().saturating_sub(1)]
        }
        Probe::PrincipalStresses { membrane } => {
            vec![group_triangles(scene, mesh, membrane.as_deref()).len(), 2]
        }
        Probe::WrinkleStates { membrane } => {
            vec![group_triangles(scene, mesh, membrane.as_deref()).len()]
        }
        Probe::SleeveSlips { cable } => vec![sleeve_points(scene, mesh, cable)],
        _ => Vec::new(),
    }
}

/// Number of scalar elements of a shape (1 for a scalar).
pub fn element_count(shape: &[usize]) -> usize {
    shape.iter().product()
}

/// Whether any input or output of the scene is an array (decided from the kinds alone, without
/// building the mesh).
pub fn has_arrays(scene: &Scene) -> bool {
    scene.inputs.iter().any(|i| {
        matches!(
            i.load,
            Load::ZonePressure { .. } | Load::SupportDisplacement { .. }
        )
    }) || scene.outputs.iter().any(|o| {
        matches!(
            o.probe,
            Probe::DisplacementField { .. }
                | Probe::PositionField { .. }
                | Probe::CableTensions { .. }
                | Probe::PrincipalStresses { .. }
                | Probe::WrinkleStates { .. }
                | Probe::SleeveSlips { .. }
        )
    })
}
