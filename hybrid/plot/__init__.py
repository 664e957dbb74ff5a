"""Layer 8: figures (matplotlib): trajectories, orbits, frequency-response curves, continuation
branches, sweep charts."""
