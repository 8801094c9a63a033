"""The language's library: built-in functions, memory, images, and what generated code calls at run time."""
