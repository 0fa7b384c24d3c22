"""Reports: summaries, pass/fail checks, machine explanations, plots, CSV traces."""
