"""An FMU of a shipped system and the library's Simulator run side by side at constant speed (the comparisons of
the reducer tests), and an FMU's in-process adapter beside the library's Simulator."""
from __future__ import annotations

import numpy as np


def fmu_and_library_runs(system: str, out_dir, names, read, speed_rad_s: float, n: int, dt: float = 1e-4,
                         port: str = "pinion1"):
    """``(path, fmu_result, library)``: the native FMI 2.0 FMU of ``system`` built into ``out_dir`` and run by fmpy
    for ``n`` communication steps of ``dt`` [s] with its input gear ``port`` at ``speed_rad_s`` [rad/s] (internal step
    2e-6 s), and the library's Simulator over the same steps; ``read(sim)`` gives the library's values of ``names``
    after each step (library: name -> (n,) array)."""
    import fmpy

    from hacgear_core.dynamics.simulator import Simulator
    from hacgear_core.fmu import build_fmu
    from hacgear_core.kinds import build_system, load_model
    from hacgear_core.model import resolve_model_path
    from hacgear_core.tables import load_system_tables

    path = resolve_model_path(system)
    fmu = build_fmu(path.parent, out_dir)
    res = fmpy.simulate_fmu(str(fmu), stop_time=n * dt, output_interval=dt, output=list(names),
                            start_values={f"{port}.speed_in": speed_rad_s, "internal_step": 2e-6})
    sim = Simulator(build_system(load_model(path), load_system_tables(path)), internal_step_s=2e-6)
    sim.reset(speed_rad_s=speed_rad_s)
    lib = {k: [] for k in names}
    for _ in range(n):
        assert sim.advance(dt).success
        for k, v in zip(names, read(sim)):
            lib[k].append(v)
    return fmu, res, {k: np.asarray(v) for k, v in lib.items()}


def adapter_and_library_forces(adapter, system, steps: int = 40, dt: float = 2e-5):
    """``(ours, library)`` (steps, m) [N]: the mesh forces of an FMU's adapter (in process, already configured) and
    of the library's Simulator of ``system`` over ``steps`` communication steps of ``dt`` [s], both at the adapter's
    start speed of its reference gear (constant-speed experiment)."""
    from hacgear_core.dynamics.simulator import Simulator

    sim = Simulator(system)
    w = float(adapter.by_name[f"{adapter.ref_ident}.speed_in"].start)
    sim.reset(speed_rad_s=w)
    sim.set_speed_input(speed_rad_s=w)
    ours, lib = [], []
    for _ in range(steps):
        assert adapter.advance(dt) == ""
        assert sim.advance(dt).success
        ours.append(np.array(adapter.sim.mesh_force_N, float))
        lib.append(np.array(sim.mesh_force_N, float))
    return np.array(ours), np.array(lib)
