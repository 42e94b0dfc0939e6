"""Shared check of the drivetrain-bench tests (tests/test_fmu*.py): the final hold of a bench run."""
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
