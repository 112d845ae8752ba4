"""Signal conditioning (pure core): tare, derivatives, inertia subtraction."""
