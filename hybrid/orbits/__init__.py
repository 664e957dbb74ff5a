"""Layer 5: periodic orbits (forced: shooting and switch-time Newton; autonomous), flow maps,
equilibria, and what is read off an orbit (multipliers, amplitudes, verdict)."""
