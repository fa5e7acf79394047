"""Recording: the MCAP writer, the one strict reader of cpf logs, and the recovery of cut logs."""
