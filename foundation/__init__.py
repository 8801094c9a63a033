"""The foundation every stage of labsim stands on, and that imports nothing else of labsim.

What a user's file meets first: ``source`` (YAML composed with positions, and the ``Reader``
every file reader builds on), ``diagnostics`` (the one format of a user-facing mistake),
``files`` (the one way in and out for every file labsim reads or writes), ``kinds`` (the one
rule for what kind of file a path holds), ``numbers`` (the one rule for numbers), ``limits``
(the sizes labsim accepts and a run's budgets), ``cache`` (where labsim keeps what it can
rebuild) and ``options`` (the command line's argument types).
"""
