"""Parameter and load-history sweeps through an FMU on Dask: the harness's entry point over the
package's `velarium.sweep` (docs/python.md, docs/fmu.md "Sweeps"). Same as

    .venv/bin/python -m velarium.sweep SCENE.json|MODEL.fmu [--grid NAME=V1,V2,...] ...

`python harness/sweep.py --help` lists every option.
"""

from __future__ import annotations

from velarium.sweep import main

if __name__ == "__main__":
    main()
