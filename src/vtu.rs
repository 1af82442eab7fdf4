//! VTK XML unstructured grids (`.vtu`) of a model: the state of a load row (`velarium solve
//! --vtk`, through `vtk.rs`) and the reference mesh every FMU carries as
//! `resources/mesh.vtu` (`pack.rs`), so that a master's array outputs can be drawn without
//! solving again (harness/fmu_vtk.py).
//!
//! ```text
//! points       every model node at its REFERENCE position (m): mesh nodes in id order, then
//!              the cable points of sleeves (each tied to its sleeve node); the deformed shape
//!              is points + displacement_m (ParaView's Warp By Vector, scale 1)
//! cells        membrane triangles (VTK_TRIANGLE, model order), then cable segments
//!              (VTK_LINE, cable by cable, in order along each cable)
//! field data   TimeValue                the row's time, s (state grids)
//!              <kind>:<output>          (mesh grid) for every array output of kind
//!                                       displacement_field the point index of each of its
//!                                       rows, for principal_stresses, wrinkle_states and
//!                                       cable_tensions the cell index
//! point data   displacement_m (3)       u, m
//!              cable_slip_m             -s at sleeve cable points (as the cable_slip probe), m;
//!                                       0 at every other node
//! cell data    kind                     0 triangle, 1 cable segment
//!              id                       mesh triangle id / segment index within its cable
//!              cable                    cable index (scene order), -1 for triangles
//!              wrinkle_state            0 taut, 1 wrinkled, 2 slack; -1 for segments
//!              sigma_max_Pa, sigma_min_Pa   principal Cauchy stresses, Pa; NaN for segments
//!              tension_direction (3)    unit major principal direction (current configuration)
//!                                       of a triangle; unit axis of a segment
//!              cable_tension_N          axial force of a segment, N; NaN for triangles
//!              slip_m                   unstretched length that flowed into the segment
//!                                       through its sleeve points (s_end - s_start), m; NaN
//!                                       for triangles
//! ```
//! The mesh grid has the points, the cells, `kind`, `id`, `cable` and the field data of the
//! outputs; a unit is the suffix of a field's name (`_m`, `_Pa`, `_N`; none: dimensionless).
//!
//! Two encodings of the same arrays: [`Grid::binary`] (what the files hold: appended raw data,
//! each array one zlib stream per 32 KiB block behind VTK's compression header of UInt64
//! sizes, `compressor="vtkZLibDataCompressor"`: vtkXMLWriter's appended mode with its data
//! not base64-encoded, 6x smaller than ASCII on the shipped scenes) and
//! [`Grid::ascii`] (every number in shortest round-trip form, for reading by eye and for the
//! tests that compare documents). Both carry the f64 values exactly.

use crate::engine::Engine;
use crate::format::{vtk_double, xs_double};
use crate::model::{ElementKind, ProbeModel};
use crate::results;
use crate::scene::Probe;
use crate::variables::Binding;
use std::fmt::Write as _;
use std::io::Write as _;

/// Uncompressed bytes per compressed block (vtkXMLWriter's default block size).
pub const BLOCK_SIZE: usize = 32768;

/// zlib level 6, zlib's own default (vtkXMLWriter uses 5).
const LEVEL: u32 = 6;

/// The values of one `DataArray`.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    Float64(Vec<f64>),
    Int64(Vec<i64>),
    Int32(Vec<i32>),
    UInt8(Vec<u8>),
}

impl Values {
    fn type_name(&self) -> &'static str {
        match self {
            Values::Float64(_) => "Float64",
            Values::Int64(_) => "Int64",
            Values::Int32(_) => "Int32",
            Values::UInt8(_) => "UInt8",
        }
    }

    fn len(&self) -> usize {
        match self {
            Values::Float64(v) => v.len(),
            Values::Int64(v) => v.len(),
            Values::Int32(v) => v.len(),
            Values::UInt8(v) => v.len(),
        }
    }

    /// Little-endian bytes.
    fn bytes(&self) -> Vec<u8> {
        match self {
            Values::Float64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::Int64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::Int32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::UInt8(v) => v.clone(),
        }
    }

    /// Shortest round-trip text, one space before each value.
    fn text(&self, per_line: usize, out: &mut String) {
        let n = self.len();
        for k in 0..n {
            if k > 0 && k % per_line == 0 {
                out.push_str("\n         ");
            }
            out.push(' ');
            match self {
                Values::Float64(v) => out.push_str(&vtk_double(v[k])),
                Values::Int64(v) => {
                    let _ = write!(out, "{}", v[k]);
                }
                Values::Int32(v) => {
                    let _ = write!(out, "{}", v[k]);
                }
                Values::UInt8(v) => {
                    let _ = write!(out, "{}", v[k]);
                }
            }
        }
    }
}

/// One named array of a grid.
#[derive(Clone, Debug, PartialEq)]
pub struct DataArray {
    pub name: String,
    pub components: usize,
    pub values: Values,
}

impl DataArray {
    pub fn new(name: &str, components: usize, values: Values) -> DataArray {
        DataArray {
            name: name.to_string(),
            components,
            values,
        }
    }
}

/// An unstructured grid: points, cells and their data, in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// x, y, z of every point, m.
    pub points: Vec<f64>,
    pub connectivity: Vec<i64>,
    pub offsets: Vec<i64>,
    /// VTK cell types (5 triangle, 3 line).
    pub types: Vec<u8>,
    pub field_data: Vec<DataArray>,
    pub point_data: Vec<DataArray>,
    pub cell_data: Vec<DataArray>,
}

/// One cell of the grid: an element drawn in ParaView.
struct Cell<'m> {
    nodes: &'m [usize],
    /// VTK cell type (5 triangle, 3 line).
    vtk_type: u8,
    /// The `kind` cell data: 0 triangle, 1 cable segment.
    kind: i32,
    /// Mesh triangle id / segment index within its cable.
    id: i32,
    /// Cable index (scene order), -1 for triangles.
    cable: i32,
    /// The model element: triangle index, or segment index into `Model::segments`.
    element: usize,
}

/// The cells of `engine`'s model, kind by kind (`ElementKind::ALL`), each kind in model order.
fn cells(engine: &Engine) -> Vec<Cell<'_>> {
    let model = engine.model();
    let mut cells = Vec::with_capacity(model.triangles.len() + model.segments.len());
    for kind in ElementKind::ALL {
        match kind {
            ElementKind::Membrane => {
                for (k, t) in model.triangles.iter().enumerate() {
                    cells.push(Cell {
                        nodes: &t.nodes,
                        vtk_type: 5,
                        kind: 0,
                        id: t.id as i32,
                        cable: -1,
                        element: k,
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
                            id: k as i32,
                            cable: c as i32,
                            element: s,
                        });
                    }
                }
            }
            // Not drawn: a tie joins a sleeve's cable point to its sleeve node, at the same
            // place to the tie's gap; its force and gap are the sleeve probes'.
            ElementKind::Tie => {}
            // Not drawn: contacts act at nodes; their totals are the contact probes'.
            ElementKind::ContactPair | ElementKind::ContactPoint => {}
        }
    }
    cells
}

/// The reference points, the cells and their `kind`, `id`, `cable` arrays.
fn skeleton(engine: &Engine, cells: &[Cell]) -> Grid {
    let model = engine.model();
    let ints = |f: fn(&Cell) -> i32| Values::Int32(cells.iter().map(f).collect());
    Grid {
        points: model
            .reference
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .collect(),
        connectivity: cells
            .iter()
            .flat_map(|c| c.nodes.iter().map(|&n| n as i64))
            .collect(),
        offsets: cells
            .iter()
            .scan(0i64, |end, c| {
                *end += c.nodes.len() as i64;
                Some(*end)
            })
            .collect(),
        types: cells.iter().map(|c| c.vtk_type).collect(),
        field_data: Vec::new(),
        point_data: Vec::new(),
        cell_data: vec![
            DataArray::new("kind", 1, ints(|c| c.kind)),
            DataArray::new("id", 1, ints(|c| c.id)),
            DataArray::new("cable", 1, ints(|c| c.cable)),
        ],
    }
}

impl Grid {
    /// The committed state of `engine` (see the module docs), with `TimeValue` if a time is
    /// given.
    pub fn state(engine: &Engine, time: Option<f64>) -> Grid {
        let model = engine.model();
        let u = &engine.state().displacement;
        let nodes = model.reference.len();
        let cells = cells(engine);
        let mut grid = skeleton(engine, &cells);
        if let Some(t) = time {
            grid.field_data
                .push(DataArray::new("TimeValue", 1, Values::Float64(vec![t])));
        }

        let mut slip_at_node = vec![0.0; nodes];
        for (j, point) in model.slips.iter().enumerate() {
            slip_at_node[point.node] = 0.0 - u[model.dof_count() + j];
        }
        grid.point_data = vec![
            DataArray::new(
                "displacement_m",
                3,
                Values::Float64(u[..3 * nodes].to_vec()),
            ),
            DataArray::new("cable_slip_m", 1, Values::Float64(slip_at_node)),
        ];

        let data: Vec<results::ElementData> = cells
            .iter()
            .map(|c| match c.kind {
                0 => results::triangle_data(
                    model,
                    u,
                    &model.triangles[c.element],
                    &engine.membranes()[c.element],
                ),
                _ => results::segment_data(model, u, c.element),
            })
            .collect();
        let floats =
            |f: fn(&results::ElementData) -> f64| Values::Float64(data.iter().map(f).collect());
        grid.cell_data.extend([
            DataArray::new(
                "wrinkle_state",
                1,
                Values::Int32(
                    data.iter()
                        .map(|d| d.state.map_or(-1, |s| results::state_code(s) as i32))
                        .collect(),
                ),
            ),
            DataArray::new("sigma_max_Pa", 1, floats(|d| d.principal.0)),
            DataArray::new("sigma_min_Pa", 1, floats(|d| d.principal.1)),
            DataArray::new(
                "tension_direction",
                3,
                Values::Float64(
                    data.iter()
                        .flat_map(|d| [d.direction.x, d.direction.y, d.direction.z])
                        .collect(),
                ),
            ),
            DataArray::new("cable_tension_N", 1, floats(|d| d.tension)),
            DataArray::new("slip_m", 1, floats(|d| d.slip)),
        ]);
        grid
    }

    /// The reference mesh of `engine`'s model and, as field data `<kind>:<output>`, where the
    /// rows of every array output of the kinds a state grid draws go: the point index of each
    /// row of a `displacement_field` output, the cell index of each row of a
    /// `principal_stresses`, `wrinkle_states` or `cable_tensions` output. Other outputs
    /// (`position_field`, `sleeve_slips`, scalars) are not listed.
    pub fn mesh(engine: &Engine) -> Grid {
        let model = engine.model();
        let cells = cells(engine);
        let mut grid = skeleton(engine, &cells);
        let triangles = model.triangles.len();
        // The cell of cable c's first segment.
        let mut first_cell = Vec::with_capacity(model.cables.len());
        let mut next = triangles;
        for cable in &model.cables {
            first_cell.push(next);
            next += cable.segments.len();
        }
        for var in engine.arrays() {
            let Binding::Output(slot) = var.binding else {
                continue;
            };
            let Some(output) = engine.scene().outputs.iter().find(|o| o.name == var.name) else {
                continue;
            };
            let probes = &model.probes[slot..slot + var.len()];
            let (kind, rows): (&str, Vec<i64>) = match &output.probe {
                Probe::DisplacementField { .. } => (
                    "displacement_field",
                    probes.iter().step_by(3).map(|p| index(p) / 3).collect(),
                ),
                Probe::PrincipalStresses { .. } => (
                    "principal_stresses",
                    probes.iter().step_by(2).map(index).collect(),
                ),
                Probe::WrinkleStates { .. } => {
                    ("wrinkle_states", probes.iter().map(index).collect())
                }
                Probe::CableTensions { .. } => (
                    "cable_tensions",
                    probes
                        .iter()
                        .map(|p| match p {
                            ProbeModel::CableTension {
                                cable,
                                segment: Some(s),
                            } => (first_cell[*cable] + s) as i64,
                            other => unreachable!("a cable_tensions element is {other:?}"),
                        })
                        .collect(),
                ),
                _ => continue,
            };
            grid.field_data.push(DataArray::new(
                &format!("{kind}:{}", var.name),
                1,
                Values::Int64(rows),
            ));
        }
        grid
    }

    /// The array of point, cell or field data named `name`.
    pub fn array(&self, name: &str) -> Option<&DataArray> {
        self.point_data
            .iter()
            .chain(&self.cell_data)
            .chain(&self.field_data)
            .find(|a| a.name == name)
    }

    fn point_count(&self) -> usize {
        self.points.len() / 3
    }

    /// The grid's arrays in file order, each with its XML section: points, cells, then the
    /// field, point and cell data.
    fn sections(&self) -> Vec<(&'static str, DataArray)> {
        let mut arrays: Vec<(&'static str, DataArray)> = Vec::new();
        for a in &self.field_data {
            arrays.push(("FieldData", a.clone()));
        }
        arrays.push((
            "Points",
            DataArray::new("Points", 3, Values::Float64(self.points.clone())),
        ));
        arrays.push((
            "Cells",
            DataArray::new("connectivity", 1, Values::Int64(self.connectivity.clone())),
        ));
        arrays.push((
            "Cells",
            DataArray::new("offsets", 1, Values::Int64(self.offsets.clone())),
        ));
        arrays.push((
            "Cells",
            DataArray::new("types", 1, Values::UInt8(self.types.clone())),
        ));
        for a in &self.point_data {
            arrays.push(("PointData", a.clone()));
        }
        for a in &self.cell_data {
            arrays.push(("CellData", a.clone()));
        }
        arrays
    }

    /// The XML document around the arrays; `array` writes one `DataArray` element.
    fn document(
        &self,
        compressor: &str,
        mut array: impl FnMut(&mut String, &str, &DataArray),
    ) -> String {
        let sections = self.sections();
        let mut x = String::with_capacity(4096);
        let _ = write!(
            x,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"{compressor}>\n  <UnstructuredGrid>\n"
        );
        let mut open: Option<&str> = None;
        for (section, a) in &sections {
            if open != Some(section) {
                if let Some(previous) = open {
                    close(&mut x, previous);
                }
                match *section {
                    "FieldData" => x.push_str("    <FieldData>\n"),
                    "Points" | "Cells" | "PointData" | "CellData" => {
                        if matches!(open, None | Some("FieldData")) {
                            let _ = writeln!(
                                x,
                                "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
                                self.point_count(),
                                self.types.len()
                            );
                        }
                        let attributes = match *section {
                            "PointData" => " Vectors=\"displacement_m\"",
                            "CellData" if self.array("wrinkle_state").is_some() => {
                                " Scalars=\"wrinkle_state\" Vectors=\"tension_direction\""
                            }
                            _ => "",
                        };
                        let _ = writeln!(x, "      <{section}{attributes}>");
                    }
                    _ => unreachable!("no section {section}"),
                }
                open = Some(section);
            }
            array(&mut x, section, a);
        }
        if let Some(previous) = open {
            close(&mut x, previous);
        }
        x
    }

    /// The document with every array as ASCII text (numbers in shortest round-trip form).
    pub fn ascii(&self) -> String {
        let mut x = self.document("", |x, section, a| {
            let indent = if section == "FieldData" { "      " } else { "        " };
            let _ = write!(
                x,
                "{indent}<DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\"{} format=\"ascii\">\n         ",
                a.values.type_name(),
                a.name,
                a.components,
                tuples(section, a),
            );
            let per_line = match a.values {
                Values::Float64(_) => 3 * a.components.max(1),
                _ => 12,
            };
            a.values.text(per_line, x);
            let _ = writeln!(x, "\n{indent}</DataArray>");
        });
        x.push_str("</VTKFile>\n");
        x
    }

    /// The document with every array zlib-compressed in one raw appended block (see the
    /// module docs).
    pub fn binary(&self) -> Vec<u8> {
        let mut appended: Vec<u8> = Vec::new();
        let mut x = self.document(" compressor=\"vtkZLibDataCompressor\"", |x, section, a| {
            let indent = if section == "FieldData" { "      " } else { "        " };
            let _ = writeln!(
                x,
                "{indent}<DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\"{} format=\"appended\" offset=\"{}\"/>",
                a.values.type_name(),
                a.name,
                a.components,
                tuples(section, a),
                appended.len()
            );
            compress_into(&a.values.bytes(), &mut appended);
        });
        x.push_str("  <AppendedData encoding=\"raw\">\n   _");
        let mut bytes = x.into_bytes();
        bytes.extend_from_slice(&appended);
        bytes.extend_from_slice(b"\n  </AppendedData>\n</VTKFile>\n");
        bytes
    }
}

/// `NumberOfTuples` of a field-data array (VTK's field data needs it; the piece's counts give
/// the others).
fn tuples(section: &str, a: &DataArray) -> String {
    if section == "FieldData" {
        format!(
            " NumberOfTuples=\"{}\"",
            a.values.len() / a.components.max(1)
        )
    } else {
        String::new()
    }
}

/// Close the XML section `section` (and the piece after the last of its sections).
fn close(x: &mut String, section: &str) {
    match section {
        "FieldData" => x.push_str("    </FieldData>\n"),
        _ => {
            let _ = writeln!(x, "      </{section}>");
            if section == "CellData" {
                x.push_str("    </Piece>\n  </UnstructuredGrid>\n");
            }
        }
    }
}

/// Append `data` as VTK's zlib compression header (UInt64: block count, block size, size of a
/// partial last block or 0, the compressed size of each block) and the blocks, each one zlib
/// stream.
fn compress_into(data: &[u8], out: &mut Vec<u8>) {
    let blocks: Vec<Vec<u8>> = data
        .chunks(BLOCK_SIZE)
        .map(|chunk| {
            let mut z = flate2::write::ZlibEncoder::new(
                Vec::with_capacity(chunk.len() / 2 + 64),
                flate2::Compression::new(LEVEL),
            );
            z.write_all(chunk)
                .and_then(|()| z.finish())
                .expect("zlib into memory does not fail")
        })
        .collect();
    let header = [
        blocks.len() as u64,
        BLOCK_SIZE as u64,
        (data.len() % BLOCK_SIZE) as u64,
    ];
    for h in header
        .iter()
        .copied()
        .chain(blocks.iter().map(|b| b.len() as u64))
    {
        out.extend_from_slice(&h.to_le_bytes());
    }
    for b in &blocks {
        out.extend_from_slice(b);
    }
}

/// The model index a field element's probe names: the DOF of a displacement, the triangle of
/// a stress or state.
fn index(probe: &ProbeModel) -> i64 {
    match probe {
        ProbeModel::Displacement { dof } => *dof as i64,
        ProbeModel::MaxPrincipalStress(e) | ProbeModel::MinPrincipalStress(e) => e[0] as i64,
        ProbeModel::ElementState(e) => *e as i64,
        other => unreachable!("not an element of a field output: {other:?}"),
    }
}

/// The `.pvd` collection of `(time, file name)` rows.
pub fn collection(rows: &[(f64, String)]) -> String {
    let mut pvd = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for (time, file) in rows {
        let _ = writeln!(
            pvd,
            "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{file}\"/>",
            xs_double(*time)
        );
    }
    pvd.push_str("  </Collection>\n</VTKFile>\n");
    pvd
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read as _;

    /// The header and blocks decoded by hand (the layout vtkZLibDataCompressor reads): sizes,
    /// then each block inflated by flate2's decoder, give back the input.
    #[test]
    fn compressed_arrays_carry_vtks_block_header() {
        for n in [0usize, 1, BLOCK_SIZE, BLOCK_SIZE + 3, 3 * BLOCK_SIZE] {
            let data: Vec<u8> = (0..n).map(|k| (k * 7 % 251) as u8).collect();
            let mut out = Vec::new();
            compress_into(&data, &mut out);
            let word = |k: usize| u64::from_le_bytes(out[8 * k..8 * k + 8].try_into().unwrap());
            let blocks = word(0) as usize;
            assert_eq!(blocks, n.div_ceil(BLOCK_SIZE), "{n}");
            assert_eq!(word(1), BLOCK_SIZE as u64);
            assert_eq!(word(2), (n % BLOCK_SIZE) as u64);
            let mut at = 8 * (3 + blocks);
            let mut back = Vec::new();
            for b in 0..blocks {
                let size = word(3 + b) as usize;
                flate2::read::ZlibDecoder::new(&out[at..at + size])
                    .read_to_end(&mut back)
                    .unwrap();
                at += size;
            }
            assert_eq!(at, out.len());
            assert_eq!(back, data, "{n}");
        }
    }

    /// Every `DataArray` of a document as (name, values as f64): the binary one decoded from
    /// its offsets and blocks, the ASCII one parsed from its text.
    fn arrays(doc: &[u8]) -> Vec<(String, Vec<f64>)> {
        let start = doc
            .windows(5)
            .position(|w| w == b"\n   _")
            .map_or(doc.len(), |p| p + 5);
        let xml = String::from_utf8_lossy(&doc[..start]).into_owned();
        let appended = &doc[start.min(doc.len())..];
        let attr = |tag: &str, key: &str| -> Option<String> {
            let k = tag.find(&format!(" {key}=\""))? + key.len() + 3;
            Some(tag[k..k + tag[k..].find('"')?].to_string())
        };
        let mut out = Vec::new();
        for piece in xml.split("<DataArray").skip(1) {
            let tag = &piece[..piece.find('>').unwrap()];
            let name = attr(tag, "Name").unwrap();
            let ty = attr(tag, "type").unwrap();
            let values: Vec<f64> = match attr(tag, "offset") {
                Some(offset) => {
                    let at: usize = offset.parse().unwrap();
                    let word = |k: usize| {
                        u64::from_le_bytes(appended[at + 8 * k..at + 8 * k + 8].try_into().unwrap())
                            as usize
                    };
                    let mut next = at + 8 * (3 + word(0));
                    let mut bytes = Vec::new();
                    for b in 0..word(0) {
                        flate2::read::ZlibDecoder::new(&appended[next..next + word(3 + b)])
                            .read_to_end(&mut bytes)
                            .unwrap();
                        next += word(3 + b);
                    }
                    let size = match ty.as_str() {
                        "Float64" | "Int64" => 8,
                        "Int32" => 4,
                        _ => 1,
                    };
                    bytes
                        .chunks(size)
                        .map(|c| match ty.as_str() {
                            "Float64" => f64::from_le_bytes(c.try_into().unwrap()),
                            "Int64" => i64::from_le_bytes(c.try_into().unwrap()) as f64,
                            "Int32" => i32::from_le_bytes(c.try_into().unwrap()) as f64,
                            _ => c[0] as f64,
                        })
                        .collect()
                }
                None => piece[piece.find('>').unwrap() + 1..piece.find("</DataArray>").unwrap()]
                    .split_whitespace()
                    .map(|s| s.parse().unwrap())
                    .collect(),
            };
            out.push((name, values));
        }
        out
    }

    /// The two encodings carry the same values, bit for bit: NaN, infinities, -0, the
    /// extremes of f64, negative integers, UInt8.
    #[test]
    fn binary_and_ascii_carry_the_same_values() {
        let floats = vec![
            0.1,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            f64::MAX,
            1e-300 / 3.0,
            -2.5e7,
        ];
        let grid = Grid {
            points: (0..9).map(|k| k as f64 / 7.0).collect(),
            connectivity: vec![0, 1, 2, 1, 2],
            offsets: vec![3, 5],
            types: vec![5, 3],
            field_data: vec![DataArray::new(
                "a:b",
                1,
                Values::Int64(vec![-1, i64::MAX, 0]),
            )],
            point_data: vec![DataArray::new(
                "displacement_m",
                3,
                Values::Float64(floats.clone()),
            )],
            cell_data: vec![
                DataArray::new("kind", 1, Values::Int32(vec![0, -1])),
                DataArray::new("u8", 1, Values::UInt8(vec![0, 255])),
            ],
        };
        let (binary, ascii) = (arrays(&grid.binary()), arrays(grid.ascii().as_bytes()));
        assert_eq!(binary.len(), 8);
        let names: Vec<&str> = binary.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "a:b",
                "Points",
                "connectivity",
                "offsets",
                "types",
                "displacement_m",
                "kind",
                "u8"
            ]
        );
        for ((n1, v1), (n2, v2)) in binary.iter().zip(&ascii) {
            assert_eq!(n1, n2);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(v1), bits(v2), "{n1}");
        }
        let displacement = &binary[5].1;
        assert_eq!(
            displacement.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            floats.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(binary[7].1, [0.0, 255.0]);
    }
}
