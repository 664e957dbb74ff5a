"""Layer 7: parameter studies (sweeps) and their files."""
