"""``python -m petswarm`` = the ``petswarm`` command."""

from petswarm.cli.main import main

raise SystemExit(main())
