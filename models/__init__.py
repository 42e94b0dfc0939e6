"""The shipped gear systems, one folder each (model.toml, readme.md, tables.h5 where generated); installed as the
package data ``hacgear_core.systems`` (:func:`hacgear_core.model.resolve_model_path` finds them by name)."""
