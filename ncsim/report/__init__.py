"""Reports: summaries, pass/fail checks, machine explanations, plots, CSV traces.

``summary`` (the JSON and text summary), ``check`` (CI thresholds), ``explain`` (a machine's
limits against the radius), ``plot`` (matplotlib, imported lazily), ``csvio`` and its compiled
row writer ``csvformat``, ``pathtext`` (the lines of ``ncsim parse``, compiled).
"""
