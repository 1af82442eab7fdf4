//! ParaView output: one VTK XML unstructured grid (`.vtu`) per load row and a `.pvd`
//! collection that orders them in time (`velarium solve --vtk DIR`). What a row holds and how
//! it is encoded (reference points, `displacement_m`, zlib-compressed binary) is `vtu.rs`'s.
//!
//! Every file is written through a temporary file and renamed into place: a reader never sees
//! a half-written file, and a failed write leaves none behind.

use crate::engine::Engine;
use crate::error::Error;
use crate::pack::write_atomically;
use crate::vtu::{collection, Grid};
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
        let bytes = Grid::state(engine, Some(time)).binary();
        write_atomically(&self.dir.join(&name), &bytes)?;
        self.written.push((time, name));
        Ok(())
    }

    /// Write mode `k` (1-based) of the engine's committed equilibrium as the next row of the
    /// series, at time `k`: the state's arrays plus the point data `mode_shape` (3: the mode,
    /// scaled to a largest nodal amplitude of 1, dimensionless; Warp By Vector with a scale
    /// in m draws it) and the field data `frequency_Hz`.
    pub fn write_mode(
        &mut self,
        engine: &Engine,
        k: usize,
        frequency: f64,
        shape: &[f64],
    ) -> Result<(), Error> {
        use crate::vtu::{DataArray, Values};
        let nodes = engine.model().reference.len();
        let shape = &shape[..3 * nodes];
        let largest = shape
            .chunks(3)
            .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
            .fold(0.0f64, f64::max);
        let scale = if largest > 0.0 { 1.0 / largest } else { 1.0 };
        let mut grid = Grid::state(engine, Some(k as f64));
        grid.point_data.push(DataArray::new(
            "mode_shape",
            3,
            Values::Float64(shape.iter().map(|v| v * scale).collect()),
        ));
        grid.field_data.push(DataArray::new(
            "frequency_Hz",
            1,
            Values::Float64(vec![frequency]),
        ));
        let name = format!("{}_{:04}.vtu", self.stem, self.written.len());
        write_atomically(&self.dir.join(&name), &grid.binary())?;
        self.written.push((k as f64, name));
        Ok(())
    }

    /// Write `<stem>.pvd` listing every row written so far; returns its path.
    pub fn finish(&self) -> Result<PathBuf, Error> {
        let path = self.dir.join(format!("{}.pvd", self.stem));
        write_atomically(&path, collection(&self.written).as_bytes())?;
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

/// The committed state of `engine` as an ASCII VTK XML document: the same arrays as a row of
/// the series, every number in shortest round-trip form (for reading by eye and for tests
/// that compare documents).
pub fn unstructured_grid(engine: &Engine) -> String {
    Grid::state(engine, None).ascii()
}
