"""Layer 1: errors, options, budgets and small numerics. Imports nothing else of :mod:`hybrid`."""
