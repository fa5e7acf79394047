"""Scenario configuration: the file's schema, its checks, digests, the reference and the models built from it."""
