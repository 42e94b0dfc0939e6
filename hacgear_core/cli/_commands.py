"""The subcommands of ``hacgear``: name, module and one-line help, importable without the library."""
from __future__ import annotations

__all__ = ["COMMANDS", "command_help"]

#: subcommand -> (module of hacgear_core.cli that registers it, one-line help shown by ``hacgear --help``)
COMMANDS: dict[str, tuple[str, str]] = {
    "campbell": ("campbell", "Campbell diagram: natural frequencies and mesh/shaft order lines over speed, crossings"),
    "demo": ("demo", "run the whole pipeline on the default model and write its outputs"),
    "fmu": ("fmu", "build FMI 2.0 / 3.0 co-simulation FMUs of gear systems (-> dist/<system>.fmu)"),
    "info": ("info", "derived geometry: centre distance, base radii, contact ratios, roll angles, masses"),
    "list": ("list_systems", "the shipped gear systems: kind, gears, meshes, whether tables are committed"),
    "modes": ("modes", "natural frequencies and mode shapes at a torque (modal analysis + impulse test)"),
    "plot": ("plot", "plot a tables.h5 (FDF, strain), a sweep or a study results file"),
    "plot-geometry": ("plot_geometry", "plot teeth in mesh, line of action and the (exaggerated) modifications"),
    "simulate": ("simulate", "time simulation at a mesh frequency (or a run-up) with post-processed outputs"),
    "spectrum": ("spectrum", "order spectrum of a steady-state response: mesh harmonics, sidebands, shaft orders"),
    "statics": ("statics", "static contact analyses on the mesh grids → tables.h5 (FDF, strains, pressures)"),
    "stiffness": ("stiffness", "static transmission error and mesh stiffness over a mesh cycle"),
    "study": ("study", "design study: model variants -> tables -> Harris map and dynamic map (one HDF5 file)"),
    "sweep": ("sweep", "steady-state speed sweep (up/down/both) with jump detection"),
}


def command_help(name: str) -> str:
    """One-line help of subcommand ``name``."""
    return COMMANDS[name][1]
