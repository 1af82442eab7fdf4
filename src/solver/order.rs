//! Sleeve points keep their order along a cable: the unilateral contact between neighbouring
//! sleeve points, in the cable's material coordinate.
//!
//! ```text
//! gap            g_e = L_e = l0_e + s_j − s_i  between neighbouring sleeve points i < j of one
//!                cable (segment e joins them): the unstretched cable between them
//! Kuhn-Tucker    g_e >= 0,  λ_e >= 0,  λ_e g_e = 0   (λ_e the contact force of the two points)
//! open  (g > 0)  segment e is an ordinary cable segment; the slip step keeps g > 0
//!                (fraction to the boundary, `Settings::keep_length`)
//! close          when g_e <= merge_gap · L⁰_e the points touch: j joins the group of i
//!                (state Merged), its slip is set so that L_e = −δ L⁰_e (δ = CLOSED_OFFSET: the
//!                sign marks the segment closed whatever the round-off), its cable point (and
//!                those of its own group) moves onto i's
//! closed         the segment carries no cable force: a zero-length link k_l (x_j − x_i) holds
//!                the two cable points together (k_l = LINK_FACTOR × the stiffer tie: no 1/l);
//!                j's slip row is the closure row k (L_e + δ L⁰_e) = 0; the group's first point
//!                (its leader) carries one Coulomb row for the whole group, between the segment
//!                entering the group and the one leaving it (`sleeve::group_slip_row`)
//! open again     at a converged point, when the contact force would pull: the link force
//!                T_c = k_l |x_j − x_i| is what the zero-length cable between the two points
//!                carries, less their contact force λ; at frictionless points the cable's
//!                tension T is the same on both sides, λ = T − T_c, and the points part when
//!                T_c > T. With friction the group's entering (T_a) and leaving (T_b) tensions
//!                bound it: the points part when T_c exceeds either by more than friction
//!                holds, (T_c − T_side) cos(Δθ/2) > μ (T_c + T_side) sin(Δθ/2) (the bisector
//!                law, Δθ between the side's segment and the link); the group is treated as one
//!                bead, the approximation this makes for chains of three or more points
//! ```
//! Only frictionless neighbours merge (both μ = 0): with friction an iteration that wanders can
//! slide a point that should stick onto its neighbour and land in an admissible but wrong
//! group (measured on SlidingCable, μ = 0.1 and 0.3), so frictional gaps stay open and a step
//! that needs them closed fails (open work). The parting test below is written for friction
//! too.
//!
//! A group of touching points acts on the cable as one sleeve point that carries the sum of
//! their ties: the seed's "the nodes 7 and 9 converge to the node 8" (Fig. 6, frictionless).
//!
//! # References
//! Wriggers 2006, §4.1 and §5.2 (Kuhn-Tucker conditions of unilateral contact, active set);
//! seed paper §3 (Kuhn-Tucker conditions of the contact element).

use crate::model::sleeve::{self, Contact};
use crate::model::Model;
use nalgebra::Vector3;

/// Slip index of the last point of the group that sleeve point `j` leads (j itself when no
/// point is merged into it).
pub(crate) fn group_last(model: &Model, states: &[Contact], j: usize) -> usize {
    let mut last = j;
    while let Some(next) = follower(model, last) {
        if states[next] != Contact::Merged {
            break;
        }
        last = next;
    }
    last
}

/// The sleeve point right after sleeve point `j` along its cable, when the segment between
/// them has both ends sleeved.
fn follower(model: &Model, j: usize) -> Option<usize> {
    let e = model.slips[j].segments[1];
    match model.segments[e].slip {
        [Some(i), Some(k)] if i == j => Some(k),
        _ => None,
    }
}

/// The sleeve point right before sleeve point `j`, when the segment between them has both
/// ends sleeved.
fn leader_side(model: &Model, j: usize) -> Option<usize> {
    let e = model.slips[j].segments[0];
    match model.segments[e].slip {
        [Some(i), Some(k)] if k == j => Some(i),
        _ => None,
    }
}

/// Move the group led by `j` (its slips by `ds`, its cable points by `dx`).
fn shift_group(
    model: &Model,
    u: &mut [f64],
    states: &[Contact],
    j: usize,
    ds: f64,
    dx: Vector3<f64>,
) {
    let n3 = model.dof_count();
    let last = group_last(model, states, j);
    let mut k = j;
    loop {
        u[n3 + k] += ds;
        let node = model.slips[k].node;
        for c in 0..3 {
            if !model.held[3 * node + c] {
                u[3 * node + c] += dx[c];
            }
        }
        if k == last {
            break;
        }
        k = follower(model, k).expect("a group is a chain of followers");
    }
}

/// Close every open gap whose unstretched length fell to `merge_gap` of its reference value:
/// the later point joins the earlier one's group (module docs). Returns how many closed.
pub(crate) fn close_gaps(
    model: &Model,
    u: &mut [f64],
    states: &mut [Contact],
    merge_gap: f64,
) -> usize {
    let n3 = model.dof_count();
    let mut closed = 0;
    for j in 0..model.slips.len() {
        if states[j] == Contact::Merged {
            continue;
        }
        let Some(i) = leader_side(model, j) else {
            continue;
        };
        if model.slips[i].mu > 0.0 || model.slips[j].mu > 0.0 {
            // Frictional points do not merge (yet): measured on SlidingCable with μ = 0.1 and
            // 0.3, an iteration that wanders (stick/slip states flipping under long slip steps)
            // can slide a point that should stick onto its neighbour, and the merged group is
            // then an admissible friction equilibrium, but not the one the load path reaches.
            // The gap stays open (fraction to the boundary) and such a step fails instead.
            continue;
        }
        let e = model.slips[j].segments[0];
        let reference = model.segments[e].l0;
        if model.segment_l0(u, e) > merge_gap * reference {
            continue;
        }
        // L_e = l0 + s_j − s_i  →  −δ l0.
        let target = u[n3 + i] - reference - sleeve::CLOSED_OFFSET * reference;
        let ds = target - u[n3 + j];
        let dx = model.position(u, model.slips[i].node) - model.position(u, model.slips[j].node);
        shift_group(model, u, states, j, ds, dx);
        states[j] = Contact::Merged;
        closed += 1;
    }
    closed
}

/// What a segment next to a touching pair carries: its tension when open, its link force when
/// closed; and its direction (x_end − x_start, unnormalised).
fn carried(model: &Model, u: &[f64], e: usize) -> (f64, Vector3<f64>) {
    let s = &model.segments[e];
    let d = model.position(u, s.nodes[1]) - model.position(u, s.nodes[0]);
    if model.segment_closed(u, e) {
        (model.link_stiffness(e) * d.norm(), d)
    } else {
        (model.segment_tension(u, e), d)
    }
}

/// (cos, sin) of half the angle between two directions; (1, 0) when either is zero.
fn half_kink(a: &Vector3<f64>, b: &Vector3<f64>) -> (f64, f64) {
    let (na, nb) = (a.norm(), b.norm());
    if na == 0.0 || nb == 0.0 {
        return (1.0, 0.0);
    }
    let g = (a.dot(b) / (na * nb)).clamp(-1.0, 1.0);
    (((1.0 + g) / 2.0).sqrt(), ((1.0 - g) / 2.0).sqrt())
}

/// At a converged point: part every touching pair whose contact force would pull (module
/// docs), `tol_f` (N) the force tolerance. The later point leaves the group with the trial
/// state slipping (σ = −1, the way that opens the gap) and a gap of `reopen` times its segment's reference unstretched length.
/// Returns how many pairs parted.
pub(crate) fn open_gaps(
    model: &Model,
    u: &mut [f64],
    states: &mut [Contact],
    tol_f: f64,
    reopen: f64,
) -> usize {
    let n3 = model.dof_count();
    let mut opened = 0;
    for j in 0..model.slips.len() {
        if states[j] != Contact::Merged {
            continue;
        }
        let Some(i) = leader_side(model, j) else {
            continue;
        };
        // The group as the cable sees it: the open segments entering and leaving it.
        let mut first = i;
        while states[first] == Contact::Merged {
            first = leader_side(model, first).expect("a merged point follows a sleeve point");
        }
        let e_in = model.slips[first].segments[0];
        let e_out = model.slips[group_last(model, states, first)].segments[1];
        let e = model.slips[j].segments[0];
        let (t_in, d_in) = carried(model, u, e_in);
        let (t_out, d_out) = carried(model, u, e_out);
        let (t_c, d_c) = carried(model, u, e);
        let mu = model.slips[i].mu.max(model.slips[j].mu);
        let pulls = |t_side: f64, (c, s): (f64, f64)| {
            (t_c - t_side) * c > mu * (t_c + t_side) * s + tol_f + 1e-12 * (t_c + t_side)
        };
        if !(pulls(t_in, half_kink(&d_in, &d_c)) || pulls(t_out, half_kink(&d_c, &d_out))) {
            continue;
        }
        let segment = &model.segments[e];
        let new_l0 = reopen * segment.l0;
        let ds = (u[n3 + i] - segment.l0 + new_l0) - u[n3 + j];
        // The new segment starts at the tension it carried as a link, along the link.
        let length = new_l0 * (1.0 + t_c / segment.ea);
        let dir = if d_c.norm() > 0.0 {
            d_c.normalize()
        } else {
            Vector3::zeros()
        };
        // Trial state: slipping the way that opens the gap (s_j grows: σ = −1).
        states[j] = Contact::Backward;
        shift_group(model, u, states, j, ds, dir * length - d_c);
        opened += 1;
    }
    opened
}
