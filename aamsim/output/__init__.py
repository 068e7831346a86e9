"""Run outputs: trajectory and flight logs, summaries, run directories."""
