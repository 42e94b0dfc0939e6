"""``hacgear plot FILE --out PNG``: a picture of a tables file or of a sweep results file.

* ``tables.h5`` (from ``hacgear statics``): the force-deflection function over two mesh cycles with the
  single/double contact regions (dissertation Fig. 3.3) and, with ``--gauge``, the strain-deflection
  function of that gauge (Fig. 4.6), written to ``<out>`` and ``<out stem>_sdf.png``; a helical mesh table
  (twist axis) adds ``<out stem>_helical_{gfdf,twist,pattern,sdf}.png`` (Figs. 5.3, 5.4, 5.6);
* a sweep results file (from ``hacgear sweep --out``): RMS and mean of the mesh deflection over the mesh
  frequency, up and down branches, confirmed jumps marked (Figs. 3.5, 3.10);
* a study results file (from ``hacgear study``): the Harris map (static transmission error peak-to-peak over
  torque, one curve per variant) to ``<out>``, the dynamic map (force dynamic factor and peak root strain over mesh
  frequency x variant, jumps marked) to ``<out stem>_dynamic.png`` and the best variant per criterion over the
  study's load spectrum to ``<out stem>_best.png``.

Axes are labelled with their units (µm, kN, Hz, µε).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from hacgear_core.cli._commands import command_help
from hacgear_core.cli._help import plain_text
from hacgear_core.dynamics.sweep import missing_branches
from hacgear_core.errors import TableError
from hacgear_core.h5files import file_kind
from hacgear_core.outpaths import check_out_path, save_figure
from hacgear_core.plots.helical import write_helical_figures
from hacgear_core.plots.study import plot_study_file
from hacgear_core.plots.sweep import plot_sweep_file
from hacgear_core.plots.tables import plot_fdf, plot_sdf
from hacgear_core.tables import read_tables

__all__ = ["register", "run"]

_SUFFIXES = (".png", ".pdf", ".svg")


def register(subparsers: Any) -> None:
    p = subparsers.add_parser("plot", help=command_help("plot"),
                              description=plain_text(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", help="tables.h5, sweep results .h5 or study results .h5")
    p.add_argument("--out", required=True, help="image file to write (.png, .pdf or .svg; its folder must exist)")
    p.add_argument("--mesh", default=None, help="mesh of a tables file (default: the first)")
    p.add_argument("--gauge", default=None, help="gauge '<gear>/<gauge>' for the strain-deflection plot")
    p.add_argument("--run", default=None, help="run id of a sweep file holding several runs (default: all)")
    p.set_defaults(func=run)


def run(args) -> int:
    path = Path(args.file)
    if not path.exists():
        raise TableError(f"no such file: {path}")
    out = check_out_path(args.out, "--out", suffixes=_SUFFIXES)
    what = file_kind(path)
    if what == "other":
        raise TableError(f"{path} is not an HDF5 file")
    if what == "tables":
        tabs = read_tables(path)
        table = tabs.mesh(args.mesh)
        if args.gauge is not None and args.gauge not in table.strain:   # before any figure is written
            raise TableError(f"--gauge {args.gauge!r} not in {path}; gauges: {sorted(table.strain)}")
        fig = plot_fdf(table)
        save_figure(fig, out, dpi=110)
        print(f"FDF of mesh '{table.name}': {out}")
        if args.gauge is not None:
            sdf = out.with_name(out.stem + "_sdf.png")
            save_figure(plot_sdf(table, args.gauge), sdf, dpi=110)
            print(f"strain-deflection function of {args.gauge}: {sdf}")
        if table.twist is not None:
            for p in write_helical_figures(path, out.parent, table.name):
                target = out.with_name(f"{out.stem}_{p.name}")
                p.replace(target)
                print(f"helical mesh figure: {target}")
        return 0
    if what == "sweep":
        jumps = plot_sweep_file(path, out, args.run)
        print(f"sweep response: {out}")
        for rid, lost in missing_branches(path).items():
            if args.run in (None, rid):
                print(f"  WARNING: run {rid}: the {' and '.join(lost)} sweep is missing (interrupted; the same sweep "
                      "command completes it); the figure says so", file=sys.stderr)
        for j in jumps:
            print(f"  {j['kind']} of mesh {j['mesh']} at {j['frequency_Hz']:.0f} Hz ({j['branch']} sweep)")
        return 0
    if what == "study":
        for p in plot_study_file(path, out):
            print(f"study figure: {p}")
        return 0
    raise TableError(f"{path} is neither a hacgear tables file (attribute format='hacgear-tables'), a sweep "
                     "results file (group 'sweeps') nor a study results file (format='hacgear-study')")
