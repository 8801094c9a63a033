"""The ``labsim`` command line: one subcommand per job, each application imported when its command runs.

``main`` (the entry point: parse, prepare, run, exit code), ``parser`` (each command's options,
declared by one small function), ``commands`` (what each command does), ``report`` (the
progress bar and the text summary), ``completion`` (shell completion), ``schemas``
(``labsim schema``) and ``pytest_plugin`` (goldens as pytest tests, ``labsim test``).
"""
