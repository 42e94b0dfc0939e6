"""Studies on top of the HAC model: the direct dynamic contact models it is checked against and where its
quasi-static body assumption holds.

:mod:`.direct` (level 1: the static contact solved at every RK4 stage), :mod:`.direct_elastic` (level 2: elastic
gear bodies in motion), :mod:`.direct_compare` (HAC against level 1 at one speed), :mod:`.validity` (level-2 runs
of the validity map).  Nothing in the pipeline (model -> statics -> tables -> dynamics -> FMU) imports them.
"""
from __future__ import annotations

__all__ = ["direct", "direct_compare", "direct_elastic", "validity"]
