"""``python -m neuraltex.cli``."""

from neuraltex.cli import main

raise SystemExit(main())
