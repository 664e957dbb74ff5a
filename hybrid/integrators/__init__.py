"""Layer 3: integrators of one mode's flow (a common step contract, IDA and the exact flow of affine
modes), found by name in a registry. Imports :mod:`hybrid.core` and :mod:`hybrid.model`."""
