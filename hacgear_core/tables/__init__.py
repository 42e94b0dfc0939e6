"""Force-deflection tables: :mod:`.interp` (the one interpolation over mesh position × deflection),
:mod:`.table` (in-memory :class:`MeshTable` / :class:`SystemTables`), :mod:`.format` (the ``tables.h5``
HDF5 format: schema, incremental writing, reading with provenance checks)."""
from __future__ import annotations

from hacgear_core.tables.format import (
    DATASETS,
    FORMAT,
    FORMAT_VERSION,
    TWIST_FORMAT_VERSION,
    MeshLayout,
    completed_table_matches,
    consistency_summary,
    load_system_tables,
    open_statics_file,
    read_tables,
    write_deflection_grid,
    write_position,
    write_tables,
)
from hacgear_core.tables.table import InterpolationStats, MeshTable, StrainTable, SystemTables, TwistTable

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "TWIST_FORMAT_VERSION",
    "DATASETS",
    "TwistTable",
    "InterpolationStats",
    "MeshTable",
    "StrainTable",
    "SystemTables",
    "MeshLayout",
    "read_tables",
    "write_tables",
    "load_system_tables",
    "open_statics_file",
    "write_position",
    "completed_table_matches",
    "write_deflection_grid",
    "consistency_summary",
]
