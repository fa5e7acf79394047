"""The bus and access to it: Zenoh sessions and publishers, per-run credentials and access rules, TLS, the
lifeline every child process watches, and the private file a process is handed over in.
Builds on the records; knows nothing of the channel."""
