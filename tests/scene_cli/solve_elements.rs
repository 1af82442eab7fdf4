//! `velarium solve --elements` writes, per load row and membrane triangle, the wrinkle state,
//! the unit tension direction, the centroid and the principal stresses.

use std::process::Command;

#[test]
fn element_table_has_one_line_per_triangle_and_row() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("velarium-elements-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let loads = dir.join("loads.csv");
    std::fs::write(&loads, "time,lift_force\n0,0\n1,20\n2,50\n").unwrap();
    let elements = dir.join("elements.csv");
    let scene = format!(
        "{}/modelDescription/LiftedMembrane/scene.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let out = Command::new(env!("CARGO_BIN_EXE_velarium"))
        .args(["solve", &scene, "--loads"])
        .arg(&loads)
        .arg("--elements")
        .arg(&elements)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&elements).unwrap();
    let mut lines = text.lines();
    assert!(lines
        .next()
        .unwrap()
        .starts_with("time,triangle,state,tension_x"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    // 20 x 12 cells, two triangles each, three load rows.
    assert_eq!(rows.len(), 3 * 480);
    let mut wrinkled = 0;
    for r in &rows {
        assert!([0.0, 1.0, 2.0].contains(&r[2]), "state code {}", r[2]);
        let n = (r[3] * r[3] + r[4] * r[4] + r[5] * r[5]).sqrt();
        assert!(
            (n - 1.0).abs() < 1e-12,
            "tension direction not a unit vector: {n}"
        );
        assert!(r[9] >= r[10], "sigma_max >= sigma_min");
        wrinkled += (r[2] == 1.0) as usize;
    }
    // Lifting a sheet clamped on two edges wrinkles part of it (the free edges pull in).
    assert!(
        wrinkled > 0,
        "some triangles wrinkle under the lifting force"
    );
    std::fs::remove_dir_all(&dir).ok();
}
