"""Gait planning by constrained direct collocation (DIRCON); the public API is in `dircon`."""
