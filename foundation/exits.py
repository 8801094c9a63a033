"""Exit codes: what every ``labsim`` command tells the shell, defined once.

The command line (``labsim.runtime.cli``) returns them, and so do the applications it hands a
command to (a sweep, the live view, the plots, the stand-in server, the scene builder); they
live in the foundation because those applications may import neither each other nor the
command line.
"""
from __future__ import annotations

from typing import Final

EXIT_OK: Final = 0
# a golden trace differs (or is missing); some of a sweep's runs failed
EXIT_FAILED: Final = 1
# a user's mistake (a bad behaviour file, an unknown option or parameter, an unreachable
# simulator, a run over its budget), reported as ``path:line:col: message``, never a traceback
EXIT_USAGE: Final = 2
# 128 + SIGHUP, as a shell reports a process whose terminal closed: handled as Ctrl-C is
EXIT_HANGUP: Final = 129
# 128 + SIGINT, as a shell reports Ctrl-C: what was done so far is kept (the trace closed)
EXIT_INTERRUPTED: Final = 130
# 128 + SIGTERM, as a shell reports a process SIGTERM ended: handled as Ctrl-C is
EXIT_TERMINATED: Final = 143
