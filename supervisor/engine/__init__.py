"""The engines: in-process, the Zenoh supervisor and its processes, and re-simulation; thin drivers of the plan."""
