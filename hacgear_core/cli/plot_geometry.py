"""``hacgear plot-geometry MODEL --out FILE.png [--mesh NAME] [--exaggerate K]``: the teeth of one mesh in contact
at its pitch point with the line of action, and the exaggerated tip relief and crowning
(:func:`hacgear_core.plots.geometry.plot_mesh_geometry`)."""
from __future__ import annotations

import argparse
import math
from typing import Any

from hacgear_core.cli._commands import command_help
from hacgear_core.errors import ModelError
from hacgear_core.kinds import load_model
from hacgear_core.outpaths import check_out_path
from hacgear_core.plots.geometry import plot_mesh_geometry

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "plot-geometry", help=command_help("plot-geometry"),
        description="Plot the teeth of one mesh of MODEL at a mesh position with the line of action, base and tip "
                    "circles and SAP/EAP marks, plus the tip relief / crowning exaggerated.")
    p.add_argument("model", help="model file, folder or system name")
    p.add_argument("--out", required=True, help="output image (.png, .pdf or .svg; its folder must exist)")
    p.add_argument("--mesh", default=None, help="mesh name (default: the first mesh)")
    p.add_argument("--exaggerate", type=float, default=None,
                   help="factor K multiplying the deviation from the true involute (default: the largest "
                        "modification is drawn as 0.3 module)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.exaggerate is not None and not (args.exaggerate > 0 and math.isfinite(args.exaggerate)):
        raise ModelError(f"--exaggerate = {args.exaggerate} must be a positive finite factor")
    check_out_path(args.out, "--out", suffixes=(".png", ".pdf", ".svg"))
    model = load_model(args.model)
    out = plot_mesh_geometry(model, args.mesh, args.out, args.exaggerate)
    print(f"wrote {out}")
    return 0
