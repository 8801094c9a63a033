"""The language's syntax: the grammar, the expression tree, the parser and the file reader."""
