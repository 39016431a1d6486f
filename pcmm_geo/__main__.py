"""``python -m pcmm_geo ARGS`` runs the ``pcmm`` command (the same as the installed ``pcmm`` script)."""

from __future__ import annotations

from pcmm_geo.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
