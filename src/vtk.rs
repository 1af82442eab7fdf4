//! ParaView output: one VTK XML unstructured grid (`.vtu`, ASCII) per load row and a `.pvd`
//! collection that orders them in time (`velarium solve --vtk DIR`).
//!
//! ```text
//! points       every model node at its CURRENT position (m): mesh nodes, then the cable
//!              points of sleeves (each tied to its sleeve node)
//! cells        membrane triangles (VTK_TRIANGLE, model order), then cable segments
//!              (VTK_LINE, cable by cable, in order along each cable)
//! point data   displacement (3)        u, m; the reference position is points - displacement
//!              cable_slip              -s at sleeve cable points (as the cable_slip probe), m;
//!                                      0 at every other node
//! cell data    kind                    0 triangle, 1 cable segment
//!              id                      mesh triangle id / segment index within its cable
//!              cable                   cable index (scene order), -1 for triangles
//!              wrinkle_state           0 taut, 1 wrinkled, 2 slack; -1 for segments
//!              sigma_max, sigma_min    principal Cauchy stresses, Pa; NaN for segments
//!              tension_direction (3)   unit major principal direction (current configuration)
//!                                      of a triangle; unit axis of a segment
//!              cable_tension           axial force of a segment, N; NaN for triangles
//!              slip                    unstretched length that flowed into the segment
//!                                      through its sleeve points (s_end - s_start), m; NaN for
//!                                      triangles
//! ```
//!
//! Numbers are written in shortest round-trip form, so a reader gets the f64 values exactly.
//! Every file is written through a temporary file and renamed into place: a reader never sees
//! a half-written file, and a failed write leaves none behind.

use crate::engine::Engine;
use crate::error::Error;
use crate::format::{vtk_double, xs_double};
use crate::pack::write_atomically;
use crate::results;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Writes the `.vtu` files of a run into a directory and, at the end, its `.pvd` collection.
pub struct Series {
    dir: PathBuf,
    stem: String,
    /// (time, file name) of every written row.
    written: Vec<(f64, String)>,
}

impl Series {
    /// Create `dir` (and its parents) if needed. Files are named `<stem>_<row>.vtu` and
    /// `<stem>.pvd`.
    pub fn create(dir: &Path, stem: &str) -> Result<Series, Error> {
        std::fs::create_dir_all(dir).map_err(|e| Error::Io {
            path: dir.display().to_string(),
            message: format!("cannot create the directory: {e}"),
        })?;
        Ok(Series {
            dir: dir.to_path_buf(),
            stem: stem.to_string(),
            written: Vec::new(),
        })
    }

    /// Write the engine's committed state as the next row of the series, at `time`.
    pub fn write_row(&mut self, engine: &Engine, time: f64) -> Result<(), Error> {
        let name = format!("{}_{:04}.vtu", self.stem, self.written.len());
        write_atomically(&self.dir.join(&name), unstructured_grid(engine).as_bytes())?;
        self.written.push((time, name));
        Ok(())
    }

    /// Write `<stem>.pvd` listing every row written so far; returns its path.
    pub fn finish(&self) -> Result<PathBuf, Error> {
        let mut pvd = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n",
        );
        for (time, file) in &self.written {
            let _ = writeln!(
                pvd,
                "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{file}\"/>",
                xs_double(*time)
            );
        }
        pvd.push_str("  </Collection>\n</VTKFile>\n");
        let path = self.dir.join(format!("{}.pvd", self.stem));
        write_atomically(&path, pvd.as_bytes())?;
        Ok(path)
    }

    /// Number of rows written.
    pub fn len(&self) -> usize {
        self.written.len()
    }

    pub fn is_empty(&self) -> bool {
        self.written.is_empty()
    }
}

/// The committed state of `engine` as a VTK XML UnstructuredGrid document (ASCII).
pub fn unstructured_grid(engine: &Engine) -> String {
    let model = engine.model();
    let u = &engine.state().displacement;
    let nodes = model.reference.len();
    let triangles = model.triangles.len();
    let segments = model.segments.len();
    let membranes = engine.membranes();

    let mut slip_at_node = vec![0.0; nodes];
    for (j, point) in model.slips.iter().enumerate() {
        slip_at_node[point.node] = 0.0 - u[model.dof_count() + j];
    }
    // Cable index and position along the cable of every segment.
    let mut segment_cable = vec![(0usize, 0usize); segments];
    for (c, cable) in model.cables.iter().enumerate() {
        for (k, s) in cable.segments.clone().enumerate() {
            segment_cable[s] = (c, k);
        }
    }

    let mut x = String::with_capacity(64 * (nodes + triangles + segments));
    let _ = write!(
        x,
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"{nodes}\" NumberOfCells=\"{}\">\n",
        triangles + segments
    );

    x.push_str("      <Points>\n");
    array(
        &mut x,
        "Float64",
        "position",
        3,
        (0..nodes).flat_map(|i| {
            let p = model.position(u, i);
            [p.x, p.y, p.z]
        }),
    );
    x.push_str("      </Points>\n");

    x.push_str("      <Cells>\n");
    int_array(
        &mut x,
        "Int64",
        "connectivity",
        1,
        model
            .triangles
            .iter()
            .flat_map(|t| t.nodes.iter().map(|&n| n as i64))
            .chain(
                model
                    .segments
                    .iter()
                    .flat_map(|s| s.nodes.iter().map(|&n| n as i64)),
            ),
    );
    int_array(
        &mut x,
        "Int64",
        "offsets",
        1,
        (1..=triangles)
            .map(|k| 3 * k as i64)
            .chain((1..=segments).map(|k| (3 * triangles + 2 * k) as i64)),
    );
    int_array(
        &mut x,
        "UInt8",
        "types",
        1,
        std::iter::repeat_n(5i64, triangles).chain(std::iter::repeat_n(3i64, segments)),
    );
    x.push_str("      </Cells>\n");

    x.push_str("      <PointData Vectors=\"displacement\">\n");
    array(
        &mut x,
        "Float64",
        "displacement",
        3,
        u[..3 * nodes].iter().copied(),
    );
    array(
        &mut x,
        "Float64",
        "cable_slip",
        1,
        slip_at_node.iter().copied(),
    );
    x.push_str("      </PointData>\n");

    x.push_str("      <CellData Scalars=\"wrinkle_state\" Vectors=\"tension_direction\">\n");
    int_array(
        &mut x,
        "Int32",
        "kind",
        1,
        std::iter::repeat_n(0i64, triangles).chain(std::iter::repeat_n(1i64, segments)),
    );
    int_array(
        &mut x,
        "Int32",
        "id",
        1,
        model
            .triangles
            .iter()
            .map(|t| t.id as i64)
            .chain(segment_cable.iter().map(|&(_, k)| k as i64)),
    );
    int_array(
        &mut x,
        "Int32",
        "cable",
        1,
        std::iter::repeat_n(-1i64, triangles).chain(segment_cable.iter().map(|&(c, _)| c as i64)),
    );
    int_array(
        &mut x,
        "Int32",
        "wrinkle_state",
        1,
        membranes
            .iter()
            .map(|m| results::state_code(m.state) as i64)
            .chain(std::iter::repeat_n(-1i64, segments)),
    );
    array(
        &mut x,
        "Float64",
        "sigma_max",
        1,
        membranes
            .iter()
            .map(|m| m.cauchy.0)
            .chain(std::iter::repeat_n(f64::NAN, segments)),
    );
    array(
        &mut x,
        "Float64",
        "sigma_min",
        1,
        membranes
            .iter()
            .map(|m| m.cauchy.1)
            .chain(std::iter::repeat_n(f64::NAN, segments)),
    );
    let segment_axis = |s: usize| {
        let [a, b] = model.segments[s].nodes;
        let d = model.position(u, b) - model.position(u, a);
        if d.norm() > 0.0 {
            d.normalize()
        } else {
            d
        }
    };
    array(
        &mut x,
        "Float64",
        "tension_direction",
        3,
        model
            .triangles
            .iter()
            .zip(membranes)
            .flat_map(|(t, m)| {
                let d = results::tension_direction(model, u, t, m);
                [d.x, d.y, d.z]
            })
            .chain((0..segments).flat_map(|s| {
                let d = segment_axis(s);
                [d.x, d.y, d.z]
            })),
    );
    array(
        &mut x,
        "Float64",
        "cable_tension",
        1,
        std::iter::repeat_n(f64::NAN, triangles)
            .chain((0..segments).map(|s| model.segment_tension(u, s))),
    );
    array(
        &mut x,
        "Float64",
        "slip",
        1,
        std::iter::repeat_n(f64::NAN, triangles)
            .chain((0..segments).map(|s| model.segment_l0(u, s) - model.segments[s].l0)),
    );
    x.push_str("      </CellData>\n");

    x.push_str("    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
    x
}

/// One ASCII `DataArray` of floats, `components` values per tuple, 3 tuples... per line.
fn array(
    out: &mut String,
    ty: &str,
    name: &str,
    components: usize,
    values: impl Iterator<Item = f64>,
) {
    let _ = write!(
        out,
        "        <DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{components}\" format=\"ascii\">\n         "
    );
    for (k, v) in values.enumerate() {
        if k > 0 && k % (3 * components.max(1)) == 0 {
            out.push_str("\n         ");
        }
        let _ = write!(out, " {}", vtk_double(v));
    }
    out.push_str("\n        </DataArray>\n");
}

/// One ASCII `DataArray` of integers.
fn int_array(
    out: &mut String,
    ty: &str,
    name: &str,
    components: usize,
    values: impl Iterator<Item = i64>,
) {
    let _ = write!(
        out,
        "        <DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{components}\" format=\"ascii\">\n         "
    );
    for (k, v) in values.enumerate() {
        if k > 0 && k % 12 == 0 {
            out.push_str("\n         ");
        }
        let _ = write!(out, " {v}");
    }
    out.push_str("\n        </DataArray>\n");
}
