"""Planning: Path -> per-block limits -> look-ahead feed law (Motion) -> samples.

``kinematics`` (the paper's equations as pure functions) -> ``limits`` (set points and
junction feeds) -> ``lookahead`` with ``ramps`` (eq. 16) and ``_kernels`` (compiled loops) ->
``sample``; ``crosscheck`` compares every block with ruckig. Imports nothing of ``gap`` or
``cli``.
"""
