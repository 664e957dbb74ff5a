"""Layer 4: the event-driven run (simulate), its trajectory, recording and sinks, files, and the
variational equations with saltation matrices."""
