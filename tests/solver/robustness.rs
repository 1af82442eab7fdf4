//! GOAL: the CI slice of the robustness corpus (issue 27): no member of the slice comes back
//!       wrong, and every failure is honest. The slice is the members marked `quick` in
//!       examples/robustness/corpus.rs (the smallest of every family, plus the reported
//!       16x16 quarter cushion, 10 and 14 rings on a cable and the cable loaded to 1e9 N
//!       across and along), each
//!       solved loaded and then unloaded at default solver settings; the whole corpus is
//!       `cargo run --release --example robustness` (docs/robustness.md).
//! MESH, BOUNDARY CONDITIONS, PARAMETERS: per family, in corpus.rs (seed 27).
//! REFERENCE: checks independent of the solver's convergence test, on every converged run:
//!       the residual at every free DOF within 1e-6 of the largest force acting (applied loads
//!       computed from the scene and the deformed geometry, reactions, element forces) plus
//!       the round-off 100 ε K X; reactions + applied loads and their moments within 1e-6 of
//!       the loads and reactions plus what the free residuals add up to; mirror symmetry of
//!       the displacements (of the reactions where a part is slack) within 1e-6 of the
//!       largest; after unloading an elastic, frictionless, prestressed or clamped member, the
//!       start equilibrium within 1e-6 of the model's size; closed forms (pretensioned cable
//!       1e-6, rings on a frictionless cable bracketed by their link gaps, Hencky disc
//!       0.4/rings²) as stated in corpus.rs. A failure is honest unless its message is empty,
//!       it panicked, or it claims a mechanism where supports stop every rigid motion.
//!       Convergence shares are printed, not asserted: the slice asserts no wrong answer and
//!       no dishonest failure.

#[path = "../../examples/robustness/corpus.rs"]
mod corpus;

use corpus::Verdict;

/// Members of the slice that the current solver answers wrongly or fails dishonestly on,
/// (family, label prefix): left out of the slice's test and run each by an ignored test of its
/// own below (`#[ignore = "issue 27: ..."]` calling [`defect`]), so that they stay visible.
/// None today.
const DEFECTS: &[(&str, &str)] = &[];

/// One member of DEFECTS, which must come back right or fail honestly.
#[allow(dead_code)]
fn defect(family: &str, label: &str) {
    let runs = run(|m| m.family == family && m.label.starts_with(label));
    assert_right_or_honest(&runs);
}

fn is_defect(m: &corpus::Member) -> bool {
    DEFECTS
        .iter()
        .any(|(f, l)| m.family == *f && m.label.starts_with(l))
}

fn run(select: impl Fn(&corpus::Member) -> bool) -> Vec<corpus::Run> {
    let members: Vec<corpus::Member> = corpus::members(27)
        .into_iter()
        .filter(|m| m.quick && select(m))
        .collect();
    assert!(!members.is_empty(), "no member selected");
    let runs: Vec<corpus::Run> = members.iter().flat_map(corpus::run_member).collect();
    print!("{}", corpus::table(&runs));
    runs
}

/// Every member of the whole corpus (not only the CI slice) that `select` picks, run loaded
/// and unloaded; the table printed.
fn run_all(select: impl Fn(&corpus::Member) -> bool) -> Vec<corpus::Run> {
    let members: Vec<corpus::Member> = corpus::members(27)
        .into_iter()
        .filter(|m| select(m))
        .collect();
    let runs: Vec<corpus::Run> = members.iter().flat_map(corpus::run_member).collect();
    print!("{}", corpus::table(&runs));
    runs
}

/// Every run right by the corpus's independent checks.
/// Set a corpus row's inputs on an engine built from its member's scene.
fn set_row(engine: &mut velarium::Engine, row: &corpus::Row) {
    for (name, value) in &row.set {
        let vr = engine
            .variables()
            .iter()
            .find(|v| v.name == *name)
            .expect("the input")
            .value_reference;
        engine.set_real(vr, *value).expect("set");
    }
}

fn assert_all_right(runs: &[corpus::Run]) {
    for r in runs {
        assert!(
            matches!(r.verdict, Verdict::Right),
            "{} {} [{}]: {}",
            r.family,
            r.row,
            r.member,
            corpus::short(&r.verdict)
        );
    }
}

fn assert_right_or_honest(runs: &[corpus::Run]) {
    let bad: Vec<String> = runs
        .iter()
        .filter(|r| {
            matches!(
                r.verdict,
                Verdict::Wrong(_) | Verdict::Dishonest(_) | Verdict::Corpus(_)
            )
        })
        .map(|r| {
            format!(
                "{} {} [{}]: {}",
                r.family,
                r.row,
                r.member,
                corpus::short(&r.verdict)
            )
        })
        .collect();
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn quick_slice_is_right_or_fails_honestly() {
    let runs = run(|m| !is_defect(m));
    assert_right_or_honest(&runs);
}

/// Issue 27's target: rings gathering on one frictionless cable converge right, 100 and 200 of
/// them (before the merge prediction of `src/solver/order.rs` every member from 14 rings up
/// failed). Right means the corpus's checks above, with the closed form: every ring at
/// mid-span, one V under the whole weight, within the contact links' gaps; loaded and then
/// unloaded at default settings. Measured: 100 rings in 101 and 17 iterations, 200 in 44 and 17.
#[test]
fn a_hundred_and_two_hundred_rings_converge_right() {
    let runs = run_all(|m| {
        m.family == "rings"
            && (m.label.starts_with("100 rings") || m.label.starts_with("200 rings"))
    });
    assert_eq!(
        runs.len(),
        4,
        "the 100- and 200-ring members, each loaded and unloaded"
    );
    assert_all_right(&runs);
}

/// The 16x16 quarter cushion reported from outside (issue 27: "converges on an 8x8 mesh and
/// fails at 16x16 and finer"), inflated from flat and unloaded at default settings. Through
/// the overshoot continuation (src/solver/overshoot.rs; before it, the proximal one) it
/// converges: measured 187 and 21 iterations. REQUIRED: both rows come back right by the
/// slice's independent checks (header).
#[test]
fn the_reported_16x16_quarter_cushion_converges_right() {
    let runs = run(|m| m.family == "cushion-quarter" && m.label.starts_with("square n=16 a=1.52"));
    assert_eq!(runs.len(), 2, "loaded and unloaded");
    assert_all_right(&runs);
}

/// The frictionless drawstrings (the SleeveDrawstring kind of scene, the cable ends held across
/// the sleeve and pulled along it by the pretension's loads) loaded and unloaded back to the
/// undeformed sheet. Unloaded, no load acts at a free DOF: every load goes straight into the
/// ends' supports, and the convergence test's absolute floor (src/solver/system.rs, module docs)
/// takes the scene's load scale from those applied loads. Before (the floor from the reactions,
/// which vanish with the stress-free sheet) four of the five unloaded rows spent the step's work
/// budget at |R| of 6e-12 to 4e-5 of the force scale. REQUIRED: every row right by the slice's
/// independent checks (header).
#[test]
fn frictionless_drawstrings_unload_right() {
    let runs = run_all(|m| m.family == "drawstring" && m.label.contains(" mu=0.00 "));
    assert_eq!(runs.len(), 10, "five members, loaded and unloaded");
    assert_all_right(&runs);
}

/// The overshoot continuation (src/solver/overshoot.rs): two quarter cushions of the corpus
/// inflated from flat with a load small against the sheets' stiffness (p a/(E t) 2.5e-5 and
/// 1.1e-5), which failed on their work budget before it (the direct path, the prestress and
/// the proximal continuations all stalled in wrinkle chatter). The increment is solved at
/// about 1000 and 250 times the pressure first, then the pressure is brought back in steps.
/// Measured at default settings: the 12x12 circle in 200 and 15 iterations (loaded, unloaded),
/// the 1:1.5 rectangle at 16 cells in 251 and 14. REQUIRED: every row right by the corpus's
/// independent checks (header): the residual against the forces acting, global equilibrium,
/// the top/bottom mirror.
#[test]
fn quarter_cushions_from_flat_converge_through_the_overshoot_continuation() {
    let runs = run_all(|m| {
        m.family == "cushion-quarter"
            && (m.label.starts_with("circle n=12") || m.label.starts_with("rect 1:1.50 n=16"))
    });
    assert_eq!(runs.len(), 4, "two members, loaded and unloaded");
    assert_all_right(&runs);
}

/// The coarse start forced on (`solver.coarse_start: on`, docs/solver.md "The coarse start")
/// on every tent of the corpus: form-found annuli written out as explicit meshes with their
/// prestress fields, held on both rims, so the coarse start collapses their edges (the inner
/// rim is a circle of 32-60 nodes). Before the carried-over start held its held DOFs at 0,
/// every one of these 16 runs came back wrong (held rim nodes kept the coarse mesh's answer:
/// mirror asymmetries of 6e-4 to 1.8e-3 m, with a residual within the convergence test;
/// measured again with the fix removed, 2026-11-29).
/// REQUIRED: every row right by the corpus's independent checks (header).
#[test]
fn tents_under_a_forced_coarse_start_come_back_right() {
    let members: Vec<corpus::Member> = corpus::members(27)
        .into_iter()
        .filter(|m| m.family == "tent")
        .map(|mut m| {
            m.scene.solver.coarse_start = velarium::scene::CoarseStart::On;
            m
        })
        .collect();
    let runs: Vec<corpus::Run> = members.iter().flat_map(corpus::run_member).collect();
    print!("{}", corpus::table(&runs));
    assert_eq!(runs.len(), 16, "eight tents, loaded and unloaded");
    assert_all_right(&runs);
}

/// What a failed step says of a film being gathered (src/solver/mechanism.rs, module docs, 0):
/// the three drawstrings of the corpus that fail loaded (friction 0.22, 0.33, 0.45) stop where
/// the sleeved edge's corner triangle is squeezed to 0.59-0.67 of its reference area. On load
/// rows of 1 % (2026-11-29, `velarium solve` of the dumped members) the same triangle falls on
/// (0.64, 0.44, 0.18 at 40, 44 and 47.5 % of the load for friction 0.22; 0.37 at 45 % for
/// 0.45; 0.48 at 54 % for 0.33) until the path stops: a tension-only film does not resist the
/// gathering, so the load cannot be carried without a collapsed triangle. The hypar that fails
/// loaded (corner lowered 0.34 m) has no such triangle and gets no such clause.
/// REQUIRED: each drawstring's loaded row an honest failure whose message names a triangle
/// squeezed below 3/4 of its area; the hypar's message without that clause.
#[test]
fn a_failed_step_names_the_triangle_a_gathering_squeezes() {
    let runs = run_all(|m| {
        (m.family == "drawstring"
            && (m.label.contains(" mu=0.22 ") || m.label.contains(" mu=0.33 ")))
            || (m.family == "hypar" && m.label.contains(" drop=0.34 "))
    });
    let loaded: Vec<&corpus::Run> = runs.iter().filter(|r| r.row == "loaded").collect();
    assert_eq!(loaded.len(), 3, "two drawstrings and a hypar");
    for r in loaded {
        let Verdict::Honest(message) = &r.verdict else {
            panic!("{} [{}]: {}", r.family, r.member, corpus::short(&r.verdict));
        };
        let ratio = message
            .split("is squeezed to ")
            .nth(1)
            .and_then(|rest| rest.split(' ').next())
            .and_then(|v| v.parse::<f64>().ok());
        if r.family == "drawstring" {
            let ratio = ratio
                .unwrap_or_else(|| panic!("[{}] names no squeezed triangle: {message}", r.member));
            assert!(ratio < 0.75, "[{}] squeezed to {ratio}", r.member);
        } else {
            assert!(ratio.is_none(), "[{}]: {message}", r.member);
        }
    }
}

/// GOAL: a symmetric scene whose symmetric equilibrium is unstable converges to a stable
///       equilibrium without that symmetry, and the corpus tells such an answer from a wrong
///       one by verifying the instability, not by trusting the solver.
/// MESH, BOUNDARY CONDITIONS, PARAMETERS: the full two-sheet square cushion of the corpus
///       (corpus.rs, `cushion_scene`): a = 1.0130 m, 32x32 cells over [−a, a]², rim held in z
///       and free in its plane, in-plane rigid motions stopped at the four rim points on the
///       axes; SVK E = 6.728e8 Pa, ν = 0.3, t = 9.867e-6 m (E t = 6639 N/m); follower pressure
///       19.30 Pa from flat in one row (the member seed 28 drew before its seeds were told
///       apart). The control: the 8x8 cushion at the same a, E t and p a/(E t).
/// REFERENCE: the signs of the lowest eigenvalues of K x = λ M x about each state (the
///       engine's shift-invert Lanczos, verified against closed forms in tests/verification;
///       any positive-definite M gives the signs of K's, Sylvester's law of inertia), with
///       the symmetric equilibrium from a twin of the scene with the planes x = 0 and y = 0
///       held. Measured: the 32x32 answer is twisted (mirror x differs by 4.6e-2 m of a
///       largest 0.514 m) and stable (lowest λ 12.5 1/s² with 1000 kg/m³), its symmetric
///       twin unstable (−9.22 1/s², three negative λ); the twisted state's potential
///       U − pV is 5.8e-5 J below the symmetric one's. The 8x8 cushion's answer is
///       symmetric and its twin stable.
/// REQUIRED: the 32x32 loaded row right with the corpus's note of a verified broken
///       symmetry; for the 8x8, `broken_symmetry` refuses (the symmetric equilibrium is
///       stable), so an asymmetric answer there would be wrong.
#[test]
fn a_cushion_whose_symmetric_equilibrium_is_unstable_breaks_the_symmetry_verified() {
    let (a, young, t, p) = (
        1.0130328492516258,
        672813893.1345196,
        9.867182786039431e-6,
        1.9299880690521288e1,
    );
    let (scene, mirrors) =
        corpus::cushion_scene(corpus::Shape::Square, 32, false, false, a, young, t);
    let member = corpus::Member {
        family: "cushion-full",
        label: "square n=32, the twisted one".into(),
        scene,
        then: None,
        rows: vec![corpus::row("loaded", vec![("p", p)], false)],
        mirrors,
        known: None,
        quick: false,
    };
    let runs = corpus::run_member(&member);
    print!("{}", corpus::table(&runs));
    let r = &runs[0];
    assert_eq!(r.verdict, Verdict::Right, "{}", corpus::short(&r.verdict));
    assert!(
        r.notes.iter().any(|n| n.contains(corpus::BROKEN)),
        "the answer kept its symmetry: {:?}",
        r.notes
    );

    // The control: at 8x8 the symmetric equilibrium is stable, so a broken symmetry there
    // would not be verified.
    let (scene, mirrors) =
        corpus::cushion_scene(corpus::Shape::Square, 8, false, false, a, young, t);
    let mut engine = velarium::Engine::try_new(scene).expect("the 8x8 cushion builds");
    let vr = engine
        .variables()
        .iter()
        .find(|v| v.name == "p")
        .expect("input p")
        .value_reference;
    engine.set_real(vr, p).expect("p set");
    assert!(engine.solve().converged(), "the 8x8 cushion converges");
    let held: Vec<&corpus::Mirror> = mirrors.iter().filter(|m| m.plane.is_some()).collect();
    assert_eq!(held.len(), 2, "the planes x = 0 and y = 0");
    // The residual bound of the corpus's check (1e-6 of the pressure on a cell) and its size.
    let bound = 1e-6 * p * (2.0 * a / 8.0).powi(2);
    let why = corpus::broken_symmetry(&engine, &held, bound, 2.0 * a)
        .expect_err("a stable symmetric equilibrium verifies no broken symmetry");
    assert!(why.contains("stable too"), "{why}");
}

/// GOAL: a failing step's whole work is bounded however much its nodal relaxation evaluates,
///       so that it ends within a few times `check`'s announced cost (issue 27, "fail fast").
/// MESH, BOUNDARY CONDITIONS, PARAMETERS: the frictional drawstring that corpus seed 34
///       draws (s = 0.134 m, 16x16, μ = 0.16, 2P = 0.369 N; corpus.rs, `drawstring_scene`),
///       loaded from its start in one row at default settings.
/// REFERENCE: the step's whole work (`StepReport::whole_work`: its budgeted work plus each
///       relaxation round's element evaluations in assemblies' worth, half an iteration per
///       assembly) against `solver.max_step_iterations`. Measured: without the bound the step
///       spent 392 counted iterations in 9.3 s, 10.5 times the announced 0.886 s at load
///       average 3.5 (67 % of it in the patch Newton); with it, 299 iterations in 3.7 s.
/// REQUIRED: the row fails honestly, its whole work above its budgeted work (the relaxation
///       is counted) and at most 20.5 times the budget: the bound of 20 is checked before
///       each Newton iteration and after each relaxation round, so one round may pass it
///       (measured: 20070 of 20000).
#[test]
fn a_failing_steps_relaxation_is_counted_at_its_cost() {
    let member = corpus::members(34)
        .into_iter()
        .find(|m| m.family == "drawstring" && m.label.contains("mu=0.16 2P=3.693e-1"))
        .expect("seed 34 draws the drawstring");
    let mut engine = velarium::Engine::try_new(member.scene.clone()).expect("it builds");
    assert!(engine.solve().converged(), "the start converges");
    set_row(&mut engine, &member.rows[0]);
    let report = engine.solve();
    assert!(
        !report.converged(),
        "the loaded row fails: {}",
        report.message
    );
    assert!(report.message.contains("work budget"), "{}", report.message);
    let settings = &engine.scene().solver;
    let budget = settings.max_step_iterations as f64;
    println!(
        "work {} whole work {} budget {budget}: {}",
        report.work, report.whole_work, report.message
    );
    assert!(report.whole_work > report.work, "the relaxation is counted");
    assert!(
        report.whole_work <= 20.5 * budget,
        "whole work {} against a budget of {budget}",
        report.whole_work
    );
}

/// GOAL: a structure without prestress unloaded to nothing, whose path to a slack rest spends
///       its budget on forces that vanish, ends at its reference configuration when that is
///       an equilibrium of the step's (zero) loads (stepper.rs, `reference_answer`).
/// MESH, BOUNDARY CONDITIONS, PARAMETERS: the free-rim orthotropic cushion that corpus seed 27
///       draws (`cushion-fabric`, circle, 12x12 cells, a = 1.96 m, E_fill/E_warp = 0.74,
///       83.8 Pa), inflated from flat, then let down to 0 Pa in one row.
/// REFERENCE: zero load and no prestress: the unstressed flat sheets are an equilibrium (every
///       strain zero up to round-off). The corpus's own checks judge both rows independently
///       (residual within 1e-6 of the forces acting plus 100 ε of the stiffness times the size,
///       force and moment balance, mirror symmetries). Measured before: the unloaded row spent
///       its budget of 1000 (663 Newton iterations, |R| 1.3e-12 of the force scale, at load
///       fraction 0.997).
/// REQUIRED: the unloaded row converges (the reference is tried before the path), its message
///       names the reference, every displacement is 0, and the corpus finds both rows right.
#[test]
fn a_slack_cushion_let_down_to_nothing_rests_at_its_reference() {
    let select = |m: &corpus::Member| {
        m.family == "cushion-fabric" && m.label.starts_with("circle n=12 a=1.96 m")
    };
    let member = corpus::members(27)
        .into_iter()
        .find(select)
        .expect("seed 27 draws the cushion");
    let mut engine = velarium::Engine::try_new(member.scene.clone()).expect("it builds");
    assert!(engine.solve().converged(), "the start converges");
    for row in &member.rows {
        set_row(&mut engine, row);
        let report = engine.solve();
        assert!(report.converged(), "{}: {}", row.label, report.message);
        if row.label == "unloaded" {
            assert!(
                report.message.contains("reference configuration"),
                "{}",
                report.message
            );
            let u = &engine.state().displacement;
            assert!(u.iter().all(|&x| x == 0.0), "displacement not 0");
        }
    }
    let runs = run_all(select);
    assert_all_right(&runs);
}

/// GOAL: a free-rim cushion inflated from flat by a gas amount (the pressure an unknown of the
///       solve) converges to an equilibrium: the proximal continuation now runs with volume and
///       gas inputs, their rows constraints of every problem (src/solver/proximal.rs).
/// MESH, BOUNDARY CONDITIONS, PARAMETERS: the `cushion-volume` member corpus seed 27 draws:
///       a circular two-sheet cushion, 12x12 cells mapped onto the disc, a = 1.20 m, rim held in
///       z and free in its plane, SVK E t = 3.48e5 N/m; gas ΔN = 0.630 m³ (0.116 of the plan
///       area times a) at a soft 5 kPa atmosphere; then the gas let out (ΔN = 0).
/// REFERENCE: below the volume an inextensible pillow of this outline holds (about 0.38 π a³)
///       the bag is partly inflated: an equilibrium with every triangle slack or wrinkled at
///       (nearly) zero pressure, one of many. The corpus's own checks judge it independently:
///       residual within 1e-6 of the forces acting plus 100 ε of the stiffness times the size,
///       force and moment balance with the enclosed pressure applied as a follower pressure on
///       the current triangles, mirror symmetries (reactions where slack), and the gas law
///       (p + p_atm) V / p_atm = ΔN with V computed from the deformed nodes, within 1e-6 of
///       the plan area times a. Measured: without the continuation the loaded row spent its
///       budget (385 iterations, |R| 0.13 of the scale); with it, right in 202 iterations.
/// REQUIRED: both rows right.
#[test]
fn a_free_rim_cushion_partly_inflated_by_gas_from_flat_converges_right() {
    let runs =
        run_all(|m| m.family == "cushion-volume" && m.label.starts_with("circle n=12 a=1.20 m"));
    assert_eq!(runs.len(), 2, "seed 27 draws the member");
    assert_all_right(&runs);
}

/// GOAL: a step to zero loads followed by arc length ends at the reference configuration when
///       that is an equilibrium, as a load-controlled one does (stepper.rs, `reference_answer`,
///       since the sixteenth session for arc length too).
/// MESH, BOUNDARY CONDITIONS, PARAMETERS: the shipped HenckyDisc (16 rings, a = 0.5 m,
///       h = 0.1 mm, E = 200 MPa, ν = 0.3, rim clamped) with `solver.path: arc_length`.
/// LOADING: 40 Pa (follower), then 0 in one row.
/// REFERENCE: loaded, docs/mechanics.md §4a: w0/a = 0.065404 at qa/(Eh) = 1e-3 (16 rings:
///       CST error within 1e-3, as tests/verification/hencky_disc.rs measures at 20 rings,
///       0.19/rings² here); unloaded, the flat disc is the one equilibrium (clamped, no
///       prestress): every displacement 0. Measured before: the unloaded step spent its budget
///       (1000 iterations, 2.4 s) at load fraction 0.999967 on the singular path w³ ∝ q.
/// REQUIRED: both steps converge, the loaded within 1e-3 of the closed form (measured 7.3e-4),
///       the unloaded in 0 iterations at zero displacement, naming the reference.
#[test]
fn an_arc_length_step_to_nothing_rests_at_the_reference() {
    let mut scene = crate::common::read_scene(&crate::common::shipped("HenckyDisc"));
    scene.solver.path = velarium::scene::PathMethod::ArcLength;
    let mut e = velarium::Engine::try_new(scene).expect("it builds");
    assert!(e.solve().converged());
    crate::common::set(&mut e, "pressure", 40.0);
    let r = e.solve();
    assert!(r.converged(), "{}", r.message);
    let w = crate::common::get(&e, "center_uz") / 0.5;
    let error = (w / 0.065404 - 1.0).abs();
    println!(
        "loaded: w0/a {w:.6}, error {error:.2e}, {} iterations",
        r.iterations
    );
    assert!(error < 1e-3, "w0/a {w}");
    crate::common::set(&mut e, "pressure", 0.0);
    let r = e.solve();
    assert!(r.converged(), "{}", r.message);
    assert_eq!(r.iterations, 0);
    assert!(
        r.message.contains("reference configuration"),
        "{}",
        r.message
    );
    assert!(e.state().displacement.iter().all(|&x| x == 0.0));
}

/// GOAL: an arc-length step whose first (load-controlled) increment fails down to the smallest
///       increment goes by load control as a whole, with the continuations a failed
///       load-controlled increment has (arc.rs, `first_increment`; since the sixteenth session).
///       Before, it failed at load fraction 0.
/// MESH, BOUNDARY CONDITIONS, PARAMETERS: the quarter airbag of issue 27 as corpus seed 27
///       draws it (`cushion-quarter`, square, 8x8 cells, a = 0.70 m, E t = 1.505e8 N/m, two flat
///       sheets sharing the rim, symmetry planes x = 0 and y = 0, rim held in z), with
///       `solver.path: arc_length`; follower pressure 4167 Pa from flat, then 0.
/// REFERENCE: the corpus's own checks (residual within 1e-6 of the forces acting plus 100 ε of
///       the stiffness times the size, force and moment balance with the pressure computed from
///       the current triangles, top/bottom and diagonal mirrors). Measured before: "no
///       equilibrium found beyond load fraction 0 of the step" after 353 iterations; now right
///       in 520 (the prestress and overshoot continuations), unloaded in 0.
/// REQUIRED: both rows right; the loaded step's log names the switch to load control.
#[test]
fn an_arc_length_step_that_cannot_start_goes_by_load_control_with_its_continuations() {
    let mut member = corpus::members(27)
        .into_iter()
        .find(|m| m.family == "cushion-quarter" && m.label.starts_with("square n=8 a=0.70 m"))
        .expect("seed 27 draws the airbag");
    member.scene.solver.path = velarium::scene::PathMethod::ArcLength;
    let runs = corpus::run_member(&member);
    print!("{}", corpus::table(&runs));
    assert_eq!(runs.len(), 2);
    assert_all_right(&runs);
    let mut engine = velarium::Engine::try_new(member.scene.clone()).expect("it builds");
    assert!(engine.solve().converged());
    set_row(&mut engine, &member.rows[0]);
    let report = engine.solve();
    assert!(report.converged(), "{}", report.message);
    assert!(
        report
            .log
            .iter()
            .any(|l| l.contains("the whole step by load control instead")),
        "the log names the switch"
    );
}
