"""Force-deflection tables: :mod:`.interp` (the one interpolation over mesh position × deflection),
:mod:`.table` (in-memory :class:`MeshTable` / :class:`SystemTables`), :mod:`.format` (the ``tables.h5``
HDF5 format: schema, incremental writing, reading with provenance and checksum checks), :mod:`.check`
(physical sanity of a table)."""
from __future__ import annotations

from hacgear_core.tables.check import hard_problems, sanity_problems
from hacgear_core.tables.format import (
    ATTRS_DIGEST,
    DATASETS,
    FORMAT,
    FORMAT_VERSION,
    READABLE_VERSIONS,
    MeshLayout,
    completed_table_matches,
    layout_difference,
    consistency_summary,
    file_integrity,
    load_system_tables,
    open_statics_file,
    read_tables,
    seal_file,
    write_deflection_grid,
    write_position,
    write_tables,
)
from hacgear_core.tables.table import (InterpolationStats, MeshTable, StrainTable, SystemTables, TwistTable,
                                      with_constant_twist)

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "READABLE_VERSIONS",
    "DATASETS",
    "TwistTable",
    "with_constant_twist",
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
    "layout_difference",
    "write_deflection_grid",
    "consistency_summary",
    "seal_file",
    "file_integrity",
    "ATTRS_DIGEST",
    "hard_problems",
    "sanity_problems",
]
