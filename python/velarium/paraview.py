"""A ParaView series from an FMU's array outputs, without solving again.

Every FMU that ``velarium pack`` writes carries ``resources/mesh.vtu``: the reference mesh
(points at their reference positions, membrane triangles then cable segments, cell data
``kind``, ``id``, ``cable``) and, as field data ``<kind>:<output>``, where the rows of each
array output go on it: the point of every row of a ``displacement_field`` output, the cell of
every row of a ``principal_stresses``, ``wrinkle_states`` or ``cable_tensions`` output
(docs/scenes.md, "A series from an FMU's outputs"). :func:`write_series` turns the rows a
master recorded (``fmpy.simulate_fmu``'s result, FMI 2 scalars ``u[i,j]`` or FMI 3 arrays)
into one ``.vtu`` per row and a ``.pvd``, the same arrays under the same names as
``velarium solve --vtk`` writes:

    displacement_m (points)          from the displacement_field outputs (required: every
                                     point must be covered)
    wrinkle_state (cells)            from wrinkle_states outputs; -1 where none gives a value
    sigma_max_Pa, sigma_min_Pa       from principal_stresses outputs; NaN where none does
    cable_tension_N (cells)          from cable_tensions outputs; NaN where none does
    TimeValue (field data)           the row's time

A field no output feeds is left out. ``tension_direction``, ``cable_slip_m`` and ``slip_m``
are not outputs of any probe, so only ``velarium solve --vtk`` writes them. A scene with
sleeves cannot be drawn from an FMU: a sleeve's cable points are points of the mesh that no
``displacement_field`` covers (its ``nodes`` are mesh nodes).

Only numpy and the standard library: the files are written and read here (zlib-compressed
binary appended data with VTK's UInt64 block header, ``compressor="vtkZLibDataCompressor"``),
so neither VTK nor fmpy is needed to make a series.

    python -m velarium.paraview FMU.fmu RESULT.csv OUT_DIR   # a CSV fmpy wrote
"""

from __future__ import annotations

import os
import re
import struct
import sys
import xml.etree.ElementTree as ET
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Vtu", "read_vtu", "write_vtu", "mesh_of", "write_series", "MESH_RESOURCE"]

#: The reference mesh's member inside an FMU archive.
MESH_RESOURCE = "resources/mesh.vtu"

_TYPES = {"Float64": np.float64, "Int64": np.int64, "Int32": np.int32, "UInt8": np.uint8,
          "Float32": np.float32, "UInt64": np.uint64, "UInt32": np.uint32, "Int8": np.int8}
_NAMES = {np.dtype(v): k for k, v in _TYPES.items()}
_BLOCK = 32768


@dataclass
class Vtu:
    """An unstructured grid in memory. Data arrays have shape (n,) or (n, components)."""

    points: np.ndarray
    connectivity: np.ndarray
    offsets: np.ndarray
    types: np.ndarray
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    cell_data: dict[str, np.ndarray] = field(default_factory=dict)
    field_data: dict[str, np.ndarray] = field(default_factory=dict)


def _inflate(data: bytes, at: int, header: np.dtype) -> tuple[bytes, int]:
    """One compressed array at ``at``: (its bytes, the offset after it)."""
    size = header.itemsize
    blocks = int(np.frombuffer(data, header, 1, at)[0])
    sizes = np.frombuffer(data, header, 3 + blocks, at)[3:]
    at += size * (3 + blocks)
    out = []
    for s in sizes:
        out.append(zlib.decompress(data[at:at + int(s)]))
        at += int(s)
    return b"".join(out), at


def read_vtu(source: Path | bytes) -> Vtu:
    """Read a ``.vtu`` with raw appended data, zlib-compressed or not (what
    ``velarium solve --vtk``, ``resources/mesh.vtu`` and :func:`write_vtu` hold)."""
    raw = source if isinstance(source, bytes) else Path(source).read_bytes()
    start = raw.find(b"<AppendedData")
    if start < 0:
        raise ValueError("not a .vtu with appended data (no <AppendedData>)")
    underscore = raw.index(b"_", raw.index(b">", start)) + 1
    root = ET.fromstring(raw[:start] + b"</VTKFile>")
    header = np.dtype(_TYPES[root.get("header_type", "UInt32")]).newbyteorder("<")
    if root.get("byte_order", "LittleEndian") != "LittleEndian":
        raise ValueError("byte_order: only LittleEndian files are read")
    compressor = root.get("compressor")
    if compressor not in (None, "vtkZLibDataCompressor"):
        raise ValueError(f"compressor: {compressor} is not read (only vtkZLibDataCompressor)")
    data = raw[underscore:]

    def values(da: ET.Element) -> np.ndarray:
        at = int(da.get("offset"))
        if compressor:
            body, _ = _inflate(data, at, header)
        else:
            n = int(np.frombuffer(data, header, 1, at)[0])
            body = data[at + header.itemsize:at + header.itemsize + n]
        v = np.frombuffer(body, np.dtype(_TYPES[da.get("type")]).newbyteorder("<")).astype(_TYPES[da.get("type")])
        c = int(da.get("NumberOfComponents", "1"))
        return v.reshape(-1, c) if c > 1 else v

    grid = root.find("UnstructuredGrid")
    piece = grid.find("Piece")
    cells = {da.get("Name"): values(da) for da in piece.find("Cells")}
    section = lambda e: {} if e is None else {da.get("Name"): values(da) for da in e}  # noqa: E731
    return Vtu(
        points=values(piece.find("Points")[0]),
        connectivity=cells["connectivity"], offsets=cells["offsets"], types=cells["types"],
        point_data=section(piece.find("PointData")), cell_data=section(piece.find("CellData")),
        field_data=section(grid.find("FieldData")),
    )


def _deflated(array: np.ndarray) -> bytes:
    """VTK's compression header (UInt64) and the zlib blocks of one array."""
    body = np.ascontiguousarray(array).astype(array.dtype.newbyteorder("<")).tobytes()
    blocks = [zlib.compress(body[k:k + _BLOCK], 6) for k in range(0, len(body), _BLOCK)]
    head = [len(blocks), _BLOCK, len(body) % _BLOCK] + [len(b) for b in blocks]
    return struct.pack(f"<{len(head)}Q", *head) + b"".join(blocks)


def write_vtu(path: Path, grid: Vtu) -> None:
    """Write ``grid`` as a ``.vtu`` (binary appended, zlib), whole or not at all: written to a
    temporary file beside ``path`` and renamed over it."""
    appended = bytearray()
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
             'header_type="UInt64" compressor="vtkZLibDataCompressor">', "  <UnstructuredGrid>"]

    def array(name: str, a: np.ndarray, indent: str, tuples: bool = False) -> None:
        a = np.asarray(a)
        c = 1 if a.ndim == 1 else a.shape[1]
        extra = f' NumberOfTuples="{len(a)}"' if tuples else ""
        lines.append(f'{indent}<DataArray type="{_NAMES[a.dtype]}" Name="{name}" NumberOfComponents="{c}"'
                     f'{extra} format="appended" offset="{len(appended)}"/>')
        appended.extend(_deflated(a))

    if grid.field_data:
        lines.append("    <FieldData>")
        for name, a in grid.field_data.items():
            array(name, a, "      ", tuples=True)
        lines.append("    </FieldData>")
    lines.append(f'    <Piece NumberOfPoints="{len(grid.points)}" NumberOfCells="{len(grid.types)}">')
    lines.append("      <Points>")
    array("Points", grid.points, "        ")
    lines += ["      </Points>", "      <Cells>"]
    for name in ("connectivity", "offsets", "types"):
        array(name, getattr(grid, name), "        ")
    lines.append("      </Cells>")
    vectors = ' Vectors="displacement_m"' if "displacement_m" in grid.point_data else ""
    lines.append(f"      <PointData{vectors}>")
    for name, a in grid.point_data.items():
        array(name, a, "        ")
    scalars = ' Scalars="wrinkle_state"' if "wrinkle_state" in grid.cell_data else ""
    lines += ["      </PointData>", f"      <CellData{scalars}>"]
    for name, a in grid.cell_data.items():
        array(name, a, "        ")
    lines += ["      </CellData>", "    </Piece>", "  </UnstructuredGrid>", '  <AppendedData encoding="raw">', "   _"]
    data = "\n".join(lines).encode() + bytes(appended) + b"\n  </AppendedData>\n</VTKFile>\n"
    _write_whole(Path(path), data)


def _write_whole(path: Path, data: bytes) -> None:
    temp = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        with open(temp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(temp, path)
    finally:
        if temp.exists():
            temp.unlink()


def mesh_of(fmu: Path) -> Vtu:
    """The reference mesh an FMU carries (``resources/mesh.vtu``)."""
    with zipfile.ZipFile(fmu) as z:
        try:
            return read_vtu(z.read(MESH_RESOURCE))
        except KeyError:
            raise ValueError(f"{fmu}: no {MESH_RESOURCE} in the archive (packed by a velarium "
                             "older than the mesh resource? pack the scene again)") from None


def _rows(result: np.ndarray, name: str, count: int, columns: int) -> np.ndarray:
    """Output ``name`` of every recorded row as (rows, count[, columns]) from an FMI 3 array
    field or the FMI 2 scalars ``name[i]`` / ``name[i,j]``."""
    names = result.dtype.names or ()
    shape = (len(result), count) + ((columns,) if columns > 1 else ())
    if name in names:
        return np.asarray(result[name]).reshape(shape)
    if columns > 1:
        keys = [f"{name}[{i + 1},{j + 1}]" for i in range(count) for j in range(columns)]
    else:
        keys = [f"{name}[{i + 1}]" for i in range(count)]
    missing = [k for k in keys if k not in names]
    if missing:
        raise ValueError(f"result: output {name!r} is not in the recorded rows (no field {name!r}, "
                         f"and {len(missing)} of its {len(keys)} scalars such as {missing[0]!r} are missing); "
                         "record every output (fmpy.simulate_fmu's default) or name it in output=")
    return np.stack([np.asarray(result[k]) for k in keys], axis=1).reshape(shape)


def write_series(fmu: Path, result: np.ndarray, directory: Path, name: str | None = None) -> Path:
    """Write the rows a master recorded from ``fmu`` as a ParaView series and return the
    ``.pvd``.

    ``result`` is a structured array with a ``time`` field and the FMU's array outputs, as
    ``fmpy.simulate_fmu`` returns it (FMI 3 arrays as fields with a shape, FMI 2 as scalars
    ``u[i,j]``). Row k becomes ``<name>_<k:04d>.vtu`` at ``result["time"][k]`` (fmpy records
    after each step: the row at t_{k+1} is the equilibrium under the inputs of t_k, the
    one-step lag of docs/fmu.md). ``name`` defaults to the archive's stem. Raises ValueError
    naming what is missing when the outputs do not place every point (no
    ``displacement_field`` output, or one of a subset of the nodes).
    """
    fmu, directory = Path(fmu), Path(directory)
    mesh = mesh_of(fmu)
    name = name or fmu.stem
    if result.dtype.names is None or "time" not in result.dtype.names:
        raise ValueError("result: a structured array with a 'time' field is needed (fmpy.simulate_fmu's result)")
    n_points, n_cells, n = len(mesh.points), len(mesh.types), len(result)
    maps: dict[str, list[tuple[str, np.ndarray]]] = {}
    for key, rows in mesh.field_data.items():
        kind, _, output = key.partition(":")
        maps.setdefault(kind, []).append((output, rows.astype(np.int64)))

    displacement = np.full((n, n_points, 3), np.nan)
    covered = np.zeros(n_points, bool)
    for output, rows in maps.get("displacement_field", []):
        displacement[:, rows] = _rows(result, output, len(rows), 3)
        covered[rows] = True
    if not covered.all():
        raise ValueError(
            f"{fmu.name}: the outputs place {int(covered.sum())} of the mesh's {n_points} points; a series needs a "
            "displacement_field output of every node (\"probe\": {\"kind\": \"displacement_field\"}, no \"nodes\")"
            + (" and a scene without sleeves (a sleeve's cable points are not mesh nodes)" if covered.sum() else ""))

    cell_fields: dict[str, np.ndarray] = {}
    if "wrinkle_states" in maps:
        cell_fields["wrinkle_state"] = np.full((n, n_cells), -1, np.int32)
        for output, rows in maps["wrinkle_states"]:
            cell_fields["wrinkle_state"][:, rows] = _rows(result, output, len(rows), 1)
    if "principal_stresses" in maps:
        stress = np.full((n, n_cells, 2), np.nan)
        for output, rows in maps["principal_stresses"]:
            stress[:, rows] = _rows(result, output, len(rows), 2)
        cell_fields["sigma_max_Pa"], cell_fields["sigma_min_Pa"] = stress[..., 0], stress[..., 1]
    if "cable_tensions" in maps:
        cell_fields["cable_tension_N"] = np.full((n, n_cells), np.nan)
        for output, rows in maps["cable_tensions"]:
            cell_fields["cable_tension_N"][:, rows] = _rows(result, output, len(rows), 1)

    directory.mkdir(parents=True, exist_ok=True)
    entries = []
    for k in range(n):
        time = float(result["time"][k])
        grid = Vtu(
            points=mesh.points, connectivity=mesh.connectivity, offsets=mesh.offsets, types=mesh.types,
            point_data={"displacement_m": displacement[k]},
            cell_data={**{key: mesh.cell_data[key] for key in ("kind", "id", "cable")},
                       **{key: v[k] for key, v in cell_fields.items()}},
            field_data={"TimeValue": np.array([time])},
        )
        file = f"{name}_{k:04d}.vtu"
        write_vtu(directory / file, grid)
        entries.append(f'    <DataSet timestep="{time!r}" group="" part="0" file="{file}"/>')
    pvd = directory / f"{name}.pvd"
    _write_whole(pvd, ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                       "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n").encode())
    return pvd


def _read_result_csv(path: Path) -> np.ndarray:
    """A result CSV with a header row (fmpy's ``write_csv``, or ``velarium solve --out``)."""
    with open(path) as f:
        header = next(f).strip()
    names = [re.sub(r'^"|"$', "", c) for c in re.findall(r'"[^"]*"|[^,]+', header)]
    data = np.atleast_2d(np.loadtxt(path, delimiter=",", skiprows=1))
    return np.rec.fromarrays(data.T, dtype=[(c, np.float64) for c in names])


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 3:
        sys.exit(__doc__.rsplit("\n\n", 1)[-1].strip())
    print(write_series(Path(args[0]), _read_result_csv(Path(args[1])), Path(args[2])))


if __name__ == "__main__":
    main()
