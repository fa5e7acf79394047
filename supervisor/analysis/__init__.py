"""Analysis of a run: summaries, metrics and figures, from a run's series or its log."""
