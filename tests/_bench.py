"""Shared checks of the FMU tests (tests/test_fmu*.py): the final hold of a drivetrain-bench run, a constant-speed
run with the torque reversed."""
from __future__ import annotations

import math

import numpy as np
import pytest


def assert_final_hold(res: dict, cfg, ratio: float, window_s: float, rel_speed: float) -> np.ndarray:
    """Over the last ``window_s`` [s] of ``run_drivetrain_bench``'s result ``res`` (run with ``cfg``): the input
    gear turns at the motor's end speed and the output gear at ``ratio`` times it (within ``rel_speed``), and the
    output shaft carries the load torque (within 5 %).  Returns the window's sample mask."""
    t = res["time_s"]
    end = t > t[-1] - window_s
    w_end = cfg.speed_end_rpm * 2 * math.pi / 60
    assert np.mean(res["input_speed_rad_s"][end]) == pytest.approx(w_end, rel=rel_speed)
    assert np.mean(res["output_speed_rad_s"][end]) == pytest.approx(w_end * ratio, rel=rel_speed)
    assert np.mean(res["shaft2_torque_Nm"][end]) == pytest.approx(-cfg.load_torque_Nm, rel=0.05)
    return end


def assert_reversed_torque_run(fmpy, path, system, speed_rad_s: float = 300.0, planet_count: int | None = None) -> None:
    """Constant-speed experiment (mode 0) of the FMU at ``path`` with its parameter ``torque`` = minus the model's
    torque, 10 ms at ``speed_rad_s`` of the reference gear: every active mesh is on its coast flanks at every output
    (``contact`` = 2, ``force`` = 0, ``coast_force`` > 0), its deflection within [-(backlash + coast table range),
    0), no ``out_of_range``, and its mean coast force is the library's static coast force of the torque flow within
    3 % (the planets' instantaneous load sharing: 2.4 %)."""
    from hacgear_core.kinds import build_system
    from hacgear_core.kinds import load_model
    from hacgear_core.tables import load_system_tables

    model = load_model(system)
    torque = -model.operating.torque_Nm
    sy = build_system(model, load_system_tables(system), torque_Nm=torque,
                      **({} if planet_count is None else {"planet_count": planet_count}))
    names = sy.mesh_names
    out = [f"{m}.{q}" for m in names for q in ("force", "coast_force", "deflection", "contact", "out_of_range")]
    start = {"mode": 0, "torque": torque, f"{sy.reference_gear}.speed_in": speed_rad_s}
    if planet_count is not None:
        start["planet_count"] = planet_count
    res = fmpy.simulate_fmu(str(path), stop_time=0.01, output_interval=1e-4, start_values=start, output=out)
    nominal = sy.nominal_coast_forces_N()
    for k, c in enumerate(sy.meshes):
        m = c.name
        assert np.all(res[f"{m}.contact"] == 2) and np.all(res[f"{m}.force"] == 0.0), m
        assert np.all(res[f"{m}.coast_force"] > 0.0) and not np.any(res[f"{m}.out_of_range"]), m
        x = res[f"{m}.deflection"]
        assert np.all(x < 0.0) and np.all(x >= -(c.backlash_m + np.ptp(c.coast_table.deflection_m))), m
        assert np.mean(res[f"{m}.coast_force"]) == pytest.approx(nominal[k], rel=0.03), m
