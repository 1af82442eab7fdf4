"""The harness's name for the package's ParaView series writer (python/velarium/paraview.py):
a series from an FMU's array outputs without solving again (docs/scenes.md, "A series from an
FMU's outputs").

    .venv/bin/python harness/fmu_vtk.py FMU.fmu RESULT.csv OUT_DIR   # a CSV fmpy wrote
"""

from velarium.paraview import (  # noqa: F401
    Vtu,
    main,
    mesh_of,
    read_vtu,
    write_series,
    write_vtu,
)

if __name__ == "__main__":
    main()
