"""Studies on top of the HAC model: design studies over model variants, the direct dynamic contact models HAC is
checked against, and where its quasi-static body assumption holds.

:mod:`.design` (design studies from study files, :mod:`.study_file`), :mod:`.direct` (level 1: the static contact
solved at every RK4 stage), :mod:`.direct_elastic` (level 2: elastic gear bodies in motion), :mod:`.direct_compare`
(HAC against level 1 at one speed), :mod:`.validity` (level-2 runs of the validity map).  Nothing in the pipeline
(model -> statics -> tables -> dynamics -> FMU) imports them.
"""
from __future__ import annotations

from hacgear_core.studies.design import (DYNAMIC_METRICS, STATIC_METRICS, StudyReport, StudyResults, VariantOutcome,
                                         best_variants, read_study, run_study, variant_model_text)
from hacgear_core.studies.study_file import MODEL_KEY, StudySpec, Variable, apply_key, load_study, parse_study

__all__ = ["DYNAMIC_METRICS", "STATIC_METRICS", "StudyReport", "StudyResults", "VariantOutcome", "best_variants",
           "read_study", "run_study", "variant_model_text", "MODEL_KEY", "StudySpec", "Variable", "apply_key",
           "load_study", "parse_study", "design", "study_file", "direct", "direct_compare", "direct_elastic",
           "validity"]
