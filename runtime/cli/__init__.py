"""The ``labsim`` command line: one subcommand per job, each application's parser added lazily.

``main`` (the entry point and the subcommands' dispatch), ``report`` (the progress bar and the
text summary), ``completion`` (shell completion), ``schemas`` (``labsim schema``) and
``pytest_plugin`` (goldens as pytest tests, ``labsim test``).
"""
