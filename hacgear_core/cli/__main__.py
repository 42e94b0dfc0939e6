"""``python -m hacgear_core.cli``: the ``hacgear`` command."""
from hacgear_core.cli import main

raise SystemExit(main())
