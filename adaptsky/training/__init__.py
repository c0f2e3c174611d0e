"""Training loops: one seed (algorithm 1) and several seeds in parallel processes."""
