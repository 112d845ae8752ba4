"""Signal conditioning (pure core): tare, derivatives, inertia subtraction (issue 4)."""
