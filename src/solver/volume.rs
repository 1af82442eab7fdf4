//! Volume control: the pressure in a closed membrane group as an unknown, held by the
//! prescribed enclosed volume (a bordered system on the LDLT of K).
//!
//! ```text
//! unknowns   u (displacements), p (one pressure per volume input, after the slips)
//! equations  R(u, p) = f_int(u) − p f_p(u) − f_other = 0        f_p: follower force per unit
//!                                                               pressure (model/pressure.rs)
//!            h(u) = k_V (V(u) − V⁰ − ΔV) = 0                    k_V = E t / A of the group (N/m³):
//!                                                               the row is a force, so it meets
//!                                                               the convergence test's tolerance
//! Newton     [K − p K_p   −f_p] [Δu]     [R]
//!            [k_V gᵀ        0 ] [Δp] = − [h]        g = ∂V/∂u (= f_p on a closed surface)
//! solve      y0 = −K⁻¹ R,  y1 = K⁻¹ (−f_p)          two solves on one LDLT of K − p K_p
//!            Δp = (−h − k_V gᵀ y0) / (−k_V gᵀ y1),  Δu = y0 − y1 Δp
//! ```
//! Gas control (an isothermal ideal gas, p_abs V = const: `gas` inputs) replaces the row by
//! h = k_V ((p + p_atm) V/p_atm − V⁰ − ΔN), ΔN the added gas as its volume at p_atm; the border
//! then has the diagonal entry k_V V/p_atm and the row k_V (p + p_atm)/p_atm gᵀ.
//!
//! The border goes through the same Schur elimination as the slip unknowns (`slip.rs`: these
//! are its extra rows and columns). Under pressure control the sphere's tangent K − p K_p
//! turns singular at the limit pressure and the step fails there; under volume control the
//! bordered matrix stays regular through the limit point (the volume grows monotonically along
//! the whole pressure-stretch curve), so the path goes on past it: K − p K_p is then indefinite
//! (one negative pivot) and the LDLT, which does not pivot, factors it as it is.
//!
//! # References
//! Crisfield 1991, vol. 1, §9.4 (bordered systems by two solves); Bonet & Wood 2008, §8.4
//! (enclosed volume, follower pressure); Bonet, Wood, Mahaney & Heywood 2000, CMAME 190:579
//! (gas-filled membranes, volume as the control).

use super::assemble::NONE;
use super::rows::Row;
use crate::model::{pressure, LoadModel, Model};

/// One row per volume input: h = k_V (V(u) − V⁰ − ΔV) and its derivative k_V g on the free
/// equations.
pub(super) fn rows(model: &Model, eq: &[usize], u: &[f64], loads: &[f64]) -> Vec<Row> {
    let mut out = Vec::new();
    for (l, load) in model.loads.iter().enumerate() {
        let LoadModel::Volume {
            triangles,
            reference,
            stiffness,
            unknown,
            atmosphere,
        } = load
        else {
            continue;
        };
        let mut grad = vec![0.0; eq.len()];
        let mut volume = 0.0;
        for &e in triangles {
            let nodes = model.triangles[e].nodes;
            let x = nodes.map(|i| model.position(u, i));
            volume += pressure::enclosed_volume(&x);
            for (g, &i) in pressure::enclosed_volume_gradient(&x).iter().zip(&nodes) {
                for c in 0..3 {
                    grad[3 * i + c] += g[c];
                }
            }
        }
        let target = reference + loads[l];
        // Volume: h = k (V − target); gas: h = k ((p + p_atm) V/p_atm − target), whose
        // derivatives are k (p + p_atm)/p_atm g and k V/p_atm (on its own pressure).
        let (factor, own) = match atmosphere {
            None => (1.0, None),
            Some(atm) => {
                let p = u[model.volume_unknown(*unknown)];
                ((p + atm) / atm, Some(volume / atm))
            }
        };
        let dx = grad
            .iter()
            .enumerate()
            .filter(|&(d, g)| eq[d] != NONE && *g != 0.0)
            .map(|(d, g)| (eq[d], stiffness * factor * g))
            .collect();
        let ds = own
            .map(|d| vec![(model.slips.len() + unknown, stiffness * d)])
            .unwrap_or_default();
        out.push(Row {
            r: stiffness * (factor * volume - target),
            dx,
            ds,
            magnitude: stiffness * (factor * volume).abs().max(target.abs()),
            damped: false,
        });
    }
    out
}

/// One column per volume input: ∂R/∂p = −f_p (the follower force per unit pressure) on the
/// free equations.
pub(super) fn columns(model: &Model, eq: &[usize], u: &[f64]) -> Vec<Vec<(usize, f64)>> {
    let mut out = Vec::new();
    for load in &model.loads {
        let LoadModel::Volume { triangles, .. } = load else {
            continue;
        };
        let mut col = Vec::new();
        for &e in triangles {
            let nodes = model.triangles[e].nodes;
            let f = pressure::follower_force(1.0, &nodes.map(|i| model.position(u, i)));
            for &i in &nodes {
                for c in 0..3 {
                    let q = eq[3 * i + c];
                    if q != NONE {
                        col.push((q, -f[c]));
                    }
                }
            }
        }
        out.push(col);
    }
    out
}

/// ∂h/∂λ of every volume row (in the order of [`rows`]) when the loads move as
/// from + λ (to − from): −k_V (ΔV_to − ΔV_from) (the row's target is affine in its input, for
/// the volume and the gas law alike). The arc-length border's coupling of the volume rows
/// (`arc.rs`).
pub(super) fn load_rates(model: &Model, from: &[f64], to: &[f64]) -> Vec<f64> {
    model
        .loads
        .iter()
        .zip(from.iter().zip(to))
        .filter_map(|(load, (a, b))| match load {
            LoadModel::Volume { stiffness, .. } => Some(-stiffness * (b - a)),
            _ => None,
        })
        .collect()
}
