"""Rig drivers (edge): the simulated rig and the NI-DAQ rig behind one interface."""
