"""The plan of a run: what is in force over each step (faults, process actions, network, disturbances)."""
