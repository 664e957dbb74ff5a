"""Layer 6: continuation: pseudo-arclength, special points, branches of forced and autonomous orbits
and equilibria, frequency-response curves, the cold start of a periodic orbit."""
