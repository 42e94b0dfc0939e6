"""Studies over many model variants: design studies (:mod:`.design`) from study files (:mod:`.study_file`)."""
from __future__ import annotations

from hacgear_core.studies.design import (DYNAMIC_METRICS, STATIC_METRICS, StudyReport, StudyResults, VariantOutcome,
                                         best_variants, read_study, run_study, variant_model_text)
from hacgear_core.studies.study_file import MODEL_KEY, StudySpec, Variable, apply_key, load_study, parse_study

__all__ = ["DYNAMIC_METRICS", "STATIC_METRICS", "StudyReport", "StudyResults", "VariantOutcome", "best_variants",
           "read_study", "run_study", "variant_model_text", "MODEL_KEY", "StudySpec", "Variable", "apply_key",
           "load_study", "parse_study"]
