"""The language's code generation: the slot layout, the generated Python, the compiled Program."""
