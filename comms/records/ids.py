"""The range of a vehicle id, on its own: the command line's options take it without importing numpy (the records
do, and a `cpf` process sets numpy's BLAS threads before numpy is first imported: supervisor.cli)."""

MAX_VEHICLE_ID = 65535  # two bytes on the wire (comms.records.wire)
NARROW_IDS = 255  # ids a one-byte sender holds
