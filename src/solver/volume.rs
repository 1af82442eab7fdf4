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
//! Water-volume control (`water_volume` inputs, `LoadModel::Water`) is the same border with
//! the ponding level h in place of the pressure:
//!
//! ```text
//! row        h_W = γ_w (V_w(u, h) − V_w⁰)      V_w = Σ c_z (d_1 + d_2 + d_3)/6 over the region,
//!                                              d_i = max(h − z_i, 0) (model/pressure.rs,
//!                                              ponding_volume): γ_w V_w is the vertical
//!                                              resultant of the ponding forces, so the row is
//!                                              the weight of water missing (N)
//! border     ∂h_W/∂u = γ_w ∂V_w/∂u, ∂h_W/∂h = γ_w A_wet (the wet plan area c_z Σ w/6;
//!            the region's whole plan area while it is dry, so that an empty region's first
//!            step fills it to the mean depth V_w⁰/A)
//! column     ∂R/∂h = −∂f_ponding/∂h (SurfaceLaw::rate)
//! unknown    η with h = datum + η, the datum the region's lowest reference z
//! ```
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
/// equations (a water volume's row in its place: [`water_row`]).
pub(super) fn rows(model: &Model, eq: &[usize], u: &[f64], loads: &[f64]) -> Vec<Row> {
    let mut out = Vec::new();
    for (l, load) in model.loads.iter().enumerate() {
        if let LoadModel::Water {
            triangles,
            gamma_w,
            unknown,
            ..
        } = load
        {
            let h = model.load_value(l, u, loads);
            out.push(water_row(
                model, eq, u, triangles, *gamma_w, *unknown, h, loads[l],
            ));
            continue;
        }
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

/// The row of a water volume (module docs): h = γ_w (V_w(u, level) − target).
#[allow(clippy::too_many_arguments)]
fn water_row(
    model: &Model,
    eq: &[usize],
    u: &[f64],
    triangles: &[usize],
    gamma_w: f64,
    unknown: usize,
    level: f64,
    target: f64,
) -> Row {
    let mut grad = vec![0.0; eq.len()];
    let (mut volume, mut wet, mut plan) = (0.0, 0.0, 0.0);
    for &e in triangles {
        let nodes = model.triangles[e].nodes;
        let x = nodes.map(|i| model.position(u, i));
        let (v, g, dh) = pressure::ponding_volume(level, &x);
        volume += v;
        wet += dh;
        plan += 0.5 * (x[1] - x[0]).cross(&(x[2] - x[0])).z;
        for (g, &i) in g.iter().zip(&nodes) {
            for c in 0..3 {
                grad[3 * i + c] += g[c];
            }
        }
    }
    // Dry everywhere: the level's own derivative is 0; the whole plan area in its place.
    let own = if wet > 0.0 { wet } else { plan.abs() };
    let dx = grad
        .iter()
        .enumerate()
        .filter(|&(d, g)| eq[d] != NONE && *g != 0.0)
        .map(|(d, g)| (eq[d], gamma_w * g))
        .collect();
    Row {
        r: gamma_w * (volume - target),
        dx,
        ds: vec![(model.slips.len() + unknown, gamma_w * own)],
        magnitude: gamma_w * volume.abs().max(target.abs()),
        damped: false,
    }
}

/// One column per volume input: ∂R/∂p = −f_p (the follower force per unit pressure) on the
/// free equations; per water volume ∂R/∂h = −∂f/∂h of its ponding forces.
pub(super) fn columns(model: &Model, eq: &[usize], u: &[f64]) -> Vec<Vec<(usize, f64)>> {
    let mut out = Vec::new();
    for (l, load) in model.loads.iter().enumerate() {
        if let LoadModel::Water {
            triangles, gamma_w, ..
        } = load
        {
            // The level is the load's value whatever the input values (`load_value`).
            let level = model.load_value(l, u, &[]);
            let law = pressure::SurfaceLaw::Ponding { gamma_w: *gamma_w };
            let mut col = Vec::new();
            for &e in triangles {
                let nodes = model.triangles[e].nodes;
                let rate = law.rate(level, &nodes.map(|i| model.position(u, i)));
                for (&i, f) in nodes.iter().zip(&rate) {
                    for c in 0..3 {
                        let q = eq[3 * i + c];
                        if q != NONE && f[c] != 0.0 {
                            col.push((q, -f[c]));
                        }
                    }
                }
            }
            out.push(col);
            continue;
        }
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
            LoadModel::Water { gamma_w, .. } => Some(-gamma_w * (b - a)),
            _ => None,
        })
        .collect()
}
