//! Validation of the scene's `contacts` (`model::contact`).

use super::{coordinate, is_identifier, positive, suggest, Validator};
use crate::scene::generate::Mesh;
use crate::scene::{Contact, Scene};
use std::collections::BTreeSet;

impl Validator {
    /// A contact output's `contact` names one of the scene's contacts.
    pub(super) fn contact_name(&mut self, s: &Scene, name: &str, path: &str) {
        if !s.contacts.iter().any(|c| c.name() == name) {
            let names: Vec<String> = s.contacts.iter().map(|c| c.name().to_string()).collect();
            self.push(
                path,
                format!(
                    "no contact is named \"{name}\"{}",
                    suggest(name, names.iter())
                ),
            );
        }
    }

    /// Names, node sets, geometry and penalty of every contact; none with form finding.
    pub(super) fn contacts(&mut self, s: &Scene, mesh: &Mesh, _held: &BTreeSet<(usize, usize)>) {
        let mut seen = BTreeSet::new();
        if !s.contacts.is_empty() && s.form_finding.is_some() {
            self.push(
                "contacts",
                "form finding does not take contacts: find the shape first, then add them",
            );
        }
        for (i, c) in s.contacts.iter().enumerate() {
            let p = format!("contacts[{i}]");
            let name = c.name();
            if !is_identifier(name) {
                self.push(
                    format!("{p}.name"),
                    format!("\"{name}\" must be an identifier (letters, digits, _)"),
                );
            }
            if !seen.insert(name.to_string()) {
                self.push(format!("{p}.name"), format!("\"{name}\" is used twice"));
            }
            if let Some(k) = c.penalty() {
                if !(positive(k)) {
                    self.push(
                        format!("{p}.penalty"),
                        format!("{k} is not a positive stiffness in N/m (1e-30 to 1e30)"),
                    );
                }
            }
            let vector = |v: &[f64; 3]| {
                v.iter().all(|x| coordinate(*x))
                    && positive(v.iter().map(|x| x * x).sum::<f64>().sqrt())
            };
            let point = |v: &[f64; 3]| v.iter().all(|x| coordinate(*x));
            match c {
                Contact::Sheets {
                    top,
                    bottom,
                    direction,
                    ..
                } => {
                    let t = self.nodes(mesh, top, &format!("{p}.top"));
                    let b = self.nodes(mesh, bottom, &format!("{p}.bottom"));
                    if let (Some(t), Some(b)) = (t, b) {
                        if t.len() != b.len() {
                            self.push(
                                format!("{p}.bottom"),
                                format!(
                                    "lists {} nodes and top {}: the sets pair node by node, in order",
                                    b.len(),
                                    t.len()
                                ),
                            );
                        }
                        if let Some(k) = t.iter().zip(&b).position(|(x, y)| x == y) {
                            self.push(
                                format!("{p}.bottom"),
                                format!("node {} is paired with itself (position {k})", b[k]),
                            );
                        }
                    }
                    if !vector(direction) {
                        self.push(format!("{p}.direction"), "must be a non-zero finite vector");
                    }
                }
                Contact::Plane {
                    nodes,
                    point: at,
                    normal,
                    ..
                } => {
                    self.nodes(mesh, nodes, &format!("{p}.nodes"));
                    if !point(at) {
                        self.push(format!("{p}.point"), "must be finite with |x| <= 1e30 m");
                    }
                    if !vector(normal) {
                        self.push(format!("{p}.normal"), "must be a non-zero finite vector");
                    }
                }
                Contact::Sphere {
                    nodes,
                    center,
                    radius,
                    ..
                } => {
                    self.nodes(mesh, nodes, &format!("{p}.nodes"));
                    if !point(center) {
                        self.push(format!("{p}.center"), "must be finite with |x| <= 1e30 m");
                    }
                    if !positive(*radius) {
                        self.push(format!("{p}.radius"), "must be a positive length in m");
                    }
                }
                Contact::Cylinder {
                    nodes,
                    point: at,
                    axis,
                    radius,
                    ..
                } => {
                    self.nodes(mesh, nodes, &format!("{p}.nodes"));
                    if !point(at) {
                        self.push(format!("{p}.point"), "must be finite with |x| <= 1e30 m");
                    }
                    if !vector(axis) {
                        self.push(format!("{p}.axis"), "must be a non-zero finite vector");
                    }
                    if !positive(*radius) {
                        self.push(format!("{p}.radius"), "must be a positive length in m");
                    }
                }
            }
        }
    }
}
