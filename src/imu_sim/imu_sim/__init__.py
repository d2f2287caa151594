"""Trajectory and MEMS sensor simulator; sim-versus-real diagnosis."""
