//! Verification: the mechanics against closed forms, published tables and finite differences.
//! One module per case; each starts with its GOAL / MESH / BOUNDARY CONDITIONS / PARAMETERS /
//! REFERENCE / TOLERANCE header (docs/mechanics.md, "Verification"). One case alone:
//! `cargo test --release --test verification hencky_disc::`.

#[path = "../common/mod.rs"]
mod common;

mod annulus_torsion;
mod arc_length;
mod arc_length_fallbacks;
mod cable_midspan;
mod capstan_sleeve;
mod conical_tent;
mod contact;
mod distant_member;
mod dynamics;
mod etfe;
mod form_finding;
mod hencky_disc;
mod lame_annulus;
mod lifted_membrane;
mod natural_frequencies;
mod orthotropic;
mod patch_test;
mod prestressed_membrane;
mod radial_warp;
mod rigid_motion;
mod shear_wrinkling;
mod sleeve_cable;
mod sleeve_drawstring;
mod sleeve_penalty;
mod sliding_cable;
mod stick_slip;
mod surface_loads;
mod tangent_fd;
mod tangent_fd_sleeve;
mod volume_control;
mod wrinkled_shear;
mod wrinkling_law;
