"""The language's analyses: checking, types, folding, ranges, warnings and the reference evaluator."""
