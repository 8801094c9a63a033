"""``labsim lsp``: a Language Server Protocol server for behaviour, world and assignment files.

An application of its own (docs/architecture.md): editors start it over stdio and it answers
with ``labsim check``'s diagnostics as the student types, completion, hover, go to definition
and rename (docs/editors.md). ``language`` is its one door into the language's checker and
tables; ``outline`` finds the names a file declares and uses; ``positions`` converts between
Python's characters and the protocol's columns; ``features`` answers completion, hover,
definition and rename; ``session`` holds what they share; ``server`` wires them to pygls.
"""
