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
use crate::model::ElementKind;
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

/// One cell of the grid: an element drawn in ParaView.
struct Cell<'m> {
    nodes: &'m [usize],
    /// VTK cell type (5 triangle, 3 line).
    vtk_type: i64,
    /// The `kind` cell data: 0 triangle, 1 cable segment.
    kind: i64,
    /// Mesh triangle id / segment index within its cable.
    id: i64,
    /// Cable index (scene order), -1 for triangles.
    cable: i64,
    data: results::ElementData,
}

/// The cells of `engine`'s committed state, kind by kind (`ElementKind::ALL`), each kind in
/// model order.
fn cells(engine: &Engine) -> Vec<Cell<'_>> {
    let model = engine.model();
    let u = &engine.state().displacement;
    let mut cells = Vec::with_capacity(model.triangles.len() + model.segments.len());
    for kind in ElementKind::ALL {
        match kind {
            ElementKind::Membrane => {
                for (t, m) in model.triangles.iter().zip(engine.membranes()) {
                    cells.push(Cell {
                        nodes: &t.nodes,
                        vtk_type: 5,
                        kind: 0,
                        id: t.id as i64,
                        cable: -1,
                        data: results::triangle_data(model, u, t, m),
                    });
                }
            }
            ElementKind::Cable => {
                for (c, cable) in model.cables.iter().enumerate() {
                    for (k, s) in cable.segments.clone().enumerate() {
                        cells.push(Cell {
                            nodes: &model.segments[s].nodes,
                            vtk_type: 3,
                            kind: 1,
                            id: k as i64,
                            cable: c as i64,
                            data: results::segment_data(model, u, s),
                        });
                    }
                }
            }
            // Not drawn: a tie joins a sleeve's cable point to its sleeve node, at the same
            // place to the tie's gap; its force and gap are the sleeve probes'.
            ElementKind::Tie => {}
        }
    }
    cells
}

/// The committed state of `engine` as a VTK XML UnstructuredGrid document (ASCII).
pub fn unstructured_grid(engine: &Engine) -> String {
    let model = engine.model();
    let u = &engine.state().displacement;
    let nodes = model.reference.len();
    let cells = cells(engine);

    let mut slip_at_node = vec![0.0; nodes];
    for (j, point) in model.slips.iter().enumerate() {
        slip_at_node[point.node] = 0.0 - u[model.dof_count() + j];
    }

    let mut x = String::with_capacity(64 * (nodes + cells.len()));
    let _ = write!(
        x,
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"{nodes}\" NumberOfCells=\"{}\">\n",
        cells.len()
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
    let ints = |f: fn(&Cell) -> i64| cells.iter().map(f);
    int_array(
        &mut x,
        "Int64",
        "connectivity",
        1,
        cells.iter().flat_map(|c| c.nodes.iter().map(|&n| n as i64)),
    );
    int_array(
        &mut x,
        "Int64",
        "offsets",
        1,
        cells.iter().scan(0i64, |end, c| {
            *end += c.nodes.len() as i64;
            Some(*end)
        }),
    );
    int_array(&mut x, "UInt8", "types", 1, ints(|c| c.vtk_type));
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
    let floats = |f: fn(&results::ElementData) -> f64| cells.iter().map(move |c| f(&c.data));
    int_array(&mut x, "Int32", "kind", 1, ints(|c| c.kind));
    int_array(&mut x, "Int32", "id", 1, ints(|c| c.id));
    int_array(&mut x, "Int32", "cable", 1, ints(|c| c.cable));
    int_array(
        &mut x,
        "Int32",
        "wrinkle_state",
        1,
        ints(|c| c.data.state.map_or(-1, |s| results::state_code(s) as i64)),
    );
    array(&mut x, "Float64", "sigma_max", 1, floats(|d| d.principal.0));
    array(&mut x, "Float64", "sigma_min", 1, floats(|d| d.principal.1));
    array(
        &mut x,
        "Float64",
        "tension_direction",
        3,
        cells.iter().flat_map(|c| {
            let d = c.data.direction;
            [d.x, d.y, d.z]
        }),
    );
    array(&mut x, "Float64", "cable_tension", 1, floats(|d| d.tension));
    array(&mut x, "Float64", "slip", 1, floats(|d| d.slip));
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
