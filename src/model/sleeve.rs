//! A cable sliding through a sleeve: slip unknowns at the sleeve points, the nodal Coulomb law in
//! the bisector frame, and the tie between a cable point and its membrane node (a penalty spring
//! with a multiplier: an augmented Lagrangian that closes the tie whatever the penalty).
//!
//! Formulation (docs/mechanics.md §2.3 option A, with the seed's penalty contact element):
//!
//! ```text
//! cable points   P_0 … P_n along the cable; the ends and unsleeved nodes are material points
//!                (fixed material coordinate); each sleeve point P_c is its own 3-DOF point
//!                plus one slip unknown s_c
//! material coord S_c = S⁰_c + s_c,  S⁰_c = Σ_{k<c} L⁰_k  (reference unstretched lengths)
//! segment        L_k = S_{k+1} − S_k: unstretched length of the cable between two points;
//!                material flows through a sleeve point when its s_c changes
//! tie            f = λ_c + k_c (x_c − x_m) on the cable point, −f on the membrane node m:
//!                the seed's contact element k_ce = [[k I, −k I], [−k I, k I]] as the tangent
//!                (λ_c is held fixed within a Newton solve), λ_c the tie's multiplier (below)
//! kink           segments a = (P_p → P_c), b = (P_c → P_q), unit vectors e_a, e_b,
//!                g = e_a·e_b = cos Δθ,  c = cos(Δθ/2) = √((1+g)/2),  s = sin(Δθ/2) = √((1−g)/2)
//! contact force  F = T_b e_b − T_a e_a (what the cable puts on the tie), in the bisector frame
//!                f_t = F·t = (T_b − T_a) c     (along the cable, + toward the cable's end)
//!                f_n = |F·n| = (T_a + T_b) s
//! Coulomb        |f_t| ≤ μ f_n                  (stick)
//!                f_t = σ μ f_n,  σ = sign f_t   (slip; the material moves toward σ: σ Δs ≤ 0)
//!                ⇔ at slip  T_b/T_a = (1 + μ tan(Δθ/2))/(1 − μ tan(Δθ/2))   (σ = +1)
//! frictionless   μ = 0: f_t = 0 ⇔ T_a = T_b at every sleeve point
//! ```
//!
//! Return mapping per sleeve point and Newton iteration (the trial state is stick, s_c = s_c^n of
//! the last converged increment): stick while |f_t| ≤ μ f_n, slip with σ = sign f_t when the trial
//! violates the cone; a slipping point whose slip runs backwards (σ (s_c − s_c^n) > 0) returns to
//! stick. The slip equation row is r_c = f_t − σ μ f_n; a stuck point has the row s_c − s_c^n.
//! Both depend on the geometry through l_a, l_b and g, so the tangent is non-symmetric; its
//! derivatives are written in [`slip_row`] and checked by finite differences.
//!
//! Over N equal kinks of a curve turning by θ the bisector law gives
//! `T_out/T_in = ((1 + μ tan(θ/2N))/(1 − μ tan(θ/2N)))^N → exp(μθ)` (capstan), docs/mechanics.md §4f.
//!
//! Default penalty: `k_c = 100 × max(EA/ℓ_min, E t)` with ℓ_min the shortest reference segment of
//! the cable and E t the largest membrane tensile stiffness (E = 3μ for neo-Hookean) at its
//! sleeve nodes: the middle of the range 10…1000 of docs/mechanics.md §2.3. A penalty given softer
//! than `max(EA/ℓ_min, E t)` (the neighbouring stiffness) is raised to it: below it the tie only
//! slows the multiplier updates, and the answer does not depend on it. The gap `|x_c − x_m|` is
//! reported by the `contact_gap` probe relative to the adjacent segment length.
//!
//! Augmented Lagrangian (Uzawa) closure of the ties, `solver::slip`:
//!
//! ```text
//! multiplier     λ_c (N, a 3-vector per tie), part of the converged state: stored after the
//!                slips and volume pressures in the unknown vector (`Model::multiplier_index`),
//!                carried from increment to increment and step to step; 0 at the start
//! energy         λ_c·d + ½ k_c |d|²,  d = x_c − x_m
//! update         after each converged Newton solve of an increment, while the largest tie
//!                gap |d| over the shorter adjacent segment exceeds GAP_TOLERANCE (1e-12):
//!                λ_c ← λ_c + k_c d at every tie, and Newton solves again (at most
//!                MAX_UZAWA_ROUNDS rounds; a gap still open then fails the increment, naming
//!                the sleeve and the gap)
//! rate           near the solution, with C the compliance of the structure between the tie's
//!                two points, each round multiplies the gap by 1/(1 + C k_c): C k_c is of
//!                order 1 with k_c at the neighbouring stiffness (measured about 1/2 per round
//!                on the rigid capstan sleeve), 25 and more with the default
//! converged      λ_c → the contact force; d → 0 (the constraint x_c = x_m), so the answer
//!                does not depend on k_c (to the gap tolerance)
//! ```
//!
//! ```text
//! Symbols: T tension (N), L unstretched length (m), l current length (m), S material
//! coordinate (m, unstretched length from the cable's first node), s slip (m), μ friction
//! coefficient, k_c tie penalty (N/m), σ slip direction (±1).
//! ```
//!
//! # References
//! Wriggers, *Computational Contact Mechanics*, 2nd ed. 2006, §5.2 (penalty, Coulomb return
//! mapping); Simo & Laursen 1992, Comput. Struct. 42:97–116; Aufaure 1993 and Chen et al. 2010
//! (cables sliding through nodes); Bel Hadj Ali, Sychterz & Smith 2017, IJSS 126–127:240–251
//! (nodal friction, Euler–Eytelwein); Simo & Laursen 1992 (an augmented Lagrangian treatment of
//! contact, Uzawa updates of the multipliers); Nocedal & Wright 2006, §17.3 (the method of
//! multipliers and its rate); docs/mechanics.md §2.3, §4f; seed paper eqs. (4)–(7).

use super::cable::{self, Law};
use super::element::Element;
use nalgebra::Vector3;

/// Default tie penalty as a multiple of the stiffer of EA/ℓ_min and E t.
pub const PENALTY_FACTOR: f64 = 100.0;

/// Below this sin(Δθ/2) the kink is treated as straight in the tangent (the friction cone has
/// its apex there and f_n is not differentiable).
const STRAIGHT: f64 = 1e-10;

/// One slip unknown: a sleeve point of a cable.
#[derive(Clone, Debug)]
pub struct SlipPoint {
    /// Cable point (its own node, tied to `membrane`).
    pub node: usize,
    /// The membrane (or free) node the sleeve point belongs to (mesh id).
    pub membrane: usize,
    /// Previous and next cable points (node ids) and the segments (indices into
    /// `Model::segments`) before and after.
    pub prev: usize,
    pub next: usize,
    pub segments: [usize; 2],
    pub mu: f64,
    /// Index into `Model::ties`.
    pub tie: usize,
    /// Index into `Model::cables`.
    pub cable: usize,
}

/// Tie between a cable point and a membrane node: a penalty spring plus the tie's multiplier
/// (in the unknown vector, `Model::tie_multiplier`).
#[derive(Clone, Debug)]
pub struct Tie {
    /// (cable point, membrane node)
    pub nodes: [usize; 2],
    /// Penalty (N/m) Newton uses: the scene's (or the default), at least the neighbouring
    /// stiffness (module docs).
    pub k: f64,
}

impl Element for Tie {
    fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    /// The penalty k.
    fn reference_stiffness(&self, _a: usize) -> f64 {
        self.k
    }
}

/// Default stiffness of the link that holds the cable points of a closed segment together, as
/// a multiple of the stiffer of the two ties: the points then coincide to |F|/k_link, three
/// orders below the tie gap |F|/k_c.
pub const LINK_FACTOR: f64 = 1e3;

/// A closed segment keeps the unstretched length −CLOSED_OFFSET·L_ref (L_ref its reference
/// unstretched length), not 0: the sign of L then tells every routine that the segment is closed,
/// whatever the round-off in l0 + s_end − s_start.
pub const CLOSED_OFFSET: f64 = 1e-9;

/// Stick/slip state of a sleeve point, as the solver, the engine state and FMU snapshots hold
/// it. Serialized as its variant index (0 stick, 1 forward, 2 backward, 3 merged), the codes
/// the outputs and the VTK files show ([`Contact::code`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Contact {
    #[default]
    Stick,
    /// Slipping toward the cable's end (σ = +1).
    Forward,
    /// Slipping toward the cable's start (σ = −1).
    Backward,
    /// Touching the previous sleeve point of the cable (closed segment between them): the
    /// point moves with its group, whose leader (first point) carries the group's stick/slip
    /// state.
    Merged,
}

impl Contact {
    /// The number an output or a VTK file shows: 0 stick, 1 slipping toward the cable's end,
    /// 2 toward its start, 3 merged.
    pub fn code(self) -> u8 {
        match self {
            Contact::Stick => 0,
            Contact::Forward => 1,
            Contact::Backward => 2,
            Contact::Merged => 3,
        }
    }

    /// σ: +1 forward, −1 backward, 0 stuck or merged.
    pub fn sigma(self) -> f64 {
        match self {
            Contact::Forward => 1.0,
            Contact::Backward => -1.0,
            Contact::Stick | Contact::Merged => 0.0,
        }
    }
}

/// The material law of one segment.
#[derive(Clone, Copy, Debug)]
pub struct SegmentLaw {
    pub law: Law,
    pub ea: f64,
}

/// Bisector-frame contact forces (f_t, f_n) at a kink with tensions `ta` before and `tb` after.
pub fn contact_forces(
    xp: &Vector3<f64>,
    xc: &Vector3<f64>,
    xq: &Vector3<f64>,
    ta: f64,
    tb: f64,
) -> (f64, f64) {
    let ea = (xc - xp).normalize();
    let eb = (xq - xc).normalize();
    let g = ea.dot(&eb).clamp(-1.0, 1.0);
    let c = ((1.0 + g) / 2.0).sqrt();
    let s = ((1.0 - g) / 2.0).sqrt();
    ((tb - ta) * c, (ta + tb) * s)
}

/// [`contact_forces`] at a group of coincident sleeve points: segment a ends at `xca` (the
/// group's first point), segment b starts at `xcb` (its last).
pub fn group_contact_forces(
    xp: &Vector3<f64>,
    xca: &Vector3<f64>,
    xcb: &Vector3<f64>,
    xq: &Vector3<f64>,
    ta: f64,
    tb: f64,
) -> (f64, f64) {
    let ea = (xca - xp).normalize();
    let eb = (xq - xcb).normalize();
    let g = ea.dot(&eb).clamp(-1.0, 1.0);
    let c = ((1.0 + g) / 2.0).sqrt();
    let s = ((1.0 - g) / 2.0).sqrt();
    ((tb - ta) * c, (ta + tb) * s)
}

/// Ratio T_b/T_a at slip (σ = +1) of the bisector law at a kink Δθ.
pub fn slip_ratio(mu: f64, kink: f64) -> f64 {
    let t = (kink / 2.0).tan();
    (1.0 + mu * t) / (1.0 - mu * t)
}

/// Slip row r = f_t − σμ f_n of a slipping point (σμ given as `sigma_mu`), and its derivatives
/// with respect to the positions of the previous, own and next cable points and the unstretched
/// lengths (L_a, L_b) of the segments before and after.
#[allow(clippy::too_many_arguments)]
pub fn slip_row(
    a: SegmentLaw,
    b: SegmentLaw,
    la0: f64,
    lb0: f64,
    xp: &Vector3<f64>,
    xc: &Vector3<f64>,
    xq: &Vector3<f64>,
    sigma_mu: f64,
) -> (f64, [Vector3<f64>; 3], [f64; 2]) {
    let (r, [dp, dca, dcb, dq], dl) = group_slip_row(a, b, la0, lb0, xp, xc, xc, xq, sigma_mu);
    (r, [dp, dca + dcb, dq], dl)
}

/// [`slip_row`] of a group of coincident sleeve points (one closed segment or more between
/// them): segment a ends at `xca` (the group's first point) and segment b starts at `xcb` (its
/// last); the derivatives are with respect to x_p, x_ca, x_cb, x_q. With `xca == xcb` this is
/// the single point's row.
#[allow(clippy::too_many_arguments)]
pub fn group_slip_row(
    a: SegmentLaw,
    b: SegmentLaw,
    la0: f64,
    lb0: f64,
    xp: &Vector3<f64>,
    xca: &Vector3<f64>,
    xcb: &Vector3<f64>,
    xq: &Vector3<f64>,
    sigma_mu: f64,
) -> (f64, [Vector3<f64>; 4], [f64; 2]) {
    let (da, db) = (xca - xp, xq - xcb);
    let (la, lb) = (da.norm(), db.norm());
    let (ea, eb) = (da / la, db / lb);
    let (ta, ka) = cable::tension(a.law, a.ea, la0, la);
    let (tb, kb) = cable::tension(b.law, b.ea, lb0, lb);
    let ma = cable::tension_dl0(a.law, a.ea, la0, la);
    let mb = cable::tension_dl0(b.law, b.ea, lb0, lb);
    let g = ea.dot(&eb).clamp(-1.0, 1.0);
    let c = ((1.0 + g) / 2.0).sqrt();
    let s = ((1.0 - g) / 2.0).sqrt();
    let r = (tb - ta) * c - sigma_mu * (ta + tb) * s;
    let dr_ta = -c - sigma_mu * s;
    let dr_tb = c - sigma_mu * s;
    // dc/dg = 1/(4c), ds/dg = −1/(4s).
    let mut dr_g = if c > STRAIGHT {
        (tb - ta) / (4.0 * c)
    } else {
        0.0
    };
    if s > STRAIGHT {
        dr_g += sigma_mu * (ta + tb) / (4.0 * s);
    }
    // ∂g/∂d_a = (I − e_a e_aᵀ) e_b / l_a,  ∂g/∂d_b = (I − e_b e_bᵀ) e_a / l_b.
    let ha = (eb - ea * ea.dot(&eb)) / la;
    let hb = (ea - eb * eb.dot(&ea)) / lb;
    let dp = -ea * (dr_ta * ka) - ha * dr_g;
    let dca = ea * (dr_ta * ka) + ha * dr_g;
    let dcb = -eb * (dr_tb * kb) - hb * dr_g;
    let dq = eb * (dr_tb * kb) + hb * dr_g;
    (r, [dp, dca, dcb, dq], [dr_ta * ma, dr_tb * mb])
}

/// Tie force on the cable point (the membrane node gets its negative) and energy.
pub fn tie_force(k: f64, xc: &Vector3<f64>, xm: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let d = xc - xm;
    (d * k, 0.5 * k * d.norm_squared())
}

/// Tie force on the cable point (the membrane node gets its negative) and energy with the
/// multiplier `lambda`: f = λ + k d, W = λ·d + ½ k |d|², d = x_c − x_m (module docs).
pub fn augmented_tie_force(
    k: f64,
    lambda: &Vector3<f64>,
    xc: &Vector3<f64>,
    xm: &Vector3<f64>,
) -> (Vector3<f64>, f64) {
    let d = xc - xm;
    (lambda + d * k, lambda.dot(&d) + 0.5 * k * d.norm_squared())
}

/// Tangent of a tie: [[k I, −k I], [−k I, k I]] (cable point, membrane node).
pub fn tie_stiffness(k: f64) -> cable::Mat6 {
    let mut m = cable::Mat6::zeros();
    for i in 0..3 {
        m[(i, i)] = k;
        m[(i + 3, i + 3)] = k;
        m[(i, i + 3)] = -k;
        m[(i + 3, i)] = -k;
    }
    m
}
