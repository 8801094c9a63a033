"""``python -m labsim``: the same command line as the ``labsim`` script."""
from labsim.runtime.cli.main import main

raise SystemExit(main())
