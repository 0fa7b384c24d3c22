"""Sim-to-real gap diagnosis: measured traces -> alignment -> effects -> fits -> diagnosis.

``measured`` (loaders), ``align``, ``effects`` (the library of unmodelled effects),
``diagnose`` (traces), ``published`` (published values), ``servo_part`` and ``lag``
(commanded against actual), ``iso230``, ``report`` and ``plot``; ``pipeline.diagnose`` is what
``ncsim gap`` runs. ``truth/`` holds the validation generators, used only by tests and
benchmarks.
"""
