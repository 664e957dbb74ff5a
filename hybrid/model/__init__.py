"""Layer 2: models as data: expressions, :class:`HybridSystem`, model files, Filippov systems,
the compiled form of a system at a parameter set, its linearisation. Imports only :mod:`hybrid.core`."""
