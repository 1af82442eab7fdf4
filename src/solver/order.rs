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
//! With friction the point that slid onto a sticking neighbour takes the closure step (the
//! sticking point stays where friction holds it), and the new group sticks from where the
//! points met (stick anchor reset to the leader's present slip) until the return map, at a
//! settled iterate, finds it slipping: inheriting the slider's slip state made the group slide
//! on with full friction to an admissible but wrong equilibrium (SlidingCable, μ = 0.15-0.2).
//! The parting test below is written for friction too.
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
    anchor: &mut [f64],
    merge_gap: f64,
) -> usize {
    close_where(model, u, states, anchor, |e, length| {
        length <= merge_gap * model.segments[e].l0
    })
}

/// The open gaps that the slip step `ds` (one entry per sleeve point) would close or carry
/// past zero: segment e between two frictionless sleeve points i < j whose unstretched length
/// L_e + ds_j − ds_i falls to `merge_gap` of its reference or below. One flag per segment.
///
/// This is the primal-dual active-set prediction (Hintermüller, Ito & Kunisch 2002: the
/// semismooth Newton step of the Kuhn-Tucker conditions g >= 0, λ >= 0, λ g = 0 adds every
/// constraint the linearised step violates at once). The fraction-to-the-boundary rule
/// (`keep_length`) alone closes one gap per three iterations and shortens the whole step each
/// time: a chain of n rings gathering at one point then needs about 3n iterations.
pub(crate) fn predicted_closures(
    model: &Model,
    u: &[f64],
    states: &[Contact],
    ds: &[f64],
    merge_gap: f64,
) -> Vec<bool> {
    let mut close = vec![false; model.segments.len()];
    for j in 0..model.slips.len() {
        if states[j] == Contact::Merged {
            continue;
        }
        let Some(i) = leader_side(model, j) else {
            continue;
        };
        if model.slips[i].mu > 0.0 || model.slips[j].mu > 0.0 {
            continue;
        }
        let e = model.slips[j].segments[0];
        let after = model.segment_l0(u, e) + ds[j] - ds[i];
        if after <= merge_gap * model.segments[e].l0 {
            close[e] = true;
        }
    }
    close
}

/// Close the open gaps between neighbouring sleeve points for which `close(e, L_e)` holds (e
/// the segment between them, L_e its unstretched length): the later point joins the earlier
/// one's group (module docs). Returns how many closed.
pub(crate) fn close_where(
    model: &Model,
    u: &mut [f64],
    states: &mut [Contact],
    anchor: &mut [f64],
    close: impl Fn(usize, f64) -> bool,
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
        let e = model.slips[j].segments[0];
        let reference = model.segments[e].l0;
        if !close(e, model.segment_l0(u, e)) {
            continue;
        }
        // L_e = l0 + s_j − s_i  →  −δ l0.
        let mut leader = i;
        while states[leader] == Contact::Merged {
            leader = leader_side(model, leader).expect("a merged point follows a sleeve point");
        }
        let frictional = model.slips[i].mu > 0.0 || model.slips[j].mu > 0.0;
        let xi = model.position(u, model.slips[i].node);
        let xj = model.position(u, model.slips[j].node);
        if frictional && states[leader] != Contact::Stick && states[j] == Contact::Stick {
            // With friction the point that slid onto a sticking neighbour takes the last
            // step of the closure (its group moves onto j), so the sticking point stays where
            // friction holds it: L_e = l0 + s_j − s_i → −δ l0 by s_i.
            let target = u[n3 + j] + reference + sleeve::CLOSED_OFFSET * reference;
            shift_group(model, u, states, leader, target - u[n3 + i], xj - xi);
        } else {
            let target = u[n3 + i] - reference - sleeve::CLOSED_OFFSET * reference;
            shift_group(model, u, states, j, target - u[n3 + j], xi - xj);
        }
        states[j] = Contact::Merged;
        closed += 1;
        if frictional {
            // The points met: the slide that closed the gap ends here. The group starts
            // sticking where it stands (its stick anchor the leader's present slip), and the
            // return map decides at a settled iterate whether the group as a whole slips.
            // Inheriting the leader's slip state would make the group slide on with full
            // friction the way the leader came: an admissible but wrong equilibrium.
            states[leader] = Contact::Stick;
            anchor[leader] = u[n3 + leader];
        }
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
    (roundoff, size): (f64, f64),
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
        // The link force is known only to the round-off floor of its nodes' balance (system.rs:
        // c ε K X, K the link's stiffness, X the coordinate size): a stiff link's force, read
        // from the tiny distance between its points, resolves a pull no finer than that. With
        // the points at rest on a straight cable (no load on the group) the contact force is
        // zero and the reading is noise: parting on it sent ten unloaded rings apart and back
        // together until the increment failed (the robustness corpus, rings, 2026-11-28).
        let noise = roundoff * model.link_stiffness(e) * size;
        let pulls = |t_side: f64, (c, s): (f64, f64)| {
            (t_c - t_side) * c > mu * (t_c + t_side) * s + tol_f + noise + 1e-12 * (t_c + t_side)
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
