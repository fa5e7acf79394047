"""Tools on recorded runs and many runs: info, replay, sweeps."""
