"""``python -m labsim``: the same command line as the ``labsim`` script."""
from labsim.runtime.cli import main

raise SystemExit(main())
